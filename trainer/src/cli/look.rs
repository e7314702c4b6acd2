//! `trainer summarize`: a file as the loader sees it, before anything is fitted.

use std::path::{Path, PathBuf};

use clap::Args;
use firmware_sim::console::{Console, ConsoleFlags};
use firmware_sim::data::log::Maps;
use firmware_sim::data::stream::Stream;
use firmware_sim::io::{ensure_not_input, write_json};

use crate::data::points::{Points, Screen};
use crate::data::summary::{self, Summary};

/// The arguments of `trainer summarize`.
#[derive(Args)]
pub(super) struct SummarizeArgs {
    /// Rate-table points CSV.
    #[arg(long, required_unless_present = "stream")]
    points: Option<PathBuf>,
    /// Stream or static log CSV.
    #[arg(long)]
    stream: Option<PathBuf>,
    #[command(flatten)]
    maps: Maps,
    /// A static table's nominal scale factor (as `fit` would need it), output units per °/s.
    #[arg(long, value_name = "K")]
    scale_factor: Option<f64>,
    /// The summaries as JSON (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// A table's summary, with the rows the implausible-row screen would refuse listed as left out.
pub(super) fn points_summary(
    path: &Path,
    maps: &Maps,
    scale_factor: Option<f64>,
) -> anyhow::Result<Summary> {
    let (points, left_out) =
        Points::load_screened(path, &maps.list, None, scale_factor, Screen::Exclude)?;
    Ok(summary::of_points(
        &path.display().to_string(),
        &points,
        &maps.list,
        &left_out,
    ))
}

/// A stream's summary.
pub(super) fn stream_summary(path: &Path, maps: &Maps) -> anyhow::Result<Summary> {
    let stream = Stream::load(path, &maps.list)?;
    Ok(summary::of_stream(
        &path.display().to_string(),
        &stream,
        &maps.list,
    ))
}

/// `trainer summarize`: each file's summary, as text and JSON.
pub(super) fn summarize_command(args: SummarizeArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let SummarizeArgs {
        points,
        stream,
        maps,
        scale_factor,
        json,
    } = args;
    let console = Console::new(flags, json.as_deref());
    let inputs: Vec<&Path> = points.iter().chain(&stream).map(PathBuf::as_path).collect();
    if let Some(out) = &json {
        ensure_not_input(out, &inputs)?;
    }
    let mut all = Vec::new();
    if let Some(p) = &points {
        all.push(points_summary(p, &maps, scale_factor)?);
    }
    if let Some(s) = &stream {
        all.push(stream_summary(s, &maps)?);
    }
    for s in &all {
        console.result(s.text().trim_end());
    }
    if let Some(out) = &json {
        write_json(out, &inputs, &all)?;
    }
    Ok(())
}
