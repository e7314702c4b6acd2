//! `trainer summarize`: a file as the loader sees it, before anything is fitted.

use std::path::{Path, PathBuf};

use clap::Args;
use fog_data::channels::{Channels, Read};
use fog_data::columns::Source;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_json};
use fog_terminal::log::{Maps, UnitArgs};
use fog_terminal::schema::{self, PerFile};

use crate::data::points::{Points, Screen};
use crate::data::summary::{self, Summary};
use firmware_core::Quantity;
use serde::Serialize;

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
    let units = unit.units(stream.as_deref(), &console)?;
    if let Some(first) = units.first() {
        anyhow::ensure!(
            scale_factor.is_none(),
            "--scale-factor is for one channel: a unit's channels give theirs in {}",
            first.path.display()
        );
        let mut all = Vec::new();
        for channels in &units {
            if let Some(p) = points.as_ref().filter(|_| channels.recorded.is_none()) {
                let each = unit_summaries(p, channels, &maps, Read::Table)?;
                console.result(unit_text(channels, &each).trim_end());
                all.push(SummarizedFile::Unit(each));
            }
            if let Some(s) = &stream {
                let each = unit_summaries(s, channels, &maps, Read::Log)?;
                console.result(unit_text(channels, &each).trim_end());
                all.push(SummarizedFile::Unit(each));
            }
        }
        if let Some(out) = &json {
            write_json(out, &inputs, schema::SUMMARIZE, &PerFile { files: &all })?;
        }
        return Ok(());
    }
    let mut all = Vec::new();
    if let Some(p) = &points {
        all.push(summary::of_points_file(p, &maps.list, scale_factor)?);
    }
    if let Some(s) = &stream {
        all.push(summary::of_stream_file(s, &maps.list)?);
    }
    for s in &all {
        console.result(s.text().trim_end());
    }
    let all: Vec<SummarizedFile> = all
        .into_iter()
        .map(|s| SummarizedFile::File(Box::new(s)))
        .collect();
    if let Some(out) = &json {
        write_json(out, &inputs, schema::SUMMARIZE, &PerFile { files: &all })?;
    }
    Ok(())
}

/// What `summarize --json` lists under `files`, per file: its summary, or (a unit's file) each
/// channel's.
#[derive(Serialize, schemars::JsonSchema)]
#[serde(untagged)]
pub(super) enum SummarizedFile {
    /// A file of one channel.
    File(Box<Summary>),
    /// A unit's file: each channel's summary.
    Unit(Vec<ChannelSummary>),
}

/// One channel of a unit's file, summarized (`summarize --channels --json`: one per channel).
#[derive(Serialize, schemars::JsonSchema)]
pub(super) struct ChannelSummary {
    channel: String,
    quantity: Quantity,
    units: &'static str,
    #[serde(flatten)]
    summary: Summary,
}

/// Each channel's summary of the file at `path`, read as `read` (a log once for all channels,
/// with its time and handling checked once; a table with each channel's columns).
pub(super) fn unit_summaries(
    path: &Path,
    channels: &Channels,
    maps: &Maps,
    read: Read,
) -> anyhow::Result<Vec<ChannelSummary>> {
    let file = path.display().to_string();
    let streams = match read {
        Read::Log => Some(channels.load_log(path, &maps.list)?),
        Read::Table => None,
    };
    channels
        .list
        .iter()
        .enumerate()
        .map(|(k, ch)| {
            let own = channels.maps(k, &maps.list, read)?;
            let summary = match &streams {
                Some(s) => {
                    let summary = summary::of_stream(&file, &s[k], &own);
                    match (&channels.recorded, &ch.output) {
                        (Some(sensor), Source::Column { name, .. }) => {
                            summary.recorded_from(sensor, name)
                        }
                        _ => summary,
                    }
                }
                None => {
                    let (points, left_out) =
                        Points::load_screened(path, &own, None, ch.scale_factor, Screen::Exclude)?;
                    summary::of_points(&file, &points, &own, &left_out)
                }
            };
            Ok(ChannelSummary {
                channel: ch.name.clone(),
                quantity: ch.quantity,
                units: ch.quantity.unit(),
                summary,
            })
        })
        .collect()
}

/// A unit's file as text: what the channels share once (the file's rows, time, temperature,
/// sampling and what was left out), then a line per channel.
pub(super) fn unit_text(channels: &Channels, each: &[ChannelSummary]) -> String {
    let Some(first) = each.first() else {
        return String::new();
    };
    let shared = first.summary.shared_text(&format!(
        "a unit of {} channels{}",
        channels.len(),
        if channels.sensor_id.is_empty() {
            String::new()
        } else {
            format!(", sensor '{}'", channels.sensor_id)
        }
    ));
    let mut s = shared;
    for (ch, c) in channels.list.iter().zip(each) {
        s.push_str(
            &c.summary
                .channel_text(&ch.name, &ch.unit.to_string(), ch.quantity),
        );
    }
    s
}
