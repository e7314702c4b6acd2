//! `trainer` binary: parses the command line and reports errors; the work lives in the library.

use std::process::ExitCode;

use clap::Parser;
use trainer::cli::{Cli, run};

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("trainer: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
