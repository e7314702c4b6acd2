//! `trainer summarize`: a file as the loader sees it, before anything is fitted (the work is
//! [`crate::pipeline::summarize`]'s).

use std::path::{Path, PathBuf};

use clap::Args;
use fog_data::channels::{Channels, Read};
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_json};
use fog_terminal::log::{Maps, UnitArgs};
use fog_terminal::schema::{self, PerFile};

use crate::pipeline::summarize::{unit_summaries, unit_text};

/// The arguments of `trainer summarize`.
#[derive(Args)]
pub(super) struct SummarizeArgs {
    /// Rate-table points CSV.
    #[arg(long, required_unless_present = "stream")]
    points: Option<PathBuf>,
    /// Stream or static log: a CSV, or a flight controller's log (PX4 ULog, ArduPilot
    /// DataFlash), each of its sensors summarized as a unit.
    #[arg(long)]
    stream: Option<PathBuf>,
    #[command(flatten)]
    maps: Maps,
    /// A static table's nominal scale factor (as `fit` would need it), output units per °/s.
    #[arg(long, value_name = "K")]
    scale_factor: Option<f64>,
    #[command(flatten)]
    unit: UnitArgs,
    /// The summaries as JSON (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// `trainer summarize`: each file's summary, as text and JSON.
pub(super) fn summarize_command(args: SummarizeArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let SummarizeArgs {
        points,
        stream,
        maps,
        scale_factor,
        unit,
        json,
    } = args;
    let console = Console::new(flags, json.as_deref());
    let mut inputs: Vec<&Path> = points.iter().chain(&stream).map(PathBuf::as_path).collect();
    inputs.extend(unit.channels.as_deref());
    if let Some(out) = &json {
        ensure_not_input(out, &inputs)?;
    }
    let mut units = unit.units(stream.as_deref(), &console)?;
    if let (true, Some(table)) = (units.is_empty(), &points) {
        units.push(Channels::single(table));
    }
    let mut all = Vec::new();
    for channels in &mut units {
        channels.take_scale_factor(scale_factor)?;
        if let Some(p) = points.as_ref().filter(|_| channels.recorded.is_none()) {
            let each = unit_summaries(p, channels, &maps.list, Read::Table)?;
            console.result(unit_text(channels, &each).trim_end());
            all.push(each);
        }
        if let Some(s) = &stream {
            let each = unit_summaries(s, channels, &maps.list, Read::Log)?;
            console.result(unit_text(channels, &each).trim_end());
            all.push(each);
        }
    }
    if let Some(out) = &json {
        write_json(out, &inputs, schema::SUMMARIZE, &PerFile { files: &all })?;
    }
    Ok(())
}
