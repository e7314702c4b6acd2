//! `trainer` binary: parses the command line and reports errors; the work lives in the library.
//! Its allocator is mimalloc: the exact GP's n × n buffers are allocated and freed at every
//! likelihood, and glibc's allocator hands such large blocks back to the kernel each time, so a
//! fit would spend its time in page faults.

use std::process::ExitCode;

use clap::Parser;
use trainer::cli::{Cli, run};

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("trainer: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
