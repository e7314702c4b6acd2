//! Data in: rate-table points (or stream blocks) as the model's inputs and targets, and a
//! summary of a file as loaded ([`summary`]). The files themselves are read by [`fog_data`],
//! which the replay shares.

pub mod points;
pub mod summary;
