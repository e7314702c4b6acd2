//! Logs as flight controllers record them: a PX4 ULog (`.ulg`) and an ArduPilot DataFlash log
//! (`.bin`), read as they are, with no conversion, no column map and no channels file.
//!
//! Each sensor instance of the log becomes a unit whose channels are its axes ([`Sensor`]):
//! a ULog's `sensor_gyro` and `sensor_accel` instances (`gyro0`, `accel1`, …, keyed by their
//! device IDs), a DataFlash log's `IMU` instances (`imu0`, …, whose gyro and accelerometer share
//! one temperature). A unit's channels ([`Channels::of_sensor`](crate::channels::Channels::of_sensor)) then go through every command as
//! those of a channels file do. The well-kept parsers of each ecosystem read the bytes
//! (`yule_log`, `ardupilot-binlog`); what is written here is what the project asks of a log: which
//! instances are sensors, in which units, and what about them a calibration must be told
//! ([`Recorded::notes`]).
//!
//! A bench log usually ends with a power cut: the file is read up to the damage, which is named
//! with its byte offset ([`Damage`]), and the samples before it are kept.

mod dataflash;
mod error;
mod framing;
mod rotation;
mod sensor;
#[cfg(test)]
mod tests;
mod ulog;
pub mod write;

pub use error::{Damage, Format, Progress, RecordedError};
pub use rotation::BoardRotation;
pub use sensor::{Axis, Correction, Finding, MIN_SPAN_C, Mounting, Sensor, gravity_reference};

use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The magic a ULog begins with (its header, before the version byte).
const ULOG_MAGIC: &[u8] = b"ULog\x01\x12\x35";
/// The bytes every DataFlash message begins with; a log's first message is a format (`FMT`, 128).
const DATAFLASH_HEAD: &[u8] = &[0xA3, 0x95, 0x80];

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

    /// The sensors a command takes where none is named: all but the learning means
    /// ([`Sensor::learned`]), or those where the log holds nothing else.
    pub fn taken(&self) -> impl Iterator<Item = &Arc<Sensor>> {
        let recorded = self.sensors.iter().any(|s| !s.learned);
        self.sensors
            .iter()
            .filter(move |s| !(recorded && s.learned))
    }

    /// What a calibration must be told about the log, a line each: its damage, then each kind of
    /// finding with the sensors it holds for, of those [`Self::taken`] ([`Sensor::findings`]),
    /// then what else it holds.
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
            self.taken().flat_map(|s| s.findings()).collect();
        findings.sort_by_key(|f| f.0);
        for group in findings.chunk_by(|a, b| a.0 == b.0) {
            let which: Vec<&str> = group.iter().map(|f| f.1.as_str()).collect();
            out.push(format!(
                "{}: {}",
                self.path.display(),
                group[0].0.line(&which.join(", "))
            ));
        }
        let learned: Vec<&str> = self
            .sensors
            .iter()
            .filter(|s| s.learned)
            .map(|s| s.name.as_str())
            .collect();
        if !learned.is_empty() && self.taken().any(|s| !s.learned) {
            out.push(format!(
                "{}: also holds the means its temperature learning logged (TCLR), the same \
                 sensors again: {}; taken when named (--sensor {})",
                self.path.display(),
                learned.join(", "),
                learned[0]
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
