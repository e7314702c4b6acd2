//! The simulated gyro and its rigs: the open-loop FOG ([`plant`]), the hidden physical effects
//! ([`effects`]), the paper's rate-table protocol ([`paper`]), the chamber-ramp stream
//! ([`stream`]), and their CSV output ([`output`]).

pub mod effects;
pub mod output;
pub mod paper;
pub mod plant;
pub mod stream;
