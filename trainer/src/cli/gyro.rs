//! The measured gyro's noise, read from its logs: `trainer allan` (its noise terms; the bench's
//! `firmware-sim identify` makes the simulator's twin of it).

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use firmware_core::Quantity;
use fog_data::allan;
use fog_data::channels::Channels;
use fog_data::replay;
use fog_data::stream::Stream;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_atomically, write_json, write_json_list};
use fog_terminal::log::LogArgs;
use fog_terminal::schema;

use crate::plot;

/// The arguments of `trainer allan`.
#[derive(Args)]
pub(super) struct AllanArgs {
    #[command(flatten)]
    log: LogArgs,
    /// The output in °/s as output / K (K in output units per °/s): the raw gyro.
    #[arg(long, conflicts_with = "model", required_unless_present_any = ["model", "channels"])]
    scale_factor: Option<f64>,
    /// The output in °/s as this model compensates it: the compensated gyro.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Write tau_s, adev_dps and the noise terms as JSON here (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw the Allan deviation with the lines its terms come from, as SVG.
    #[arg(long)]
    plot: Option<PathBuf>,
}

/// `trainer allan`: the Allan deviation of a log's rate, raw (output / K) or compensated by a
/// model, less the reference where the log has one throughout; its noise terms and figure (every
/// channel's, with `--channels`, on one figure).
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
        .chain(model.as_deref())
        .collect();
    inputs.extend(log.unit.channels.as_deref());
    for out in json.iter().chain(&plot) {
        ensure_not_input(out, &inputs)?;
    }
    if let Some(channels) = log.unit.load(Some(stream), &console)? {
        return allan_unit(
            (&log, &channels),
            model.as_deref(),
            (json.as_deref(), plot.as_deref()),
            &inputs,
            &console,
        );
    }
    let data = log.load(&console)?;
    let rate: (Vec<f64>, String) = match (&model, scale_factor) {
        (Some(path), _) => {
            let bytes =
                std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
            let fw = fog_data::replay::decode(&bytes)
                .with_context(|| format!("decoding {}", path.display()))?;
            let comp = fog_data::replay::means(&fw, &data);
            (
                comp.rate_dps.iter().map(|&w| f64::from(w)).collect(),
                format!("the output compensated by {}", path.display()),
            )
        }
        (None, Some(k)) => {
            anyhow::ensure!(
                k.is_finite() && k != 0.0,
                "--scale-factor {k}: a scale factor is a finite non-zero number"
            );
            (
                data.voltage_v.iter().map(|v| v / k).collect(),
                format!("output / {k}"),
            )
        }
        (None, None) => anyhow::bail!("give --scale-factor K or --model M"),
    };
    let analysis = analyse(stream, &data, rate, &console)?;
    console.result(&analysis.text());
    quantization(
        &data,
        (scale_factor.filter(|_| model.is_none()), &analysis),
        &console,
    );
    if let Some(path) = &json {
        write_json(path, &inputs, schema::ALLAN, &analysis)?;
    }
    if let Some(path) = &plot {
        let curve = analysis.curve();
        let svg = plot::allan(
            &format!("Allan deviation: {}", analysis.of),
            &[plot::AllanSeries {
                label: &analysis.of,
                colour: plot::BLUE,
                curve: &curve,
                terms: analysis.terms,
            }],
        )?;
        write_atomically(path, svg.as_bytes())?;
    }
    Ok(())
}

/// The Allan analysis of `rate` (and what it is, in words) of a log, less the reference where the
/// log has one: the samples without (handled windows, the windows `--exclude` names) are left out
/// of the clusters, not fed in raw.
fn analyse(
    path: &Path,
    data: &Stream,
    (rate, what): (Vec<f64>, String),
    console: &Console,
) -> anyhow::Result<allan::Analysis> {
    let referenced = data.rate_dps.iter().any(|r| r.is_finite());
    let left_out = data.rate_dps.iter().filter(|r| !r.is_finite()).count();
    if referenced && left_out > 0 {
        console.result(&format!(
            "left out of the Allan deviation: the {left_out} samples without a reference (the \
             windows above); it is computed over the stretches between them"
        ));
    }
    let analysis = allan::Analysis::less_reference(&what, &data.time_s, &rate, &data.rate_dps);
    analysis
        .enough()
        .with_context(|| path.display().to_string())?;
    Ok(analysis)
}

/// What the quantizer of a log's output adds to its white noise, where the output moves in whole
/// steps: how much of the measured term is the quantizer's, with the scale factor that makes it a
/// rate.
fn quantization(data: &Stream, (k, analysis): (Option<f64>, &allan::Analysis), console: &Console) {
    let Some(step) = fog_data::stats::quantization_step(&data.voltage_v) else {
        return;
    };
    match (k, analysis.terms.arw_deg_per_sqrt_h) {
        (Some(k), Some(arw)) => {
            let q = allan::quantization_arw(step / k.abs(), analysis.tau0_s);
            if q >= 0.3 * arw {
                console.warn(&format!(
                    "the output is quantized in steps of {step:e} (a logger that keeps every \
                     n-th raw sample rather than averaging): the steps alone make a random walk \
                     of {q:.4}, {:.0}% of the {arw:.4} measured, which is the quantizer's as \
                     much as the sensor's",
                    100.0 * q / arw
                ));
            }
        }
        _ => console.warn(&format!(
            "the output is quantized in steps of {step:e}: the quantizer adds white noise of \
             step/√12 per sample to the random walk"
        )),
    }
}

/// One channel's Allan analysis, as `allan --channels --json` writes it: its figures in `units`.
#[derive(serde::Serialize)]
struct ChannelAllan {
    name: String,
    quantity: Quantity,
    units: &'static str,
    #[serde(flatten)]
    analysis: allan::Analysis,
}

/// `trainer allan --channels`: every channel of a unit's log, raw (its output in its quantity's
/// unit, or over its scale factor) or compensated by the unit's blob; one line each, one figure
/// with a panel per quantity.
fn allan_unit(
    (log, channels): (&LogArgs, &Channels),
    model: Option<&Path>,
    (json, figure): (Option<&Path>, Option<&Path>),
    inputs: &[&Path],
    console: &Console,
) -> anyhow::Result<()> {
    let streams = log.load_unit(channels, console)?;
    let compensated = match model {
        Some(path) => {
            let bytes =
                std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
            let unit = replay::decode_unit(&bytes)
                .with_context(|| format!("decoding {}", path.display()))?;
            let names: Vec<&str> = channels.list.iter().map(|c| c.name.as_str()).collect();
            let ordered = replay::in_unit_order(&unit, &names, &streams)
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            let comps = replay::replay_unit(&unit, &ordered, false);
            // Back in the channels file's order.
            let mut by_name: Vec<Option<Vec<f64>>> = vec![None; channels.len()];
            for (ch, comp) in unit.channels().iter().zip(comps) {
                if let Some(k) = names.iter().position(|n| *n == ch.name()) {
                    by_name[k] = Some(comp.rate_dps.iter().map(|&w| f64::from(w)).collect());
                }
            }
            Some((path, by_name))
        }
        None => None,
    };
    let mut out = Vec::new();
    for (k, (ch, data)) in channels.list.iter().zip(&streams).enumerate() {
        let rate = match &compensated {
            Some((path, by_name)) => by_name[k]
                .clone()
                .map(|r| (r, format!("{} compensated by {}", ch.name, path.display()))),
            None => ch.bias_scale_factor().map(|s| {
                (
                    data.voltage_v.iter().map(|v| v / s).collect(),
                    format!("{} raw", ch.name),
                )
            }),
        };
        let Some(rate) = rate else {
            console.result(&format!(
                "{}: skipped: {}",
                ch.name,
                if compensated.is_some() {
                    "the blob has no such channel"
                } else {
                    "a raw output without a scale_factor in the channels file"
                }
            ));
            continue;
        };
        let analysis = analyse(&log.stream, data, rate, console)?;
        console.result(&format!("{}: {}", ch.name, analysis.text_in(ch.quantity)));
        out.push(ChannelAllan {
            name: ch.name.clone(),
            quantity: ch.quantity,
            units: ch.quantity.unit(),
            analysis,
        });
    }
    if let Some(path) = json {
        write_json_list(path, inputs, schema::ALLAN_UNIT, "channels", &out)?;
    }
    if let Some(path) = figure {
        let curves: Vec<allan::Curve> = out.iter().map(|c| c.analysis.curve()).collect();
        let mut panels: Vec<(Quantity, Vec<plot::AllanSeries<'_>>)> = Vec::new();
        for (k, (c, curve)) in out.iter().zip(&curves).enumerate() {
            let series = plot::AllanSeries {
                label: &c.name,
                colour: plot::CHANNEL_COLOURS[k % plot::CHANNEL_COLOURS.len()],
                curve,
                terms: c.analysis.terms,
            };
            match panels.iter_mut().find(|(q, _)| *q == c.quantity) {
                Some((_, s)) => s.push(series),
                None => panels.push((c.quantity, vec![series])),
            }
        }
        let title = match model {
            Some(m) => format!("compensated by {}", m.display()),
            None => "raw".to_owned(),
        };
        let svg = plot::allan_unit(&format!("Allan deviation, {title}"), &panels)?;
        write_atomically(path, svg.as_bytes())?;
    }
    Ok(())
}
