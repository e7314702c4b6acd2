//! `trainer` binary: parses the command line and reports errors; the work lives in the library.
//! Its allocator is mimalloc: the exact GP's n × n buffers, allocated and freed at every
//! likelihood, went back to the kernel under glibc each time (a leave-one-sweep-out run spent 4–9 s
//! of system time on it, 0.8 s with mimalloc; docs/performance.md).

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
