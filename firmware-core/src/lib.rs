//! Evaluates FOG temperature-drift compensation models on the gyro's microcontroller.
//!
//! `no_std`, no allocation, no `unsafe`, no panics on data paths: a model is decoded from a blob
//! ([`blob`]) into fixed-size storage whose capacities the integrator chooses ([`model::Model`]),
//! and evaluated in f32; a whole sensor unit's channels (an IMU's gyro and accelerometer axes)
//! come in one blob ([`blob::unit`]) and are evaluated together ([`unit::Unit`]). The host trainer
//! builds its blobs with these same types.
#![cfg_attr(not(test), no_std)]

pub mod blob;
pub mod error;
pub mod features;
pub mod model;
pub mod record;
pub mod slots;
pub mod status;
#[cfg(test)]
mod testing;
pub mod unit;
pub mod units;

pub use blob::{Beyond, Dims, ErrorModel, Feature, Limits};
pub use error::{BlobError, PredictError};
pub use features::{FeatureState, MAX_FEATURES, MAX_INPUTS, Sample};
pub use model::{Evaluation, MAX_CENTRES, Mean, Model, Prediction, Prepared};
pub use slots::{Calibration, Flash, FlashError, Layout, LayoutError, Slot, SlotError};
pub use status::Status;
pub use unit::{StaticUnit, Unit, UnitSample};
pub use units::Quantity;

/// The firmware-integration guide, whose Rust example is compiled and run as a doc test of this
/// crate (its other blocks are shell and text).
#[cfg(doctest)]
#[doc = include_str!("../../docs/firmware.md")]
struct FirmwareGuide;
