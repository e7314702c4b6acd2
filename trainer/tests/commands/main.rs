//! The trainer as its users meet it: the binary as a script sees it, and degenerate and
//! malformed data. One test binary, so that one link serves them all and their tests run side by
//! side.

mod cli;
mod degenerate_data;
mod malformed_csv;
