//! What `trainer fit` reports: its JSON (one channel's, a unit's) and the lines it prints.

use std::path::Path;

use firmware_core::Feature;
use fog_data::cause::Cause;
use fog_data::stream::Handled;
use fog_terminal::console::Console;
use serde::Serialize;

use crate::analysis::beyond::BeyondChoice;
use crate::analysis::budget;
use crate::analysis::capacity;
use crate::analysis::diagnose::Diagnosis;
use crate::analysis::extend;
use crate::analysis::investigate;
use crate::analysis::pool::PoolCheck;
use crate::analysis::table::TableDiagnosis;
use crate::analysis::uncertainty::Calibration;
use crate::cli::text::causes_text;
use crate::data::points::Points;
use crate::firmware::export::{AgreementReport, Extension};
use crate::firmware::unit;
use crate::models::gp::sparse::SparseFit;
use crate::models::gp::{GpModel, Hyperparameters, Optimization, StartReport};
use crate::models::prior::{MeanBasis, PolyPrior};
use firmware_core::Quantity;
use fog_data::channels::Channels;

/// A model fitted and checked: its blob, what `fit` reports of it, the GP and its points' count.
pub(super) struct ChannelFit {
    pub(super) blob: Vec<u8>,
    pub(super) summary: FitReport,
    pub(super) model: GpModel,
    pub(super) n: usize,
}

/// What `trainer fit --json` writes (docs/design.md §6): the fitted GP, the extension that
/// shipped, and how the firmware's f32 evaluation follows the host.
#[derive(Serialize)]
pub(super) struct FitReport {
    pub(super) scale_factor: Option<f64>,
    pub(super) log_marginal_likelihood: f64,
    pub(super) hyperparameters: Hyperparameters,
    pub(super) fit_seconds: f64,
    pub(super) n_train: usize,
    pub(super) features: Inputs,
    pub(super) mean_basis: MeanBasis,
    pub(super) prior_mean: PolyPrior,
    pub(super) output_scale: f64,
    pub(super) jitter: f64,
    pub(super) centres: usize,
    pub(super) sparse: Option<SparseFit>,
    pub(super) starts: Vec<StartReport>,
    pub(super) optimization: Optimization,
    pub(super) warnings: Vec<String>,
    /// The diagnosis of a table recorded in time order (`--features auto` without a stream).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) table_diagnosis: Option<TableDiagnosis>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) extension: Option<ExtensionReport>,
    /// The pooled model against the table's alone, forward in time (`--pool-stream` with
    /// `--points`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) pool_check: Option<PoolCheck>,
    /// The diagnosis of the stream and the forward check (`--features` with a stream).
    #[serde(flatten)]
    pub(super) stream_choice: Option<StreamChoice>,
    /// How the default chose a sparse GP's size for more points than the firmware holds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) centres_choice: Option<capacity::Choice>,
    pub(super) handled: Vec<Handled>,
    /// The shipped model's σ, measured on the training data alone.
    pub(super) calibration: Option<Calibration>,
    /// What the mean does beyond the trained range, and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) beyond: Option<BeyondChoice>,
    pub(super) firmware_agreement: AgreementReport,
    pub(super) blob_bytes: usize,
    /// How the budget was met, where one was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) budget: Option<budget::Report>,
}

/// A model's inputs: the points' columns for a static model, the firmware's features for an
/// extended one.
#[derive(Serialize)]
#[serde(untagged)]
pub(super) enum Inputs {
    Columns(Vec<&'static str>),
    Firmware(Vec<Feature>),
}

/// The extension in the blob: a table's transient terms, or inputs fitted on a stream.
#[derive(Serialize)]
#[serde(untagged)]
pub(super) enum ExtensionReport {
    Table(Extension),
    Stream(extend::ExtensionFit),
}

/// What the diagnosis of the training stream chose, and why.
#[derive(Serialize)]
pub(super) struct StreamChoice {
    pub(super) diagnosis: Diagnosis,
    /// The causes whose extension was fitted and checked last: the named ones, or the nested
    /// design that shipped in their place.
    pub(super) causes: Vec<Cause>,
    pub(super) forward_check: Option<investigate::ForwardCheck>,
    pub(super) shipped: investigate::Shipped,
    pub(super) verdict: String,
}

impl FitReport {
    /// The static part, from the model and its points; the rest is filled in as it is known.
    pub(super) fn new(
        m: &GpModel,
        points: &Points,
        agreement: AgreementReport,
        blob_bytes: usize,
    ) -> Self {
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
            pool_check: None,
            extension: None,
            stream_choice: None,
            centres_choice: None,
            handled: Vec::new(),
            calibration: None,
            beyond: None,
            firmware_agreement: agreement,
            blob_bytes,
            budget: None,
        }
    }
}

/// What `trainer fit --channels --json` writes: the sensor, its trained temperature range, each
/// channel's fit as `fit --json` gives one channel's, and what the unit's blob costs.
#[derive(Serialize)]
pub(super) struct UnitFitReport<'a> {
    pub(super) sensor_id: &'a str,
    pub(super) temperature_c: [f32; 2],
    pub(super) channels: Vec<ChannelReport<'a>>,
    pub(super) blob_bytes: usize,
    pub(super) footprint: &'a unit::UnitFootprint,
    /// How the budget was met, where one was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) budget: Option<budget::Report>,
    /// The cubic per channel the autopilots' parameters were written from (`--px4-params`,
    /// `--ardupilot-params`), in the channel's units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) autopilot: Option<&'a crate::firmware::autopilot::SensorCubics>,
}

/// One channel of [`UnitFitReport`]: its figures in `units` (the `_dps` fields too).
#[derive(Serialize)]
pub(super) struct ChannelReport<'a> {
    pub(super) name: &'a str,
    pub(super) quantity: Quantity,
    pub(super) units: &'static str,
    #[serde(flatten)]
    pub(super) fit: &'a FitReport,
}

/// A quantity in words.
pub(super) fn quantity_words(q: Quantity) -> &'static str {
    match q {
        Quantity::AngularRate => "angular rate",
        Quantity::SpecificForce => "specific force",
    }
}

/// What `trainer fit --channels` prints last: each channel's model and what ships, and the
/// unit's blob with what it costs the firmware.
pub(super) fn unit_table(
    channels: &Channels,
    fitted: &[ChannelFit],
    f: &unit::UnitFootprint,
    out: &Path,
) -> String {
    let mut rows = Vec::new();
    for ((ch, fit), (_, fp)) in channels.list.iter().zip(fitted).zip(&f.channels) {
        let ships = match &fit.summary.stream_choice {
            Some(c) if c.shipped == investigate::Shipped::Extended => {
                format!("extended: {}", causes_text(&c.causes))
            }
            Some(c) if !c.diagnosis.causes.is_empty() => {
                format!("static ({} named)", causes_text(&c.diagnosis.causes))
            }
            _ => "static".to_owned(),
        };
        let sigma = fit.summary.calibration.as_ref().map_or(String::new(), |c| {
            let q = ch.quantity;
            format!("{:.3} {}", c.floor_std * q.bias_per_unit(), q.bias_unit())
        });
        rows.push((ch, fp, ships, sigma));
    }
    let wide = rows
        .iter()
        .map(|r| r.2.chars().count())
        .max()
        .unwrap_or(0)
        .max(5);
    let mut s = format!(
        "channel           quantity          centres  inputs  {:<wide$}  model error σ (floor)\n",
        "ships"
    );
    for (ch, fp, ships, sigma) in rows {
        s.push_str(&format!(
            "{:<17} {:<17} {:>7}  {:>6}  {ships:<wide$}  {sigma}\n",
            ch.name,
            quantity_words(ch.quantity),
            fp.m,
            fp.d,
        ));
    }
    s.push_str(&format!(
        "wrote {} ({} bytes: {} channels, sensor '{}', trained {:.1} … {:.1} °C); on the \
         firmware {} numbers, {} bytes of RAM in a StaticUnit sized to it and {} of scratch, \
         about {:.0} instructions per sample on the Cortex-M4F",
        out.display(),
        f.blob_bytes,
        f.channels.len(),
        f.sensor_id,
        f.temperature_c[0],
        f.temperature_c[1],
        f.numbers,
        f.unit_bytes,
        f.scratch_bytes,
        f.instructions
    ));
    s
}

/// What `trainer fit` prints of the model it wrote: the GP, the blob, and the firmware's f32
/// evaluation against the host's.
pub(super) fn print_fit(
    console: &Console,
    fitted: &ChannelFit,
    (out, bytes): (Option<&Path>, usize),
    q: Quantity,
) {
    let (model, n, agreement) = (&fitted.model, fitted.n, &fitted.summary.firmware_agreement);
    if let Some(s) = &model.sparse {
        console.result(&format!(
            "sparse GP ({}): {} inducing points for {} samples, starting hyperparameters from an exact GP on {}; bound {:.3}",
            s.method, s.inducing, s.n_train, s.subset, s.bound
        ));
    }
    console.result(&format!(
        "fitted GP on {n} points: log ML {:.3}, length scales {:?}, σ_f {:.4}, σ_n {:.3e} (normalized), jitter {:e}, {:.1} ms",
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
    console.result(&match out {
        Some(out) => format!("wrote {} ({bytes} bytes)", out.display()),
        None => format!("its model: {bytes} bytes of the unit's blob"),
    });
    console.result(&format!(
        "firmware (f32) vs host (f64):      n   max |Δmean| ({:>4})   max rel Δvar   extrapolating",
        q.unit()
    ));
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
}
