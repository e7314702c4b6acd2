//! Logs as flight controllers record them: a PX4 ULog (`.ulg`) and an ArduPilot DataFlash log
//! (`.bin`), read as they are, with no conversion, no column map and no channels file.
//!
//! Each sensor instance of the log becomes a unit whose channels are its axes ([`Sensor`]):
//! a ULog's `sensor_gyro` and `sensor_accel` instances (`gyro0`, `accel1`, …, keyed by their
//! device IDs), a DataFlash log's `IMU` instances (`imu0`, …, whose gyro and accelerometer share
//! one temperature). A unit's channels ([`Sensor::channels`]) then go through every command as
//! those of a channels file do. The well-kept parsers of each ecosystem read the bytes
//! (`yule_log`, `ardupilot-binlog`); what is written here is what the project asks of a log: which
//! instances are sensors, in which units, and what about them a calibration must be told
//! ([`Recorded::notes`]).
//!
//! A bench log usually ends with a power cut: the file is read up to the damage, which is named
//! with its byte offset ([`Damage`]), and the samples before it are kept.

mod dataflash;
mod framing;
#[cfg(test)]
mod tests;
mod ulog;
pub mod write;

use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use firmware_core::Quantity;
use firmware_core::units::STANDARD_GRAVITY;

use crate::channels::{Channel, Channels, OutputUnit};
use crate::columns::Source;
use crate::stream::{self, Stream};

/// What kind of file a log is, told by its first bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Text: read as CSV.
    Csv,
    /// A PX4 ULog.
    ULog,
    /// An ArduPilot DataFlash log.
    DataFlash,
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Csv => "a CSV",
            Self::ULog => "a PX4 ULog",
            Self::DataFlash => "an ArduPilot DataFlash log",
        })
    }
}

/// The magic a ULog begins with (its header, before the version byte).
const ULOG_MAGIC: &[u8] = b"ULog\x01\x12\x35";
/// The bytes every DataFlash message begins with; a log's first message is a format (`FMT`, 128).
const DATAFLASH_HEAD: &[u8] = &[0xA3, 0x95, 0x80];

/// A log that cannot be read as one.
#[derive(Debug, thiserror::Error)]
pub enum RecordedError {
    /// Unreadable.
    #[error("{path}: cannot read ({source})")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Neither a CSV, a ULog nor a DataFlash log.
    #[error(
        "{path}: neither a CSV, a PX4 ULog nor an ArduPilot DataFlash log: it begins with {found}"
    )]
    Unknown {
        /// The file.
        path: PathBuf,
        /// What it begins with, and what that looks like.
        found: String,
    },
    /// Recognized, but broken before any sensor sample.
    #[error("{path}: {format} damaged before any sensor sample: {what}")]
    Damaged {
        /// The file.
        path: PathBuf,
        /// What it was recognized as.
        format: Format,
        /// The parser's words, with the byte offset.
        what: String,
    },
    /// Read, but it holds no gyro or accelerometer.
    #[error("{path}: {format} with no gyro or accelerometer samples (it holds: {found})")]
    NoSensor {
        /// The file.
        path: PathBuf,
        /// What it was recognized as.
        format: Format,
        /// The topics or message types it holds.
        found: String,
    },
    /// A sensor named that the log does not hold.
    #[error("{path}: no sensor '{asked}' (it holds: {found})")]
    NoSuchSensor {
        /// The file.
        path: PathBuf,
        /// The name asked.
        asked: String,
        /// The sensors it holds.
        found: String,
    },
}

/// Tells what kind of log `path` is by its first bytes; a binary file of neither format is
/// refused, with what it begins with.
pub fn sniff(path: &Path) -> Result<Format, RecordedError> {
    let io = |source| RecordedError::Io {
        path: path.to_owned(),
        source,
    };
    let mut head = Vec::with_capacity(512);
    std::fs::File::open(path)
        .map_err(io)?
        .take(512)
        .read_to_end(&mut head)
        .map_err(io)?;
    if head.starts_with(ULOG_MAGIC) {
        return Ok(Format::ULog);
    }
    if head.starts_with(DATAFLASH_HEAD) {
        return Ok(Format::DataFlash);
    }
    // Text is CSV (its reader says what is wrong with it); a zero byte or bytes that are not UTF-8
    // (a multi-byte character cut at the 512th byte aside) are a binary file of another kind.
    let text = match std::str::from_utf8(&head) {
        Ok(_) => true,
        Err(e) => e.error_len().is_none(),
    };
    if text && !head.contains(&0) {
        return Ok(Format::Csv);
    }
    Err(RecordedError::Unknown {
        path: path.to_owned(),
        found: describe(&head),
    })
}

/// The first bytes of a binary file, in hex, and what they look like where they are a known magic.
fn describe(head: &[u8]) -> String {
    let hex: Vec<String> = head.iter().take(8).map(|b| format!("{b:02X}")).collect();
    let looks = [
        (&b"PK\x03\x04"[..], "a zip archive"),
        (&b"\x1f\x8b"[..], "a gzip file"),
        (&b"%PDF"[..], "a PDF"),
        (&b"\x89PNG"[..], "a PNG image"),
        (&b"\x7fELF"[..], "an executable"),
        (&b"ULog"[..], "a ULog header of an unknown version"),
        (
            &b"\xA3\x95"[..],
            "a DataFlash message that is not a format (a log cut at its start?)",
        ),
    ]
    .into_iter()
    .find(|(magic, _)| head.starts_with(magic))
    .map_or(String::new(), |(_, what)| format!(" ({what})"));
    format!("bytes {}{looks}", hex.join(" "))
}

/// Where a log stops being readable: a power cut's torn last message, or corruption.
#[derive(Debug, Clone, PartialEq)]
pub struct Damage {
    /// Byte offset of the first unreadable byte.
    pub offset: u64,
    /// What the parser found there.
    pub what: String,
}

/// One axis of a sensor instance.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// Its channel name (`x`, `gyr.x`, `acc.z`).
    pub name: String,
    /// What it measures (its values in °/s or m/s²).
    pub quantity: Quantity,
    /// Its samples, converted to the quantity's unit.
    pub values: Vec<f64>,
}

/// One sensor instance of a log: a unit whose channels are its axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Its name in the project (`gyro0`, `accel1`, `imu0`): the topic or message and instance.
    pub name: String,
    /// The topic or message type it was read from (`sensor_gyro`, `IMU`).
    pub topic: String,
    /// Its instance in the log.
    pub instance: u8,
    /// The device ID it reported first (ULog), where it reports one.
    pub device_id: Option<u32>,
    /// Where the device ID changes mid-log: (time s from the first sample, the new ID).
    pub id_changes: Vec<(f64, u32)>,
    /// Sample times, s from the log's start.
    pub time_s: Vec<f64>,
    /// Its temperature, °C; empty where the log has no temperature for it.
    pub temp_c: Vec<f64>,
    /// Its axes.
    pub axes: Vec<Axis>,
    /// Samples left out because their temperature or an axis was not a number.
    pub unreadable: usize,
}

impl Sensor {
    /// Its ID in a unit blob (at most 32 bytes): the device ID where the log gives one, else the
    /// name.
    pub fn sensor_id(&self) -> String {
        match self.device_id {
            Some(id) => format!("{} {id}", self.name),
            None => self.name.clone(),
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// True when it has no sample.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// Its channels, as a channels file would name them: each axis's output in its quantity's
    /// unit, its reference that of a board at rest (no rotation; gravity along the axis nearest
    /// the vertical, from the first minute's median: [`gravity_reference`]).
    pub fn channels(self: &Arc<Self>, path: &Path) -> Channels {
        let list = self
            .axes
            .iter()
            .map(|a| Channel {
                name: a.name.clone(),
                quantity: a.quantity,
                unit: match a.quantity {
                    Quantity::AngularRate => OutputUnit::DegreePerSecond,
                    Quantity::SpecificForce => OutputUnit::MetrePerSecond2,
                },
                output: Source::Column {
                    name: a.name.clone(),
                    factor: 1.0,
                },
                reference: Source::Constant(match a.quantity {
                    Quantity::AngularRate => 0.0,
                    Quantity::SpecificForce => gravity_reference(&self.time_s, &a.values),
                }),
                scale_factor: None,
            })
            .collect();
        Channels {
            path: path.to_owned(),
            sensor_id: self.sensor_id(),
            time: None,
            temperature: None,
            list,
            recorded: Some(Arc::clone(self)),
        }
    }

    /// One stream per axis, sharing the time and temperature, the handled minutes screened on
    /// every axis as in a channels file's log ([`Channels::load_log`]). Each sample's "line" is its
    /// 1-based ordinal among the sensor's samples.
    pub fn streams(&self, references: &[f64]) -> Vec<Stream> {
        let lines: Vec<u64> = (1..=self.len() as u64).collect();
        let (step_s, time_issues) = stream::time_checks(&self.time_s, &lines);
        let mut data: Vec<(Vec<f64>, Vec<f64>)> = self
            .axes
            .iter()
            .zip(references)
            .map(|(a, &r)| (a.values.clone(), vec![r; self.len()]))
            .collect();
        let handled = stream::screen_unit_handling(&self.time_s, &mut data, &lines);
        data.into_iter()
            .map(|(voltage_v, rate_dps)| Stream {
                time_s: self.time_s.clone(),
                temp_c: self.temp_c.clone(),
                voltage_v,
                rate_dps,
                lines: lines.clone(),
                step_s,
                time_issues: time_issues.clone(),
                handled: handled.clone(),
            })
            .collect()
    }

    /// Leaves out the samples whose temperature (where it has one) or an axis is not a number.
    fn keep_numbers(&mut self) {
        let keep: Vec<bool> = (0..self.len())
            .map(|i| {
                self.temp_c.get(i).is_none_or(|t| t.is_finite())
                    && self.axes.iter().all(|a| a.values[i].is_finite())
            })
            .collect();
        let lost = keep.iter().filter(|k| !**k).count();
        if lost == 0 {
            return;
        }
        let pick = |v: &mut Vec<f64>| {
            if v.len() == keep.len() {
                let mut k = keep.iter();
                v.retain(|_| *k.next().unwrap_or(&false));
            }
        };
        pick(&mut self.time_s);
        pick(&mut self.temp_c);
        for a in &mut self.axes {
            pick(&mut a.values);
        }
        self.unreadable += lost;
    }

    /// What a calibration must be told about this sensor: each finding as (kind, what of this
    /// sensor), so that a log's sensors alike are said in one line ([`Recorded::notes`]): no
    /// temperature, a temperature in whole degrees, a span under [`MIN_SPAN_C`], samples that are
    /// not numbers, a device ID that changes.
    pub fn findings(&self) -> Vec<(Finding, String)> {
        let mut out = Vec::new();
        let name = &self.name;
        if self.temp_c.is_empty() {
            out.push((Finding::NoTemperature, name.clone()));
        } else {
            if self.temp_c.len() > 1 && self.temp_c.iter().all(|t| t.fract() == 0.0) {
                out.push((Finding::WholeDegrees, name.clone()));
            }
            let (lo, hi) = self
                .temp_c
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &t| {
                    (lo.min(t), hi.max(t))
                });
            if hi - lo < MIN_SPAN_C {
                out.push((
                    Finding::NarrowSpan,
                    format!("{name} {:.1} °C ({lo:.1} to {hi:.1})", hi - lo),
                ));
            }
        }
        if self.unreadable > 0 {
            out.push((
                Finding::NotNumbers,
                format!("{name} {} samples", self.unreadable),
            ));
        }
        if let Some(&(t, id)) = self.id_changes.first() {
            out.push((
                Finding::IdChanges,
                format!(
                    "{name} at {t:.1} s ({} to {id}{})",
                    self.device_id.unwrap_or_default(),
                    if self.id_changes.len() > 1 {
                        format!(", and {} more times", self.id_changes.len() - 1)
                    } else {
                        String::new()
                    }
                ),
            ));
        }
        out
    }
}

/// What a calibration must be told about a sensor of a log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Finding {
    /// The log records no temperature for it.
    NoTemperature,
    /// Its temperature is in whole degrees.
    WholeDegrees,
    /// Its temperature spans less than [`MIN_SPAN_C`].
    NarrowSpan,
    /// Some samples were not numbers.
    NotNumbers,
    /// Its device ID changes mid-log.
    IdChanges,
}

impl Finding {
    /// The line that says it, of the sensors `which`.
    fn line(self, which: &str) -> String {
        match self {
            Self::NoTemperature => {
                format!("no temperature recorded for {which}: no thermal model can be fitted to it")
            }
            Self::WholeDegrees => format!(
                "the temperature of {which} is quantized to whole degrees: the model sees the \
                 1 °C steps, and a lag fitted on them is coarse"
            ),
            Self::NarrowSpan => format!(
                "the temperature spans under the {MIN_SPAN_C:.0} °C a thermal calibration needs: \
                 {which}; the curve beyond is a guess"
            ),
            Self::NotNumbers => {
                format!("samples left out, their temperature or an axis not a number: {which}")
            }
            Self::IdChanges => format!(
                "the device ID changes: {which}; another sensor answered as this instance, and \
                 its samples are read as one sensor's"
            ),
        }
    }
}

/// The smallest temperature span a thermal calibration should cover (PX4's and ArduPilot's
/// guides ask for a cold soak well below and a warm-up well above the flying range).
pub const MIN_SPAN_C: f64 = 10.0;

/// An accelerometer axis's reference on a board at rest: the component of gravity along it, taken
/// as −g, 0 or +g, whichever is nearest the median of its first minute (a board level to within a
/// few degrees; its tilt is a constant the model takes as bias).
pub fn gravity_reference(time_s: &[f64], values: &[f64]) -> f64 {
    let t0 = time_s.first().copied().unwrap_or(0.0);
    let mut first: Vec<f64> = time_s
        .iter()
        .zip(values)
        .take_while(|(t, _)| **t - t0 < 60.0)
        .map(|(_, v)| *v)
        .filter(|v| v.is_finite())
        .collect();
    first.sort_by(f64::total_cmp);
    let median = first.get(first.len() / 2).copied().unwrap_or(0.0);
    [-STANDARD_GRAVITY, 0.0, STANDARD_GRAVITY]
        .into_iter()
        .min_by(|a, b| (a - median).abs().total_cmp(&(b - median).abs()))
        .unwrap_or(0.0)
}

/// A log as recorded: its sensors, what else it holds, and where it stops being readable.
#[derive(Debug, Clone)]
pub struct Recorded {
    /// The file.
    pub path: PathBuf,
    /// Its format.
    pub format: Format,
    /// Its gyro and accelerometer instances, in the log's order.
    pub sensors: Vec<Arc<Sensor>>,
    /// The other sensor topics it holds, with their sample counts (`sensor_baro 0`: listed, not
    /// calibrated).
    pub others: Vec<(String, usize)>,
    /// Where it stops being readable, if it does.
    pub damage: Option<Damage>,
}

/// Reports how far a long read has come: bytes read, bytes in the file.
pub type Progress<'a> = &'a mut dyn FnMut(u64, u64);

/// What a format's reader returns: the sensors, the other sensor topics with their counts, and
/// the damage where the log stops being readable.
type Collected = (Vec<Sensor>, Vec<(String, usize)>, Option<Damage>);

/// The file opened, and its size.
fn open(path: &Path) -> Result<(std::fs::File, u64), RecordedError> {
    let io = |source| RecordedError::Io {
        path: path.to_owned(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let total = file.metadata().map_err(io)?.len();
    Ok((file, total))
}

impl Recorded {
    /// Reads a ULog or a DataFlash log (told by its content, [`sniff`]); `progress` hears how far
    /// the read has come. A CSV is not one: `Ok(None)`.
    pub fn read(path: &Path, progress: Progress<'_>) -> Result<Option<Self>, RecordedError> {
        let format = sniff(path)?;
        let read = match format {
            Format::Csv => return Ok(None),
            Format::ULog => ulog::read(path, progress)?,
            Format::DataFlash => dataflash::read(path, progress)?,
        };
        let (mut sensors, others, damage) = read;
        for s in &mut sensors {
            s.keep_numbers();
        }
        sensors.retain(|s| !s.is_empty());
        if sensors.is_empty() {
            if let Some(d) = damage {
                return Err(RecordedError::Damaged {
                    path: path.to_owned(),
                    format,
                    what: format!("at byte {}: {}", d.offset, d.what),
                });
            }
            let found: Vec<String> = others.iter().map(|(t, n)| format!("{t} ({n})")).collect();
            return Err(RecordedError::NoSensor {
                path: path.to_owned(),
                format,
                found: if found.is_empty() {
                    "no sensor topic".to_owned()
                } else {
                    found.join(", ")
                },
            });
        }
        Ok(Some(Self {
            path: path.to_owned(),
            format,
            sensors: sensors.into_iter().map(Arc::new).collect(),
            others,
            damage,
        }))
    }

    /// What a calibration must be told about the log, a line each: its damage, then each kind of
    /// finding with the sensors it holds for ([`Sensor::findings`]), then what else it holds.
    pub fn notes(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(d) = &self.damage {
            out.push(format!(
                "{}: unreadable from byte {} ({}): read up to there (a power cut's torn last \
                 message is the usual end of a bench log)",
                self.path.display(),
                d.offset,
                d.what
            ));
        }
        let mut findings: Vec<(Finding, String)> =
            self.sensors.iter().flat_map(|s| s.findings()).collect();
        findings.sort_by_key(|f| f.0);
        for group in findings.chunk_by(|a, b| a.0 == b.0) {
            let which: Vec<&str> = group.iter().map(|f| f.1.as_str()).collect();
            out.push(format!(
                "{}: {}",
                self.path.display(),
                group[0].0.line(&which.join(", "))
            ));
        }
        if !self.others.is_empty() {
            let others: Vec<String> = self
                .others
                .iter()
                .map(|(t, n)| format!("{t} ({n})"))
                .collect();
            out.push(format!(
                "{}: also holds {}: listed, not calibrated",
                self.path.display(),
                others.join(", ")
            ));
        }
        out
    }

    /// The sensors named `names` (all where none is named), each as a unit's channels.
    pub fn units(&self, names: &[String]) -> Result<Vec<Channels>, RecordedError> {
        if names.is_empty() {
            return Ok(self
                .sensors
                .iter()
                .map(|s| s.channels(&self.path))
                .collect());
        }
        names
            .iter()
            .map(|n| {
                self.sensors
                    .iter()
                    .find(|s| &s.name == n)
                    .map(|s| s.channels(&self.path))
                    .ok_or_else(|| RecordedError::NoSuchSensor {
                        path: self.path.clone(),
                        asked: n.clone(),
                        found: self.listing(),
                    })
            })
            .collect()
    }

    /// Its sensors, named with their IDs: `gyro0 (ID 2621444), accel0 (ID 2490372)`.
    pub fn listing(&self) -> String {
        let names: Vec<String> = self
            .sensors
            .iter()
            .map(|s| match s.device_id {
                Some(id) => format!("{} (ID {id})", s.name),
                None => s.name.clone(),
            })
            .collect();
        names.join(", ")
    }
}
