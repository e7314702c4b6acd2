//! The measured gyro's noise, read from its logs: `trainer allan` (its noise terms; the bench's
//! `firmware-sim identify` makes the simulator's twin of it).

use std::path::{Path, PathBuf};

use clap::Args;
use fog_data::allan::{Analysis, Curve};
use fog_data::channels::Channel;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_atomically, write_json};
use fog_terminal::log::LogArgs;
use fog_terminal::schema::{self, PerChannel};

use super::sensors::{Blob, units_of_blobs};
use crate::pipeline::ChannelEntry;
use crate::pipeline::allan::{self, Output};
use crate::plot;
use fog_terminal::log::Each;

/// The arguments of `trainer allan`.
#[derive(Args)]
pub(super) struct AllanArgs {
    #[command(flatten)]
    log: LogArgs,
    /// The output in °/s as output / K (K in output units per °/s): the raw gyro, for a log of
    /// one channel (a unit's channels take theirs from its channels file; a flight controller's
    /// log is in °/s already).
    #[arg(long, conflicts_with = "model")]
    scale_factor: Option<f64>,
    /// The output in °/s as this model compensates it: the compensated gyro. With a flight
    /// controller's log, a sensor's blob compensates the sensor it names; give several
    /// (`--model fit.gyro0.bin fit.gyro1.bin`) for several.
    #[arg(long, num_args = 1..)]
    model: Vec<PathBuf>,
    /// Write tau_s, adev_dps and the noise terms as JSON here (`-`: stdout, alone; one per
    /// sensor beside this name where a flight controller's log holds several).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw the Allan deviation with the lines its terms come from, as SVG (one per sensor, as
    /// --json).
    #[arg(long)]
    plot: Option<PathBuf>,
}

/// `trainer allan`: the Allan deviation of a log's rate, raw (output / K) or compensated by a
/// model, less the reference where the log has one throughout; its noise terms and figure (every
/// channel's, for a unit, on one figure; each sensor's, of a flight controller's log).
pub(super) fn allan_command(args: AllanArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let AllanArgs {
        log,
        scale_factor,
        model,
        json,
        plot,
    } = args;
    let console = Console::new(flags, json.as_deref());
    let stream = &log.stream;
    let mut inputs: Vec<&Path> = std::iter::once(stream.as_path())
        .chain(model.iter().map(PathBuf::as_path))
        .collect();
    inputs.extend(log.unit.channels.as_deref());
    for out in json.iter().chain(&plot) {
        ensure_not_input(out, &inputs)?;
    }
    let blobs = Blob::read(&model)?;
    let mut units = log.unit.units(Some(stream), &console)?;
    for unit in &mut units {
        anyhow::ensure!(
            !unit.single || scale_factor.is_some() || !blobs.is_empty(),
            "give --scale-factor K or --model M"
        );
        unit.take_scale_factor(scale_factor)?;
    }
    let pairs: Vec<_> = if blobs.is_empty() {
        units.into_iter().map(|u| (u, None)).collect()
    } else {
        units_of_blobs(units, blobs, stream)?
            .into_iter()
            .map(|(u, b)| (u, Some(b)))
            .collect()
    };
    let each = Each::new(pairs.len(), stream, json.as_deref())?;
    for (channels, blob) in &pairs {
        each.heading(channels, &console);
        let label = blob.as_ref().map(|b| b.path.display().to_string());
        let output = match (blob, &label) {
            (Some(b), Some(label)) => Output::Compensated {
                blob: &b.bytes,
                label,
            },
            _ => Output::Raw,
        };
        let analysed = (|| {
            let streams = log.load_unit(channels, &console)?;
            allan::unit(
                &stream.display().to_string(),
                (channels, &streams),
                output,
                &console,
            )
        })()
        .map_err(|e| each.naming(channels, e))?;
        let mut read = inputs.clone();
        read.push(&channels.path);
        if let Some(path) = &json {
            let entries: Vec<_> = analysed
                .iter()
                .map(|(c, a)| ChannelEntry::new(c, a))
                .collect();
            let path = each.file(channels, path);
            let body = PerChannel { channels: &entries };
            write_json(&path, &read, schema::ALLAN, &body)?;
        }
        if let Some(path) = &plot {
            let title = match &label {
                Some(m) => format!("compensated by {m}"),
                None => "raw".to_owned(),
            };
            let svg = figure(&format!("Allan deviation, {title}"), &analysed)?;
            write_atomically(&each.file(channels, path), svg.as_bytes())?;
        }
    }
    Ok(())
}

/// A unit's Allan deviations on one figure, a panel per quantity.
fn figure(title: &str, analysed: &[(&Channel, Analysis)]) -> anyhow::Result<String> {
    let curves: Vec<Curve> = analysed.iter().map(|(_, a)| a.curve()).collect();
    let mut panels: Vec<(firmware_core::Quantity, Vec<plot::AllanSeries<'_>>)> = Vec::new();
    for (k, ((c, a), curve)) in analysed.iter().zip(&curves).enumerate() {
        let series = plot::AllanSeries {
            label: &c.name,
            colour: plot::CHANNEL_COLOURS[k % plot::CHANNEL_COLOURS.len()],
            curve,
            terms: a.terms,
        };
        match panels.iter_mut().find(|(q, _)| *q == c.quantity) {
            Some((_, s)) => s.push(series),
            None => panels.push((c.quantity, vec![series])),
        }
    }
    Ok(plot::allan_unit(title, &panels)?)
}
