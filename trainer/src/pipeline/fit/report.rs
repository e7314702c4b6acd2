//! What `trainer fit` reports of a fit: its JSON (one channel's, a unit's) and its lines of text.

use std::path::Path;

use crate::pipeline::ChannelEntry;
use crate::progress::Messages;
use firmware_core::Feature;
use fog_data::cause::Cause;
use fog_data::stream::Handled;
use serde::Serialize;

use crate::analysis::basis::BasisChoice;
use crate::analysis::beyond::BeyondChoice;
use crate::analysis::budget;
use crate::analysis::capacity;
use crate::analysis::diagnose::Diagnosis;
use crate::analysis::diagnose::causes_text;
use crate::analysis::extend;
use crate::analysis::investigate;
use crate::analysis::pool::PoolCheck;
use crate::analysis::table::TableDiagnosis;
use crate::analysis::uncertainty::Calibration;
use crate::data::points::Points;
use crate::firmware::export::{AgreementReport, Extension};
use crate::firmware::unit;
use crate::models::gp::sparse::SparseFit;
use crate::models::gp::{GpModel, Hyperparameters, Optimization, StartReport};
use crate::models::prior::{MeanBasis, PolyPrior};
use firmware_core::Quantity;
use fog_data::channels::Channels;

/// A model fitted and checked: its blob, what `fit` reports of it, the GP and its points' count.
pub struct ChannelFit {
    /// The blob: its model, error model, limits and rule beyond the trained range.
    pub blob: Vec<u8>,
    /// What `fit --json` reports of it.
    pub summary: FitReport,
    /// The static GP (or, where a pooled check kept the table's, the table's).
    pub model: GpModel,
    /// The points it was fitted on.
    pub n: usize,
}

/// What `trainer fit --json` writes (docs/design.md §6): the fitted GP, the extension that
/// shipped, and how the firmware's f32 evaluation follows the host.
#[derive(Serialize, schemars::JsonSchema)]
pub struct FitReport {
    /// The nominal scale factor the bias was learned with (`--scale-factor`, or a unit's), output units per °/s; `null` for the map ω = f(T, output).
    pub scale_factor: Option<f64>,
    /// The GP's log marginal likelihood (a sparse GP's bound), on the normalized data.
    pub log_marginal_likelihood: f64,
    /// Length scales, signal and noise σ (normalized inputs and output).
    pub hyperparameters: Hyperparameters,
    /// Wall time of the static fit, s (the one field two runs do not share).
    pub fit_seconds: f64,
    /// Points the static model was fitted on.
    pub n_train: usize,
    /// The model's inputs: the points' columns, or the firmware's features once extended.
    pub features: Inputs,
    /// The prior mean's basis (`physics`, `constant`, `polyN`).
    pub mean_basis: MeanBasis,
    /// How `--mean auto` (the default) chose it, on temperature bands left out.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub basis_choice: Option<BasisChoice>,
    /// The prior mean's terms and their GLS coefficients.
    pub prior_mean: PolyPrior,
    /// The output's normalization scale, its units.
    pub output_scale: f64,
    /// Jitter added to the kernel's diagonal for its Cholesky factor (0: none needed).
    pub jitter: f64,
    /// Centres in the blob: training points for an exact GP, inducing points for a sparse one.
    pub centres: usize,
    /// The sparse fit (method, inducing points, bound), where sparse.
    pub sparse: Option<SparseFit>,
    /// Every optimizer start: where it began and ended.
    pub starts: Vec<StartReport>,
    /// How the chosen start's optimization ended.
    pub optimization: Optimization,
    /// What the fit warns of (no start converged, a length scale at its bound, …).
    pub warnings: Vec<String>,
    /// The diagnosis of a table recorded in time order (`--features auto` without a stream).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub table_diagnosis: Option<TableDiagnosis>,
    /// The extension in the blob, where one shipped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extension: Option<ExtensionReport>,
    /// The pooled model against the table's alone, forward in time (`--pool-stream` with
    /// `--points`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pool_check: Option<PoolCheck>,
    /// The diagnosis of the stream and the forward check (`--features` with a stream).
    #[serde(flatten)]
    pub stream_choice: Option<StreamChoice>,
    /// How the default chose a sparse GP's size for more points than the firmware holds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub centres_choice: Option<capacity::Choice>,
    /// The streams' handling events, left out of the fit.
    pub handled: Vec<Handled>,
    /// The shipped model's σ, measured on the training data alone.
    pub calibration: Option<Calibration>,
    /// What the mean does beyond the trained range, and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beyond: Option<BeyondChoice>,
    /// The firmware's f32 evaluation of the blob as written against the host's f64: on the training points, a grid over the trained range and 10% beyond.
    pub firmware_agreement: AgreementReport,
    /// The blob's size.
    pub blob_bytes: usize,
    /// How the budget was met, where one was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub budget: Option<budget::Report>,
}

/// A model's inputs: the points' columns for a static model, the firmware's features for an
/// extended one.
#[derive(Serialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum Inputs {
    /// The points' columns (`temp_c`, `voltage_v`).
    Columns(Vec<&'static str>),
    /// The firmware's features, as the blob computes them.
    Firmware(Vec<Feature>),
}

/// The extension in the blob: a table's transient terms, or inputs fitted on a stream.
#[derive(Serialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum ExtensionReport {
    /// A table's transient terms.
    Table(Extension),
    /// Inputs fitted on a stream, with the training residual before and after.
    Stream(extend::ExtensionFit),
}

/// What the diagnosis of the training stream chose, and why.
#[derive(Serialize, schemars::JsonSchema)]
pub struct StreamChoice {
    /// The diagnosis of the training stream's residuals.
    pub diagnosis: Diagnosis,
    /// The causes whose extension was fitted and checked last: the named ones, or the nested
    /// design that shipped in their place.
    pub causes: Vec<Cause>,
    /// The extension against the static model on the stream's later part, each fitted on the earlier.
    pub forward_check: Option<investigate::ForwardCheck>,
    /// Which model ships: `static` or `extended`.
    pub shipped: investigate::Shipped,
    /// Why, in words.
    pub verdict: String,
}

impl FitReport {
    /// The static part, from the model and its points; the rest is filled in as it is known.
    pub fn new(
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
            basis_choice: None,
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

/// What `trainer fit --json` writes: the sensor, its trained temperature range, each channel's
/// fit, and what the unit's blob costs (one channel's data: a unit of one).
#[derive(Serialize, schemars::JsonSchema)]
pub struct UnitFitReport<'a> {
    /// The sensor's ID, as the blob carries it.
    pub sensor_id: &'a str,
    /// The unit's trained temperature range, °C.
    pub temperature_c: [f32; 2],
    /// Each channel's fit.
    pub channels: Vec<ChannelEntry<'a, FitReport>>,
    /// The unit blob's size.
    pub blob_bytes: usize,
    /// What the blob costs the firmware: RAM, scratch, instructions per sample.
    pub footprint: &'a unit::UnitFootprint,
    /// How the budget was met, where one was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub budget: Option<budget::Report>,
    /// The cubic per channel the autopilots' parameters were written from (`--px4-params`,
    /// `--ardupilot-params`), in the channel's units.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub autopilot: Option<&'a crate::firmware::autopilot::SensorCubics>,
}

/// A quantity in words.
pub fn quantity_words(q: Quantity) -> &'static str {
    match q {
        Quantity::AngularRate => "angular rate",
        Quantity::SpecificForce => "specific force",
    }
}

/// What `trainer fit` prints last: each channel's model and what ships, and the
/// unit's blob with what it costs the firmware.
pub fn unit_table(
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
        "wrote {} ({} bytes: {} channel{}, sensor '{}', trained {:.1} … {:.1} °C); on the \
         firmware {} numbers, {} bytes of RAM in a StaticUnit sized to it and {} of scratch, \
         about {:.0} instructions per sample on the Cortex-M4F",
        out.display(),
        f.blob_bytes,
        f.channels.len(),
        if f.channels.len() == 1 { "" } else { "s" },
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
pub fn say_fit(
    messages: &dyn Messages,
    fitted: &ChannelFit,
    (out, bytes): (Option<&Path>, usize),
    q: Quantity,
) {
    let (model, n, agreement) = (&fitted.model, fitted.n, &fitted.summary.firmware_agreement);
    if let Some(s) = &model.sparse {
        messages.result(&format!(
            "sparse GP ({}): {} inducing points for {} samples, starting hyperparameters from an exact GP on {}; bound {:.3}",
            s.method, s.inducing, s.n_train, s.subset, s.bound
        ));
    }
    messages.result(&format!(
        "fitted GP on {n} points: log ML {:.3}, length scales {:?}, σ_f {:.4}, σ_n {:.3e} (normalized), jitter {:e}, {:.1} ms",
        model.log_marginal_likelihood(),
        model.posterior.hyper.length_scales,
        model.posterior.hyper.signal_std,
        model.posterior.hyper.noise_std,
        model.posterior.jitter,
        model.fit_seconds * 1e3
    ));
    if let Some(g) = model.posterior.hyper.offset_std {
        messages.result(&format!(
            "offsets between groups: σ_g {:.3e} (output units), counted as noise in the \
             firmware's variance (a new run's offset is unknown)",
            g * model.output_scale
        ));
    }
    messages.result(&match out {
        Some(out) => format!("wrote {} ({bytes} bytes)", out.display()),
        None => format!("its model: {bytes} bytes of the unit's blob"),
    });
    messages.result(&format!(
        "firmware (f32) vs host (f64):      n   max |Δmean| ({:>4})   max rel Δvar   extrapolating",
        q.unit()
    ));
    for (name, a) in [
        ("training points", agreement.training),
        ("grid, trained range", agreement.grid_inside),
        ("grid, 10% beyond", agreement.grid_beyond),
    ] {
        messages.result(&format!(
            "  {name:<22} {:>7}   {:>17.3e}   {:>12.3e}   {:>13}",
            a.n, a.max_abs_mean_diff, a.max_rel_var_diff, a.n_extrapolating
        ));
    }
}
