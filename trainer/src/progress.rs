//! Progress on long work: a bar on stderr when it is a terminal, nothing when stderr is piped or
//! the caller asked for quiet, so scripts and `--json` runs see only results.

use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};

/// A bar of `total` steps; hidden under `quiet` (indicatif hides it by itself off a terminal).
pub fn steps(total: u64, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total);
    if let Ok(style) =
        ProgressStyle::with_template("[{elapsed_precise}] {bar:30} {pos}/{len} {msg}")
    {
        bar.set_style(style);
    }
    bar.enable_steady_tick(Duration::from_millis(250));
    bar
}
