//! `trainer report`: the HTML report, on the user's data or on a simulated gyro.

use std::path::{Path, PathBuf};

use clap::Args;
use fog_data::stream::Window;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::ensure_not_input;

use super::demo;
use super::fit::params::ParamsArgs;
use super::inputs::{DatasheetArgs, FitOptions, HeldOut, ModelInput};
use crate::data::summary::Summary;
use crate::firmware::autopilot::SensorCubics;
use crate::pipeline::report::{Held, ReportPlan};
use crate::pipeline::summarize::{unit_summaries, unit_text};
use crate::report;
use fog_data::channels::{Channels, Datasheet, Read};
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
    /// The samples before it are its history: the firmware's state runs through them from the
    /// power-on, as it did on the gyro, but nothing is fitted or scored on them.
    #[arg(long)]
    window: Option<Window>,
    #[command(flatten)]
    held_out: HeldOut,
    #[command(flatten)]
    params: ParamsArgs,
    #[command(flatten)]
    datasheet: DatasheetArgs,
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
        params,
        datasheet,
        out: out_dir,
    } = args;
    let sheet = datasheet.sheet();
    crate::pipeline::check_datasheet(&sheet)?;
    let console = Console::new(flags, None);
    let (input, stream, held_out) = match stream {
        None if input.points.is_none() && input.unit.channels.is_none() => {
            let (input, a, b) = demo::simulated(&out_dir.join("data"), &console)?;
            let held_out = HeldOut {
                hold_out_from: None,
                valid_stream: Some(b),
            };
            (input, Some(a), held_out)
        }
        _ => (input, stream, held_out),
    };
    anyhow::ensure!(
        stream.is_some() || input.points.is_some(),
        "--channels names a unit's files: give them (--points, --stream, and --valid-stream for a \
         held-out log of its own)"
    );
    let mut units = input.unit.units(stream.as_deref(), &console)?;
    if let (true, Some(table)) = (units.is_empty(), &input.points) {
        units.push(Channels::single(table));
    }
    crate::pipeline::check_one_channel(&sheet, false, &units, "report")?;
    anyhow::ensure!(
        !params.asked() || (units.iter().all(|u| !u.single) && stream.is_some()),
        "--px4-params and --ardupilot-params take a sensor's three axes, fitted on a log: a \
         unit's log (a flight controller's, or --channels with --stream)"
    );
    let inputs: Vec<&Path> = input
        .points
        .iter()
        .chain(&stream)
        .map(PathBuf::as_path)
        .collect();
    for p in params.files() {
        ensure_not_input(p, &inputs)?;
    }
    // A log of several sensors: a page each, in a folder named for it.
    let several = units.len() > 1;
    let mut cubics = Vec::new();
    for channels in &mut units {
        channels.take_scale_factor(input.scale_factor)?;
        let files = match &stream {
            Some(s) => Files::Logs(s.clone(), held_out.clone()),
            None => Files::None,
        };
        let dir = match channels.unit_name().filter(|_| several) {
            Some(name) => out_dir.join(name),
            None => out_dir.clone(),
        };
        let unit = (&input, &*channels, params.asked());
        let fitting = (&fit, &sheet, files, window);
        cubics.extend(report_unit(unit, fitting, &dir, &console)?);
    }
    params.write(&cubics, &console)
}

/// The streams a report is given besides the points.
enum Files {
    /// None: a rate table alone.
    None,
    /// A training log, and where its held-out data are.
    Logs(PathBuf, HeldOut),
}

/// `trainer report` on a unit's files: every channel analysed as one channel's data are (the logs
/// read once), on one page (`report::unit`).
fn report_unit(
    (input, channels, params): (&ModelInput, &Channels, bool),
    (fit, sheet, files, window): (&FitOptions, &Datasheet, Files, Option<Window>),
    out_dir: &Path,
    console: &Console,
) -> anyhow::Result<Option<SensorCubics>> {
    let mut inputs: Vec<&Path> = input.points.iter().map(PathBuf::as_path).collect();
    match &files {
        Files::Logs(s, held_out) => {
            inputs.push(s);
            inputs.extend(held_out.valid_stream.as_deref());
        }
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
    let mut per_channel: Vec<Vec<Summary>> = vec![Vec::new(); channels.len()];
    let mut add = |path: &Path, read| -> anyhow::Result<()> {
        let each = unit_summaries(path, channels, &input.maps.list, read)?;
        summary.push_str(&unit_text(channels, &each));
        for (k, c) in each.into_iter().enumerate() {
            per_channel[k].push(c.summary);
        }
        Ok(())
    };
    if let Some(p) = &input.points {
        add(p, Read::Table)?;
    }
    let held = match &files {
        Files::None => None,
        Files::Logs(path, held_out) => {
            add(path, Read::Log)?;
            if let Some(v) = &held_out.valid_stream {
                add(v, Read::Log)?;
            }
            let (train, valid, said) = held_out.parts((path, load(path)?), load, console)?;
            Some(Held {
                path,
                own_log: held_out.valid_stream.is_some(),
                train,
                valid,
                said,
            })
        }
    };
    let plan = ReportPlan {
        source: input.source(),
        gp: fit.gp(),
        sheet: *sheet,
    };
    let (pages, cubics) = plan.unit((channels, per_channel), held.as_ref(), params, console)?;
    let source = inputs
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ");
    for path in report::unit::write(out_dir, &source, &summary, &pages)? {
        console.result(&format!("wrote {}", path.display()));
    }
    Ok(cubics)
}
