//! The commands that evaluate and diagnose: `loo`, `reproduce`, `diagnose`, `investigate` (the
//! simulator's `challenge` is in its own module).

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use fog_data::sigma::Coverage;
use fog_data::stream::Window;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_atomically, write_json};
use fog_terminal::log::LogArgs;
use fog_terminal::schema::{self, PerChannel};

use super::inputs::{DatasheetArgs, FitOptions, HeldOut, Input, MethodArg, ModelInput, Runs};
use super::sensors::{Blob, units_of_blobs};
use crate::analysis::evaluate::{EvalConfig, Evaluation};
use crate::analysis::extend;
use crate::analysis::investigate;
use crate::analysis::reproduce;
use crate::data::points::Points;
use crate::pipeline::diagnose;
use crate::pipeline::investigate::InvestigatePlan;
use crate::pipeline::loo::LooPlan;
use crate::pipeline::source::{load_points, load_runs};
use fog_terminal::log::Each;
use fog_terminal::log::load_unit_log;

/// The arguments of `trainer diagnose`.
#[derive(Args)]
pub(super) struct DiagnoseArgs {
    /// Model blob. With a flight controller's log, a sensor's blob is diagnosed on the sensor it
    /// names; give several (`--model fit.gyro0.bin fit.gyro1.bin`, or repeat the flag) for several.
    #[arg(long, required = true, num_args = 1..)]
    model: Vec<PathBuf>,
    #[command(flatten)]
    log: LogArgs,
    /// Write the diagnosis as JSON here (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// The arguments of `trainer investigate`.
#[derive(Args)]
pub(super) struct InvestigateArgs {
    #[command(flatten)]
    input: ModelInput,
    #[command(flatten)]
    runs: Runs,
    #[command(flatten)]
    fit: FitOptions,
    /// The stream or log the extension fits on (and the static model, without --points); its
    /// last third in time is held out unless --hold-out-from or --valid-stream says otherwise.
    #[arg(long)]
    stream: PathBuf,
    /// Use only this part of each log: START:END, s from its first sample (either end open).
    /// The samples before it are its history: the firmware's state runs through them from the
    /// power-on, as it did on the gyro, but nothing is fitted or scored on them.
    #[arg(long)]
    window: Option<Window>,
    #[command(flatten)]
    held_out: HeldOut,
    /// Inputs to add: auto (what the diagnosis calls for) or a list, as for fit.
    #[arg(long, default_value = "auto")]
    features: String,
    #[command(flatten)]
    datasheet: DatasheetArgs,
    /// Write the extended model's blob here: a unit blob, every channel's (one entry for one
    /// channel's data); one per sensor beside this name where a flight controller's log holds
    /// several.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the static model's blob here (as --out).
    #[arg(long)]
    out_static: Option<PathBuf>,
    /// Write the investigation as JSON here (`-`: stdout, alone; one per sensor beside this
    /// name where a flight controller's log holds several).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// The arguments of `trainer loo`.
#[derive(Args)]
pub(super) struct LooArgs {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    fit: FitOptions,
    /// Method to evaluate.
    #[arg(long, value_enum, default_value_t = MethodArg::Gpr)]
    method: MethodArg,
    /// Leave out one group of this column at a time (default: temperature plateaus).
    #[arg(long)]
    group: Option<String>,
    /// Give each group of --group its own offset in the GP (gpr): fitted as a variance, left
    /// out of every prediction, so a left-out group's offset is never known to its scores.
    #[arg(long, requires = "group")]
    offsets: bool,
    /// `auto`: a table recorded in time order (`--map time_s=…`) is diagnosed for transients
    /// on the bias and the scale factor, and the GP extended with those that win, the choice
    /// redone inside every fold from its training rows alone (gpr only).
    #[arg(long, value_parser = ["auto"])]
    features: Option<String>,
    /// Hold out a table of its own (another run, another power-on): also fit on all of
    /// --points and score on these, inside the temperature and rate range both cover (as
    /// --valid-stream holds out a log).
    #[arg(long, alias = "test-points")]
    valid_points: Option<PathBuf>,
    /// The scale factor's run-to-run repeatability, 1σ in ppm, as a datasheet gives it: stated
    /// in the GP's σ on the --valid-points run, as `fit --scale-repeatability` states it in a
    /// blob (default: assumed as `fit` assumes it, where the --run tables do not measure it).
    #[arg(long, value_name = "PPM", requires = "valid_points")]
    scale_repeatability: Option<f64>,
    /// The bias's run-to-run repeatability, 1σ in the table's units, as a datasheet gives it:
    /// stated in the GP's σ on the --valid-points run, as `fit --repeatability` states it in a
    /// blob (default: assumed as `fit` assumes it, where the --run tables do not measure it).
    #[arg(long, value_name = "SIGMA", requires = "valid_points")]
    repeatability: Option<f64>,
    #[command(flatten)]
    runs: Runs,
    /// Write the evaluation as JSON here (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// The arguments of `trainer reproduce`.
#[derive(Args)]
pub(super) struct ReproduceArgs {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    fit: FitOptions,
    /// Write all figures as JSON here (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// `trainer diagnose`: replays a stream through a blob and names the cause of its residual (each
/// channel's, for a unit's blob and log; each sensor's blob on its sensor of a flight
/// controller's log).
pub(super) fn diagnose_command(args: DiagnoseArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let DiagnoseArgs { model, log, json } = args;
    let console = Console::new(flags, json.as_deref());
    let blobs = Blob::read(&model)?;
    let units = log.unit.units(Some(&log.stream), &console)?;
    let pairs = units_of_blobs(units, blobs, &log.stream)?;
    let each = Each::new(pairs.len(), &log.stream, json.as_deref())?;
    for (channels, blob) in &pairs {
        each.heading(channels, &console);
        let diagnosed = (|| {
            let streams = log.load_unit(channels, &console)?;
            diagnose::unit(&blob.bytes, (channels, &streams), &console)
                .with_context(|| blob.path.display().to_string())
        })()
        .map_err(|e| each.naming(channels, e))?;
        if let Some(path) = &json {
            let inputs = [blob.path.as_path(), log.stream.as_path(), &channels.path];
            let entries = diagnose::entries(&diagnosed);
            let path = each.file(channels, path);
            let body = PerChannel { channels: &entries };
            write_json(&path, &inputs, schema::DIAGNOSE, &body)?;
        }
    }
    Ok(())
}

/// `trainer investigate`: static fit, diagnosis and extension on the training stream, both scored
/// on the held-out one (every channel's, with `--channels`).
pub(super) fn investigate_command(
    args: InvestigateArgs,
    flags: ConsoleFlags,
) -> anyhow::Result<()> {
    let InvestigateArgs {
        input,
        runs,
        fit,
        stream,
        window,
        held_out,
        features,
        datasheet,
        out,
        out_static,
        json,
    } = args;
    let sheet = datasheet.sheet();
    crate::pipeline::check_datasheet(&sheet)?;
    let input = input.with_runs(runs);
    let console = Console::new(flags, json.as_deref());
    let mut inputs: Vec<&Path> = input
        .points
        .iter()
        .chain(&input.runs)
        .map(PathBuf::as_path)
        .collect();
    inputs.push(&stream);
    inputs.extend(held_out.valid_stream.as_deref());
    inputs.extend(input.unit.channels.as_deref());
    for o in out.iter().chain(&out_static).chain(&json) {
        ensure_not_input(o, &inputs)?;
    }
    let plan = InvestigatePlan {
        source: input.source(),
        gp: fit.gp(),
        asked: match features.as_str() {
            "auto" => None,
            list => Some(extend::parse_features(list)?),
        },
        calibration_run: held_out.valid_stream.is_none(),
        sheet,
    };
    let units = input.unit.units(Some(&stream), &console)?;
    crate::pipeline::check_one_channel(&sheet, false, &units, "investigate")?;
    let each = Each::new(units.len(), &stream, json.as_deref())?;
    for channels in &units {
        each.heading(channels, &console);
        let load = |path: &Path| {
            load_unit_log(
                path,
                channels,
                &input.maps.list,
                (window, &input.exclude.list),
                &console,
            )
        };
        let named = |e| each.naming(channels, e);
        let (train, valid, _) = held_out
            .parts((&stream, load(&stream)?), load, &console)
            .map_err(named)?;
        let investigated = plan
            .unit(channels, (&stream, &train, &valid), &console)
            .map_err(named)?;
        let mut read = inputs.clone();
        read.push(&channels.path);
        for (path, pick) in [
            (
                &out,
                (|b| &b.extended_blob) as fn(&investigate::Blobs) -> &Vec<u8>,
            ),
            (&out_static, |b| &b.static_blob),
        ] {
            if let Some(path) = path {
                let path = each.file(channels, path);
                ensure_not_input(&path, &read)?;
                write_atomically(&path, &investigated.blob(channels, pick)?)?;
            }
        }
        if let Some(path) = &json {
            let report = investigated.report(channels);
            let path = each.file(channels, path);
            write_json(&path, &read, schema::INVESTIGATE, &report)?;
        }
    }
    Ok(())
}

/// `trainer loo`: leave-one-out and leave-one-group-out of one method.
pub(super) fn loo_command(args: LooArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let LooArgs {
        input,
        fit,
        method,
        group,
        offsets,
        features,
        valid_points,
        scale_repeatability,
        repeatability,
        runs: Runs { list: runs },
        json,
    } = args;
    anyhow::ensure!(
        features.is_none() || (runs.is_empty() && valid_points.is_none()),
        "--features auto evaluates the GP on one table; --valid-points and --run are not \
         supported with it"
    );
    let cfg = EvalConfig {
        gp: fit.gp(),
        offsets,
        ..EvalConfig::default()
    };
    let plan = LooPlan::new(
        cfg,
        method.into(),
        features.is_some(),
        (repeatability, scale_repeatability),
    )?;
    let console = Console::new(flags, json.as_deref());
    let points = load_runs(
        &input.points,
        &runs,
        &input.maps.list,
        (group.as_deref(), None),
        input.exclude_implausible,
        &console,
    )?;
    let test = match &valid_points {
        Some(path) => Some((
            path.as_path(),
            Points::load(path, &input.maps.list, None, None)?,
        )),
        None => None,
    };
    let loo = plan.run(&points, test.as_ref().map(|(p, t)| (*p, t)), &console)?;
    if let (Some(c), Some(path)) = (&loo.cross_run, &valid_points) {
        console.result(&format!(
            "{}: fitted on {}, tested on {}: RMSE {:.3e} °/s ({:.2} °/h) over {} points in \
             {:.2}–{:.2} °C, |rate| ≤ {:.1} °/s ({} outside, not scored)",
            c.method,
            input.points.display(),
            path.display(),
            c.rmse_dps,
            c.rmse_dph,
            c.n,
            c.temp_range_c.0,
            c.temp_range_c.1,
            c.max_abs_rate_dps,
            c.n_outside
        ));
        if let Some(sigma) = &c.sigma {
            console.result(&format!("  its σ there: {}", sigma_line(sigma)));
        }
        if let Some(d) = &c.difference {
            console.result(&format!(
                "  what differs, read off these errors (nothing uses it): a scale of {:+.0} ppm \
                 of the rate and an offset of {:+.1} °/h; without the offset {:.1} °/h remain, \
                 without both {:.1} (the training run's own groups left out: {:.1})",
                d.scale_ppm,
                d.offset_dph,
                d.without_offset_dph,
                d.without_both_dph,
                loo.evaluation.group_rmse_dph
            ));
        }
    }
    print_loo(&console, &loo.evaluation);
    if let Some(path) = json {
        let mut inputs = vec![input.points.as_path()];
        inputs.extend(runs.iter().map(PathBuf::as_path));
        inputs.extend(valid_points.as_deref());
        write_json(&path, &inputs, schema::LOO, &loo)?;
    }
    Ok(())
}

/// What `loo` prints of an evaluation: the diagnosis of a table in time order where there is
/// one, the figures, the σ and each left-out group.
fn print_loo(console: &Console, e: &Evaluation) {
    if let Some(d) = &e.diagnosis {
        console.result(&format!("diagnosis on all points: {}", d.all_rows.verdict));
        for t in &d.terms {
            console.result(&format!(
                "  {}: coefficient {:.4e}, feature range {:.4}…{:.4}",
                t.candidate.name(),
                t.coefficient,
                t.range.0,
                t.range.1
            ));
        }
        let static_folds = d.per_group.iter().filter(|c| c.shipped.is_empty()).count();
        console.result(&format!(
            "inside the {} folds (training rows alone): {} shipped an extension, {} static",
            d.per_group.len(),
            d.per_group.len() - static_folds,
            static_folds
        ));
        for c in &d.per_group {
            let what = if c.shipped.is_empty() {
                String::from("static")
            } else {
                c.shipped.join(" + ")
            };
            console.result(&format!("  fold {}: {what}", c.group));
        }
    }
    for w in &e.warnings {
        console.warn(w);
    }
    if !e.skipped.is_empty() {
        console.warn(&format!("skipped: {}", e.skipped.join("; ")));
    }
    console.result(&format!(
        "{}: leave-one-out RMSE {:.3e} °/s ({:.2} °/h) over {} points; Q-Q correlation {:.4}",
        e.method, e.rmse_dps, e.rmse_dph, e.n, e.qq_correlation
    ));
    if !e.per_temperature.is_empty() {
        console.result(&format!(
            "leave-one-group-out RMSE {:.3e} °/s ({:.2} °/h) over {} groups",
            e.group_rmse_dps,
            e.group_rmse_dph,
            e.per_temperature.len()
        ));
    }
    if let Some(sigma) = &e.sigma_groups {
        console.result(&format!(
            "σ on the left-out groups (each fold's error model from its own groups): {}",
            sigma_line(sigma)
        ));
    }
    if let Some(c) = &e.calibration {
        console.result(&format!("the model on all points: {}", c.describe("°/s")));
    }
    if !e.per_temperature.is_empty() {
        console.result("leave-one-group-out:  group   T (°C)     n   RMSE (°/s)   RMSE (°/h)");
    }
    for g in &e.per_temperature {
        console.result(&format!(
            "                     {:>6}  {:>7.2}  {:>4}   {:>10.3e}   {:>10.2}",
            g.group, g.temp_c, g.n, g.rmse_dps, g.rmse_dph
        ));
    }
}

/// Coverage at 1, 2 and 3 σ and sharpness, in one phrase.
fn sigma_line(c: &Coverage) -> String {
    format!(
        "{:.0}/{:.0}/{:.0}% within 1/2/3σ (a Gaussian: 68/95/99.7%), median σ {:.2}× the RMS error",
        100.0 * c.within_1sigma,
        100.0 * c.within_2sigma,
        100.0 * c.within_3sigma,
        c.sharpness
    )
}

/// `trainer reproduce`: our figures beside the reference paper's.
pub(super) fn reproduce_command(args: ReproduceArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let ReproduceArgs { input, fit, json } = args;
    let console = Console::new(flags, json.as_deref());
    let points = load_points(
        &input.points,
        &input.maps.list,
        (None, None),
        input.exclude_implausible,
        &console,
    )?;
    let cfg = EvalConfig {
        gp: fit.gp(),
        ..EvalConfig::default()
    };
    let progress = crate::progress::Messages::counted(&console);
    let r = reproduce::reproduce(&points, &cfg, &*progress)?;
    drop(progress);
    console.result(r.render(&input.points.display().to_string()).trim_end());
    if let Some(path) = json {
        write_json(&path, &[input.points.as_path()], schema::REPRODUCE, &r)?;
    }
    Ok(())
}
