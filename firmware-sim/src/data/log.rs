//! A log as every command reads it, in both programs: the `--map` and `--exclude` flags, and the
//! loader that applies them with a `--window` and says in one line what it left out.

use std::path::PathBuf;

use clap::Args;

use crate::console::Console;
use crate::data::columns::ColumnMap;
use crate::data::stream::Window;

/// The `--map` flag of every data-reading command, in both programs.
#[derive(Args, Clone, Default)]
pub struct Maps {
    /// Map a canonical column onto a source column, COLUMN*FACTOR, or a constant (repeatable).
    #[arg(long = "map", value_name = "NAME=SOURCE")]
    pub list: Vec<ColumnMap>,
}

/// The `--exclude` flag of every command that reads a log, in both programs.
#[derive(Args, Clone, Default)]
pub struct Excludes {
    /// Leave START:END out of every fit, score and Allan deviation, as a handled window is (s
    /// from the log's first sample; repeatable): a handling event the screening missed, a door
    /// opened, a cable touched.
    #[arg(long = "exclude", id = "exclude", value_name = "START:END")]
    pub list: Vec<Window>,
}

/// One log and how to read it: the flags of every command that reads one log.
#[derive(Args, Clone)]
pub struct LogArgs {
    /// Stream or static log CSV: time_s,temp_c,voltage_v,rate_dps (rate_dps may be empty where
    /// unknown).
    #[arg(long)]
    pub stream: PathBuf,
    #[command(flatten)]
    maps: Maps,
    #[command(flatten)]
    exclude: Excludes,
    /// Use only this part of the stream: START:END, s from its first sample (either end open).
    #[arg(long)]
    pub window: Option<Window>,
}

impl LogArgs {
    /// The log, loaded as [`load_log`] loads it.
    pub fn load(&self, console: &Console) -> anyhow::Result<crate::data::stream::Stream> {
        load_log(
            &self.stream,
            &self.maps.list,
            (self.window, &self.exclude.list),
            console,
        )
    }
}

/// Loads a log as the commands read it: `exclude` left out (s from its first sample), then the
/// part inside `window` kept. The windows left out (the handled ones the loader found and those
/// named) are said in one line, each under `--verbose`; the time problems a line each.
pub fn load_log(
    path: &std::path::Path,
    maps: &[ColumnMap],
    (window, exclude): (Option<Window>, &[Window]),
    console: &Console,
) -> anyhow::Result<crate::data::stream::Stream> {
    let mut s = crate::data::stream::Stream::load(path, maps)?;
    s.exclude(exclude)?;
    let s = match window {
        Some(w) => {
            let part = s.window(w);
            anyhow::ensure!(
                part.len() >= 2,
                "{}: the window {w} s holds {} samples",
                path.display(),
                part.len()
            );
            part
        }
        None => s,
    };
    if s.time_issues.len() <= 3 {
        for issue in &s.time_issues {
            console.warn(&format!("{} {issue}", path.display()));
        }
    } else {
        console.warn(&format!(
            "{}: {} time problems (jumps, steps back, repeated stamps), the first {} (each with -v)",
            path.display(),
            s.time_issues.len(),
            s.time_issues[0]
        ));
        for issue in &s.time_issues {
            console.detail(&format!("{} {issue}", path.display()));
        }
    }
    if let Some(line) = crate::data::stream::left_out_summary(&s.handled) {
        console.warn(&format!("{}: {line}", path.display()));
    }
    for h in &s.handled {
        console.detail(&format!("{} {h}", path.display()));
    }
    Ok(s)
}
