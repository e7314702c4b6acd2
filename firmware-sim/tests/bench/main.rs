//! The bench as its users meet it: the binary as a script sees it, and the calibration slots on
//! simulated NOR flash. One test binary, so that one link serves both.

mod cli;
mod slots;
