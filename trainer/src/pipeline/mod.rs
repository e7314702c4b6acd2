//! What the commands do, as a library: each takes a plan (its settings, checked once by whoever
//! built it) and the data already read, and returns a typed result; it says its choices as it
//! makes them through [`crate::progress::Messages`]. The command line builds the plans from its
//! flags and prints or writes the results; the Python package and the tests call the same code.

pub mod fit;
pub mod source;
