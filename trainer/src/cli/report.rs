//! `trainer report`: the HTML report, on the user's data or on a simulated gyro.

use std::path::{Path, PathBuf};

use clap::Args;
use fog_data::stream::{Stream, Window};
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::ensure_not_input;

use super::demo;
use super::inputs::{FitOptions, HeldOut, ModelInput, load_stream};
use super::look::{points_summary, stream_summary, unit_summaries, unit_text};
use crate::report;
use fog_data::channels::{Channels, Read};
use fog_terminal::log::load_unit_log;

/// The arguments of `trainer report`.
#[derive(Args)]
pub(super) struct ReportArgs {
    #[command(flatten)]
    input: ModelInput,
    #[command(flatten)]
    fit: FitOptions,
    /// The stream or log the extension fits on (and the static model, without --points); its
    /// last third in time is held out unless --hold-out-from or --valid-stream says otherwise. A
    /// static log needs --scale-factor.
    #[arg(long)]
    stream: Option<PathBuf>,
    /// Use only this part of each log: START:END, s from its first sample (either end open).
    #[arg(long)]
    window: Option<Window>,
    #[command(flatten)]
    held_out: HeldOut,
    /// Directory for report.html and the figures (created if missing).
    #[arg(long, visible_alias = "out-dir")]
    out: PathBuf,
}

/// `trainer report`: the HTML report and its figures, for whatever data the user brings.
pub(super) fn report_command(args: ReportArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let ReportArgs {
        input,
        fit,
        stream,
        window,
        held_out,
        out: out_dir,
    } = args;
    let console = Console::new(flags, None);
    if let Some(channels) = input.unit.load()? {
        let files = match (stream, held_out.valid_stream.clone()) {
            (Some(a), Some(b)) => Files::Two(a, b),
            (Some(s), None) => Files::One(s),
            _ if input.points.is_some() => Files::None,
            _ => anyhow::bail!(
                "--channels names a unit's files: give them (--points, --stream, and \
                 --valid-stream for a held-out log of its own)"
            ),
        };
        return report_unit(
            (&input, &channels),
            (&fit, files),
            (window, &held_out),
            &out_dir,
            &console,
        );
    }
    let (input, files) = match (stream, held_out.valid_stream.clone()) {
        (Some(a), Some(b)) => (input, Files::Two(a, b)),
        (Some(s), None) => (input, Files::One(s)),
        _ if input.points.is_some() => (input, Files::None),
        _ => {
            let (input, a, b) = demo::simulated(&out_dir.join("data"), &console)?;
            (input, Files::Two(a, b))
        }
    };
    let mut inputs: Vec<&Path> = input.points.iter().map(PathBuf::as_path).collect();
    match &files {
        Files::One(s) => inputs.push(s),
        Files::Two(a, b) => inputs.extend([a.as_path(), b.as_path()]),
        Files::None => {}
    }
    let names = report::FIGURES.iter().map(|f| f.0).chain(["report.html"]);
    for name in names {
        ensure_not_input(&out_dir.join(name), &inputs)?;
    }
    let mut summaries = Vec::new();
    if let Some(p) = &input.points {
        summaries.push(points_summary(p, &input.maps, input.scale_factor)?);
    }
    let bar = console.bar(0);
    let gp = fit.gp();
    let r = match files {
        Files::None => {
            let points = input.static_points(&[], false)?;
            report::table(
                &input.points.clone().unwrap_or_default(),
                summaries,
                points,
                &gp,
                &bar,
            )?
        }
        Files::One(path) => {
            summaries.push(stream_summary(&path, &input.maps)?);
            let parts = (window, input.exclude.list.as_slice());
            let whole = load_stream(&path, &input.maps.list, parts, &console)?;
            let (train, valid, split_s) = held_out.split(&whole)?;
            let train = [(path.as_path(), train)];
            let points = input.static_points(&train, false)?;
            let rebuild =
                |part: &Stream| input.static_points(&[(path.as_path(), part.clone())], false);
            let (kind, source) = match &input.points {
                Some(p) => (report::ReportKind::TableAndStream, p.clone()),
                None => (report::ReportKind::Log, path.clone()),
            };
            report::with_streams(
                &source,
                kind,
                summaries,
                points,
                &train[0].1,
                valid,
                held_out.said(&path, split_s),
                (&gp, &rebuild),
                &bar,
            )?
        }
        Files::Two(a, b) => {
            summaries.push(stream_summary(&a, &input.maps)?);
            summaries.push(stream_summary(&b, &input.maps)?);
            let parts = (window, input.exclude.list.as_slice());
            let train = [(
                a.as_path(),
                load_stream(&a, &input.maps.list, parts, &console)?,
            )];
            let valid = load_stream(&b, &input.maps.list, parts, &console)?;
            let points = input.static_points(&train, false)?;
            let rebuild =
                |part: &Stream| input.static_points(&[(a.as_path(), part.clone())], false);
            let source = input.points.clone().unwrap_or_else(|| a.clone());
            report::with_streams(
                &source,
                report::ReportKind::Full,
                summaries,
                points,
                &train[0].1,
                valid,
                format!("all of {}, a run of its own", b.display()),
                (&gp, &rebuild),
                &bar,
            )?
        }
    };
    bar.finish_and_clear();
    for path in report::write(&out_dir, &r)? {
        console.result(&format!("wrote {}", path.display()));
    }
    Ok(())
}

/// The streams a report is given besides the points.
enum Files {
    /// None: a rate table alone.
    None,
    /// One stream or log, split in time.
    One(PathBuf),
    /// A training stream and a held-out one.
    Two(PathBuf, PathBuf),
}

/// `trainer report --channels`: every channel of a unit's files analysed as one channel's report
/// analyses its data (the logs read once), on one page (`report::unit`).
fn report_unit(
    (input, channels): (&ModelInput, &Channels),
    (fit, files): (&FitOptions, Files),
    (window, held_out): (Option<Window>, &HeldOut),
    out_dir: &Path,
    console: &Console,
) -> anyhow::Result<()> {
    let mut inputs: Vec<&Path> = input.points.iter().map(PathBuf::as_path).collect();
    match &files {
        Files::One(s) => inputs.push(s),
        Files::Two(a, b) => inputs.extend([a.as_path(), b.as_path()]),
        Files::None => {}
    }
    inputs.push(&channels.path);
    let names: Vec<&str> = channels.list.iter().map(|c| c.name.as_str()).collect();
    for name in report::unit::files(&names) {
        ensure_not_input(&out_dir.join(name), &inputs)?;
    }
    let parts = (window, input.exclude.list.as_slice());
    let load = |path: &Path| load_unit_log(path, channels, &input.maps.list, parts, console);
    let mut summary = String::new();
    let mut add = |path: &Path, read| -> anyhow::Result<()> {
        let each = unit_summaries(path, channels, &input.maps, read)?;
        summary.push_str(&unit_text(channels, &each));
        Ok(())
    };
    if let Some(p) = &input.points {
        add(p, Read::Table)?;
    }
    let logs: Vec<(PathBuf, Vec<Stream>)> = match &files {
        Files::None => Vec::new(),
        Files::One(s) => vec![(s.clone(), load(s)?)],
        Files::Two(a, b) => vec![(a.clone(), load(a)?), (b.clone(), load(b)?)],
    };
    for (path, _) in &logs {
        add(path, Read::Log)?;
    }
    let bar = console.bar(0);
    let gp = fit.gp();
    let mut pages = Vec::new();
    for (k, ch) in channels.list.iter().enumerate() {
        bar.set_message(format!("channel {}", ch.name));
        let own = input.for_channel(channels, k)?;
        let report = match (&files, logs.as_slice()) {
            (Files::None, _) => {
                let points = own.static_points(&[], false)?;
                report::table(
                    &own.points.clone().unwrap_or_default(),
                    Vec::new(),
                    points,
                    &gp,
                    &bar,
                )?
            }
            (Files::One(path), [(_, streams)]) => {
                let (train, valid, split_s) = held_out.split(&streams[k])?;
                let train = [(path.as_path(), train)];
                let points = own.static_points(&train, false)?;
                let rebuild =
                    |part: &Stream| own.static_points(&[(path.as_path(), part.clone())], false);
                let kind = if own.points.is_some() {
                    report::ReportKind::TableAndStream
                } else {
                    report::ReportKind::Log
                };
                report::with_streams(
                    path,
                    kind,
                    Vec::new(),
                    points,
                    &train[0].1,
                    valid,
                    held_out.said(path, split_s),
                    (&gp, &rebuild),
                    &bar,
                )?
            }
            (Files::Two(a, b), [(_, train), (_, valid)]) => {
                let train = [(a.as_path(), train[k].clone())];
                let points = own.static_points(&train, false)?;
                let rebuild =
                    |part: &Stream| own.static_points(&[(a.as_path(), part.clone())], false);
                report::with_streams(
                    a,
                    report::ReportKind::Full,
                    Vec::new(),
                    points,
                    &train[0].1,
                    valid[k].clone(),
                    format!("all of {}, a run of its own", b.display()),
                    (&gp, &rebuild),
                    &bar,
                )?
            }
            _ => anyhow::bail!("the unit's files did not load"),
        };
        pages.push(report::unit::ChannelSection {
            name: &ch.name,
            quantity: ch.quantity,
            report,
        });
    }
    bar.finish_and_clear();
    let source = inputs
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ");
    for path in report::unit::write(out_dir, &source, &summary, &pages)? {
        console.result(&format!("wrote {}", path.display()));
    }
    Ok(())
}
