//! Simulated open-loop FOG with its test rigs (thermal chamber, rate table), and the tools that write
//! what it produces in the project's CSV formats (docs/design.md §3).
//!
//! The simulator is the ground truth of the project's tests: every number it produces can be
//! reproduced from a seed, and the physics behind it is documented in [`plant`].

pub mod challenge;
pub mod cli;
pub mod effects;
pub mod output;
pub mod paper;
pub mod plant;
pub mod qemu;
pub mod stream;
