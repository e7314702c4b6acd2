//! The test bench below the trainer: a simulated open-loop FOG with its rigs, the project's data
//! files, and the replay of a stream through firmware-core (docs/design.md §1).
//!
//! - [`gyro`]: the simulated gyro, thermal chamber and rate table, with the hidden physical effects
//!   named by [`cause`]; every number it produces can be reproduced from a seed.
//! - [`data`]: the CSV formats, read as the trainer and the replay read them (the writers are in
//!   [`gyro::output`]), so one crate holds both sides of each format (docs/design.md §3).
//! - [`replay`]: every sample of a stream through the firmware evaluator (host build) and its
//!   scores; [`qemu`]: the same on the Cortex-M4F image under QEMU; [`c_replay`]: the same
//!   through firmware-core's C interface, from a C program; [`flash`]: NOR flash with power
//!   cuts, for the firmware's calibration slots.
//! - [`console`], [`io`], [`cli`]: what the person at the terminal sees, how files are written,
//!   and the `firmware-sim` command line; the trainer's command line uses the first two as well.

pub mod c_replay;
pub mod cause;
pub mod cli;
pub mod console;
pub mod data;
pub mod flash;
pub mod gyro;
pub mod io;
pub mod qemu;
pub mod replay;
pub mod sigma;
pub mod source_tree;
pub mod stats;
