//! Errors of blob decoding and prediction: a small `Copy` enum, cheap to return and log.

use core::fmt;

/// Why a blob was refused (or could not be written).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum BlobError {
    /// The first four bytes are not the blob magic (of a model blob, or of a unit blob where
    /// either is read).
    BadMagic,
    /// A format version this firmware does not read.
    UnsupportedVersion(u16),
    /// Fewer bytes than the header says.
    Truncated,
    /// More bytes than the header says.
    TrailingBytes,
    /// The payload's CRC does not match the header's.
    CrcMismatch,
    /// The model needs more room than the integrator's capacity.
    CapacityExceeded {
        /// Which storage is too small.
        what: Storage,
        /// Elements the blob needs.
        needed: usize,
        /// Elements the capacity holds.
        capacity: usize,
    },
    /// The payload is not a valid postcard encoding of the model.
    Malformed,
    /// The payload's sizes disagree with the header's dimensions.
    InconsistentDimensions,
    /// A number in the blob is NaN or infinite (index into the flat array).
    NonFinite(usize),
    /// A number is out of its domain (a scale or length scale ≤ 0, a negative variance, a
    /// non-positive factor diagonal, an input range with min > max).
    InvalidParameter,
    /// The output buffer is too small for the blob (encoding).
    BufferTooSmall,
    /// A blob of this format version has no sequence number, so it cannot go into a calibration
    /// slot (re-export it with this trainer).
    NoSequence(u16),
}

/// The storage a capacity refers to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Storage {
    /// Inputs (`D`).
    Inputs,
    /// Prior-mean exponents (`E`).
    Exponents,
    /// The flat f32 array (`N`; a unit's: every channel's together).
    Floats,
    /// A unit's channels (`C`).
    Channels,
    /// The features a unit's channels share, computed once per sample
    /// ([`crate::features::MAX_FEATURES`]).
    Features,
}

impl fmt::Display for BlobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BadMagic => write!(f, "not a model blob (bad magic)"),
            Self::UnsupportedVersion(v) => write!(f, "unsupported blob format version {v}"),
            Self::Truncated => write!(f, "blob truncated"),
            Self::TrailingBytes => write!(f, "blob longer than its header says"),
            Self::CrcMismatch => write!(f, "blob CRC mismatch (corrupted)"),
            Self::CapacityExceeded {
                what,
                needed,
                capacity,
            } => write!(
                f,
                "blob needs {needed} {what:?} but the capacity is {capacity}"
            ),
            Self::Malformed => write!(f, "blob payload is malformed"),
            Self::InconsistentDimensions => write!(f, "blob sizes disagree with its header"),
            Self::NonFinite(i) => write!(f, "blob number {i} is not finite"),
            Self::InvalidParameter => write!(f, "blob parameter out of its domain"),
            Self::BufferTooSmall => write!(f, "output buffer too small for the blob"),
            Self::NoSequence(v) => write!(
                f,
                "a format version {v} blob has no sequence number for a calibration slot: \
                 re-export it"
            ),
        }
    }
}

/// So that host code can carry it as a cause (`?` into `anyhow`, `#[source]` in `thiserror`).
impl core::error::Error for BlobError {}

/// A prediction could not be made (the inputs themselves are flagged in the prediction's status).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PredictError {
    /// The scratch buffer for the variance is shorter than the number of centres.
    ScratchTooSmall {
        /// Elements needed.
        needed: usize,
    },
    /// A unit's sample carries fewer outputs than the unit has channels.
    TooFewOutputs {
        /// Outputs needed: one per channel.
        needed: usize,
    },
    /// Fewer result slots than the unit has channels.
    ResultsTooShort {
        /// Slots needed: one per channel.
        needed: usize,
    },
}

impl fmt::Display for PredictError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::ScratchTooSmall { needed } => {
                write!(f, "variance scratch buffer needs {needed} elements")
            }
            Self::TooFewOutputs { needed } => {
                write!(
                    f,
                    "the sample needs an output for each of the {needed} channels"
                )
            }
            Self::ResultsTooShort { needed } => {
                write!(f, "the results need room for each of the {needed} channels")
            }
        }
    }
}

impl core::error::Error for PredictError {}
