//! The test bench: a simulated open-loop FOG with its rigs, and the firmware run as it runs on the
//! gyro (docs/design.md §1). What a log is, and its replay through firmware-core on the host, are
//! [`fog_data`]'s, under this crate and the trainer alike.
//!
//! - [`gyro`]: the simulated gyro, thermal chamber and rate table, with the hidden physical effects
//!   named by [`fog_data::cause`]; every number it produces can be reproduced from a seed.
//! - [`qemu`]: a stream through the Cortex-M4F image under QEMU; [`c_replay`]: the same through
//!   firmware-core's C interface, from a C program; [`flash`]: NOR flash with power cuts, for the
//!   firmware's calibration slots.
//! - [`twin`]: the simulator's twin of a measured gyro, its parameters and missing effects fitted
//!   to the gyro's table and logs, so that the bench simulates that gyro.
//! - [`cli`]: the `firmware-sim` command line, on [`fog_terminal`]'s flags and console as the
//!   trainer's.

pub mod board;
pub mod c_replay;
pub mod cli;
pub mod flash;
pub mod gyro;
pub mod qemu;
pub mod source_tree;
pub mod twin;
