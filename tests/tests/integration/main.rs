//! Cross-crate integration tests: one binary, one module per capability.

mod autopilot;
mod c;
mod cli;
mod diagnosis;
mod docs;
mod firmware;
mod layers;
mod m4;
mod paper;
mod real;
mod report;
mod service;
mod sigma;
mod sparse;
mod twin;
mod unit;

use std::path::{Path, PathBuf};

/// Runs `firmware-sim` with these arguments, in process.
pub fn sim(args: &[&str]) -> anyhow::Result<()> {
    use clap::Parser;
    let argv = std::iter::once("firmware-sim").chain(args.iter().copied());
    firmware_sim::cli::run(firmware_sim::cli::Cli::try_parse_from(argv)?)
}

/// Runs `trainer` with these arguments, in process.
pub fn trainer(args: &[&str]) -> anyhow::Result<()> {
    use clap::Parser;
    let argv = std::iter::once("trainer").chain(args.iter().copied());
    trainer::cli::run(trainer::cli::Cli::try_parse_from(argv)?)
}

/// A path inside `dir`, as a string for argument lists.
pub fn at(dir: &Path, name: &str) -> String {
    dir.join(name).display().to_string()
}

/// Reads a JSON file.
pub fn json(path: impl Into<PathBuf>) -> serde_json::Value {
    let text = std::fs::read_to_string(path.into()).expect("JSON output exists");
    serde_json::from_str(&text).expect("valid JSON")
}

/// The MIT-licensed MEMS thermal-cycle log copied in `tests/data/`.
pub fn imu() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/tofupilot-imu-thermal/imu_raw_data.tsv")
        .display()
        .to_string()
}

/// The MEMS log's time, temperature and (static) reference columns; the gyro axis is mapped by
/// each test.
pub const IMU_MAPS: [&str; 6] = [
    "--map",
    "time_s=timestamp*1e-6",
    "--map",
    "temp_c=imu.temperature",
    "--map",
    "rate_dps=0",
];
