//! The commands that evaluate and diagnose: `loo`, `reproduce`, `diagnose`, `investigate` (the
//! simulator's `challenge` is in its own module).

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use fog_data::cause::Cause;
use fog_data::sigma::{self, Coverage};
use fog_data::stream::{Stream, Window};
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_atomically, write_json, write_json_list};
use fog_terminal::log::LogArgs;
use fog_terminal::schema;
use serde::Serialize;

use super::inputs::{FitOptions, HeldOut, Input, MethodArg, ModelInput, Runs, load_stream};
use super::text::render_diagnosis;
use crate::analysis::capacity;
use crate::analysis::diagnose;
use crate::analysis::diagnose::causes_text;
use crate::analysis::evaluate::{self, CrossRun, EvalConfig, Evaluation};
use crate::analysis::extend;
use crate::analysis::investigate;
use crate::analysis::reproduce;
use crate::data::points::Points;
use crate::firmware::unit::{self, ChannelBlob};
use crate::models::gp::GpConfig;
use crate::pipeline::source::{Source, load_points, load_runs};
use firmware_core::Quantity;
use fog_data::channels::Channels;
use fog_terminal::log::load_unit_log;

/// The arguments of `trainer diagnose`.
#[derive(Args)]
pub(super) struct DiagnoseArgs {
    /// Model blob.
    #[arg(long)]
    model: PathBuf,
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
    #[arg(long)]
    window: Option<Window>,
    #[command(flatten)]
    held_out: HeldOut,
    /// Inputs to add: auto (what the diagnosis calls for) or a list, as for fit.
    #[arg(long, default_value = "auto")]
    features: String,
    /// Write the extended model's blob here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the static model's blob here.
    #[arg(long)]
    out_static: Option<PathBuf>,
    /// Write the investigation as JSON here (`-`: stdout, alone).
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
    /// Another run: also fit on all of --points and score on these, inside the temperature
    /// and rate range both cover.
    #[arg(long)]
    test_points: Option<PathBuf>,
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
/// channel's, for a unit's blob and log with `--channels`).
pub(super) fn diagnose_command(args: DiagnoseArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let DiagnoseArgs { model, log, json } = args;
    let console = Console::new(flags, json.as_deref());
    let bytes = std::fs::read(&model).with_context(|| format!("reading {}", model.display()))?;
    if let Some(channels) = log.unit.load(Some(&log.stream), &console)? {
        let streams = log.load_unit(&channels, &console)?;
        let mut all = Vec::new();
        for (name, quantity, blob) in
            unit::channel_blobs(&bytes).with_context(|| format!("decoding {}", model.display()))?
        {
            let k = channels
                .list
                .iter()
                .position(|c| c.name == name)
                .with_context(|| {
                    format!(
                        "{}'s channel {name} is not in {}",
                        model.display(),
                        channels.path.display()
                    )
                })?;
            let fw = fog_data::replay::decode(&blob)?;
            let mut d = diagnose::diagnose(&fw, &streams[k]);
            d = d.in_quantity(quantity);
            let console = console.channel(&name, &format!("{name}:"));
            console.result(render_diagnosis(&d).trim_end());
            all.push(serde_json::json!({ "name": name, "units": quantity.unit(), "diagnosis": d }));
        }
        if let Some(path) = json {
            let inputs = [model.as_path(), log.stream.as_path(), &channels.path];
            write_json_list(&path, &inputs, schema::DIAGNOSE_UNIT, "channels", &all)?;
        }
        return Ok(());
    }
    let fw = fog_data::replay::decode(&bytes)
        .with_context(|| format!("decoding {}", model.display()))?;
    let data = log.load(&console)?;
    let d = diagnose::diagnose(&fw, &data);
    console.result(render_diagnosis(&d).trim_end());
    if let Some(path) = json {
        write_json(
            &path,
            &[model.as_path(), log.stream.as_path()],
            schema::DIAGNOSE,
            &d,
        )?;
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
        out,
        out_static,
        json,
    } = args;
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
    let asked = match features.as_str() {
        "auto" => None,
        list => Some(extend::parse_features(list)?),
    };
    let Some(channels) = input.unit.load(Some(&stream), &console)? else {
        let load = |path: &Path| {
            load_stream(
                path,
                &input.maps.list,
                (window, &input.exclude.list),
                &console,
            )
        };
        let (train, valid, _) = held_out.parts(
            (&stream, vec![load(&stream)?]),
            |v| Ok(vec![load(v)?]),
            &console,
        )?;
        let (Some(train), Some(valid)) = (train.into_iter().next(), valid.into_iter().next())
        else {
            anyhow::bail!("{}: no stream read", stream.display());
        };
        let (inv, blobs) = investigate_one(
            &input.source(),
            (&stream, train, valid),
            (&fit, asked.as_deref()),
            &console,
        )?;
        if let Some(path) = out {
            write_atomically(&path, &blobs.extended_blob)?;
        }
        if let Some(path) = out_static {
            write_atomically(&path, &blobs.static_blob)?;
        }
        if let Some(path) = json {
            write_json(&path, &inputs, schema::INVESTIGATE, &inv)?;
        }
        return Ok(());
    };
    let load = |path: &Path| {
        load_unit_log(
            path,
            &channels,
            &input.maps.list,
            (window, &input.exclude.list),
            &console,
        )
    };
    let (train, valid, _) = held_out.parts((&stream, load(&stream)?), load, &console)?;
    let mut each = Vec::new();
    for (k, ch) in channels.list.iter().enumerate() {
        let console = console.channel(
            &ch.name,
            &format!(
                "{} ({}, [{}/{}]):",
                ch.name,
                ch.quantity.unit(),
                k + 1,
                channels.len()
            ),
        );
        let one = investigate_one(
            &input.source().for_channel(&channels, k)?,
            (&stream, train[k].clone(), valid[k].clone()),
            (&fit, asked.as_deref()),
            &console,
        )
        .with_context(|| format!("channel {}", ch.name))?;
        each.push(one);
    }
    console.result(&unit_gains(&channels, &each));
    write_unit_investigation(&channels, &each, (out, out_static, json), &inputs)
}

/// A unit's investigation written: its extended and static unit blobs and its JSON, each where
/// asked.
fn write_unit_investigation(
    channels: &Channels,
    each: &[(investigate::Investigation, investigate::Blobs)],
    (out, out_static, json): (Option<PathBuf>, Option<PathBuf>, Option<PathBuf>),
    inputs: &[&Path],
) -> anyhow::Result<()> {
    let pack = |pick: fn(&investigate::Blobs) -> &Vec<u8>| {
        let parts: Vec<ChannelBlob<'_>> = channels
            .list
            .iter()
            .zip(each)
            .map(|(ch, (_, b))| ChannelBlob {
                name: &ch.name,
                quantity: ch.quantity,
                blob: pick(b),
            })
            .collect();
        unit::unit_blob(&channels.sensor_id, &parts)
    };
    if let Some(path) = out {
        write_atomically(&path, &pack(|b| &b.extended_blob)?)?;
    }
    if let Some(path) = out_static {
        write_atomically(&path, &pack(|b| &b.static_blob)?)?;
    }
    if let Some(path) = json {
        let report = UnitInvestigation {
            sensor_id: &channels.sensor_id,
            channels: channels
                .list
                .iter()
                .zip(each)
                .map(|(ch, (inv, _))| ChannelInvestigation {
                    name: &ch.name,
                    quantity: ch.quantity,
                    units: ch.quantity.unit(),
                    investigation: inv,
                })
                .collect(),
        };
        write_json(&path, inputs, schema::INVESTIGATE_UNIT, &report)?;
    }
    Ok(())
}

/// What `investigate --channels --json` writes: each channel's investigation, its figures in
/// `units` (the `_dps` fields too).
#[derive(Serialize)]
struct UnitInvestigation<'a> {
    sensor_id: &'a str,
    channels: Vec<ChannelInvestigation<'a>>,
}

/// One channel of [`UnitInvestigation`].
#[derive(Serialize)]
struct ChannelInvestigation<'a> {
    name: &'a str,
    quantity: Quantity,
    units: &'static str,
    #[serde(flatten)]
    investigation: &'a investigate::Investigation,
}

/// A unit's investigation in one table: each channel's held-out figures, static and shipped, in
/// its bias unit, with its causes and gain.
fn unit_gains(
    channels: &Channels,
    each: &[(investigate::Investigation, investigate::Blobs)],
) -> String {
    let mut s = String::from(
        "held out, rmse_60s:  static          shipped         gain   causes named (shipped)\n",
    );
    let mut counted = String::new();
    for (ch, (inv, _)) in channels.list.iter().zip(each) {
        let (k, u) = (ch.quantity.bias_per_unit(), ch.quantity.bias_unit());
        s.push_str(&format!(
            "  {:<16} {:>9.3} {u:<4}  {:>9.3} {u:<4}  {:>5.2}×  {} ({})\n",
            ch.name,
            inv.static_score.rmse_60s_dps * k,
            inv.extended_score.rmse_60s_dps * k,
            inv.gain,
            causes_text(&inv.diagnosis.causes),
            match inv.shipped {
                investigate::Shipped::Extended => "extended",
                investigate::Shipped::Static => "static",
            }
        ));
        counted.push_str(&format!(
            "  {:<16} {}\n",
            ch.name,
            inv.extended_score.counted()
        ));
    }
    s + &counted
}

/// One channel's investigation, said as it goes: static fit, diagnosis and extension on `train`,
/// both models scored on `valid`.
fn investigate_one(
    source: &Source,
    (train_path, train, valid): (&Path, Stream, Stream),
    (fit, asked): (&FitOptions, Option<&[Cause]>),
    console: &Console,
) -> anyhow::Result<(investigate::Investigation, investigate::Blobs)> {
    let train = [(train_path, train)];
    let points = source.static_points(&train, false, console)?;
    let [(_, train)] = train;
    let rebuild =
        |part: &Stream| source.static_points(&[(train_path, part.clone())], false, console);
    let bar = console.bar(0);
    let (inv, blobs) =
        investigate::investigate(&points, &train, &valid, &fit.gp(), asked, &rebuild, &bar)?;
    bar.finish_and_clear();
    for w in &inv.warnings {
        console.warn(w);
    }
    let (k, u, unit) = (
        points.quantity.bias_per_unit(),
        points.quantity.bias_unit(),
        points.quantity.unit(),
    );
    console.result(render_diagnosis(&inv.diagnosis).trim_end());
    console.result(&format!("shipped {:?}: {}", inv.shipped, inv.verdict));
    console.result(&format!(
        "static rmse_60s {:.3e} {unit} ({:.2} {u}) | causes {} | added {} | shipped rmse_60s \
         {:.3e} {unit} ({:.2} {u}) | gain {:.2}× {}",
        inv.static_score.rmse_60s_dps,
        inv.static_score.rmse_60s_dps * k,
        causes_text(&inv.diagnosis.causes),
        if inv.added_inputs.is_empty() {
            "nothing".to_owned()
        } else {
            inv.added_inputs.join(", ")
        },
        inv.extended_score.rmse_60s_dps,
        inv.extended_score.rmse_60s_dps * k,
        inv.gain,
        inv.extended_score.counted()
    ));
    console.result(&format!("beyond the trained range: {}", inv.beyond.verdict));
    console.result(&format!(
        "shipped model's {}",
        inv.calibration.describe(unit)
    ));
    console.result(&format!(
        "on the held-out stream, the shipped model's σ: {}",
        sigma::describe(
            &inv.extended_score.sigma_samples,
            &inv.extended_score.sigma_60s
        )
    ));
    Ok((inv, blobs))
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
        test_points,
        runs: Runs { list: runs },
        json,
    } = args;
    if features.is_some() && (method != MethodArg::Gpr || test_points.is_some() || !runs.is_empty())
    {
        anyhow::bail!(
            "--features auto evaluates the GP (--method gpr) on one table; --test-points and \
             --run are not supported with it"
        );
    }
    let console = Console::new(flags, json.as_deref());
    let points = load_runs(
        &input.points,
        &runs,
        &input.maps.list,
        (group.as_deref(), None),
        input.exclude_implausible,
        &console,
    )?;
    let bar = console.bar(0);
    let mut cfg = EvalConfig {
        gp: fit.gp(),
        offsets,
        ..EvalConfig::default()
    };
    // What `fit` would ship: its size resolved as the default fit resolves it, where it can be.
    let centres_choice = if method == MethodArg::Gpr {
        resolve_loo_size(
            &points,
            &mut cfg.gp,
            features.is_some() || offsets,
            offsets,
            &console,
        )?
    } else {
        None
    };
    let cross = match &test_points {
        Some(path) => {
            let test = Points::load(path, &input.maps.list, None, None)?;
            match evaluate::cross_run(&points, &test, method.into(), &cfg, &bar) {
                Err(e @ evaluate::EvalError::NoOverlap) => {
                    console.warn(&format!("skipped the test on {}: {e}", path.display()));
                    None
                }
                other => Some((path, other?)),
            }
        }
        None => None,
    };
    let cross = match cross {
        Some((path, c)) => {
            console.result(&format!(
                "{}: fitted on {}, tested on {}: RMSE {:.3e} °/s ({:.2} °/h) over {} points \
                 in {:.2}–{:.2} °C, |rate| ≤ {:.1} °/s ({} outside, not scored)",
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
            Some(c)
        }
        None => None,
    };
    let e = match features {
        Some(_) => evaluate::evaluate_table(&points, &cfg, &bar)?,
        None => evaluate::evaluate(&points, method.into(), &cfg, &bar)?,
    };
    bar.finish_and_clear();
    print_loo(&console, &e);
    if let Some(path) = json {
        let mut inputs = vec![input.points.as_path()];
        inputs.extend(runs.iter().map(PathBuf::as_path));
        inputs.extend(test_points.as_deref());
        let report = LooReport {
            evaluation: &e,
            cross_run: cross.as_ref(),
            centres_choice: centres_choice.as_ref(),
        };
        write_json(&path, &inputs, schema::LOO, &report)?;
    }
    Ok(())
}

/// The size of the GP `loo` evaluates: what `fit` would ship ([`capacity::resolve`]), or, where
/// the evaluation needs the exact GP (`exact_only`: `--features auto`, `--offsets`), the exact GP
/// with a warning where `fit` would refuse to export it.
fn resolve_loo_size(
    points: &Points,
    gp: &mut GpConfig,
    exact_only: bool,
    offsets: bool,
    console: &Console,
) -> anyhow::Result<Option<capacity::Choice>> {
    if exact_only {
        if capacity::needed(gp.inducing, points.len()) {
            console.warn(&format!(
                "{} points are more than the {} centres a firmware model holds, and {} needs the \
                 exact GP: these are the exact GP's figures, which `fit` would refuse to export",
                points.len(),
                firmware_core::MAX_CENTRES,
                if offsets {
                    "--offsets"
                } else {
                    "--features auto"
                }
            ));
        }
        return Ok(None);
    }
    let spinner = console.spinner("choosing the model `fit` would ship");
    let (resolved, choice) = capacity::resolve(points, gp, |step| {
        spinner.set_message(format!("choosing the model `fit` would ship: {step}"));
    })?;
    spinner.finish_and_clear();
    if let Some(c) = &choice {
        console.result(&format!(
            "evaluating what `fit` would ship (--inducing exact: the exact GP): {}",
            c.verdict
        ));
    }
    *gp = resolved;
    Ok(choice)
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

/// What `trainer loo --json` writes: the evaluation's fields, and the cross-run test when one
/// was asked for (`null` otherwise).
#[derive(Serialize)]
struct LooReport<'a> {
    #[serde(flatten)]
    evaluation: &'a Evaluation,
    cross_run: Option<&'a CrossRun>,
    /// How the default chose the size `fit` would ship (more points than the firmware holds).
    centres_choice: Option<&'a capacity::Choice>,
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
    let bar = console.bar(0);
    let r = reproduce::reproduce(&points, &cfg, &bar)?;

    bar.finish_and_clear();
    console.result(r.render(&input.points.display().to_string()).trim_end());
    if let Some(path) = json {
        write_json(&path, &[input.points.as_path()], schema::REPRODUCE, &r)?;
    }
    Ok(())
}
