//! The `trainer` command line: flags are parsed into checked settings, then dispatched to the
//! library. `main.rs` only calls [`run`]; tests call it too, with arguments of their own.

use std::path::{Path, PathBuf};

use crate::console::{AFTER_HELP, Console, ConsoleFlags};
use crate::data::ColumnMap;
use crate::dataset::{Points, Screen};
use crate::diagnose::{self, Diagnosis};
use crate::evaluate::{self, EvalConfig, Method};
use crate::export::{self, AgreementReport, Extension};
use crate::extend;
use crate::gp::{
    AUTO_EXACT_MAX, GpConfig, GpModel, Hyperparameters, Inducing, Optimization, StartReport,
};
use crate::investigate;
use crate::io::{ensure_not_input, write_atomically, write_json};
use crate::prior::{MeanBasis, PolyPrior};
use crate::report;
use crate::reproduce::Reproduction;
use crate::sparse::SparseFit;
use crate::stream::{Handled, Stream, Window};
use crate::table::{self, TableDiagnosis, TableModel, Transients};
use anyhow::Context;
use clap::{Args, Parser, Subcommand, ValueEnum};
use firmware_core::Feature;
use serde::Serialize;

/// Host trainer for FOG temperature-drift compensation (Gaussian-process regression).
#[derive(Parser)]
#[command(version, about, after_help = AFTER_HELP)]
pub struct Cli {
    #[command(subcommand)]
    /// The subcommand.
    command: Command,
    #[command(flatten)]
    console: ConsoleFlags,
}

/// The `--map` flag of every data-reading command, in both programs.
#[derive(Args, Clone, Default)]
pub struct Maps {
    /// Map a canonical column onto a source column, COLUMN*FACTOR, or a constant (repeatable).
    #[arg(long = "map", value_name = "NAME=SOURCE")]
    pub list: Vec<ColumnMap>,
}

#[derive(Args, Clone)]
struct Input {
    /// Points CSV: temp_c,voltage_v,rate_dps (extra columns ignored).
    #[arg(long)]
    points: PathBuf,
    #[command(flatten)]
    maps: Maps,
    /// Leave rows that are implausible next to the others (a temperature or rate far outside the
    /// rest) out, with a warning, instead of refusing the file.
    #[arg(long)]
    exclude_implausible: bool,
}

/// Where the static model comes from, for the commands that can fit it on a stream.
#[derive(Args, Clone)]
struct ModelInput {
    /// Rate-table points CSV: temp_c,voltage_v,rate_dps. Without it the static model is fitted on
    /// the (training) stream's 60 s block means.
    #[arg(long)]
    points: Option<PathBuf>,
    #[command(flatten)]
    maps: Maps,
    /// Nominal scale factor K, output units per °/s: learn the bias (output/K − rate) from
    /// temperature instead of the map ω = f(T, output) — all a static log allows.
    #[arg(long, value_name = "K")]
    scale_factor: Option<f64>,
    /// Leave rate-table rows that are implausible next to the others (a temperature or rate far
    /// outside the rest) out, with a warning, instead of refusing the file.
    #[arg(long, requires = "points")]
    exclude_implausible: bool,
    /// Groups of the rate table, a column (e.g. half_sweep): what the diagnosis of a table in
    /// time order leaves out, one at a time (default: temperature plateaus).
    #[arg(long, requires = "points")]
    group: Option<String>,
    /// Give each group of --group its own offset in the GP (runs, sweeps or power-ons that sit
    /// apart by a constant): fitted as a variance, left out of the firmware's predictions.
    #[arg(long, requires = "group")]
    offsets: bool,
}

impl ModelInput {
    /// Refuses --offsets where `command` has no use for it.
    fn without_offsets(&self, command: &str) -> anyhow::Result<()> {
        anyhow::ensure!(
            !self.offsets,
            "--offsets is for `fit` and `loo` on a rate table; `{command}` does not take it"
        );
        Ok(())
    }

    /// The points of the static model: the rate table when given, else the streams' block means;
    /// with `pool`, every sample of the streams as well.
    fn static_points(&self, streams: &[(&Path, Stream)], pool: bool) -> anyhow::Result<Points> {
        let mut out = match &self.points {
            Some(path) => Some(load_points(
                path,
                &self.maps.list,
                self.group.as_deref(),
                self.scale_factor,
                self.exclude_implausible,
            )?),
            None => None,
        };
        if !pool && let Some(points) = out {
            return Ok(points);
        }
        for (path, s) in streams {
            let more = if pool {
                Points::from_stream_samples(path, s, self.scale_factor)?
            } else {
                Points::from_stream(path, s, self.scale_factor)?
            };
            out = Some(match out {
                Some(p) => p.pooled(more)?,
                None => more,
            });
        }
        out.context("give --points (a rate table) or --stream to fit on")
    }
}

/// Loads rate-table points; with `exclude`, implausible rows are left out with a warning each
/// rather than refused.
fn load_points(
    path: &Path,
    maps: &[ColumnMap],
    group: Option<&str>,
    scale_factor: Option<f64>,
    exclude: bool,
) -> anyhow::Result<Points> {
    let screen = if exclude {
        Screen::Exclude
    } else {
        Screen::Refuse
    };
    let (points, left_out) = Points::load_screened(path, maps, group, scale_factor, screen)?;
    for row in &left_out {
        eprintln!(
            "warning: {} {row}: left out (--exclude-implausible)",
            path.display()
        );
    }
    Ok(points)
}

/// Loads a stream and keeps the part inside `window`.
fn load_stream(path: &Path, maps: &[ColumnMap], window: Option<Window>) -> anyhow::Result<Stream> {
    let s = Stream::load(path, maps)?;
    for h in &s.handled {
        eprintln!("warning: {} {h}", path.display());
    }
    let Some(w) = window else { return Ok(s) };
    let part = s.window(w);
    anyhow::ensure!(
        part.len() >= 2,
        "{}: the window {:?}..{:?} s holds {} samples",
        path.display(),
        w.start_s,
        w.end_s,
        part.len()
    );
    Ok(part)
}

#[derive(Args, Clone)]
struct FitOptions {
    /// Random optimizer starts, besides the paper's (all log-hyperparameters 0) and a
    /// data-informed one.
    #[arg(long, default_value_t = GpConfig::default().random_starts)]
    restarts: usize,
    /// Seed of the random starts.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// L-BFGS iteration cap of each optimizer start (a fit where no start converges says so).
    #[arg(long, default_value_t = GpConfig::default().max_iters, value_parser = clap::value_parser!(u64).range(1..))]
    max_iters: u64,
    /// Prior-mean basis: physics ({1,T,T²}×{1,V,V³}), constant (the paper's), or polyN (all
    /// monomials of degree ≤ N). Its coefficients are estimated with the GP (GLS).
    #[arg(long, default_value_t = GpConfig::default().mean)]
    mean: MeanBasis,
    /// Exact GP or sparse (variational, this many inducing points): auto fits up to
    /// 1,000 samples exactly and sparse with 24 inducing points above.
    #[arg(long, default_value_t = GpConfig::default().inducing, value_name = "auto|exact|M")]
    inducing: Inducing,
}

impl FitOptions {
    fn gp(&self) -> GpConfig {
        GpConfig {
            random_starts: self.restarts,
            seed: self.seed,
            mean: self.mean,
            inducing: self.inducing,
            max_iters: self.max_iters,
            ..GpConfig::default()
        }
    }
}

#[derive(Subcommand)]
enum Command {
    /// Fit the GP map ω = f(T, V) to rate-table points (or to a stream's 60 s block means) and
    /// export the firmware blob; with --features, extend it by the inputs named (or by what the
    /// diagnosis names: auto), fitted on the stream.
    ///
    /// Example: trainer fit --points points.csv --out model.bin --json fit.json
    ///
    /// Example: trainer fit --points points.csv --stream ramp.csv --features auto --out ext.bin
    ///
    /// Example (a turntable run, rows in time order, 21 s each): trainer fit --points run.csv
    /// --map time_s=segment*21 --features auto --out model.bin
    ///
    /// Example (a static log, gyro output in °/s): trainer fit --stream imu.tsv --map
    /// time_s=timestamp*1e-6 --map temp_c=imu.temperature --map voltage_v=imu.gyro.x*57.29577951
    /// --map rate_dps=0 --scale-factor 1 --out bias.bin
    Fit(FitArgs),
    /// Replay a stream through a model, and name the physical cause of what it gets wrong
    /// (docs/design.md §5 cause ids), with the evidence and the runner-up.
    ///
    /// Example: trainer diagnose --model model.bin --stream s.csv --json d.json
    Diagnose(DiagnoseArgs),
    /// Static fit → replay on the held-out stream → diagnosis → extended fit on the points and the
    /// training stream → replay on the held-out stream → gain.
    ///
    /// Example: trainer investigate --points p.csv --train-stream a.csv --valid-stream b.csv --json i.json
    ///
    /// Example (one static log, forward in time): trainer investigate --train-stream imu.tsv
    /// --train-window :2400 --valid-stream imu.tsv --valid-window 2400: --scale-factor 1 --map …
    Investigate(InvestigateArgs),
    /// Size and static memory of a model blob on the firmware, with the formula.
    ///
    /// Example: trainer inspect model.bin
    Inspect(InspectArgs),
    /// Leave-one-out and leave-one-temperature-out evaluation of one method.
    ///
    /// Example: trainer loo --points points.csv --method gpr --json loo.json
    Loo(LooArgs),
    /// One self-contained HTML report (inline SVG) and its figures as SVG files: the rate table,
    /// the paper's Fig. 2, 4 and 5–6, the held-out replay (static and extended, ±2σ) and the
    /// diagnosis, with the LOO, leave-one-temperature-out and gain tables. Without data, on a
    /// simulated gyro with a hidden thermal-rate drift (the main job's, written to OUT/data by the
    /// `firmware-sim` beside this program).
    ///
    /// Example: trainer report --points points.csv --train-stream train.csv --valid-stream
    /// valid.csv --out report
    Report(ReportArgs),
    /// Our figures beside the reference paper's: LOO, leave-one-temperature-out, Fig. 2, Q-Q.
    ///
    /// Example: trainer reproduce --points points.csv
    Reproduce(ReproduceArgs),
}

/// The arguments of `trainer fit`.
#[derive(Args)]
struct FitArgs {
    #[command(flatten)]
    input: ModelInput,
    #[command(flatten)]
    fit: FitOptions,
    /// Stream: time_s,temp_c,voltage_v,rate_dps (repeatable: runs are pooled). The static model
    /// is fitted on it when there are no --points; --features are fitted on it (one stream; it
    /// must excite them: ramps, power-ons).
    #[arg(long)]
    stream: Vec<PathBuf>,
    /// Use only this part of each stream: START:END, s from its first sample.
    #[arg(long, requires = "stream")]
    window: Option<Window>,
    /// Fit the static model on every sample of --stream (1 Hz, not 60 s means), pooled with
    /// --points when given: a long stream's static model (sparse GP by size).
    #[arg(long, requires = "stream")]
    pool_stream: bool,
    /// Inputs to add, fitted on --stream: auto (diagnose the stream and add what the cause
    /// calls for) or a list of temperature-rate, coil-temperature, power-on-decay,
    /// thermal-state, time-on. Without --stream, auto diagnoses --points recorded in time
    /// order (--map time_s=…) for transients on the bias and the scale factor.
    #[arg(long)]
    features: Option<String>,
    /// Model blob to write (firmware-core format).
    #[arg(long)]
    out: PathBuf,
    /// Write the fit summary as JSON here (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// The arguments of `trainer diagnose`.
#[derive(Args)]
struct DiagnoseArgs {
    /// Model blob.
    #[arg(long)]
    model: PathBuf,
    /// Stream CSV: time_s,temp_c,voltage_v,rate_dps.
    #[arg(long)]
    stream: PathBuf,
    #[command(flatten)]
    maps: Maps,
    /// Use only this part of the stream: START:END, s from its first sample.
    #[arg(long)]
    window: Option<Window>,
    /// Write the diagnosis as JSON here (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// The arguments of `trainer investigate`.
#[derive(Args)]
struct InvestigateArgs {
    #[command(flatten)]
    input: ModelInput,
    #[command(flatten)]
    fit: FitOptions,
    /// Stream the extension is fitted on (and the static model, without --points).
    #[arg(long)]
    train_stream: PathBuf,
    /// Use only this part of the training stream: START:END, s from its first sample.
    #[arg(long)]
    train_window: Option<Window>,
    /// Held-out stream: diagnosed and scored.
    #[arg(long)]
    valid_stream: PathBuf,
    /// Use only this part of the held-out stream: START:END, s from its first sample.
    #[arg(long)]
    valid_window: Option<Window>,
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

/// The arguments of `trainer inspect`.
#[derive(Args)]
struct InspectArgs {
    /// The model blob.
    model: PathBuf,
    /// Write the figures as JSON here (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// The arguments of `trainer loo`.
#[derive(Args)]
struct LooArgs {
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
    /// Write the evaluation as JSON here (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// The arguments of `trainer report`.
#[derive(Args)]
struct ReportArgs {
    #[command(flatten)]
    input: ModelInput,
    #[command(flatten)]
    fit: FitOptions,
    /// Stream the extension is fitted on.
    #[arg(long, requires = "valid_stream")]
    train_stream: Option<PathBuf>,
    /// Held-out stream: replayed, diagnosed and scored.
    #[arg(long, requires = "train_stream")]
    valid_stream: Option<PathBuf>,
    /// Directory for report.html and the figures (created if missing).
    #[arg(long, visible_alias = "out-dir")]
    out: PathBuf,
}

/// The arguments of `trainer reproduce`.
#[derive(Args)]
struct ReproduceArgs {
    #[command(flatten)]
    input: Input,
    #[command(flatten)]
    fit: FitOptions,
    /// Write all figures as JSON here (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum MethodArg {
    Gpr,
    Lssvr,
    TwoStep,
    Poly,
}

impl From<MethodArg> for Method {
    fn from(m: MethodArg) -> Self {
        match m {
            MethodArg::Gpr => Method::Gpr,
            MethodArg::Lssvr => Method::Lssvr,
            MethodArg::TwoStep => Method::TwoStep,
            MethodArg::Poly => Method::Poly,
        }
    }
}

/// The main job's data (README.md), written to `dir` by the `firmware-sim` beside this program: a
/// nominal gyro with a hidden thermal-rate drift, its rate table and two ramp streams.
fn simulated(dir: &Path, console: &Console) -> anyhow::Result<(ModelInput, PathBuf, PathBuf)> {
    let sim = std::env::current_exe()
        .context("locating this program")?
        .with_file_name(format!("firmware-sim{}", std::env::consts::EXE_SUFFIX));
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let files = [
        ("paper", 1, "points.csv"),
        ("stream", 2, "train.csv"),
        ("stream", 3, "valid.csv"),
    ];
    for (kind, seed, name) in files {
        let path = dir.join(name);
        let seed = seed.to_string();
        let args = [
            "generate",
            kind,
            "--seed",
            &seed,
            "--effect",
            "thermal-rate",
            "--quiet",
        ];
        console.detail(&format!(
            "{} {} --out {}",
            sim.display(),
            args.join(" "),
            path.display()
        ));
        let status = std::process::Command::new(&sim)
            .args(args)
            .arg("--out")
            .arg(&path)
            .status()
            .with_context(|| {
                format!(
                    "no data given, and the simulator {} could not run (build it: cargo build \
                     --release; or give --points, --train-stream and --valid-stream)",
                    sim.display()
                )
            })?;
        anyhow::ensure!(status.success(), "{} failed: {status}", sim.display());
    }
    console.result(&format!(
        "no data given: simulated a gyro with a hidden thermal-rate drift into {}",
        dir.display()
    ));
    let input = ModelInput {
        points: Some(dir.join("points.csv")),
        maps: Maps::default(),
        scale_factor: None,
        exclude_implausible: false,
        group: None,
        offsets: false,
    };
    Ok((input, dir.join("train.csv"), dir.join("valid.csv")))
}

/// Under --verbose: every optimizer start of a fit, where it began and ended.
fn log_starts(console: &Console, model: &GpModel) {
    if !console.verbose() {
        return;
    }
    console.detail("optimizer starts (θ = ln ℓ…, ln σ_f, ln σ_n[, ln σ_g]; normalized):");
    for (i, s) in model.starts.iter().enumerate() {
        let fmt = |t: &[f64]| {
            t.iter()
                .map(|v| format!("{v:.3}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        console.detail(&format!(
            "  {i:>2}: [{}] → [{}]  log ML {}  {} iterations, {} evaluations: {}",
            fmt(&s.start),
            s.end.as_deref().map_or("failed".to_owned(), fmt),
            s.log_marginal_likelihood
                .map_or("—".to_owned(), |l| format!("{l:.3}")),
            s.iterations,
            s.evaluations,
            s.status
        ));
    }
}

/// Named causes joined by " + ", or `none`.
fn causes_text(causes: &[crate::cause::Cause]) -> String {
    if causes.is_empty() {
        return "none".to_owned();
    }
    diagnose::joined(causes)
}

/// The diagnosis as a terminal reads it: the verdict, every candidate alone, then the selection.
fn render_diagnosis(d: &Diagnosis) -> String {
    let mut s = format!(
        "causes: {} — {}\nresidual rmse_60s {:.3e} °/s ({:.2} °/h) over {} blocks of 60 s\n\
         candidate       score   forward   parameter   correlation   amplitude (°/h)\n",
        causes_text(&d.causes),
        d.explanation,
        d.residual_rmse_60s_dps,
        d.residual_rmse_60s_dps * 3600.0,
        d.n_blocks
    );
    for c in &d.candidates {
        s.push_str(&format!(
            "{:<14} {:>6.3}   {:>7.3}   {:>9.1}   {:>11.3}   {:>15.2}\n",
            c.id.id(),
            c.score,
            c.forward_score,
            c.parameter,
            c.correlation,
            c.amplitude_dph
        ));
    }
    s.push_str("selection: causes                                of what is left: score   forward   taken\n");
    for st in &d.steps {
        s.push_str(&format!(
            "           {:<38} {:>21.3}   {:>7.3}   {}\n",
            causes_text(&st.causes),
            st.score,
            st.forward_score,
            if st.added { "yes" } else { "no" }
        ));
    }
    s
}

/// What `trainer fit --json` writes (docs/design.md §6): the fitted GP, the extension that
/// shipped, and how the firmware's f32 evaluation follows the host.
#[derive(Serialize)]
struct FitReport {
    scale_factor: Option<f64>,
    log_marginal_likelihood: f64,
    hyperparameters: Hyperparameters,
    fit_seconds: f64,
    n_train: usize,
    features: Inputs,
    mean_basis: MeanBasis,
    prior_mean: PolyPrior,
    output_scale: f64,
    jitter: f64,
    centres: usize,
    sparse: Option<SparseFit>,
    starts: Vec<StartReport>,
    optimization: Optimization,
    warnings: Vec<String>,
    /// The diagnosis of a table recorded in time order (`--features auto` without a stream).
    #[serde(skip_serializing_if = "Option::is_none")]
    table_diagnosis: Option<TableDiagnosis>,
    #[serde(skip_serializing_if = "Option::is_none")]
    extension: Option<ExtensionReport>,
    /// The diagnosis of the stream and the forward check (`--features` with a stream).
    #[serde(flatten)]
    stream_choice: Option<StreamChoice>,
    handled: Vec<Handled>,
    firmware_agreement: AgreementReport,
    blob_bytes: usize,
}

/// A model's inputs: the points' columns for a static model, the firmware's features for an
/// extended one.
#[derive(Serialize)]
#[serde(untagged)]
enum Inputs {
    Columns(Vec<&'static str>),
    Firmware(Vec<Feature>),
}

/// The extension in the blob: a table's transient terms, or inputs fitted on a stream.
#[derive(Serialize)]
#[serde(untagged)]
enum ExtensionReport {
    Table(Extension),
    Stream(extend::Fitted),
}

/// What the diagnosis of the training stream chose, and why.
#[derive(Serialize)]
struct StreamChoice {
    diagnosis: Diagnosis,
    forward_check: Option<investigate::ForwardCheck>,
    shipped: investigate::Shipped,
    verdict: String,
}

impl FitReport {
    /// The static part, from the model and its points; the rest is filled in as it is known.
    fn new(m: &GpModel, points: &Points, agreement: AgreementReport, blob_bytes: usize) -> Self {
        let columns = points
            .features()
            .iter()
            .map(|f| match f {
                Feature::Temperature => "temp_c",
                _ => "voltage_v",
            })
            .collect();
        Self {
            scale_factor: points.scale_factor,
            log_marginal_likelihood: m.log_marginal_likelihood(),
            hyperparameters: m.posterior.hyper.clone(),
            fit_seconds: m.fit_seconds,
            n_train: m.y.len(),
            features: Inputs::Columns(columns),
            mean_basis: m.basis,
            prior_mean: m.prior.clone(),
            output_scale: m.output_scale,
            jitter: m.posterior.jitter,
            centres: m.posterior.xs.nrows(),
            sparse: m.sparse.clone(),
            starts: m.starts.clone(),
            optimization: m.optimization.clone(),
            warnings: m.warnings(),
            table_diagnosis: None,
            extension: None,
            stream_choice: None,
            handled: Vec::new(),
            firmware_agreement: agreement,
            blob_bytes,
        }
    }
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let flags = cli.console;
    match cli.command {
        Command::Fit(args) => fit_command(args, flags),
        Command::Diagnose(args) => diagnose_command(args, flags),
        Command::Investigate(args) => investigate_command(args, flags),
        Command::Inspect(args) => inspect_command(args, flags),
        Command::Loo(args) => loo_command(args, flags),
        Command::Report(args) => report_command(args, flags),
        Command::Reproduce(args) => reproduce_command(args, flags),
    }
}

/// `trainer fit`: the static model (or a table diagnosed in time order, or a stream's extension) and its blob.
fn fit_command(args: FitArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let FitArgs {
        input,
        fit,
        stream,
        window,
        pool_stream,
        features,
        out,
        json,
    } = args;
    let console = Console::new(flags, json.as_deref());
    let mut inputs: Vec<&Path> = input.points.iter().map(PathBuf::as_path).collect();
    inputs.extend(stream.iter().map(PathBuf::as_path));
    ensure_not_input(&out, &inputs)?;
    // Without a stream, --features auto diagnoses a table recorded in time order.
    let on_table = features.is_some() && stream.is_empty() && input.points.is_some();
    anyhow::ensure!(
        features.is_none() || stream.len() == 1 || on_table,
        "--features are fitted on one stream, or (auto) on a rate table recorded in time \
         order; {} streams given",
        stream.len()
    );
    anyhow::ensure!(
        !on_table || features.as_deref() == Some("auto"),
        "on a rate table the inputs are chosen by its diagnosis: --features auto"
    );
    anyhow::ensure!(
        input.points.is_none() || stream.is_empty() || features.is_some() || pool_stream,
        "--stream would not be used: with --points the static model is fitted on the rate \
         table; add --pool-stream to fit on the stream's samples too, or --features to \
         extend the model by inputs fitted on the stream"
    );
    let streams = stream
        .iter()
        .map(|p| Ok((p.as_path(), load_stream(p, &input.maps.list, window)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let points = input.static_points(&streams, pool_stream)?;
    let gp = fit.gp();
    let centres = gp.inducing.count(points.len()).unwrap_or(points.len());
    anyhow::ensure!(
        centres <= export::MAX_CENTRES,
        "model too large to export: {} gives {centres} centres, and a firmware model holds at \
         most {} centres; ask for a sparse GP (--inducing {}) or fit on fewer points \
         (checked before fitting)",
        match gp.inducing {
            Inducing::Auto => format!(
                "an exact GP on {} points (the default up to {AUTO_EXACT_MAX})",
                points.len()
            ),
            asked => format!("--inducing {asked} on {} points", points.len()),
        },
        export::MAX_CENTRES,
        export::MAX_CENTRES
    );
    let spinner = console.spinner(&match gp.inducing.count(points.len()) {
        Some(m) => format!(
            "fitting a sparse GP ({m} inducing points) on {} samples",
            points.len()
        ),
        None => format!("fitting an exact GP on {} points", points.len()),
    });
    let table = if on_table {
        let transients = Transients::compute(&points)?;
        let all: Vec<usize> = (0..points.len()).collect();
        Some(table::fit(
            &points,
            &transients,
            &all,
            (&gp, input.offsets),
        )?)
    } else {
        None
    };
    let model = match &table {
        Some(t) => t.gp.clone(),
        None => GpModel::fit_grouped(
            &points.inputs(),
            &points.target(),
            &points.offset_groups(input.offsets),
            &gp,
        )?,
    };
    spinner.finish_and_clear();
    log_starts(&console, &model);
    // Before the f32 check: a warning may explain why it refuses the blob.
    for w in model.warnings() {
        console.warn(&w);
    }
    let extension = table
        .as_ref()
        .map(TableModel::extension)
        .unwrap_or_default();
    let mut blob = export::points_blob(&model, &points, &extension)?;
    let (firmware, mut agreement) = export::verify(&model, &blob, &points, &extension)?;
    let mut summary = FitReport::new(&model, &points, agreement, blob.len());
    if let Some(t) = &table {
        console.result(&format!(
            "diagnosis of the table (time order): {}",
            t.diagnosis.verdict
        ));
        summary.table_diagnosis = Some(t.diagnosis.clone());
        summary.extension = Some(ExtensionReport::Table(extension.clone()));
        summary.features = Inputs::Firmware(firmware.features().to_vec());
    }
    if let ([(path, data)], Some(list)) = (streams.as_slice(), &features) {
        let asked = match list.as_str() {
            "auto" => None,
            list => Some(extend::parse_features(list)?),
        };
        let rebuild = |part: &Stream| input.static_points(&[(path, part.clone())], pool_stream);
        let choice = investigate::choose(
            &points,
            &model,
            &firmware,
            data,
            &gp,
            asked.as_deref(),
            &rebuild,
        )?;
        if asked.is_none() {
            console.result(&format!(
                "diagnosis of {}: {} — {}",
                path.display(),
                causes_text(&choice.diagnosis.causes),
                choice.diagnosis.explanation
            ));
        }
        summary.stream_choice = Some(StreamChoice {
            diagnosis: choice.diagnosis.clone(),
            forward_check: choice.check.clone(),
            shipped: choice.shipped,
            verdict: choice.verdict.clone(),
        });
        if let (Some(extended), investigate::Shipped::Extended) = (choice.extended, choice.shipped)
        {
            let fitted = extended.fitted;
            blob = extended.blob;
            agreement = extended.agreement;
            let ext = export::decode(&blob)?;
            console.result(&format!(
                "extended by {:?} on {}: training residual rmse_60s {:.3e} → {:.3e} °/s",
                ext.features(),
                path.display(),
                fitted.train_rmse_60s_dps[0],
                fitted.train_rmse_60s_dps[1]
            ));
            summary.features = Inputs::Firmware(ext.features().to_vec());
            summary.extension = Some(ExtensionReport::Stream(fitted));
        }
        if choice.check.as_ref().is_some_and(|c| !c.extension_helps()) {
            console.warn(&choice.verdict);
        } else {
            console.result(&choice.verdict);
        }
    }
    summary.handled = streams
        .iter()
        .flat_map(|(_, s)| s.handled.iter().cloned())
        .collect();
    summary.firmware_agreement = agreement;
    summary.blob_bytes = blob.len();
    write_atomically(&out, &blob)?;
    if let Some(path) = json {
        write_json(&path, &inputs, &summary)?;
    }
    if let Some(s) = &model.sparse {
        console.result(&format!(
            "sparse GP ({}): {} inducing points for {} samples, starting hyperparameters from an exact GP on {}; bound {:.3}",
            s.method, s.inducing, s.n_train, s.subset, s.bound
        ));
    }
    console.result(&format!(
        "fitted GP on {} points: log ML {:.3}, length scales {:?}, σ_f {:.4}, σ_n {:.3e} (normalized), jitter {:e}, {:.1} ms",
        points.len(),
        model.log_marginal_likelihood(),
        model.posterior.hyper.length_scales,
        model.posterior.hyper.signal_std,
        model.posterior.hyper.noise_std,
        model.posterior.jitter,
        model.fit_seconds * 1e3
    ));
    if let Some(g) = model.posterior.hyper.offset_std {
        console.result(&format!(
            "offsets between groups: σ_g {:.3e} (output units), counted as noise in the \
             firmware's variance (a new run's offset is unknown)",
            g * model.output_scale
        ));
    }
    console.result(&format!("wrote {} ({} bytes)", out.display(), blob.len()));
    console.result(
        "firmware (f32) vs host (f64):      n   max |Δmean| (°/s)   max rel Δvar   extrapolating",
    );
    for (name, a) in [
        ("training points", agreement.training),
        ("grid, trained range", agreement.grid_inside),
        ("grid, 10% beyond", agreement.grid_beyond),
    ] {
        console.result(&format!(
            "  {name:<22} {:>7}   {:>17.3e}   {:>12.3e}   {:>13}",
            a.n, a.max_abs_mean_diff, a.max_rel_var_diff, a.n_extrapolating
        ));
    }
    Ok(())
}

/// `trainer diagnose`: replays a stream through a blob and names the cause of its residual.
fn diagnose_command(args: DiagnoseArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let DiagnoseArgs {
        model,
        stream,
        maps,
        window,
        json,
    } = args;
    let console = Console::new(flags, json.as_deref());
    let bytes = std::fs::read(&model).with_context(|| format!("reading {}", model.display()))?;
    let fw = export::decode(&bytes).with_context(|| format!("decoding {}", model.display()))?;
    let data = load_stream(&stream, &maps.list, window)?;
    let d = diagnose::diagnose(&fw, &data);
    console.result(render_diagnosis(&d).trim_end());
    if let Some(path) = json {
        write_json(&path, &[model.as_path(), stream.as_path()], &d)?;
    }
    Ok(())
}

/// `trainer investigate`: static fit, diagnosis and extension on the training stream, both scored on the held-out one.
fn investigate_command(args: InvestigateArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let InvestigateArgs {
        input,
        fit,
        train_stream,
        train_window,
        valid_stream,
        valid_window,
        features,
        out,
        out_static,
        json,
    } = args;
    input.without_offsets("investigate")?;
    let console = Console::new(flags, json.as_deref());
    let mut inputs: Vec<&Path> = input.points.iter().map(PathBuf::as_path).collect();
    inputs.extend([train_stream.as_path(), valid_stream.as_path()]);
    for o in out.iter().chain(&out_static).chain(&json) {
        ensure_not_input(o, &inputs)?;
    }
    let train = [(
        train_stream.as_path(),
        load_stream(&train_stream, &input.maps.list, train_window)?,
    )];
    let valid = load_stream(&valid_stream, &input.maps.list, valid_window)?;
    let points = input.static_points(&train, false)?;
    let [(_, train)] = train;
    let asked = match features.as_str() {
        "auto" => None,
        list => Some(extend::parse_features(list)?),
    };
    let rebuild =
        |part: &Stream| input.static_points(&[(train_stream.as_path(), part.clone())], false);
    let bar = console.bar(0);
    let (inv, blobs) = investigate::investigate(
        &points,
        &train,
        &valid,
        &fit.gp(),
        asked.as_deref(),
        &rebuild,
        &bar,
    )?;
    bar.finish_and_clear();
    for w in &inv.warnings {
        console.warn(w);
    }
    console.result(render_diagnosis(&inv.diagnosis).trim_end());
    console.result(&format!("shipped {:?}: {}", inv.shipped, inv.verdict));
    console.result(&format!(
        "static rmse_60s {:.3e} °/s ({:.2} °/h) | causes {} | added {} | shipped rmse_60s \
         {:.3e} °/s ({:.2} °/h) | gain {:.2}×",
        inv.static_score.rmse_60s_dps,
        inv.static_score.rmse_60s_dps * 3600.0,
        causes_text(&inv.diagnosis.causes),
        if inv.added_inputs.is_empty() {
            "nothing".to_owned()
        } else {
            inv.added_inputs.join(", ")
        },
        inv.extended_score.rmse_60s_dps,
        inv.extended_score.rmse_60s_dps * 3600.0,
        inv.gain
    ));
    if let Some(path) = out {
        write_atomically(&path, &blobs.extended_blob)?;
    }
    if let Some(path) = out_static {
        write_atomically(&path, &blobs.static_blob)?;
    }
    if let Some(path) = json {
        write_json(&path, &inputs, &inv)?;
    }
    Ok(())
}

/// `trainer inspect`: a blob's size and static memory on the firmware.
fn inspect_command(args: InspectArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let InspectArgs { model, json } = args;
    let console = Console::new(flags, json.as_deref());
    let bytes = std::fs::read(&model).with_context(|| format!("reading {}", model.display()))?;
    let f = export::footprint(&bytes)?;
    export::decode(&bytes)?;
    console.result(&format!(
        "{}: m = {} centres, d = {} inputs, p = {} prior monomials\n\
         blob: {} bytes (18-byte header + postcard payload)\n\
         flat f32 array: 7d + p + 2 + m·d + m + m(m+1)/2 = {} numbers\n\
         static memory of Model<{}, {}, {}>: 4·{} + p·d + d + 24 = {} bytes (32-bit target)\n\
         variance scratch: 4·m = {} bytes",
        model.display(),
        f.m,
        f.d,
        f.p,
        f.blob_bytes,
        f.floats,
        f.d,
        f.p * f.d,
        f.floats,
        f.floats,
        f.model_bytes,
        f.scratch_bytes
    ));
    if let Some(path) = json {
        write_json(&path, &[model.as_path()], &f)?;
    }
    Ok(())
}

/// `trainer loo`: leave-one-out and leave-one-group-out of one method.
fn loo_command(args: LooArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let LooArgs {
        input,
        fit,
        method,
        group,
        offsets,
        features,
        test_points,
        json,
    } = args;
    if features.is_some() && (method != MethodArg::Gpr || test_points.is_some()) {
        anyhow::bail!(
            "--features auto evaluates the GP (--method gpr) on one table; --test-points \
             is not supported with it"
        );
    }
    let console = Console::new(flags, json.as_deref());
    let points = load_points(
        &input.points,
        &input.maps.list,
        group.as_deref(),
        None,
        input.exclude_implausible,
    )?;
    let bar = console.bar(0);
    let cfg = EvalConfig {
        gp: fit.gp(),
        offsets,
        ..EvalConfig::default()
    };
    let cross = match &test_points {
        Some(path) => {
            let test = Points::load(path, &input.maps.list, None, None)?;
            let c = evaluate::cross_run(&points, &test, method.into(), &cfg, &bar)?;
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
            Some(c)
        }
        None => None,
    };
    let e = match features {
        Some(_) => evaluate::evaluate_table(&points, &cfg, &bar)?,
        None => evaluate::evaluate(&points, method.into(), &cfg, &bar)?,
    };
    bar.finish_and_clear();
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
    console.result(&format!(
        "{}: leave-one-out RMSE {:.3e} °/s ({:.2} °/h) over {} points; Q-Q correlation {:.4}",
        e.method, e.rmse_dps, e.rmse_dph, e.n, e.qq_correlation
    ));
    console.result(&format!(
        "leave-one-group-out RMSE {:.3e} °/s ({:.2} °/h) over {} groups",
        e.group_rmse_dps,
        e.group_rmse_dph,
        e.per_temperature.len()
    ));
    console.result("leave-one-group-out:  group   T (°C)     n   RMSE (°/s)   RMSE (°/h)");
    for g in &e.per_temperature {
        console.result(&format!(
            "                     {:>6}  {:>7.2}  {:>4}   {:>10.3e}   {:>10.2}",
            g.group, g.temp_c, g.n, g.rmse_dps, g.rmse_dph
        ));
    }
    if let Some(path) = json {
        let mut inputs = vec![input.points.as_path()];
        inputs.extend(test_points.as_deref());
        let mut value = serde_json::to_value(&e)?;
        value["cross_run"] = serde_json::to_value(&cross)?;
        write_json(&path, &inputs, &value)?;
    }
    Ok(())
}

/// `trainer report`: the HTML report and its figures.
fn report_command(args: ReportArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let ReportArgs {
        input,
        fit,
        train_stream,
        valid_stream,
        out: out_dir,
    } = args;
    input.without_offsets("report")?;
    let console = Console::new(flags, None);
    let (input, train_stream, valid_stream) = match (train_stream, valid_stream) {
        (Some(a), Some(b)) => (input, a, b),
        _ if input.points.is_some() => anyhow::bail!(
            "--points needs --train-stream and --valid-stream: the report replays a \
             held-out stream (or give no data at all for the simulated gyro)"
        ),
        _ => simulated(&out_dir.join("data"), &console)?,
    };
    let mut inputs: Vec<&Path> = input.points.iter().map(PathBuf::as_path).collect();
    inputs.extend([train_stream.as_path(), valid_stream.as_path()]);
    let names = report::FIGURES.iter().map(|f| f.0).chain(["report.html"]);
    for name in names {
        ensure_not_input(&out_dir.join(name), &inputs)?;
    }
    let train = [(
        train_stream.as_path(),
        load_stream(&train_stream, &input.maps.list, None)?,
    )];
    let valid = load_stream(&valid_stream, &input.maps.list, None)?;
    let points = input.static_points(&train, false)?;
    let source = input.points.as_deref().unwrap_or(train_stream.as_path());
    let bar = console.bar(0);
    let r = report::build(source, points, &train[0].1, valid, &fit.gp(), &bar)?;
    bar.finish_and_clear();
    for path in report::write(&out_dir, &r)? {
        console.result(&format!("wrote {}", path.display()));
    }
    Ok(())
}

/// `trainer reproduce`: our figures beside the reference paper's.
fn reproduce_command(args: ReproduceArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let ReproduceArgs { input, fit, json } = args;
    let console = Console::new(flags, json.as_deref());
    let points = load_points(
        &input.points,
        &input.maps.list,
        None,
        None,
        input.exclude_implausible,
    )?;
    let cfg = EvalConfig {
        gp: fit.gp(),
        ..EvalConfig::default()
    };
    let bar = console.bar(0);
    let r = Reproduction {
        gpr: evaluate::evaluate(&points, Method::Gpr, &cfg, &bar)?,
        lssvr: evaluate::evaluate(&points, Method::Lssvr, &cfg, &bar)?,
        two_step: evaluate::evaluate(&points, Method::TwoStep, &cfg, &bar)?,
        fig2: evaluate::fig2(&points),
    };
    bar.finish_and_clear();
    console.result(r.render(&input.points.display().to_string()).trim_end());
    if let Some(path) = json {
        write_json(&path, &[input.points.as_path()], &r)?;
    }
    Ok(())
}
