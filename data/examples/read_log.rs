//! Reads a flight controller's log as every command does, and says what it holds and how long the
//! read took: the measurement behind docs/performance.md's figure for a long log.
//!
//! `cargo run --release -p fog-data --example read_log -- LOG`

use std::path::PathBuf;
use std::time::Instant;

use fog_data::autopilot::Recorded;

fn main() -> anyhow::Result<()> {
    let path: PathBuf = std::env::args_os()
        .nth(1)
        .map(PathBuf::from)
        .ok_or_else(|| anyhow::anyhow!("usage: read_log LOG"))?;
    let bytes = std::fs::metadata(&path)?.len();
    let start = Instant::now();
    let log = Recorded::read(&path, &mut |_, _| {})?.ok_or_else(|| {
        anyhow::anyhow!("{}: a CSV, not a flight controller's log", path.display())
    })?;
    let s = start.elapsed().as_secs_f64();
    let samples: usize = log.sensors.iter().map(|s| s.len()).sum();
    println!(
        "{}: {:.2} GB read in {s:.1} s ({:.0} MB/s): {samples} samples of {}",
        path.display(),
        bytes as f64 / 1e9,
        bytes as f64 / 1e6 / s,
        log.listing()
    );
    Ok(())
}
