//! The bench as its users meet it: the binary as a script sees it, the calibration slots on
//! simulated NOR flash, and the twin of a measured gyro. One test binary, so that one link serves
//! them all.

mod cli;
mod slots;
mod twin;
