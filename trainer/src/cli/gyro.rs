//! The measured gyro's own properties, read from its logs: `trainer allan` (its noise terms) and
//! `trainer identify` (the simulator's twin of it, with the effects the twin lacks).

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use firmware_core::Quantity;
use firmware_sim::gyro::axes::{Axes, Axis};
use fog_data::channels::{Channels, Read};
use fog_data::replay;
use fog_data::stream::Stream;
use fog_data::stream::Window;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_atomically, write_json, write_json_list};
use fog_terminal::log::{Excludes, LogArgs, Maps, UnitArgs, load_unit_log};
use fog_terminal::schema;

use super::inputs::load_stream;
use crate::analysis::{allan, twin};
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

/// The arguments of `trainer identify`.
#[derive(Args)]
pub(super) struct IdentifyArgs {
    /// Rate-table points CSV: temp_c,voltage_v,rate_dps (and time_s, through --map, for a table
    /// recorded in time order).
    #[arg(long, required_unless_present = "stream")]
    points: Option<PathBuf>,
    /// Stream or static log CSV: time_s,temp_c,voltage_v,rate_dps.
    #[arg(long)]
    stream: Option<PathBuf>,
    #[command(flatten)]
    maps: Maps,
    /// Use only this part of the stream: START:END, s from its first sample.
    #[arg(long, requires = "stream")]
    window: Option<Window>,
    #[command(flatten)]
    exclude: Excludes,
    /// Nominal scale factor, output units per °/s, where the data show none (a static log).
    #[arg(long)]
    scale_factor: Option<f64>,
    #[command(flatten)]
    unit: UnitArgs,
    /// The unit file to write (`firmware-sim generate paper|stream --unit FILE` simulates it).
    #[arg(long)]
    out: PathBuf,
    /// Every parameter (value, standard error, determined or why not), the candidates tried and
    /// the fidelity before and after, as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// The held-out difference between measured and twin, before and after, as SVG.
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
    if let Some(channels) = log.unit.load()? {
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
    let rate: Vec<f64> = if referenced {
        rate.iter()
            .zip(&data.rate_dps)
            .map(|(w, r)| w - r)
            .collect()
    } else {
        rate
    };
    let what = if referenced {
        format!("{what} − reference")
    } else {
        what
    };
    let left_out = data.rate_dps.iter().filter(|r| !r.is_finite()).count();
    if referenced && left_out > 0 {
        console.result(&format!(
            "left out of the Allan deviation: the {left_out} samples without a reference (the \
             windows above); it is computed over the stretches between them"
        ));
    }
    let analysis = allan::Analysis::of(&what, &data.time_s, &rate);
    anyhow::ensure!(
        analysis.tau_s.len() >= 3,
        "{}: {} samples without a gap: too few for an Allan deviation",
        path.display(),
        analysis.samples
    );
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

/// `trainer identify`: the simulator's twin of a measured gyro, its unit file, and what it
/// still gets wrong on the held-out part before and after the effects it names (every gyro of a
/// unit's channels with `--channels`, into one unit file of several axes).
pub(super) fn identify_command(args: IdentifyArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let IdentifyArgs {
        points,
        stream,
        maps,
        window,
        exclude,
        scale_factor,
        unit,
        out,
        json,
        plot: figure,
    } = args;
    let console = Console::new(flags, json.as_deref());
    let mut inputs: Vec<&Path> = points.iter().chain(&stream).map(|p| p.as_path()).collect();
    inputs.extend(unit.channels.as_deref());
    for o in std::iter::once(&out).chain(&json).chain(&figure) {
        ensure_not_input(o, &inputs)?;
    }
    if let Some(channels) = unit.load()? {
        anyhow::ensure!(
            scale_factor.is_none(),
            "--scale-factor is for one channel: a unit's channels give theirs in {}",
            channels.path.display()
        );
        let logs = stream
            .as_deref()
            .map(|s| load_unit_log(s, &channels, &maps.list, (window, &exclude.list), &console))
            .transpose()?;
        let mut axes = Vec::new();
        let mut all = Vec::new();
        let skipped: Vec<&str> = channels
            .list
            .iter()
            .filter(|c| c.quantity != Quantity::AngularRate)
            .map(|c| c.name.as_str())
            .collect();
        if !skipped.is_empty() {
            console.result(&format!(
                "skipped {}: the simulator's twin is a gyro's (an open-loop FOG), and an \
                 accelerometer has none",
                skipped.join(", ")
            ));
        }
        for (k, ch) in channels.list.iter().enumerate() {
            if ch.quantity != Quantity::AngularRate {
                continue;
            }
            let console = console.channel(&ch.name, &format!("{}:", ch.name));
            let own = channels.maps(k, &maps.list, Read::Table)?;
            let table = points
                .as_deref()
                .map(|p| twin::load_points(p, &own))
                .transpose()?;
            let log = logs.as_ref().map(|l| twin::Source::from(&l[k]));
            let k_sf = if points.is_some() {
                ch.scale_factor
            } else {
                ch.bias_scale_factor()
            };
            let id = identified(table.as_ref(), log.as_ref(), k_sf, &console)
                .with_context(|| format!("channel {}", ch.name))?;
            if let Some(path) = &figure {
                let own = path.with_extension(format!("{}.svg", ch.name));
                write_atomically(&own, twin_figure(&id)?.as_bytes())?;
                console.result(&format!("wrote {}", own.display()));
            }
            axes.push(Axis {
                name: ch.name.clone(),
                params: id.unit.params.clone(),
                effects: id.unit.effects.clone(),
            });
            all.push(serde_json::json!({ "name": ch.name, "identification": id }));
        }
        anyhow::ensure!(!axes.is_empty(), "no gyro channel to identify");
        write_json(&out, &inputs, schema::SIM_AXES, &Axes { axes })?;
        if let Some(path) = &json {
            write_json_list(path, &inputs, schema::IDENTIFY_UNIT, "channels", &all)?;
        }
        console.result(&format!("wrote {}", out.display()));
        return Ok(());
    }
    let points = points
        .as_deref()
        .map(|p| twin::load_points(p, &maps.list))
        .transpose()?;
    let stream = match &stream {
        Some(path) => {
            let s = load_stream(path, &maps.list, (window, &exclude.list), &console)?;
            Some(twin::Source::from(&s))
        }
        None => None,
    };
    let id = identified(points.as_ref(), stream.as_ref(), scale_factor, &console)?;
    write_json(&out, &inputs, schema::SIM_UNIT, &id.unit)?;
    if let Some(path) = &json {
        write_json(path, &inputs, schema::IDENTIFY, &id)?;
    }
    if let Some(path) = &figure {
        write_atomically(path, twin_figure(&id)?.as_bytes())?;
    }
    console.result(&format!("wrote {}", out.display()));
    Ok(())
}

/// One gyro identified from its table and/or log, with a spinner while it runs and its summary
/// said.
fn identified(
    points: Option<&twin::Source>,
    stream: Option<&twin::Source>,
    scale_factor: Option<f64>,
    console: &Console,
) -> anyhow::Result<twin::Identification> {
    let spinner = console.spinner("identifying");
    let id = twin::identify(points, stream, scale_factor, |step| {
        spinner.set_message(format!("identifying: {step}"));
    })?;
    spinner.finish_and_clear();
    console.result(&twin::summary(&id));
    Ok(id)
}

/// The held-out difference between measured and twin, before and after its effects, as SVG.
fn twin_figure(id: &twin::Identification) -> anyhow::Result<String> {
    let (axis, pts): (&str, Vec<(f64, f64, f64)>) = match id.held_out {
        twin::SourceKind::Stream => ("time (h)", twin::minute_means(&id.residual)),
        twin::SourceKind::Points => ("point (file order)", id.residual.clone()),
    };
    let after = format!(
        "with {}",
        id.causes
            .iter()
            .map(|c| c.id())
            .collect::<Vec<_>>()
            .join(" + ")
    );
    Ok(plot::twin(
        &format!(
            "Held out: measured − twin, {:.2} → {:.2} °/h",
            id.fidelity_before_dph, id.fidelity_after_dph
        ),
        axis,
        &pts,
        &after,
    )?)
}
