//! What the data-reading commands share: the points or stream a model is fitted on, the fit's
//! options, and how files are loaded (with the loader's warnings shown).

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use firmware_core::Quantity;
use fog_data::channels::Datasheet;
use fog_data::stream::{Stream, Window};
use fog_terminal::console::Console;
use fog_terminal::log::{Excludes, Maps, UnitArgs};

use crate::analysis::evaluate::Method;
use crate::models::gp::{GpConfig, Inducing};
use crate::models::prior::MeanBasis;
use crate::pipeline::source::PointFiles;

#[derive(Args, Clone)]
pub(super) struct Input {
    /// Points CSV: temp_c,voltage_v,rate_dps (extra columns ignored).
    #[arg(long)]
    pub(super) points: PathBuf,
    #[command(flatten)]
    pub(super) maps: Maps,
    /// Leave rows that are implausible next to the others (a temperature or rate far outside the
    /// rest) out, with a warning, instead of refusing the file.
    #[arg(long)]
    pub(super) exclude_implausible: bool,
}

/// Other power-ons of the same sensor, for the commands that pool them (`fit`, `investigate`,
/// `loo`): a command line without this group refuses `--run` as it is read.
#[derive(Args, Clone, Default)]
pub(super) struct Runs {
    /// Another power-on's rate table of the same sensor (repeatable), with --points' columns:
    /// pooled with it as one calibration, each run left out in turn for the σ (the groups, unless
    /// --group), which so measures another power-on's bias.
    #[arg(long = "run", id = "run", value_name = "POINTS", requires = "points")]
    pub(super) list: Vec<PathBuf>,
}

/// Where the static model comes from, for the commands that can fit it on a stream.
#[derive(Args, Clone)]
pub(super) struct ModelInput {
    /// Rate-table points CSV: temp_c,voltage_v,rate_dps. Without it the static model is fitted on
    /// the (training) stream's 60 s block means.
    #[arg(long)]
    pub(super) points: Option<PathBuf>,
    /// Other power-ons' rate tables, from the commands that pool them ([`Runs`]); empty for the
    /// others, whose command lines do not take `--run`.
    #[arg(skip)]
    pub(super) runs: Vec<PathBuf>,
    #[command(flatten)]
    pub(super) maps: Maps,
    #[command(flatten)]
    pub(super) exclude: Excludes,
    /// Nominal scale factor K, output units per °/s: learn the bias (output/K − rate) from
    /// temperature instead of the map ω = f(T, output) — all a static log allows.
    #[arg(long, value_name = "K")]
    pub(super) scale_factor: Option<f64>,
    /// Leave rate-table rows that are implausible next to the others (a temperature or rate far
    /// outside the rest) out, with a warning, instead of refusing the file.
    #[arg(long, requires = "points")]
    pub(super) exclude_implausible: bool,
    /// Groups of the rate table, a column (e.g. half_sweep): what the diagnosis of a table in
    /// time order leaves out, one at a time (default: temperature plateaus).
    #[arg(long, requires = "points")]
    pub(super) group: Option<String>,
    #[command(flatten)]
    pub(super) unit: UnitArgs,
    /// What the output measures: a gyro's rate unless a unit's channel says otherwise.
    #[arg(skip = Quantity::AngularRate)]
    pub(super) quantity: Quantity,
}

impl ModelInput {
    /// Where the static model's points come from, as the pipelines take it.
    pub(super) fn source(&self) -> PointFiles {
        PointFiles {
            points: self.points.clone(),
            runs: self.runs.clone(),
            maps: self.maps.list.clone(),
            scale_factor: self.scale_factor,
            exclude_implausible: self.exclude_implausible,
            group: self.group.clone(),
            quantity: self.quantity,
        }
    }

    /// This input with the other power-ons' tables `runs` pooled with its rate table.
    pub(super) fn with_runs(self, runs: Runs) -> Self {
        Self {
            runs: runs.list,
            ..self
        }
    }
}

/// Where a command's held-out data are, named one way for every command that scores on data it
/// did not fit (`investigate`, `report`): the later part of the training log itself, or a log of
/// its own.
#[derive(Args, Clone)]
pub(super) struct HeldOut {
    /// Hold out --stream's log from this time on, s from the log's first sample (default: the
    /// last third in time of the part --window keeps): the part before fits, the part from it on
    /// is scored, forward in time, the part before as its history.
    #[arg(
        long,
        value_name = "SECONDS",
        requires = "stream",
        conflicts_with = "valid_stream"
    )]
    pub(super) hold_out_from: Option<f64>,
    /// Hold out a log of its own (another power-on, another day): scored, never fitted; all of
    /// --stream's log fits. --window and --exclude apply to both.
    #[arg(long, requires = "stream")]
    pub(super) valid_stream: Option<PathBuf>,
}

impl HeldOut {
    /// The parts of `stream` (the training log, all of it read) before and from the hold-out
    /// time, and that time (s from its first sample).
    pub(super) fn split(&self, stream: &Stream) -> anyhow::Result<(Stream, Stream, f64)> {
        let t0 = stream.time_s.first().copied().unwrap_or(0.0);
        let t1 = stream.time_s.last().copied().unwrap_or(t0);
        // A window's history is no part of either (`Stream::history`).
        let from = stream.time_s.get(stream.history).map_or(0.0, |t| t - t0);
        let split = self
            .hold_out_from
            .unwrap_or(from + (t1 - t0 - from) * 2.0 / 3.0);
        anyhow::ensure!(
            split > from && split < t1 - t0,
            "--hold-out-from {split} s: the stream runs from {from:.0} to {:.0} s, so nothing \
             would be left to fit on or to hold out",
            t1 - t0
        );
        let before = stream.window(Window {
            start_s: None,
            end_s: Some(split),
        });
        let mut after = stream.window(Window {
            start_s: Some(split),
            end_s: None,
        });
        // Fitted on the part before alone: what follows a --window was not seen, so the σ's time
        // terms count forward from the hold-out time only (`Stream::after_s`).
        after.after_s = None;
        Ok((before, after, split))
    }

    /// The training and held-out parts of a log (one stream per channel), and what is held out
    /// in words: `whole`, the training log `path` as read, split at the hold-out time (said in
    /// one line), or all of it beside the held-out log that `load` reads.
    pub(super) fn parts(
        &self,
        (path, whole): (&Path, Vec<Stream>),
        load: impl FnOnce(&Path) -> anyhow::Result<Vec<Stream>>,
        console: &Console,
    ) -> anyhow::Result<(Vec<Stream>, Vec<Stream>, String)> {
        if let Some(v) = &self.valid_stream {
            let said = format!("all of {}, a run of its own", v.display());
            return Ok((whole, load(v)?, said));
        }
        let (mut train, mut valid, mut said) = (Vec::new(), Vec::new(), String::new());
        for s in &whole {
            let (before, after, split_s) = self.split(s)?;
            if said.is_empty() {
                said = self.said(path, split_s);
                console.result(&format!("held out: {said}"));
            }
            train.push(before);
            valid.push(after);
        }
        Ok((train, valid, said))
    }

    /// What is held out, in words, for a log `path` split at `split_s`.
    pub(super) fn said(&self, path: &Path, split_s: f64) -> String {
        match self.hold_out_from {
            Some(_) => format!("{} from {split_s:.0} s on", path.display()),
            None => format!(
                "{}'s last third in time, from {split_s:.0} s on",
                path.display()
            ),
        }
    }
}

#[derive(Args, Clone)]
pub(super) struct FitOptions {
    /// Random optimizer starts, besides the paper's (all log-hyperparameters 0) and a
    /// data-informed one.
    #[arg(long, default_value_t = GpConfig::default().random_starts)]
    pub(super) restarts: usize,
    /// Seed of the random starts.
    #[arg(long, default_value_t = 0)]
    pub(super) seed: u64,
    /// L-BFGS-B iteration cap of each optimizer start (a fit where no start converges says so).
    #[arg(long, default_value_t = GpConfig::default().max_iters, value_parser = clap::value_parser!(u64).range(1..))]
    pub(super) max_iters: u64,
    /// Prior-mean basis: auto (physics, poly1 or poly2, whichever predicts temperature bands
    /// left out best, on 27–256 points spanning more than 1 °C; physics unless another misses by
    /// under 90 % of its error; `reproduce`, a report's table page and `loo` of another method
    /// than the GP: physics), physics ({1,T,T²}×{1,V,V³}), constant (the paper's), or polyN (all
    /// monomials of degree ≤ N). Its coefficients are estimated with the GP (GLS).
    #[arg(long, default_value_t = crate::analysis::basis::DEFAULT)]
    pub(super) mean: MeanBasis,
    /// Exact GP or sparse (variational, this many inducing points). auto: for `fit`, `loo` and
    /// `investigate` (and `report` through it), the exact GP up to 256 points (what a firmware model holds), else a sparse GP whose size
    /// is chosen on held-out data; the models other commands fit along the way and do not
    /// export are exact up to 1,000 points and have 24 inducing points above.
    #[arg(long, default_value_t = GpConfig::default().inducing, value_name = "auto|exact|M")]
    pub(super) inducing: Inducing,
}

impl FitOptions {
    pub(super) fn gp(&self) -> GpConfig {
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

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum MethodArg {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A log of `n` samples 1 s apart.
    fn log(n: usize) -> Stream {
        let time_s: Vec<f64> = (0..n).map(|i| i as f64).collect();
        Stream {
            temp_c: vec![20.0; n],
            voltage_v: vec![0.0; n],
            rate_dps: vec![0.0; n],
            lines: (2..).take(n).collect(),
            step_s: 1.0,
            time_issues: Vec::new(),
            handled: Vec::new(),
            time_s,
            history: 0,
            after_s: None,
        }
    }

    #[test]
    fn the_log_is_held_out_from_its_last_third_or_the_time_asked_and_never_past_its_end() {
        let s = log(301);
        let held = |from| HeldOut {
            hold_out_from: from,
            valid_stream: None,
        };
        // Default: the last third in time, every sample in exactly one part, in time order.
        let (train, valid, at) = held(None).split(&s).unwrap();
        assert_eq!(at, 200.0);
        assert_eq!(train.len() + valid.inside().len(), s.len());
        assert!(train.time_s.last().unwrap() < &valid.time_s[valid.history]);
        assert_eq!(valid.time_s[valid.history], 200.0);
        // The part held out keeps the training part as its history (`Stream::window`).
        assert_eq!((valid.history, valid.len()), (200, 301));
        assert!(
            held(None)
                .said(Path::new("a.csv"), at)
                .contains("last third")
        );
        // A window that ends before the log does: its held-out part was never fitted on what
        // follows it, so its time terms count forward only.
        let cut = s.window(":250".parse().unwrap());
        assert_eq!(cut.after_s, Some(250.0));
        let (_, valid, _) = held(None).split(&cut).unwrap();
        assert_eq!(valid.after_s, None);
        // Asked: from 60 s on.
        let (train, valid, at) = held(Some(60.0)).split(&s).unwrap();
        assert_eq!((at, train.len(), valid.inside().len()), (60.0, 60, 241));
        assert_eq!(
            held(Some(60.0)).said(Path::new("a.csv"), at),
            "a.csv from 60 s on"
        );
        // Nothing left to fit on, or nothing to hold out: refused, with the log's span.
        for from in [0.0, 300.0, 1e4] {
            let e = held(Some(from)).split(&s).unwrap_err().to_string();
            assert!(e.contains("runs from 0 to 300 s"), "{e}");
        }
        // A window's last third, its history part of neither; times from the log's start.
        let w = s.window("120:".parse().unwrap());
        let (train, valid, at) = held(None).split(&w).unwrap();
        assert_eq!(at, 240.0);
        assert_eq!((train.history, train.referenced().len()), (120, 120));
        assert_eq!(valid.inside().len(), 61);
        let e = held(Some(100.0)).split(&w).unwrap_err().to_string();
        assert!(e.contains("runs from 120 to 300 s"), "{e}");
    }
}

/// A datasheet's figures for the σ of every blob a command ships, where one power-on's
/// calibration data cannot show them (docs/uncertainty.md, "What the data cannot show"): `fit`,
/// `investigate` and `report` take them alike. A channels file's `[[channel]]` states a
/// channel's own, before these.
#[derive(Args, Clone, Default)]
pub(super) struct DatasheetArgs {
    /// The bias's run-to-run repeatability, 1σ in the channel's units (°/s, m/s²), as a datasheet
    /// gives it: every power-on in service is another than the calibration's, whose own bias was
    /// a draw too, so twice its variance is added to every sample's σ (default: where several
    /// power-ons do not measure it, the difference of two power-ons assumed as large as the
    /// model error's floor, said in the σ line; where another power-on's scale is assumed as
    /// large at the outputs' RMS as this bias, --scale-repeatability says what it does). For
    /// channels of one quantity (else each channel's `repeatability` in the channels file), but 0
    /// (a bias that repeats exactly), which every channel takes.
    #[arg(long, value_name = "SIGMA")]
    repeatability: Option<f64>,
    /// The scale factor's run-to-run repeatability, 1σ in ppm, as a datasheet gives it: every
    /// power-on in service is another than the calibration's, so twice its variance, in
    /// proportion to the output², is added to every sample's σ; on a unit, the same figure to
    /// each channel's (a channel's `scale_repeatability` in the channels file states its own;
    /// default: measured where a training stream's power-ons are left out in turn; else
    /// assumed, the difference of two power-ons as large as the residuals' model error in
    /// proportion to the output inside the trained range, where they show one, else as large at
    /// their outputs' RMS as another power-on's bias; left out at rest or where that bias is 0,
    /// which `fit` and `investigate` say in one line).
    #[arg(long, value_name = "PPM")]
    scale_repeatability: Option<f64>,
    /// The bias's temperature coefficient, in the channel's units per °C (°/s/°C, m/s²/°C), as
    /// a datasheet gives it (its zero-rate output, or offset, change over temperature): beyond
    /// the trained range the σ grows by that much per °C, in place of the growth assumed from the
    /// model's own trend inside the range where the mean is held there (under `--beyond` tangent
    /// or follow, added to what that rule assumes; a larger one the residuals fitted stands; the
    /// scale factor's part stays). For channels of one quantity (else each channel's `tempco`
    /// in the channels file).
    #[arg(long, value_name = "PER_C")]
    tempco: Option<f64>,
    /// The gap between the heating and the cooling leg at one temperature, in the channel's
    /// units, as a datasheet gives it (its thermal hysteresis): on a leg the training did not
    /// hold, the σ carries it (default: assumed as large as the training data's own
    /// out-of-sample error, said in the σ line; no term where the training held both legs, or
    /// where its states are not known: a rate table's soaks, alone or pooled with logs). For
    /// channels of one quantity (else each channel's `hysteresis` in the channels file).
    #[arg(long, value_name = "BAND")]
    hysteresis: Option<f64>,
    /// How far the temperature sensor lags the sensing element, s (the time constant of the
    /// heat's path between them, as a datasheet or a step test gives it): the model reads the
    /// sensor, wrong by the lag times the heating rate, and a calibration at one heating rate
    /// per temperature folds that into its model; at a rate outside the band the training held
    /// the σ carries the model's change per °C over the lag times that rate's excess (default:
    /// 30 s assumed, said in the σ line, as for a sensor off the die of an IMU; one power-on's
    /// calibration cannot show a lag, and a FOG's coil lags its housing's sensor by minutes; 0:
    /// no term). For every channel (else each channel's `sensor_lag` in the channels file).
    #[arg(long, value_name = "SECONDS")]
    sensor_lag: Option<f64>,
}

impl DatasheetArgs {
    /// The figures as the pipeline takes them.
    pub(super) fn sheet(&self) -> Datasheet {
        Datasheet {
            repeatability: self.repeatability,
            scale_repeatability: self.scale_repeatability,
            tempco: self.tempco,
            hysteresis: self.hysteresis,
            sensor_lag_s: self.sensor_lag,
        }
    }
}
