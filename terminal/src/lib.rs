//! The command line's edge, shared by `trainer` and `firmware-sim` so that both read a log by the
//! same flags and speak to the person at the terminal the same way.
//!
//! - [`log`]: the flags every command that reads a log takes (`--stream`, `--map`, `--exclude`,
//!   `--window`, `--channels`), and the loader that applies them through [`fog_data`] and says in
//!   one line what it left out;
//! - [`console`]: results on stdout, progress and details on stderr, by the same `--quiet`,
//!   `--verbose` and `--json`;
//! - [`io`]: files written whole or not at all, never over an input, and JSON stamped with its
//!   [`schema`];
//! - [`mod@reference`]: docs/commands.md's flag tables and contracts, rendered from the code;
//! - [`plot`]: the canvas, axes and colours of every figure, as SVG text.
//!
//! The libraries below take no type from here: what they compute comes back as values, and only
//! the command lines print it.

pub mod console;
pub mod io;
pub mod log;
pub mod plot;
pub mod reference;
pub mod schema;
