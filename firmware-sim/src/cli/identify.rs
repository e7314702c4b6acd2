//! `firmware-sim identify`: the simulator's twin of a measured gyro (its parameters fitted to a
//! rate table and/or a log, with the effects the twin lacks, [`crate::twin`]), written as the unit
//! file `generate --unit` simulates, with the held-out figure of what it still gets wrong.

use std::path::{Path, PathBuf};

use clap::Args;
use firmware_core::Quantity;
use fog_data::channels::{Channels, Read};
use fog_data::stream::Window;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_atomically, write_json};
use fog_terminal::log::{Each, Excludes, Maps, UnitArgs, load_unit_log};
use fog_terminal::plot::{BLUE, FONT, GREY, PlotError, TITLE, axes, legend, span, svg};
use fog_terminal::schema::{self, PerChannel};
use plotters::prelude::*;

use crate::gyro::axes::{Axes, Axis};
use crate::twin;

/// The arguments of `firmware-sim identify`.
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
    /// The samples before it are its history: the firmware's state runs through them from the
    /// power-on, as it did on the gyro, but nothing is fitted or scored on them.
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

/// `firmware-sim identify`: the simulator's twin of a measured gyro, its unit file, and what it
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
    let mut units = unit.units(stream.as_deref(), &console)?;
    if let (true, Some(table)) = (units.is_empty(), &points) {
        units.push(Channels::single(table));
    }
    let (gyros, others): (Vec<Channels>, Vec<Channels>) = units
        .into_iter()
        .partition(|u| u.list.iter().any(|c| c.quantity == Quantity::AngularRate));
    let names: Vec<&str> = others.iter().filter_map(Channels::unit_name).collect();
    if !names.is_empty() {
        console.result(&format!(
            "skipped {}: the simulator's twin is a gyro's (an open-loop FOG), and an \
             accelerometer has none",
            names.join(", ")
        ));
    }
    anyhow::ensure!(!gyros.is_empty(), "no gyro channel to identify");
    let from = stream.as_deref().unwrap_or(Path::new(""));
    let each = Each::new(gyros.len(), from, json.as_deref())?;
    let data = Data {
        points: points.as_deref(),
        stream: stream.as_deref(),
        maps: &maps,
        window,
        exclude: &exclude,
    };
    for channels in &gyros {
        each.heading(channels, &console);
        let files = (
            each.file(channels, &out),
            json.as_deref().map(|j| each.file(channels, j)),
            figure.as_deref().map(|f| each.file(channels, f)),
        );
        identify_unit(channels, &data, (scale_factor, files), &inputs, &console)
            .map_err(|e| each.naming(channels, e))?;
    }
    Ok(())
}

/// What `identify` reads a unit's data from: the rate table, the log, and how they are read.
#[derive(Clone, Copy)]
struct Data<'a> {
    points: Option<&'a Path>,
    stream: Option<&'a Path>,
    maps: &'a Maps,
    window: Option<Window>,
    exclude: &'a Excludes,
}

/// Where `identify` writes a unit's twin: the unit file, the JSON, the figures.
type Files = (PathBuf, Option<PathBuf>, Option<PathBuf>);

/// Every gyro channel of a unit identified, into one unit file of several axes (`out`), with its
/// JSON and a figure per channel where asked.
fn identify_unit(
    channels: &Channels,
    data: &Data<'_>,
    (scale_factor, (out, json, figure)): (Option<f64>, Files),
    inputs: &[&Path],
    console: &Console,
) -> anyhow::Result<()> {
    let Data {
        points,
        stream,
        maps,
        window,
        exclude,
    } = *data;
    let mut channels = channels.clone();
    channels.take_scale_factor(scale_factor)?;
    let channels = &channels;
    let logs = stream
        .map(|s| load_unit_log(s, channels, &maps.list, (window, &exclude.list), console))
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
        let heading = if channels.single {
            String::new()
        } else {
            format!("{}:", ch.name)
        };
        let console = console.channel(channels.label(k), &heading);
        let own = channels.maps(k, &maps.list, Read::Table)?;
        let table = points.map(|p| twin::load_points(p, &own)).transpose()?;
        let log = logs.as_ref().map(|l| twin::Measured::from(&l[k]));
        let k_sf = if points.is_some() {
            ch.scale_factor
        } else {
            ch.bias_scale_factor()
        };
        let id =
            channels.in_channel(k, identified(table.as_ref(), log.as_ref(), k_sf, &console))?;
        if let Some(path) = &figure {
            let own = if channels.len() == 1 {
                path.clone()
            } else {
                path.with_extension(format!("{}.svg", ch.name))
            };
            write_atomically(&own, twin_figure(&id)?.as_bytes())?;
            console.result(&format!("wrote {}", own.display()));
        }
        axes.push(Axis {
            name: ch.name.clone(),
            params: id.unit.params.clone(),
            effects: id.unit.effects.clone(),
        });
        all.push(IdentifiedChannel {
            name: ch.name.clone(),
            identification: id,
        });
    }
    anyhow::ensure!(!axes.is_empty(), "no gyro channel to identify");
    write_json(&out, inputs, schema::SIM_AXES, &Axes { axes })?;
    if let Some(path) = &json {
        let body = PerChannel { channels: &all };
        write_json(path, inputs, schema::IDENTIFY, &body)?;
    }
    console.result(&format!("wrote {}", out.display()));
    Ok(())
}

/// One gyro channel's identification, as `identify --json` lists it.
#[derive(serde::Serialize, schemars::JsonSchema)]
pub(super) struct IdentifiedChannel {
    /// The channel's name.
    name: String,
    /// Its identification, as one gyro's.
    identification: twin::Identification,
}

/// One gyro identified from its table and/or log, with a spinner while it runs and its summary
/// said.
fn identified(
    points: Option<&twin::Measured>,
    stream: Option<&twin::Measured>,
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
    Ok(twin_plot(
        &format!(
            "Held out: measured − twin, {:.2} → {:.2} °/h",
            id.fidelity_before_dph, id.fidelity_after_dph
        ),
        axis,
        &pts,
        &after,
    )?)
}

/// What the simulation gets wrong: the held-out difference between the measured output and the
/// twin's (°/h) on the held-out axis (hours of a stream, or index of a table's points), before
/// and after the effects are added. Streams are drawn as one-minute means.
fn twin_plot(
    title: &str,
    axis: &str,
    points: &[(f64, f64, f64)],
    after_label: &str,
) -> Result<String, PlotError> {
    svg("the twin", (900, 500), |root| {
        let (x0, x1) = span(points.iter().map(|p| p.0), 0.02);
        let (y0, y1) = span(points.iter().flat_map(|p| [p.1, p.2]), 0.05);
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, TITLE))
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        axes(&mut chart, axis, "measured − twin, rate-equivalent (°/h)")?;
        chart.draw_series(LineSeries::new([(x0, 0.0), (x1, 0.0)], BLACK.mix(0.4)))?;
        for (label, colour, pick) in [("static twin", GREY, 1usize), (after_label, BLUE, 2usize)] {
            let at = move |p: &(f64, f64, f64)| (p.0, if pick == 1 { p.1 } else { p.2 });
            chart
                .draw_series(
                    points
                        .iter()
                        .map(|p| Circle::new(at(p), 2, colour.filled())),
                )?
                .label(label)
                .legend(move |(x, y)| Circle::new((x + 8, y), 4, colour.filled()));
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight)
    })
}
