//! What reading a flight controller's log can tell besides its samples: what kind of file it is,
//! why it cannot be read, where it stops being readable, and how far a long read has come.

use std::fmt;
use std::path::{Path, PathBuf};

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

/// Where a log stops being readable: a power cut's torn last message, or corruption.
#[derive(Debug, Clone, PartialEq)]
pub struct Damage {
    /// Byte offset of the first unreadable byte.
    pub offset: u64,
    /// What the parser found there.
    pub what: String,
}

/// Reports how far a long read has come: bytes read, bytes in the file.
pub type Progress<'a> = &'a mut dyn FnMut(u64, u64);

/// The file opened, and its size.
pub(super) fn open(path: &Path) -> Result<(std::fs::File, u64), RecordedError> {
    let io = |source| RecordedError::Io {
        path: path.to_owned(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let total = file.metadata().map_err(io)?.len();
    Ok((file, total))
}
