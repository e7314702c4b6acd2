//! Loading measured data from CSV (docs/design.md §3), with the checks that keep a bad file from
//! becoming a silently wrong model.
//!
//! Files keep their own names, units and delimiters: `--map NAME=SOURCE` maps a canonical column
//! (`temp_c`, `voltage_v`, `rate_dps`, …) onto a source column, a source column times a factor
//! (`imu.gyro.x*57.29577951`) or a constant (`rate_dps=0`). Comma, tab or semicolon is detected
//! from the header; a semicolon file is a spreadsheet's export where the decimal separator may be a
//! comma (`12,5`), and its numbers are read so.
//! A UTF-8 byte-order mark and CRLF line ends are accepted. Every error names the file, and where it
//! can, the line (1-based, header is line 1) and the column.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Errors while loading data; each names the file and, where it applies, line and column.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// The file could not be read.
    #[error("{path}: cannot read")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// Not a CSV: a flight controller's log where a CSV is read, or a binary file of no known
    /// kind.
    #[error("{path}: {what}")]
    NotCsv {
        /// The file.
        path: PathBuf,
        /// What it is instead.
        what: String,
    },
    /// The file has no header line.
    #[error("{path}: empty file (expected a header line)")]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// The file has a header but no data rows.
    #[error("{path}: no data rows after the header")]
    NoRows {
        /// The file.
        path: PathBuf,
    },
    /// A required column is absent and not mapped.
    #[error(
        "{path}: missing column '{column}' (header has: {available}); map one with --map {column}=SOURCE"
    )]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The canonical or source column looked for.
        column: String,
        /// The header's columns, comma-separated.
        available: String,
    },
    /// A row has a different number of fields than the header.
    #[error("{path} line {line}: {found} fields, but the header has {expected}")]
    RowLength {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// Fields in the row.
        found: usize,
        /// Fields in the header.
        expected: usize,
    },
    /// A field is not a number.
    #[error("{path} line {line}, column {column}: '{value}' is not a number")]
    NotANumber {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The source column.
        column: String,
        /// The offending text.
        value: String,
    },
    /// A field is NaN or infinite.
    #[error("{path} line {line}, column {column}: {value} is not a finite number")]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The source column.
        column: String,
        /// The offending text.
        value: String,
    },
    /// A column that must vary is constant over the whole file.
    #[error("{path}, column {column}: constant ({value}) over all {rows} rows: {why}")]
    ConstantColumn {
        /// The file.
        path: PathBuf,
        /// The canonical column.
        column: String,
        /// Its only value.
        value: f64,
        /// Number of rows.
        rows: usize,
        /// What a constant column makes impossible.
        why: &'static str,
    },
    /// A column that must vary does, but below what the firmware's f32 arithmetic resolves.
    #[error(
        "{path}, column {column}: varies by {spread:e} around {value} only, below the f32 \
         resolution the firmware computes in ({ulp:e}): to it the column is constant, so {why}"
    )]
    BelowF32 {
        /// The file.
        path: PathBuf,
        /// The canonical column.
        column: String,
        /// A value of it.
        value: f64,
        /// max − min.
        spread: f64,
        /// The f32 spacing at that value.
        ulp: f64,
        /// What a constant column makes impossible.
        why: &'static str,
    },
    /// A window to leave out holds no sample of the log.
    #[error("--exclude {0}: no sample of the log lies there (seconds from its first sample)")]
    EmptyWindow(String),
    /// Columns given in memory are not of one length.
    #[error(
        "{column} holds {len} samples and time_s {expected}: the columns must be of one length"
    )]
    ColumnLength {
        /// The column.
        column: &'static str,
        /// Its length.
        len: usize,
        /// time_s's length.
        expected: usize,
    },
    /// The file is not valid CSV (e.g. broken quoting or invalid UTF-8).
    #[error("{path} line {line}: {message}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The CSV reader's message.
        message: String,
    },
}

/// An invalid `--map` argument.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "invalid --map '{0}': expected NAME=SOURCE, where SOURCE is a column, COLUMN*FACTOR or a number"
)]
pub struct BadMap(pub String);

/// Where a canonical column's values come from.
#[derive(Debug, Clone, PartialEq)]
pub enum ColumnSource {
    /// A source column, scaled by a factor (1 when none is given).
    Column {
        /// The source column's name.
        name: String,
        /// Multiplier applied to every value.
        factor: f64,
    },
    /// The same value on every row (e.g. `rate_dps=0` for a static log).
    Constant(f64),
}

/// One `--map NAME=SOURCE` argument.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnMap {
    /// Canonical name (`temp_c`, `voltage_v`, `rate_dps`, …).
    pub name: String,
    /// Where its values come from.
    pub source: ColumnSource,
}

impl FromStr for ColumnSource {
    type Err = BadMap;

    /// A column, `COLUMN*FACTOR` or a number.
    fn from_str(source: &str) -> Result<Self, BadMap> {
        let bad = || BadMap(source.to_owned());
        let source = source.trim();
        if source.is_empty() {
            return Err(bad());
        }
        if let Ok(v) = source.parse::<f64>() {
            return if v.is_finite() {
                Ok(ColumnSource::Constant(v))
            } else {
                Err(bad())
            };
        }
        if let Some((col, factor)) = source.rsplit_once('*') {
            let factor: f64 = factor.trim().parse().map_err(|_| bad())?;
            if !factor.is_finite() || col.trim().is_empty() {
                return Err(bad());
            }
            return Ok(ColumnSource::Column {
                name: col.trim().to_owned(),
                factor,
            });
        }
        Ok(ColumnSource::Column {
            name: source.to_owned(),
            factor: 1.0,
        })
    }
}

impl ColumnSource {
    /// The same source scaled by `k`: a column's factor times `k`, a constant times `k`.
    pub fn scaled(&self, k: f64) -> Self {
        match self {
            Self::Column { name, factor } => Self::Column {
                name: name.clone(),
                factor: factor * k,
            },
            Self::Constant(v) => Self::Constant(v * k),
        }
    }
}

impl std::fmt::Display for ColumnSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Column { name, factor } if *factor == 1.0 => write!(f, "column {name}"),
            Self::Column { name, factor } => write!(f, "column {name} × {factor}"),
            Self::Constant(v) => write!(f, "the constant {v}"),
        }
    }
}

impl FromStr for ColumnMap {
    type Err = BadMap;

    fn from_str(s: &str) -> Result<Self, BadMap> {
        let bad = || BadMap(s.to_owned());
        let (name, source) = s.split_once('=').ok_or_else(bad)?;
        let name = name.trim();
        if name.is_empty() {
            return Err(bad());
        }
        Ok(Self {
            name: name.to_owned(),
            source: source.parse().map_err(|_| bad())?,
        })
    }
}

/// Numeric columns read from one file, by canonical name, with each row's line number.
#[derive(Debug, Clone)]
pub struct Columns {
    /// The file they came from.
    pub path: PathBuf,
    /// Values per canonical column.
    pub values: HashMap<String, Vec<f64>>,
    /// Raw text of columns requested as labels (e.g. a `--group` column).
    pub labels: HashMap<String, Vec<String>>,
    /// 1-based line number of each row.
    pub lines: Vec<u64>,
}

impl Columns {
    /// The values of a column that was requested (present by construction).
    pub fn get(&self, name: &str) -> &[f64] {
        self.values.get(name).map_or(&[], Vec::as_slice)
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.lines.len()
    }

    /// Keeps the rows whose line `keep` accepts.
    pub fn retain(&mut self, keep: impl Fn(u64) -> bool) {
        let mask: Vec<bool> = self.lines.iter().map(|&l| keep(l)).collect();
        let filter = |v: &mut Vec<f64>| {
            let mut k = mask.iter();
            v.retain(|_| k.next().copied().unwrap_or(false));
        };
        self.values.values_mut().for_each(filter);
        for v in self.labels.values_mut() {
            let mut k = mask.iter();
            v.retain(|_| k.next().copied().unwrap_or(false));
        }
        let mut k = mask.iter();
        self.lines.retain(|_| k.next().copied().unwrap_or(false));
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }
}

/// Refuses a log of an autopilot given where a CSV is read, and a file of neither kind, each
/// with what it is.
fn refuse_logs(path: &Path) -> Result<(), DataError> {
    let not_csv = |what: String| DataError::NotCsv {
        path: path.to_owned(),
        what,
    };
    match crate::autopilot::sniff(path) {
        Ok(crate::autopilot::Format::Csv) => Ok(()),
        Ok(format) => Err(not_csv(format!(
            "{format}, not a CSV: give it to --stream, without --channels or --map (each of its \
             sensors is a unit of its own)"
        ))),
        Err(crate::autopilot::RecordedError::Unknown { found, .. }) => Err(not_csv(format!(
            "neither a CSV, a PX4 ULog nor an ArduPilot DataFlash log: it begins with {found}"
        ))),
        Err(_) => Ok(()),
    }
}

/// `bytes` without a byte-order mark and with LF line ends: the csv reader's line numbers drift
/// on CRLF files; plain LF keeps them exact.
fn plain_lines(bytes: &[u8]) -> Vec<u8> {
    let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    if !text.contains(&b'\r') {
        return text.to_vec();
    }
    let mut out = Vec::with_capacity(text.len());
    for (i, &b) in text.iter().enumerate() {
        if !(b == b'\r' && text.get(i + 1) == Some(&b'\n')) {
            out.push(b);
        }
    }
    out
}

/// The delimiter a header line uses: a tab where it has one, else a semicolon where it has one
/// and no comma, else a comma.
fn delimiter_of(header_line: &[u8]) -> u8 {
    if header_line.contains(&b'\t') {
        b'\t'
    } else if header_line.contains(&b';') && !header_line.contains(&b',') {
        b';'
    } else {
        b','
    }
}

/// Where a cell is: its file, line and column.
struct Cell<'a> {
    path: &'a Path,
    line: u64,
    column: &'a str,
}

impl Cell<'_> {
    /// The cell's number times `factor` (with `decimal_comma`, one comma is the decimal point):
    /// an error where it is not a number or not finite.
    fn number(&self, field: &str, decimal_comma: bool, factor: f64) -> Result<f64, DataError> {
        let parsed: Result<f64, _> = if decimal_comma && field.matches(',').count() == 1 {
            field.replacen(',', ".", 1).parse()
        } else {
            field.parse()
        };
        let (path, line, column, value) = (
            self.path.to_owned(),
            self.line,
            self.column.to_owned(),
            field.to_owned(),
        );
        let Ok(v) = parsed.map(|v| v * factor) else {
            return Err(DataError::NotANumber {
                path,
                line,
                column,
                value,
            });
        };
        if v.is_finite() {
            Ok(v)
        } else {
            Err(DataError::NonFinite {
                path,
                line,
                column,
                value,
            })
        }
    }
}

/// A canonical column's source: a column of the file (its index and name, with a factor) or a
/// constant.
enum Resolved {
    Column(usize, String, f64),
    Constant(f64),
}

impl Resolved {
    /// Its value in `record` (NaN for an empty cell where it may be empty), the cell named by
    /// `at` for an error.
    fn value<'a>(
        &'a self,
        record: &csv::StringRecord,
        may_be_empty: bool,
        decimal_comma: bool,
        at: impl Fn(&'a str) -> Cell<'a>,
    ) -> Result<f64, DataError> {
        match self {
            Self::Constant(v) => Ok(*v),
            Self::Column(i, _, _)
                if may_be_empty && record.get(*i).unwrap_or_default().is_empty() =>
            {
                Ok(f64::NAN)
            }
            Self::Column(i, col, factor) => {
                at(col).number(record.get(*i).unwrap_or_default(), decimal_comma, *factor)
            }
        }
    }
}

/// Where canonical column `name` comes from: the last of `maps` that names it, else the file's
/// column of that name; missing where the file has no such column.
fn resolve(
    name: &str,
    maps: &[ColumnMap],
    headers: &[String],
    path: &Path,
) -> Result<Resolved, DataError> {
    let missing = |column: &str| DataError::MissingColumn {
        path: path.to_owned(),
        column: column.to_owned(),
        available: headers.join(", "),
    };
    let index_of = |name: &str| headers.iter().position(|h| h == name);
    match maps
        .iter()
        .rev()
        .find(|m| m.name == name)
        .map(|m| &m.source)
    {
        Some(ColumnSource::Constant(v)) => Ok(Resolved::Constant(*v)),
        Some(ColumnSource::Column { name: col, factor }) => index_of(col)
            .map(|i| Resolved::Column(i, col.clone(), *factor))
            .ok_or_else(|| missing(col)),
        None => index_of(name)
            .map(|i| Resolved::Column(i, name.to_owned(), 1.0))
            .ok_or_else(|| missing(name)),
    }
}

/// Reads the `numeric` canonical columns (and `label` columns as text) from a CSV file. Columns
/// named in `nullable` may have empty cells, read as NaN (e.g. a stream's reference rate where it
/// is unknown); everywhere else an empty or non-finite cell is an error.
pub fn read_columns(
    path: &Path,
    numeric: &[&str],
    nullable: &[&str],
    label: &[&str],
    maps: &[ColumnMap],
) -> Result<Columns, DataError> {
    let bytes = std::fs::read(path).map_err(|source| DataError::Io {
        path: path.to_owned(),
        source,
    })?;
    refuse_logs(path)?;
    let text = plain_lines(&bytes);
    let text = text.as_slice();
    let header_line = text.split(|&b| b == b'\n').next().unwrap_or_default();
    if header_line.iter().all(u8::is_ascii_whitespace) {
        return Err(DataError::Empty {
            path: path.to_owned(),
        });
    }
    let delimiter = delimiter_of(header_line);
    // A spreadsheet's export with semicolons writes its decimals with a comma.
    let decimal_comma = delimiter == b';';
    let mut reader = csv::ReaderBuilder::new()
        .delimiter(delimiter)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text);
    let malformed = |e: csv::Error| DataError::Malformed {
        path: path.to_owned(),
        line: e.position().map_or(1, csv::Position::line),
        message: e.to_string(),
    };
    let headers: Vec<String> = reader
        .headers()
        .map_err(malformed)?
        .iter()
        .map(str::to_owned)
        .collect();
    let missing = |column: &str| DataError::MissingColumn {
        path: path.to_owned(),
        column: column.to_owned(),
        available: headers.join(", "),
    };
    let numeric_sources = numeric
        .iter()
        .map(|n| resolve(n, maps, &headers, path))
        .collect::<Result<Vec<_>, _>>()?;
    let label_sources = label
        .iter()
        .map(|n| {
            headers
                .iter()
                .position(|h| h == n)
                .ok_or_else(|| missing(n))
        })
        .collect::<Result<Vec<_>, _>>()?;

    let mut values: Vec<Vec<f64>> = vec![Vec::new(); numeric.len()];
    let mut labels: Vec<Vec<String>> = vec![Vec::new(); label.len()];
    let mut lines = Vec::new();
    let may_be_empty: Vec<bool> = numeric.iter().map(|n| nullable.contains(n)).collect();
    for record in reader.records() {
        let record = record.map_err(malformed)?;
        let line = record.position().map_or(0, csv::Position::line);
        if record.iter().all(str::is_empty) {
            continue;
        }
        if record.len() != headers.len() {
            return Err(DataError::RowLength {
                path: path.to_owned(),
                line,
                found: record.len(),
                expected: headers.len(),
            });
        }
        for ((out, source), &empty_ok) in values.iter_mut().zip(&numeric_sources).zip(&may_be_empty)
        {
            let at = |column| Cell { path, line, column };
            out.push(source.value(&record, empty_ok, decimal_comma, at)?);
        }
        for (out, &i) in labels.iter_mut().zip(&label_sources) {
            out.push(record.get(i).unwrap_or_default().to_owned());
        }
        lines.push(line);
    }
    if lines.is_empty() {
        return Err(DataError::NoRows {
            path: path.to_owned(),
        });
    }
    Ok(Columns {
        path: path.to_owned(),
        values: numeric.iter().map(|n| n.to_string()).zip(values).collect(),
        labels: label.iter().map(|n| n.to_string()).zip(labels).collect(),
        lines,
    })
}

/// Fails with [`DataError::ConstantColumn`] when `column` holds one value only, and with
/// [`DataError::BelowF32`] when it holds one value once rounded to f32, as the firmware sees it.
pub fn require_varying(
    columns: &Columns,
    column: &str,
    why: &'static str,
) -> Result<(), DataError> {
    let v = columns.get(column);
    let Some(&first) = v.first() else {
        return Ok(());
    };
    if v.iter().all(|&x| x == first) {
        return Err(DataError::ConstantColumn {
            path: columns.path.clone(),
            column: column.to_owned(),
            value: first,
            rows: v.len(),
            why,
        });
    }
    let narrow = first as f32;
    if v.iter().all(|&x| x as f32 == narrow) {
        let (lo, hi) = v
            .iter()
            .fold((first, first), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        return Err(DataError::BelowF32 {
            path: columns.path.clone(),
            column: column.to_owned(),
            value: first,
            spread: hi - lo,
            ulp: f64::from(narrow.abs().next_up() - narrow.abs()),
            why,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn file(contents: &str) -> tempfile::NamedTempFile {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        f.write_all(contents.as_bytes()).unwrap();
        f
    }

    #[test]
    fn map_parses_columns_factors_and_constants() {
        let m: ColumnMap = "rate_dps=0".parse().unwrap();
        assert_eq!(m.source, ColumnSource::Constant(0.0));
        let m: ColumnMap = "voltage_v=imu.gyro.x*57.29577951".parse().unwrap();
        assert_eq!(
            m.source,
            ColumnSource::Column {
                name: "imu.gyro.x".into(),
                factor: 57.29577951
            }
        );
        let m: ColumnMap = "temp_c=T".parse().unwrap();
        assert_eq!(
            m.source,
            ColumnSource::Column {
                name: "T".into(),
                factor: 1.0
            }
        );
        assert!("nonsense".parse::<ColumnMap>().is_err());
        assert!("a=".parse::<ColumnMap>().is_err());
        assert!("a=b*x".parse::<ColumnMap>().is_err());
    }

    #[test]
    fn tab_bom_crlf_and_maps_are_read() {
        let f = file("\u{feff}t\tcounts\tus\r\n1.5\t10\t1000000\r\n2.5\t20\t2000000\r\n");
        let maps: Vec<ColumnMap> = [
            "temp_c=t",
            "voltage_v=counts*0.5",
            "time_s=us*1e-6",
            "rate_dps=0",
        ]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();
        let c = read_columns(
            f.path(),
            &["temp_c", "voltage_v", "time_s", "rate_dps"],
            &[],
            &[],
            &maps,
        )
        .unwrap();
        assert_eq!(c.get("temp_c"), &[1.5, 2.5]);
        assert_eq!(c.get("voltage_v"), &[5.0, 10.0]);
        assert_eq!(c.get("time_s"), &[1.0, 2.0]);
        assert_eq!(c.get("rate_dps"), &[0.0, 0.0]);
        assert_eq!(c.lines, vec![2, 3]);
    }

    #[test]
    fn a_spreadsheet_export_with_semicolons_and_decimal_commas_is_read() {
        let f = file("temp_c;voltage_v;rate_dps\n25,5;0,38;10\n-3,25;1.5;-20,0\n");
        let c = read_plain(&f, &["temp_c", "voltage_v", "rate_dps"]).unwrap();
        assert_eq!(c.get("temp_c"), &[25.5, -3.25]);
        assert_eq!(c.get("voltage_v"), &[0.38, 1.5]);
        assert_eq!(c.get("rate_dps"), &[10.0, -20.0]);
        // A field that is not a number stays an error that names it.
        let f = file("temp_c;voltage_v;rate_dps\n25,5;0,3,8;10\n");
        let e = read_plain(&f, &["temp_c", "voltage_v", "rate_dps"]).unwrap_err();
        assert!(e.to_string().contains("'0,3,8' is not a number"), "{e}");
    }

    /// Canonical columns, none nullable, no labels, no maps.
    fn read_plain(f: &tempfile::NamedTempFile, numeric: &[&str]) -> Result<Columns, DataError> {
        read_columns(f.path(), numeric, &[], &[], &[])
    }

    #[test]
    fn errors_name_line_and_column() {
        let f = file("temp_c,voltage_v,rate_dps\n1,2,3\n1,abc,3\n");
        let e = read_plain(&f, &["temp_c", "voltage_v", "rate_dps"]).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("line 3, column voltage_v: 'abc' is not a number"),
            "{msg}"
        );

        let f = file("temp_c,voltage_v,rate_dps\n1,NaN,3\n");
        let e = read_plain(&f, &["temp_c", "voltage_v", "rate_dps"]).unwrap_err();
        assert!(matches!(e, DataError::NonFinite { line: 2, .. }), "{e}");

        let f = file("temp_c,voltage_v\n1,2\n");
        let e = read_plain(&f, &["temp_c", "voltage_v", "rate_dps"]).unwrap_err();
        assert!(e.to_string().contains("missing column 'rate_dps'"), "{e}");

        let f = file("temp_c,voltage_v,rate_dps\n1,2\n");
        let e = read_plain(&f, &["temp_c", "voltage_v", "rate_dps"]).unwrap_err();
        assert!(
            matches!(
                e,
                DataError::RowLength {
                    line: 2,
                    found: 2,
                    expected: 3,
                    ..
                }
            ),
            "{e}"
        );

        let f = file("");
        let e = read_plain(&f, &["temp_c"]).unwrap_err();
        assert!(matches!(e, DataError::Empty { .. }), "{e}");

        let f = file("temp_c\n");
        let e = read_plain(&f, &["temp_c"]).unwrap_err();
        assert!(matches!(e, DataError::NoRows { .. }), "{e}");
    }

    #[test]
    fn constant_column_is_refused_with_the_reason() {
        let f = file("temp_c,voltage_v\n1,2\n1,3\n");
        let c = read_plain(&f, &["temp_c", "voltage_v"]).unwrap();
        assert!(require_varying(&c, "voltage_v", "x").is_ok());
        let e =
            require_varying(&c, "temp_c", "no temperature dependence can be learnt").unwrap_err();
        assert!(e.to_string().contains("column temp_c: constant (1)"), "{e}");
        // 0.38 ± 1e-12 is one number in f32: constant to the firmware.
        let f = file("temp_c,voltage_v\n1,0.38\n2,0.380000000001\n");
        let c = read_plain(&f, &["temp_c", "voltage_v"]).unwrap();
        let e = require_varying(&c, "voltage_v", "x").unwrap_err();
        assert!(matches!(e, DataError::BelowF32 { .. }), "{e}");
        assert!(e.to_string().contains("below the f32 resolution"), "{e}");
    }
}
