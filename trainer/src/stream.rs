//! Time-series streams (DESIGN §3 `stream`): `time_s,temp_c,voltage_v,rate_dps`, the reference
//! rate empty where unknown.
//!
//! Time is checked, not trusted: a step that goes backwards or repeats a timestamp, and a gap
//! longer than [`GAP_FACTOR`] times the typical step, are collected as [`TimeIssue`]s so that every
//! command that uses the stream can report them (and stateful features can restart there) instead
//! of silently differentiating across them.

use std::path::Path;

use crate::data::{self, ColumnMap, DataError};

/// A step longer than this many typical steps is a gap.
pub const GAP_FACTOR: f64 = 3.0;

/// What is wrong with the time between two rows.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum TimeIssue {
    /// Time went backwards at this line.
    Backwards {
        /// 1-based line in the file.
        line: u64,
        /// The step, s (negative).
        step_s: f64,
    },
    /// The timestamp repeats the previous one.
    Duplicate {
        /// 1-based line in the file.
        line: u64,
    },
    /// A step much longer than the typical one.
    Gap {
        /// 1-based line in the file.
        line: u64,
        /// The step, s.
        step_s: f64,
    },
}

impl TimeIssue {
    /// The 1-based file line of the row where the issue shows.
    pub fn line(&self) -> u64 {
        match *self {
            Self::Backwards { line, .. } | Self::Duplicate { line } | Self::Gap { line, .. } => {
                line
            }
        }
    }
}

/// A loaded stream.
#[derive(Debug, Clone)]
pub struct Stream {
    /// Time, s.
    pub time_s: Vec<f64>,
    /// Temperature-sensor reading, °C.
    pub temp_c: Vec<f64>,
    /// Gyro output.
    pub voltage_v: Vec<f64>,
    /// Reference rate, °/s; NaN where unknown.
    pub rate_dps: Vec<f64>,
    /// 1-based line of each row.
    pub lines: Vec<u64>,
    /// Typical (median) time step, s.
    pub step_s: f64,
    /// Time problems found, in file order.
    pub time_issues: Vec<TimeIssue>,
}

impl Stream {
    /// Loads a stream CSV (any delimiter and column names, through `maps`).
    pub fn load(path: &Path, maps: &[ColumnMap]) -> Result<Self, DataError> {
        let c = data::read_columns(
            path,
            &["time_s", "temp_c", "voltage_v", "rate_dps"],
            &["rate_dps"],
            &[],
            maps,
        )?;
        let time_s = c.get("time_s").to_vec();
        let mut steps: Vec<f64> = time_s
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|d| *d > 0.0)
            .collect();
        steps.sort_by(f64::total_cmp);
        let typical = steps.get(steps.len() / 2).copied().unwrap_or(1.0);
        let time_issues = time_s
            .windows(2)
            .zip(&c.lines[1..])
            .filter_map(|(w, &line)| {
                let step_s = w[1] - w[0];
                if step_s < 0.0 {
                    Some(TimeIssue::Backwards { line, step_s })
                } else if step_s == 0.0 {
                    Some(TimeIssue::Duplicate { line })
                } else if step_s > GAP_FACTOR * typical {
                    Some(TimeIssue::Gap { line, step_s })
                } else {
                    None
                }
            })
            .collect();
        Ok(Self {
            time_s,
            temp_c: c.get("temp_c").to_vec(),
            voltage_v: c.get("voltage_v").to_vec(),
            rate_dps: c.get("rate_dps").to_vec(),
            lines: c.lines,
            step_s: typical,
            time_issues,
        })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// True when empty (never, once loaded).
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(text: &str) -> Result<Stream, DataError> {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        std::io::Write::write_all(&mut f, text.as_bytes()).unwrap();
        Stream::load(f.path(), &[])
    }

    #[test]
    fn empty_reference_is_unknown_and_time_problems_are_collected() {
        let s = load(
            "time_s,temp_c,voltage_v,rate_dps\n0,20,0.1,1\n1,20,0.1,\n2,20,0.1,1\n2,20,0.1,1\n\
             1.5,20,0.1,1\n10,20,0.1,1\n11,20,0.1,1\n",
        )
        .unwrap();
        assert_eq!(s.len(), 7);
        assert!(s.rate_dps[1].is_nan());
        assert_eq!(s.step_s, 1.0);
        assert_eq!(
            s.time_issues,
            vec![
                TimeIssue::Duplicate { line: 5 },
                TimeIssue::Backwards {
                    line: 6,
                    step_s: -0.5
                },
                TimeIssue::Gap {
                    line: 7,
                    step_s: 8.5
                },
            ]
        );
    }

    #[test]
    fn an_empty_temperature_is_still_an_error() {
        let e = load("time_s,temp_c,voltage_v,rate_dps\n0,,0.1,1\n").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
    }
}
