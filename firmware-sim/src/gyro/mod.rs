//! The simulated gyro and its rigs: the open-loop FOG ([`plant`]), the hidden physical effects
//! ([`effects`]), the paper's rate-table protocol ([`paper`]), the chamber-ramp stream
//! ([`stream`]), their CSV output ([`output`]), the unit file that names one gyro
//! ([`mod@unit`]), and a unit of several axes ([`axes`]).

pub mod axes;
pub mod effects;
pub mod output;
pub mod paper;
pub mod plant;
pub mod stream;
pub mod unit;
