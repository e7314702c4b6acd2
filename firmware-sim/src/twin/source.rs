//! The measured data identification reads: rate-table points (in file order, or in time where
//! the table has a clock) and a stream's referenced samples, as one record type.

use std::path::Path;

use serde::Serialize;

use fog_data::columns::{self, ColumnMap, DataError};
use fog_data::stream::Stream;

/// One measurement: a rate-table point or a stream sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Record {
    /// When, s (a stream's clock, or a time-ordered table's); `None` for a table without one.
    pub time_s: Option<f64>,
    /// Temperature-sensor reading, °C.
    pub temp_c: f64,
    /// Gyro output (V, counts, °/s …).
    pub output: f64,
    /// Reference rate, °/s.
    pub rate_dps: f64,
}

/// Measured data of one kind, in time (or file) order.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// What it is, for the report: `points` or `stream`.
    pub kind: SourceKind,
    /// The measurements.
    pub records: Vec<Record>,
    /// The chamber's setpoint of each measurement, °C, where the file has one (a simulated rate
    /// table's `setpoint_c`): the sensor's reading above it, soaked, is the self-heating.
    pub setpoint_c: Option<Vec<f64>>,
}

/// The kind of a [`Measured`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum SourceKind {
    /// Averaged rate-table points.
    Points,
    /// A stream of samples.
    Stream,
}

impl Measured {
    pub(super) fn timed(&self) -> bool {
        self.records.iter().all(|r| r.time_s.is_some())
    }
}

/// Loads a rate-table points CSV as identification reads it: `temp_c`, `voltage_v`, `rate_dps`,
/// and `time_s` where `--map` gives one (a table recorded in time order).
pub fn load_points(path: &Path, maps: &[ColumnMap]) -> Result<Measured, DataError> {
    let timed = maps.iter().any(|m| m.name == "time_s");
    let mut numeric = vec!["temp_c", "voltage_v", "rate_dps"];
    if timed {
        numeric.push("time_s");
    }
    // A simulated table carries the chamber's setpoint; a real one may, under that name.
    let header = std::fs::read_to_string(path)
        .ok()
        .and_then(|t| t.lines().next().map(str::to_owned));
    let with_setpoint = maps.iter().any(|m| m.name == "setpoint_c")
        || header.is_some_and(|h| h.split([',', '\t']).any(|c| c.trim() == "setpoint_c"));
    if with_setpoint {
        numeric.push("setpoint_c");
    }
    let c = columns::read_columns(path, &numeric, &[], &[], maps)?;
    let time = timed.then(|| c.get("time_s"));
    Ok(Measured {
        kind: SourceKind::Points,
        records: (0..c.len())
            .map(|i| Record {
                time_s: time.map(|t| t[i]),
                temp_c: c.get("temp_c")[i],
                output: c.get("voltage_v")[i],
                rate_dps: c.get("rate_dps")[i],
            })
            .collect(),
        setpoint_c: with_setpoint.then(|| c.get("setpoint_c").to_vec()),
    })
}

impl From<&Stream> for Measured {
    /// The samples with a reference rate (those without, e.g. where the unit was handled, say
    /// nothing of the map).
    fn from(s: &Stream) -> Self {
        Measured {
            kind: SourceKind::Stream,
            records: s
                .referenced()
                .into_iter()
                .map(|i| Record {
                    time_s: Some(s.time_s[i]),
                    temp_c: s.temp_c[i],
                    output: s.voltage_v[i],
                    rate_dps: s.rate_dps[i],
                })
                .collect(),
            setpoint_c: None,
        }
    }
}
