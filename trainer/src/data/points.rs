//! Rate-table points ready for fitting: inputs (T, V), target ω, and the temperature plateaus that
//! leave-one-temperature-out and the two-step model need.

use std::path::Path;
use std::sync::OnceLock;

use firmware_core::features::{self, FeatureState, Sample};
use firmware_core::{Feature, Quantity, Status};
use fog_data::columns::{self, ColumnMap, DataError};
use fog_data::replay;
use fog_data::stream::Stream;
use nalgebra::{DMatrix, DVector};

/// The inputs of a rate-table model, in order: the paper's (T, V).
pub const POINT_FEATURES: [Feature; 2] = [Feature::Temperature, Feature::Voltage];

/// Gap between sorted temperatures that separates two plateaus, °C. Soaked plateaus of a thermal
/// chamber are ≥ 5 °C apart; readings within one plateau scatter by hundredths of a degree.
pub const PLATEAU_GAP_C: f64 = 1.0;

/// Averaged rate-table points (docs/design.md §3 `points`).
#[derive(Debug, Clone)]
pub struct Points {
    /// Temperature, °C.
    pub temp_c: Vec<f64>,
    /// Gyro output (V, counts…).
    pub voltage_v: Vec<f64>,
    /// Reference rate, °/s.
    pub rate_dps: Vec<f64>,
    /// Group of each point (plateau index, or the `--group` column's label), as labels.
    pub group: Vec<String>,
    /// Power-on (run) of each point, numbered from 0: one per file pooled ([`Points::pooled`]).
    /// Points of several runs carry what one run cannot show, the bias of another power-on.
    pub run: Vec<usize>,
    /// Nominal scale factor K (output units per °/s) of a bias model: the GP learns
    /// ω − output/K from temperature alone and the firmware adds output/K back (the form a static
    /// log allows); `None` for the paper's rate model ω = f(T, output).
    pub scale_factor: Option<f64>,
    /// Whether each point was soaked at its temperature (a rate table), rather than the mean of a
    /// stream block taken while the temperature moved.
    pub soaked: bool,
    /// When each point was recorded, s, increasing row by row: a table recorded in time order
    /// (`--map time_s=…`), whose transients [`crate::analysis::table`] can diagnose and whose
    /// heating rates the σ reads (`uncertainty::heating::table_rates`). `None` otherwise.
    pub time_s: Option<Vec<f64>>,
    /// What the reference measures, and so the unit every figure of these points is stated in:
    /// a gyro's rate (°/s) unless a unit's channels file says its channel is an accelerometer.
    pub quantity: Quantity,
    /// The model inputs, computed once on first use ([`Points::inputs`]) and carried by
    /// [`Points::select`]: every fit, export and check of these points reads the same matrix.
    inputs: OnceLock<DMatrix<f64>>,
}

/// Errors specific to rate-table points.
#[derive(Debug, thiserror::Error)]
pub enum PointsError {
    /// Loading failed.
    #[error(transparent)]
    Data(#[from] DataError),
    /// One reference rate and no scale factor: nothing to learn a rate model from.
    #[error(
        "{path}: every reference rate is {rate} °/s — a static log carries no scale-factor \
         information, so no rate model can be learnt from it. Give the gyro's nominal scale factor \
         (--scale-factor K, output units per °/s): the model then learns the bias \
         (output/K − rate) from temperature and compensates by subtracting it"
    )]
    StaticLog {
        /// The file.
        path: String,
        /// The one rate, °/s.
        rate: f64,
    },
    /// A scale factor that is zero or not finite.
    #[error("--scale-factor {0}: must be a finite, non-zero number of output units per °/s")]
    BadScaleFactor(f64),
    /// Pooling a rate model's data with a bias model's.
    #[error(
        "cannot pool a rate table with a static log: fit one model form (--scale-factor) on both"
    )]
    MixedForms,
    /// Rows that are implausible next to the others.
    #[error(
        "{path} {first}{more}: implausible next to the other rows (a unit mix-up or a mistyped \
         row?); correct it, or leave such rows out with --exclude-implausible",
        more = if *count > 1 { format!(" (and {} more rows)", count - 1) } else { String::new() }
    )]
    Implausible {
        /// The file.
        path: String,
        /// The first such row.
        first: Implausible,
        /// How many there are.
        count: usize,
    },
    /// A time column that does not increase row by row.
    #[error(
        "{path} line {line}: time_s {value} s does not follow the row before ({previous} s); a \
         table recorded in time order needs a time that increases row by row"
    )]
    Unordered {
        /// The file.
        path: String,
        /// 1-based line in the file.
        line: u64,
        /// The time on that line, s.
        value: f64,
        /// The time on the row before, s.
        previous: f64,
    },
    /// A row the firmware would refuse as an input (its `Fault`).
    #[error(
        "{path} line {line}: temperature {temp_c} °C, output {output}: the firmware refuses this \
         row (a temperature outside −100…200 °C, or a value that is not finite); is the unit right?"
    )]
    Refused {
        /// The file.
        path: String,
        /// 1-based line in the file.
        line: u64,
        /// Its temperature, °C.
        temp_c: f64,
        /// Its output.
        output: f64,
    },
    /// A stream with too few 60 s blocks to fit a static model on.
    #[error("{path}: {found} scored 60 s blocks; a static model from a stream needs at least 10")]
    TooFewBlocks {
        /// The file.
        path: String,
        /// Blocks found.
        found: usize,
    },
    /// Fewer than two temperature plateaus: no temperature dependence can be learnt or tested.
    #[error(
        "{path}: temperatures span only {span:.3} °C; at least {gap} °C is needed to learn a temperature dependence"
    )]
    TooFewTemperatures {
        /// The file.
        path: String,
        /// Span of the temperatures, °C.
        span: f64,
        /// The least span, °C ([`PLATEAU_GAP_C`]).
        gap: f64,
    },
}

/// A row that is implausible next to the others: a value separated from the rest of its column
/// by a gap wider than the rest spans ([`implausible`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Implausible {
    /// 1-based line in the file.
    pub line: u64,
    /// The canonical column.
    pub column: &'static str,
    /// Its value.
    pub value: f64,
    /// Lowest and highest value of the other rows.
    pub others: [f64; 2],
}

impl std::fmt::Display for Implausible {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "line {}, column {}: {} lies far outside the other rows ({} … {})",
            self.line, self.column, self.value, self.others[0], self.others[1]
        )
    }
}

/// What loading does with implausible rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Screen {
    /// Refuse the file, naming the row.
    #[default]
    Refuse,
    /// Leave the rows out and report them.
    Exclude,
}

/// Least gap, °C, that sets a temperature apart as implausible: wider than the steps between a
/// thermal chamber's plateaus.
const IMPLAUSIBLE_TEMP_GAP_C: f64 = 20.0;
/// Fewest rows a column needs before single rows are judged against the others.
const SCREEN_MIN_ROWS: usize = 10;

/// Rows of `values` (one column, with its file lines) that are implausible next to the others:
/// sorted, the column is cut at its widest gap; the smaller side is implausible when it holds at
/// most 3 rows or 2% of them, and the gap is wider than both the larger side's span and `floor`.
/// A unit mix-up (kelvin among °C, rad/s among °/s in a table that goes beyond 1 °/s) or a
/// mistyped row lands there; a plateau or a rate of the protocol, with rows of its own, does not.
pub fn implausible(
    column: &'static str,
    values: &[f64],
    lines: &[u64],
    floor: f64,
) -> Vec<Implausible> {
    let n = values.len();
    if n < SCREEN_MIN_ROWS {
        return Vec::new();
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let Some((cut, gap)) = (1..n)
        .map(|k| (k, values[order[k]] - values[order[k - 1]]))
        .max_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return Vec::new();
    };
    let (small, large) = if cut <= n - cut {
        (&order[..cut], &order[cut..])
    } else {
        (&order[cut..], &order[..cut])
    };
    let most = 3usize.max(n / 50);
    let large_span = values[large[large.len() - 1]] - values[large[0]];
    if small.len() > most || gap <= large_span.max(floor) {
        return Vec::new();
    }
    let others = [values[large[0]], values[large[large.len() - 1]]];
    let mut rows: Vec<Implausible> = small
        .iter()
        .map(|&i| Implausible {
            line: lines[i],
            column,
            value: values[i],
            others,
        })
        .collect();
    rows.sort_by_key(|r| r.line);
    rows
}

/// Span of the temperatures (max − min), °C: it must exceed [`PLATEAU_GAP_C`] for a temperature
/// dependence to be learnt.
pub fn span(temps: &[f64]) -> f64 {
    let (lo, hi) = fog_data::stats::extent(temps.iter().copied());
    hi - lo
}

/// Plateau index of each temperature: sorted temperatures split where the gap exceeds
/// [`PLATEAU_GAP_C`]; indices ascend with temperature.
pub fn plateaus(temps: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..temps.len()).collect();
    order.sort_by(|&a, &b| temps[a].total_cmp(&temps[b]));
    let mut id = vec![0; temps.len()];
    let mut current = 0;
    for w in 0..order.len() {
        if w > 0 && temps[order[w]] - temps[order[w - 1]] > PLATEAU_GAP_C {
            current += 1;
        }
        id[order[w]] = current;
    }
    id
}

impl Points {
    /// Points from their columns (one entry per point in each); the loaders below check what a
    /// file can get wrong, this takes the columns as they are.
    pub fn new(
        temp_c: Vec<f64>,
        voltage_v: Vec<f64>,
        rate_dps: Vec<f64>,
        group: Vec<String>,
        scale_factor: Option<f64>,
        soaked: bool,
        time_s: Option<Vec<f64>>,
    ) -> Self {
        Self {
            run: vec![0; temp_c.len()],
            temp_c,
            voltage_v,
            rate_dps,
            group,
            scale_factor,
            soaked,
            time_s,
            quantity: Quantity::AngularRate,
            inputs: OnceLock::new(),
        }
    }

    /// Loads a points CSV; `group` names a column whose values define the groups for
    /// leave-one-group-out (default: temperature plateaus); `scale_factor` makes a bias model
    /// ([`Self::scale_factor`]).
    pub fn load(
        path: &Path,
        maps: &[ColumnMap],
        group: Option<&str>,
        scale_factor: Option<f64>,
    ) -> Result<Self, PointsError> {
        Self::load_screened(path, maps, group, scale_factor, Screen::Refuse).map(|(p, _)| p)
    }

    /// As [`Self::load`], with a choice of what to do with [`implausible`] rows; returns the rows
    /// left out.
    pub fn load_screened(
        path: &Path,
        maps: &[ColumnMap],
        group: Option<&str>,
        scale_factor: Option<f64>,
        screen: Screen,
    ) -> Result<(Self, Vec<Implausible>), PointsError> {
        let labels: Vec<&str> = group.into_iter().collect();
        let timed = maps.iter().any(|m| m.name == "time_s");
        let numeric: &[&str] = if timed {
            &["temp_c", "voltage_v", "rate_dps", "time_s"]
        } else {
            &["temp_c", "voltage_v", "rate_dps"]
        };
        let mut c = columns::read_columns(path, numeric, &[], &labels, maps)?;
        let mut bad: Vec<Implausible> = [
            ("temp_c", IMPLAUSIBLE_TEMP_GAP_C),
            ("rate_dps", 0.0),
            ("voltage_v", 0.0),
        ]
        .into_iter()
        .flat_map(|(column, floor)| implausible(column, c.get(column), &c.lines, floor))
        .collect();
        bad.sort_by_key(|r| r.line);
        if let (Screen::Refuse, Some(first)) = (screen, bad.first()) {
            return Err(PointsError::Implausible {
                path: path.display().to_string(),
                first: first.clone(),
                count: bad.len(),
            });
        }
        let lines: Vec<u64> = bad.iter().map(|r| r.line).collect();
        c.retain(|line| !lines.contains(&line));
        let (temps, outputs) = (c.get("temp_c"), c.get("voltage_v"));
        let at = |k: usize| Sample {
            time_s: 0.0,
            temp_c: temps[k] as f32,
            output: outputs[k] as f32,
        };
        if let Some(k) = (0..temps.len()).find(|&k| !accepted(&at(k))) {
            return Err(PointsError::Refused {
                path: path.display().to_string(),
                line: c.lines[k],
                temp_c: temps[k],
                output: outputs[k],
            });
        }
        columns::require_varying(&c, "voltage_v", "the gyro output carries no information")?;
        check_scale_factor(path, c.get("rate_dps"), scale_factor)?;
        let temp_c = c.get("temp_c").to_vec();
        // Two soaked plateaus, or a temperature that drifts over a range (a heated turntable that
        // never settles): either way the span must exceed what one plateau scatters.
        let span = span(&temp_c);
        if span <= PLATEAU_GAP_C {
            return Err(PointsError::TooFewTemperatures {
                path: path.display().to_string(),
                span,
                gap: PLATEAU_GAP_C,
            });
        }
        let group = match group {
            Some(g) => c.labels.get(g).cloned().unwrap_or_default(),
            None => plateaus(&temp_c).iter().map(usize::to_string).collect(),
        };
        let time_s = timed.then(|| c.get("time_s").to_vec());
        if let Some(t) = &time_s
            && let Some(k) = (1..t.len()).find(|&k| t[k] <= t[k - 1])
        {
            return Err(PointsError::Unordered {
                path: path.display().to_string(),
                line: c.lines[k],
                value: t[k],
                previous: t[k - 1],
            });
        }
        let points = Self {
            run: vec![0; temp_c.len()],
            voltage_v: c.get("voltage_v").to_vec(),
            rate_dps: c.get("rate_dps").to_vec(),
            temp_c,
            group,
            scale_factor,
            soaked: true,
            time_s,
            quantity: Quantity::AngularRate,
            inputs: OnceLock::new(),
        };
        Ok((points, bad))
    }

    /// The 60 s block means of a stream's samples with a reference, as points (a static model
    /// fitted on a ramp or a static log, without a rate table). Groups are 10-minute chunks.
    pub fn from_stream(
        path: &Path,
        stream: &Stream,
        scale_factor: Option<f64>,
    ) -> Result<Self, PointsError> {
        let blocks = stream_blocks(stream);
        if blocks.len() < 10 {
            return Err(PointsError::TooFewBlocks {
                path: path.display().to_string(),
                found: blocks.len(),
            });
        }
        let mean = |v: &[f64], b: &[usize]| b.iter().map(|&i| v[i]).sum::<f64>() / b.len() as f64;
        let rate_dps: Vec<f64> = blocks.iter().map(|b| mean(&stream.rate_dps, b)).collect();
        check_scale_factor(path, &rate_dps, scale_factor)?;
        Ok(Self {
            temp_c: blocks.iter().map(|b| mean(&stream.temp_c, b)).collect(),
            voltage_v: blocks.iter().map(|b| mean(&stream.voltage_v, b)).collect(),
            rate_dps,
            group: (0..blocks.len()).map(|b| (b / 10).to_string()).collect(),
            run: vec![0; blocks.len()],
            scale_factor,
            soaked: false,
            time_s: None,
            quantity: Quantity::AngularRate,
            inputs: OnceLock::new(),
        })
    }

    /// Every scored sample of a stream as a point (a long stream's static model, fitted by the
    /// sparse GP), grouped by 10-minute stretch.
    pub fn from_stream_samples(
        path: &Path,
        stream: &Stream,
        scale_factor: Option<f64>,
    ) -> Result<Self, PointsError> {
        let scored = scored(stream);
        let pick = |v: &[f64]| scored.iter().map(|&i| v[i]).collect::<Vec<f64>>();
        let rate_dps = pick(&stream.rate_dps);
        check_scale_factor(path, &rate_dps, scale_factor)?;
        let t0 = stream.time_s.first().copied().unwrap_or(0.0);
        Ok(Self {
            temp_c: pick(&stream.temp_c),
            voltage_v: pick(&stream.voltage_v),
            rate_dps,
            group: scored
                .iter()
                .map(|&i| format!("stream {}", ((stream.time_s[i] - t0) / 600.0).floor()))
                .collect(),
            run: vec![0; scored.len()],
            scale_factor,
            soaked: false,
            time_s: None,
            quantity: Quantity::AngularRate,
            inputs: OnceLock::new(),
        })
    }

    /// These points, of a channel that measures `quantity`.
    pub fn measuring(mut self, quantity: Quantity) -> Self {
        self.quantity = quantity;
        self
    }

    /// These points and `other` together. Both must be the same kind of model (rate or bias with
    /// the same scale factor); the result counts as unsoaked unless both are soaked.
    pub fn pooled(mut self, other: Self) -> Result<Self, PointsError> {
        if self.scale_factor != other.scale_factor {
            return Err(PointsError::MixedForms);
        }
        self.temp_c.extend(other.temp_c);
        self.voltage_v.extend(other.voltage_v);
        self.rate_dps.extend(other.rate_dps);
        let first = self.runs();
        self.group.extend(other.group);
        self.run.extend(other.run.iter().map(|r| r + first));
        self.soaked &= other.soaked;
        // Two recordings joined are no longer one time series (their heating rates are then
        // taken as soaks).
        self.time_s = None;
        self.inputs = OnceLock::new();
        Ok(self)
    }

    /// The model's inputs: (T, V) for a rate model, T for a bias model.
    pub fn features(&self) -> &'static [Feature] {
        match self.scale_factor {
            None => &POINT_FEATURES,
            Some(_) => &POINT_FEATURES[..1],
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.temp_c.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.temp_c.is_empty()
    }

    /// Model inputs, one row per point, in the order of [`POINT_FEATURES`]: computed by
    /// firmware-core's feature pipeline, so they are exactly what the firmware computes (each
    /// point is a soaked, independent sample: a fresh pipeline state). The constructors refuse or
    /// leave out rows the firmware refuses; were one left, its inputs would be NaN (a fit then
    /// fails), never a stale value. Computed on the first call; the columns are not to change
    /// after it.
    pub fn inputs(&self) -> &DMatrix<f64> {
        self.inputs.get_or_init(|| self.compute_inputs())
    }

    fn compute_inputs(&self) -> DMatrix<f64> {
        let features = self.features();
        let d = features.len();
        let mut x = DMatrix::zeros(self.len(), d);
        let mut row = [0.0f32; POINT_FEATURES.len()];
        for i in 0..self.len() {
            let sample = Sample {
                time_s: 0.0,
                temp_c: self.temp_c[i] as f32,
                output: self.voltage_v[i] as f32,
            };
            let status =
                features::compute(features, &sample, &mut FeatureState::default(), &mut row);
            for (k, v) in row[..d].iter().enumerate() {
                x[(i, k)] = if status == Status::Fault {
                    f64::NAN
                } else {
                    f64::from(*v)
                };
            }
        }
        x
    }

    /// Targets: the reference rate, less output/K for a bias model.
    pub fn target(&self) -> DVector<f64> {
        let k = self.scale_factor;
        DVector::from_iterator(
            self.len(),
            self.rate_dps
                .iter()
                .zip(&self.voltage_v)
                .map(|(w, v)| k.map_or(*w, |k| w - v / k)),
        )
    }

    /// The subset at `idx`.
    pub fn select(&self, idx: &[usize]) -> Self {
        let pick = |v: &[f64]| -> Vec<f64> { idx.iter().map(|&i| v[i]).collect() };
        Self {
            temp_c: pick(&self.temp_c),
            voltage_v: pick(&self.voltage_v),
            rate_dps: pick(&self.rate_dps),
            group: idx.iter().map(|&i| self.group[i].clone()).collect(),
            run: idx.iter().map(|&i| self.run[i]).collect(),
            scale_factor: self.scale_factor,
            soaked: self.soaked,
            time_s: self.time_s.as_ref().map(|t| pick(t)),
            quantity: self.quantity,
            inputs: self
                .inputs
                .get()
                .map(|x| OnceLock::from(x.select_rows(idx)))
                .unwrap_or_default(),
        }
    }

    /// How many runs (power-ons) the points come from ([`Points::run`]).
    pub fn runs(&self) -> usize {
        self.run.iter().max().map_or(0, |r| r + 1)
    }

    /// The points of each run that holds any, in run order.
    pub fn run_members(&self) -> Vec<Vec<usize>> {
        let mut out = vec![Vec::new(); self.runs()];
        for (i, &r) in self.run.iter().enumerate() {
            out[r].push(i);
        }
        out.retain(|m| !m.is_empty());
        out
    }

    /// Index of each point's group, numbered in order of first appearance.
    pub fn group_ids(&self) -> Vec<usize> {
        let groups = self.groups();
        let mut ids = vec![0; self.len()];
        for (k, (_, members)) in groups.iter().enumerate() {
            for &i in members {
                ids[i] = k;
            }
        }
        ids
    }

    /// Each point's group index for a GP with per-group offsets when `offsets` is set; else
    /// none (empty), the GP without them.
    pub fn offset_groups(&self, offsets: bool) -> Vec<usize> {
        if offsets {
            self.group_ids()
        } else {
            Vec::new()
        }
    }

    /// Distinct groups in order of first appearance, with their member indices.
    pub fn groups(&self) -> Vec<(String, Vec<usize>)> {
        let mut out: Vec<(String, Vec<usize>)> = Vec::new();
        for (i, g) in self.group.iter().enumerate() {
            match out.iter_mut().find(|(name, _)| name == g) {
                Some((_, members)) => members.push(i),
                None => out.push((g.clone(), vec![i])),
            }
        }
        out
    }
}

/// The 60 s blocks of a stream's samples that [`Points::from_stream`] makes its points of.
pub(crate) fn stream_blocks(stream: &Stream) -> Vec<Vec<usize>> {
    stream.half_filled_blocks(&scored(stream))
}

/// Indices of a stream's samples that make points: with a reference rate, taken by the firmware.
pub(crate) fn scored(stream: &Stream) -> Vec<usize> {
    (0..stream.len())
        .filter(|&i| stream.rate_dps[i].is_finite() && accepted(&replay::sample(stream, i)))
        .collect()
}

/// Whether the firmware takes a sample as an input (not a `Fault`): its own pipeline decides,
/// so the host refuses exactly what the firmware would.
fn accepted(sample: &Sample) -> bool {
    let mut row = [0.0f32; POINT_FEATURES.len()];
    features::compute(
        &POINT_FEATURES,
        sample,
        &mut FeatureState::default(),
        &mut row,
    ) != Status::Fault
}

/// A rate model needs more than one reference rate; a bias model needs a usable scale factor.
fn check_scale_factor(
    path: &Path,
    rates: &[f64],
    scale_factor: Option<f64>,
) -> Result<(), PointsError> {
    match scale_factor {
        Some(k) if !k.is_finite() || k == 0.0 => Err(PointsError::BadScaleFactor(k)),
        Some(_) => Ok(()),
        None => match rates.first() {
            Some(&rate) if rates.iter().all(|&r| r == rate) => Err(PointsError::StaticLog {
                path: path.display().to_string(),
                rate,
            }),
            _ => Ok(()),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plateaus_split_on_gaps() {
        assert_eq!(
            plateaus(&[20.0, -30.0, 20.01, -29.98, 5.0]),
            vec![2, 0, 2, 0, 1]
        );
    }

    /// Lines 2… of a table with one row per value.
    fn lines(n: usize) -> Vec<u64> {
        (2..2 + n as u64).collect()
    }

    #[test]
    fn a_row_far_outside_the_others_is_implausible_and_plateaus_are_not() {
        // 140 rows over −30…60 °C and one at 250 °C (line 142).
        let mut t: Vec<f64> = (0..140)
            .map(|i| -30.0 + 90.0 * f64::from(i % 10) / 9.0)
            .collect();
        t.push(250.0);
        let bad = implausible("temp_c", &t, &lines(t.len()), IMPLAUSIBLE_TEMP_GAP_C);
        assert_eq!(bad.len(), 1);
        assert_eq!((bad[0].line, bad[0].value), (142, 250.0));
        assert_eq!(bad[0].others, [-30.0, 60.0]);
        // A plateau with rows of its own is protocol, even far from the rest.
        let mut plateau: Vec<f64> = vec![25.0; 140];
        plateau.extend([85.0; 10]);
        assert!(implausible("temp_c", &plateau, &lines(150), IMPLAUSIBLE_TEMP_GAP_C).is_empty());
        // One kelvin reading among °C, one rad/s… the wrong way round: °/s among rad/s.
        let mut kelvin: Vec<f64> = (0..50).map(|i| 20.0 + f64::from(i) / 5.0).collect();
        kelvin[17] = 298.15;
        let bad = implausible("temp_c", &kelvin, &lines(50), IMPLAUSIBLE_TEMP_GAP_C);
        assert_eq!(bad.iter().map(|r| r.line).collect::<Vec<_>>(), vec![19]);
        let mut rates: Vec<f64> = (0..60).map(|i| f64::from(i % 15 - 7) * 0.2).collect();
        rates[3] = 80.0;
        assert_eq!(implausible("rate_dps", &rates, &lines(60), 0.0).len(), 1);
        // A gap of 20 °C or less between a lone row and a narrow cluster is not enough.
        let mut near: Vec<f64> = vec![25.0; 30];
        near.push(44.0);
        assert!(implausible("temp_c", &near, &lines(31), IMPLAUSIBLE_TEMP_GAP_C).is_empty());
        // Small tables are not judged.
        assert!(implausible("temp_c", &[0.0, 1.0, 900.0], &lines(3), 20.0).is_empty());
    }

    #[test]
    fn an_implausible_row_is_refused_with_its_line_or_left_out_when_asked() {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        let mut csv = String::from("temp_c,voltage_v,rate_dps\n");
        for t in [-30.0, 0.0, 30.0, 60.0] {
            for w in [-80.0, -10.0, 10.0, 80.0] {
                csv.push_str(&format!("{t},{},{w}\n", 0.04 * w + 1e-3 * t));
            }
        }
        csv.push_str("250,0.5,10\n");
        std::io::Write::write_all(&mut f, csv.as_bytes()).unwrap();
        let e = Points::load(f.path(), &[], None, None)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 18, column temp_c: 250 lies far outside") && e.contains("--exclude"),
            "{e}"
        );
        let (p, left_out) =
            Points::load_screened(f.path(), &[], None, None, Screen::Exclude).unwrap();
        assert_eq!((p.len(), left_out.len()), (16, 1));
        assert!(p.temp_c.iter().all(|t| *t <= 60.0));
    }

    #[test]
    fn a_table_in_kelvin_is_refused_where_the_firmware_would_fault() {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        let mut csv = String::from("temp_c,voltage_v,rate_dps\n");
        for t in [243.15, 273.15, 303.15, 333.15] {
            for w in [-80.0, -10.0, 10.0, 80.0] {
                csv.push_str(&format!("{t},{},{w}\n", 0.04 * w));
            }
        }
        std::io::Write::write_all(&mut f, csv.as_bytes()).unwrap();
        let e = Points::load(f.path(), &[], None, None)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2: temperature 243.15 °C") && e.contains("firmware refuses"),
            "{e}"
        );
    }

    #[test]
    fn stream_samples_the_firmware_refuses_are_left_out_of_the_points() {
        let n = 100;
        let mut temp_c: Vec<f64> = (0..n).map(|i| 20.0 + 0.1 * i as f64).collect();
        temp_c[40] = 300.0;
        let stream = Stream {
            time_s: (0..n).map(|i| i as f64).collect(),
            temp_c,
            voltage_v: vec![0.5; n],
            rate_dps: (0..n).map(|i| (i % 7) as f64).collect(),
            lines: (2..n as u64 + 2).collect(),
            step_s: 1.0,
            time_issues: Vec::new(),
            handled: Vec::new(),
            history: 0,
            after_s: None,
        };
        let p = Points::from_stream_samples(Path::new("s.csv"), &stream, None).unwrap();
        assert_eq!(p.len(), n - 1);
        assert!(p.temp_c.iter().all(|t| *t < 200.0));
        assert!(p.inputs().iter().all(|v| v.is_finite()));
    }

    #[test]
    fn one_temperature_is_refused() {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        std::io::Write::write_all(&mut f, b"temp_c,voltage_v,rate_dps\n20,1,1\n20.01,2,2\n")
            .unwrap();
        let e = Points::load(f.path(), &[], None, None).unwrap_err();
        assert!(e.to_string().contains("span only 0.010 °C"), "{e}");
    }

    #[test]
    fn pooling_keeps_every_point_and_refuses_mixed_forms() {
        let points = |sf: Option<f64>, soaked: bool| {
            Points::new(
                vec![1.0, 2.0],
                vec![0.1, 0.2],
                vec![5.0, 6.0],
                vec!["a".into(), "b".into()],
                sf,
                soaked,
                None,
            )
        };
        let p = points(None, true).pooled(points(None, false)).unwrap();
        assert_eq!((p.len(), p.group.len(), p.soaked), (4, 4, false));
        // Each file pooled is a run of its own, numbered in order, and a selection keeps them.
        let three = p.pooled(points(None, true)).unwrap();
        assert_eq!(three.run, [0, 0, 1, 1, 2, 2]);
        assert_eq!(three.runs(), 3);
        assert_eq!(three.select(&[1, 4]).run, [0, 2]);
        assert_eq!(three.run_members(), [vec![0, 1], vec![2, 3], vec![4, 5]]);
        assert!(matches!(
            points(None, true).pooled(points(Some(1.0), true)),
            Err(PointsError::MixedForms)
        ));
    }
}
