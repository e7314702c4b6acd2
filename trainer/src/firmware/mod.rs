//! A fitted model as the firmware will run it: the blob, and the checks that the firmware's f32
//! evaluation follows the host's f64 one; a unit's channels packed into one blob ([`mod@unit`]).

pub mod autopilot;
pub mod export;
pub mod unit;
