//! Export of a fitted GP as a firmware blob, built with firmware-core's own types (one definition
//! of the format), and the f32 fidelity of the result.
//!
//! Everything is computed in f64 and rounded once: weights `w = α·σ_f²·s_y`, variances in output
//! units², centres divided by the length scales, and the variance factor `L/σ_f` (the Cholesky
//! factor of K/σ_f²), packed by rows. Pure linear monomials of the prior mean move to the raw
//! linear terms (`c·z_k = (c/s_k)·x_k − c·o_k/s_k`, the constant absorbing the offset), with the
//! coefficient split into an f32 `hi` and the f32 rounding of its remainder `lo` (why: blob module
//! doc of firmware-core).

use firmware_core::blob::{self, Beyond, Dims, ErrorModel, Feature, HEADER_LEN, Limits, Payload};
use firmware_core::model::{Conditions, Evaluation, Prepared};
use firmware_core::{MAX_CENTRES, MAX_INPUTS};
use fog_data::replay::{self, HostModel};
use serde::Serialize;

use crate::data::points::Points;
use crate::models::gp::GpModel;

/// Errors of export.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The model is too large for the blob format or the host capacities.
    #[error("model too large to export: {0}")]
    TooLarge(String),
    /// The feature spec does not match the model's inputs.
    #[error("{features} features named for a model of {inputs} inputs")]
    FeatureMismatch {
        /// Features named.
        features: usize,
        /// Model inputs.
        inputs: usize,
    },
    /// The firmware encoder or decoder refused the blob (its reason says so: "blob truncated").
    #[error(transparent)]
    Blob(#[from] firmware_core::BlobError),
    /// A unit blob could not be made of its channels' blobs, or does not compute what they do.
    #[error("unit blob: {0}")]
    Unit(String),
    /// The firmware's evaluation of the blob does not follow the host model.
    #[error(
        "the firmware (f32) evaluation of this blob does not follow the host on {part}: {mismatch}"
    )]
    Disagrees {
        /// Which inputs: the training points or the grid over the trained range.
        part: &'static str,
        /// How.
        mismatch: Mismatch,
    },
    /// A bias temperature coefficient stated for a model without a temperature input.
    #[error(
        "a bias temperature coefficient (--tempco, or a channel's tempco) says how the bias moves \
         beyond the trained temperatures, and this model has no temperature input with a \
         trained range"
    )]
    NoTemperature,
}

/// How a blob's f32 evaluation failed to follow its host model ([`verify`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Mismatch {
    /// Some outputs were not finite numbers.
    #[error(
        "outputs that are not finite numbers; the blob cannot evaluate inputs it was fitted on \
         (report it, with the data)"
    )]
    NonFinite,
    /// The firmware refused inputs it was fitted on as faults.
    #[error(
        "{n} of {of} inputs refused as faults; the blob cannot evaluate inputs it was fitted on \
         (report it, with the data)"
    )]
    Faults {
        /// Inputs refused.
        n: usize,
        /// Inputs compared.
        of: usize,
    },
    /// The means differ by more than the model can resolve.
    #[error(
        "means differ by up to {diff:.3e}, more than the {limit:.3e} allowed (the model's noise \
         level, at most a tenth of its output scale, or 16 f32 ulps of its largest output); the \
         model is ill-conditioned for f32 (large weights that cancel): try another prior-mean \
         basis (--mean physics, poly1 … poly3) or more points"
    )]
    Exceeds {
        /// Largest |firmware − host| mean, output units.
        diff: f64,
        /// What was allowed.
        limit: f64,
    },
}

/// The prior mean with its pure linear monomials moved onto the raw inputs: (exponents,
/// coefficients, raw coefficient per input). Needs a constant monomial to absorb the offsets.
fn split_raw_linear(model: &GpModel) -> (Vec<Vec<u8>>, Vec<f64>, Vec<f64>) {
    let prior = &model.prior;
    let d = model.input_norm.offset.len();
    let mut coefficients = prior.coefficients.clone();
    let mut raw = vec![0.0; d];
    let mut moved = vec![false; coefficients.len()];
    if let Some(constant) = prior
        .exponents
        .iter()
        .position(|e| e.iter().all(|&k| k == 0))
    {
        for (j, e) in prior.exponents.iter().enumerate() {
            let unit = e.iter().filter(|&&k| k == 1).count() == 1 && e.iter().sum::<u8>() == 1;
            if let (true, Some(k)) = (unit, e.iter().position(|&k| k == 1)) {
                raw[k] = coefficients[j] / model.input_norm.scale[k];
                coefficients[constant] -= raw[k] * model.input_norm.offset[k];
                moved[j] = true;
            }
        }
    }
    let keep = |j: &usize| !moved[*j];
    let exponents = (0..coefficients.len())
        .filter(keep)
        .map(|j| prior.exponents[j].clone())
        .collect();
    let coefficients = (0..coefficients.len())
        .filter(keep)
        .map(|j| coefficients[j])
        .collect();
    (exponents, coefficients, raw)
}

/// What an extended model adds to a static GP (docs/design.md §5: keep the static GP, add the new
/// inputs' contribution as a term of its own). The kernel and its weights stay the static model's.
#[derive(Debug, Clone, Default, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Extension {
    /// Replaces the `Temperature` input (a lag-compensated coil temperature).
    pub temperature: Option<Feature>,
    /// Inputs that enter only linearly, with their coefficients.
    pub terms: Vec<Term>,
    /// Added to the mean, output units.
    pub offset: f64,
}

/// One additive input of an [`Extension`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Term {
    /// The input.
    pub feature: Feature,
    /// Mean += coefficient · input (· output, on the scale factor), output units per input unit
    /// (and per output unit).
    pub coefficient: f64,
    /// Range of the input in the training data (beyond it the firmware flags extrapolation).
    pub range: (f64, f64),
    /// The term acts on the scale factor: it is multiplied by the gyro output (the model's
    /// `Voltage` input). In the blob: a prior-mean monomial z_V·x and the raw linear term of x.
    pub on_scale_factor: bool,
}

impl Term {
    /// A term on the bias: mean += coefficient · input.
    pub fn bias(feature: Feature, coefficient: f64, range: (f64, f64)) -> Self {
        Self {
            feature,
            coefficient,
            range,
            on_scale_factor: false,
        }
    }

    /// What it adds to the mean at input `x` and gyro output `output`.
    pub fn value(&self, x: f64, output: f64) -> f64 {
        let v = self.coefficient * x;
        if self.on_scale_factor { v * output } else { v }
    }
}

/// Builds the blob of a fitted GP whose inputs are `features`, in order.
pub fn to_blob(model: &GpModel, features: &[Feature]) -> Result<Vec<u8>, ExportError> {
    to_blob_extended(model, features, &Extension::default())
}

/// Raw-input range of an input that is valid at any value (the output of a bias model).
const UNBOUNDED: f64 = 1e30;

/// The blob of a GP fitted on `points` with an extension (`carried`).
pub fn points_blob(
    model: &GpModel,
    points: &Points,
    extension: &Extension,
) -> Result<Vec<u8>, ExportError> {
    to_blob_extended(model, points.features(), &carried(points, extension))
}

/// The extension a blob of `points` carries: for a bias model ([`Points::scale_factor`]) the
/// output enters first, as ω = output/K + GP(T, …) through its raw linear term alone, valid at
/// any rate.
fn carried(points: &Points, extension: &Extension) -> Extension {
    let mut extension = extension.clone();
    if let Some(k) = points.scale_factor {
        extension.terms.insert(
            0,
            Term::bias(Feature::Voltage, 1.0 / k, (-UNBOUNDED, UNBOUNDED)),
        );
    }
    extension
}

/// Builds the blob of a fitted GP with an [`Extension`]: the additive inputs follow the GP's
/// inputs, with the kernel ignoring them (blob module doc, `IGNORED_LENGTH_SCALE`).
pub fn to_blob_extended(
    model: &GpModel,
    features: &[Feature],
    extension: &Extension,
) -> Result<Vec<u8>, ExportError> {
    let post = &model.posterior;
    let h = &post.hyper;
    let (m, d0) = post.xs.shape();
    if features.len() != d0 {
        return Err(ExportError::FeatureMismatch {
            features: features.len(),
            inputs: d0,
        });
    }
    let Basis {
        features,
        exponents,
        coefficients,
        raw,
    } = basis(model, features, extension)?;
    let (d, p) = (features.len(), coefficients.len());
    if m > MAX_CENTRES || d > MAX_INPUTS {
        return Err(ExportError::TooLarge(format!(
            "{m} centres × {d} inputs; a firmware model holds at most {MAX_CENTRES} centres \
             (about 132 KB of f32 on the microcontroller) and {MAX_INPUTS} inputs: fit on fewer points"
        )));
    }
    let dims = Dims { m, d, p };
    let sy = model.output_scale;
    let floats = numbers(model, extension, dims, &coefficients, &raw);
    let exponents: Vec<u8> = exponents.into_iter().flatten().collect();
    let payload = Payload {
        features,
        exponents,
        floats,
        beyond: Beyond::Follow,
        error: ErrorModel::noise_only((h.observation_var() * sy * sy) as f32),
        limits: Limits::DEFAULT,
    };
    let numbers = payload.floats.len() + ErrorModel::NUMBERS + Limits::NUMBERS;
    let mut buf = vec![0u8; HEADER_LEN + 17 + 5 * d + payload.exponents.len() + 5 * numbers];
    let n = blob::encode(dims, &payload, &mut buf).map_err(ExportError::Blob)?;
    buf.truncate(n);
    Ok(buf)
}

/// The inputs of an extended blob and its prior mean: the model's features (the temperature
/// replaced by the extension's, where it has one) then one per term; the prior-mean monomials and
/// coefficients with the extension's offset and its scale-factor terms; the raw linear
/// coefficients with the bias terms'.
struct Basis {
    features: Vec<Feature>,
    exponents: Vec<Vec<u8>>,
    coefficients: Vec<f64>,
    raw: Vec<f64>,
}

/// [`Basis`] of `model` (its inputs `features`) extended by `extension`.
fn basis(
    model: &GpModel,
    features: &[Feature],
    extension: &Extension,
) -> Result<Basis, ExportError> {
    let d0 = features.len();
    let mut features: Vec<Feature> = features.to_vec();
    if let Some(t) = extension.temperature {
        for f in features.iter_mut().filter(|f| **f == Feature::Temperature) {
            *f = t;
        }
    }
    features.extend(extension.terms.iter().map(|t| t.feature));
    let d = features.len();
    let (mut exponents, mut coefficients, mut raw) = split_raw_linear(model);
    for e in &mut exponents {
        e.resize(d, 0);
    }
    match exponents.iter().position(|e| e.iter().all(|&k| k == 0)) {
        Some(c) => coefficients[c] += extension.offset,
        None => {
            exponents.push(vec![0; d]);
            coefficients.push(extension.offset);
        }
    }
    // A scale-factor term c·x·V: with z_V = (V − o)/s (x enters unnormalized), c·s·z_V·x as a
    // monomial and c·o·x as x's raw linear term.
    let output = features.iter().position(|f| *f == Feature::Voltage);
    let (o, sv) = match output {
        Some(k) if k < d0 => (model.input_norm.offset[k], model.input_norm.scale[k]),
        _ => (0.0, 1.0),
    };
    for (j, t) in extension.terms.iter().enumerate() {
        if !t.on_scale_factor {
            raw.push(t.coefficient);
            continue;
        }
        let Some(kv) = output else {
            return Err(ExportError::FeatureMismatch {
                features: features.len(),
                inputs: d0,
            });
        };
        let mut e = vec![0u8; d];
        e[kv] = 1;
        e[d0 + j] = 1;
        exponents.push(e);
        coefficients.push(t.coefficient * sv);
        raw.push(t.coefficient * o);
    }
    Ok(Basis {
        features,
        exponents,
        coefficients,
        raw,
    })
}

/// The blob's numbers in the format's section order (`Dims::sections`), rounded to f32 once.
fn numbers(
    model: &GpModel,
    extension: &Extension,
    dims: Dims,
    coefficients: &[f64],
    raw: &[f64],
) -> Vec<f32> {
    let post = &model.posterior;
    let h = &post.hyper;
    let (m, d, d0) = (dims.m, dims.d, post.xs.ncols());
    let sf2 = h.signal_std.powi(2);
    let sy = model.output_scale;
    // The model's own inputs, then one per extension term (after the model's, in `features`).
    let per_input = |model_value: &dyn Fn(usize) -> f64, term_value: &dyn Fn(&Term) -> f64| {
        (0..d0)
            .map(model_value)
            .chain(extension.terms.iter().map(term_value))
            .collect::<Vec<f64>>()
    };
    let s = dims.sections();
    let mut floats = vec![0.0f64; dims.floats()];
    let mut put = |range: std::ops::Range<usize>, values: &[f64]| {
        floats[range].copy_from_slice(values);
    };
    put(
        s.offset,
        &per_input(&|k| model.input_norm.offset[k], &|_| 0.0),
    );
    put(
        s.scale,
        &per_input(&|k| model.input_norm.scale[k], &|_| 1.0),
    );
    put(
        s.min,
        &per_input(&|k| model.input_range[k].0, &|t| t.range.0),
    );
    put(
        s.max,
        &per_input(&|k| model.input_range[k].1, &|t| t.range.1),
    );
    put(
        s.length,
        &per_input(&|k| h.length_scales[k], &|_| {
            f64::from(blob::IGNORED_LENGTH_SCALE)
        }),
    );
    put(s.prior, coefficients);
    // hi is an f32 (so exact in f64); lo is what it misses, rounded once below.
    let hi: Vec<f64> = raw.iter().map(|&r| f64::from(r as f32)).collect();
    let lo: Vec<f64> = raw.iter().zip(&hi).map(|(r, h)| r - h).collect();
    put(s.raw_hi, &hi);
    put(s.raw_lo, &lo);
    put(s.variances, &[sf2 * sy * sy, h.observation_var() * sy * sy]);
    let centres: Vec<f64> = (0..m)
        .flat_map(|i| (0..d).map(move |k| if k < d0 { post.xs[(i, k)] } else { 0.0 }))
        .collect();
    put(s.centres, &centres);
    let weights: Vec<f64> = post.alpha.iter().map(|a| a * sf2 * sy).collect();
    put(s.weights, &weights);
    let l = post.chol.l_dirty();
    let sf = h.signal_std;
    let factor: Vec<f64> = (0..m)
        .flat_map(|i| (0..=i).map(move |j| l[(i, j)] / sf))
        .collect();
    put(s.factor, &factor);
    floats.into_iter().map(|v| v as f32).collect()
}

/// Which of `features` is the model's temperature: the sensor's reading, or where a model reads
/// a coil's estimate instead, that; `None` without either.
pub fn temperature_input(features: &[Feature]) -> Option<usize> {
    features
        .iter()
        .position(|f| *f == Feature::Temperature)
        .or_else(|| features.iter().position(Feature::is_temperature))
}

/// `blob` with `error` as its error model (the variance besides the latent one): what the
/// trainer writes once it has measured the model's errors on its own training data
/// ([`crate::analysis::uncertainty`]). Exported blobs start with their noise variance alone.
pub fn with_error_model(blob: &[u8], error: &ErrorModel) -> Result<Vec<u8>, ExportError> {
    let mut out = blob.to_vec();
    blob::set_error_model(&mut out, error)?;
    Ok(out)
}

/// `blob` with `beyond`: what its mean does beyond the trained range (exported blobs start with
/// [`Beyond::Follow`], the GP's own prediction, which every check of the trainer's sees; `fit`
/// and `investigate` write the rule chosen for the blob they ship).
pub fn with_beyond(blob: &[u8], beyond: Beyond) -> Result<Vec<u8>, ExportError> {
    let mut out = blob.to_vec();
    blob::set_beyond(&mut out, beyond)?;
    Ok(out)
}

/// `blob` with `limits`: what a reading that cannot be true is for the sensor (exported blobs
/// start with [`Limits::DEFAULT`]).
pub fn with_limits(blob: &[u8], limits: &Limits) -> Result<Vec<u8>, ExportError> {
    let mut out = blob.to_vec();
    blob::set_limits(&mut out, limits)?;
    Ok(out)
}

/// The firmware's rule beyond the trained range, on the host (firmware-core's `model` module
/// doc), for the GP's own inputs (all read by its kernel): `x` held at the range's edge, and what
/// the prior mean adds past the edge: under [`Beyond::Hold`] the raw linear terms of the gyro
/// output and the time since power-on, under [`Beyond::Tangent`] its tangent at the edge; under
/// [`Beyond::Follow`], `x` as it is.
pub fn held_at_range(
    model: &GpModel,
    x: &[f64],
    features: &[Feature],
    beyond: Beyond,
) -> (Vec<f64>, f64) {
    if beyond == Beyond::Follow {
        return (x.to_vec(), 0.0);
    }
    let held: Vec<f64> = x
        .iter()
        .zip(&model.input_range)
        .map(|(&v, &(lo, hi))| v.clamp(lo, hi))
        .collect();
    let extra = match beyond {
        Beyond::Follow => 0.0,
        Beyond::Hold => {
            let (_, _, raw) = split_raw_linear(model);
            x.iter()
                .zip(&held)
                .zip(features)
                .zip(raw)
                .filter(|((_, f), _)| matches!(f, Feature::Voltage | Feature::TimeOn))
                .map(|(((&v, &h), _), c)| c * (v - h))
                .sum()
        }
        Beyond::Tangent => {
            let norm = &model.input_norm;
            let z = |v: &[f64]| -> Vec<f64> {
                v.iter()
                    .enumerate()
                    .map(|(k, &v)| (v - norm.offset[k]) / norm.scale[k])
                    .collect()
            };
            let (zx, zh) = (z(x), z(&held));
            let prior = &model.prior;
            (0..zh.len())
                .filter(|&k| zx[k] != zh[k])
                .map(|k| {
                    let slope: f64 = prior
                        .exponents
                        .iter()
                        .zip(&prior.coefficients)
                        .filter(|(e, _)| e[k] > 0)
                        .map(|(e, c)| {
                            c * f64::from(e[k])
                                * e.iter()
                                    .enumerate()
                                    .map(|(i, &ei)| {
                                        let n = if i == k { ei - 1 } else { ei };
                                        zh[i].powi(i32::from(n))
                                    })
                                    .product::<f64>()
                        })
                        .sum();
                    slope * (zx[k] - zh[k])
                })
                .sum()
        }
    };
    (held, extra)
}

/// How closely the firmware (f32) follows the host (f64) over one set of inputs.
#[derive(Debug, Clone, Copy, Default, Serialize, schemars::JsonSchema)]
pub struct Agreement {
    /// Inputs compared.
    pub n: usize,
    /// Largest |firmware mean − host mean|, output units.
    pub max_abs_mean_diff: f64,
    /// Largest |firmware bias variance − host's| / host's (latent variance and the blob's model
    /// error) where the host's exceeds 1e-3 of the signal variance (below that, it is rounding
    /// noise of a near-zero number).
    pub max_rel_var_diff: f64,
    /// Inputs the relative variance figure covers.
    pub n_var: usize,
    /// Inputs the firmware flagged as extrapolating.
    pub n_extrapolating: usize,
    /// Inputs the firmware refused as faults (mean not compared).
    pub n_fault: usize,
    /// Largest |host mean|, output units.
    pub max_abs_host_mean: f64,
    /// Every firmware output was finite.
    pub all_finite: bool,
}

/// The agreement figures of a blob: on the training inputs, on a dense grid over the trained
/// range, and on the band 10% of the range beyond it.
#[derive(Debug, Clone, Copy, Serialize, schemars::JsonSchema)]
pub struct AgreementReport {
    /// The training inputs.
    pub training: Agreement,
    /// A grid over the trained range (`GRID` points per input).
    pub grid_inside: Agreement,
    /// The grid over the range widened by 10% each side, outside the trained range only.
    pub grid_beyond: Agreement,
}

/// Grid points per input of the agreement check.
pub const GRID: usize = 61;

/// Compares the firmware with the host on rows of raw inputs `x` (the GP's inputs). Inputs are
/// rounded to f32 first, so both sides see the same numbers. The inputs `extension` adds after
/// the GP's (its terms, a bias model's output) are held at the middle of their ranges (0 for an
/// unbounded one), and the host adds their terms and the offset as the firmware does.
pub fn agreement(
    model: &GpModel,
    firmware: &HostModel,
    x: &nalgebra::DMatrix<f64>,
    extension: &Extension,
) -> Agreement {
    let held: Vec<f32> = extension
        .terms
        .iter()
        .map(|t| (0.5 * t.range.0 + 0.5 * t.range.1) as f32)
        .collect();
    // The gyro output among the GP's inputs, for the scale-factor terms (a bias model's output
    // is a term of its own, held at 0 like the others' middle).
    let d0 = model.input_norm.offset.len();
    let output = firmware
        .features()
        .iter()
        .position(|f| *f == Feature::Voltage)
        .filter(|&k| k < d0);
    let threshold = 1e-3 * model.posterior.hyper.signal_std.powi(2) * model.output_scale.powi(2);
    let mut a = Agreement {
        all_finite: true,
        ..Agreement::default()
    };
    let features = firmware.features();
    let beyond = firmware.beyond();
    let rows: Vec<Vec<f32>> = x
        .row_iter()
        .map(|row| {
            row.iter()
                .map(|&v| v as f32)
                .chain(held.iter().copied())
                .collect()
        })
        .collect();
    let prepared: Vec<Prepared<MAX_INPUTS>> = rows
        .iter()
        .map(|raw| Prepared::inputs(raw, Conditions::at_hours(0.0)))
        .collect();
    let mut scratch = vec![0.0f32; firmware.evaluate_scratch_len()];
    let mut evaluations = vec![Evaluation::NONE; rows.len()];
    let evaluated = firmware
        .evaluate(&prepared, &mut scratch, &mut evaluations)
        .is_ok();
    for (raw, evaluation) in rows.iter().zip(&evaluations) {
        let exact: Vec<f64> = raw[..x.ncols()].iter().map(|&v| f64::from(v)).collect();
        // Beyond the trained range the firmware holds the inputs at its edge.
        let (at, past) = held_at_range(model, &exact, &features[..d0], beyond);
        let mut host = model.predict(&at);
        host.mean += past;
        // The extension's scale-factor terms read the output as the prior mean does: held at the
        // edge under `Hold`, as it is under `Tangent` (their tangent is exact) and `Follow`.
        let read = if beyond == Beyond::Hold { &at } else { &exact };
        let v = output.and_then(|k| read.get(k)).copied().unwrap_or(0.0);
        host.mean += extension.offset
            + extension
                .terms
                .iter()
                .zip(&held)
                .map(|(t, &x)| t.value(f64::from(x), v))
                .sum::<f64>();
        if !evaluated {
            a.all_finite = false;
            continue;
        }
        let fw = evaluation.prediction;
        a.n += 1;
        a.all_finite &= fw.mean.is_finite() && fw.bias_variance.is_finite();
        a.n_extrapolating += usize::from(fw.status == firmware_core::Status::Extrapolating);
        a.max_abs_host_mean = a.max_abs_host_mean.max(host.mean.abs());
        if fw.status == firmware_core::Status::Fault {
            a.n_fault += 1;
            continue;
        }
        a.max_abs_mean_diff = a
            .max_abs_mean_diff
            .max((f64::from(fw.mean) - host.mean).abs());
        let e2 = excess2(&exact, &model.input_range);
        let host_bias = host.latent_var
            + f64::from(firmware.error_model().model_error(
                e2 as f32,
                host.mean as f32,
                Conditions::at_hours(0.0),
            ));
        if host_bias > threshold {
            a.n_var += 1;
            let rel = (f64::from(fw.bias_variance) - host_bias).abs() / host_bias;
            a.max_rel_var_diff = a.max_rel_var_diff.max(rel);
        }
    }
    a
}

/// e(x)² of the error model, in f64: how far `x` lies beyond `range`, in its widths, squared
/// (firmware-core's `blob::ErrorModel`; the firmware's own f32 is what is checked against it).
pub fn excess2(x: &[f64], range: &[(f64, f64)]) -> f64 {
    x.iter()
        .zip(range)
        .map(|(&v, &(lo, hi))| {
            let excess = (lo - v).max(v - hi).max(0.0);
            let width = if hi > lo { hi - lo } else { lo.abs().max(1.0) };
            (excess / width).powi(2)
        })
        .sum()
}

/// Rows of a `GRID`ⁿ grid over `range` widened by `widen` of its width each side; with
/// `outside_only`, only the rows that leave `range` in some input.
fn grid(range: &[(f64, f64)], widen: f64, outside_only: bool) -> nalgebra::DMatrix<f64> {
    let d = range.len();
    let axes: Vec<Vec<f64>> = range
        .iter()
        .map(|&(lo, hi)| {
            let (a, b) = (lo - widen * (hi - lo), hi + widen * (hi - lo));
            (0..GRID)
                .map(|i| a + (b - a) * i as f64 / (GRID - 1) as f64)
                .collect()
        })
        .collect();
    let total = GRID.pow(u32::try_from(d).unwrap_or(u32::MAX));
    let rows: Vec<Vec<f64>> = (0..total)
        .map(|mut i| {
            axes.iter()
                .map(|axis| {
                    let v = axis[i % GRID];
                    i /= GRID;
                    v
                })
                .collect()
        })
        .filter(|r: &Vec<f64>| {
            // Compared as the firmware does: in f32.
            let f = |v: f64| v as f32;
            !outside_only
                || r.iter()
                    .zip(range)
                    .any(|(v, &(lo, hi))| f(*v) < f(lo) || f(*v) > f(hi))
        })
        .collect();
    nalgebra::DMatrix::from_fn(rows.len(), d, |i, k| rows[i][k])
}

/// The agreement report of a blob against the model and extension it was exported from.
pub fn agreement_report(
    model: &GpModel,
    firmware: &HostModel,
    training: &nalgebra::DMatrix<f64>,
    extension: &Extension,
) -> AgreementReport {
    let on = |x: &nalgebra::DMatrix<f64>| agreement(model, firmware, x, extension);
    AgreementReport {
        training: on(training),
        grid_inside: on(&grid(&model.input_range, 0.0, false)),
        grid_beyond: on(&grid(&model.input_range, 0.1, true)),
    }
}

/// Relative part of the largest output the firmware may differ by: 16 f32 ulps.
const F32_TOLERANCE: f64 = 16.0 * f32::EPSILON as f64;

/// Largest σ_n (normalized) the tolerance of [`verify`] takes as the model's noise level: a fit
/// that calls most of the signal noise (a fallback's σ_n reaches 10) must not loosen the check.
const NOISE_CAP: f64 = 0.1;

/// Decodes `blob` (exported from `model` fitted on `points`, with `extension`), compares it with
/// the host on the training inputs and over the trained range, and refuses it
/// ([`ExportError::Disagrees`]) where the firmware faults, returns a non-finite number or differs
/// by more than the model's own noise level (σ_n·s_y with σ_n at most `NOISE_CAP`: what the data
/// cannot resolve) or 16 f32 ulps of the largest output, whichever is larger. A legitimate model
/// sits orders of magnitude inside (docs/reliability.md); an ill-conditioned one (huge weights
/// that cancel) fails by orders of magnitude. The band beyond the range is reported, not judged.
/// Returns the decoded firmware model with the report, so callers decode once.
pub fn verify(
    model: &GpModel,
    blob: &[u8],
    points: &Points,
    extension: &Extension,
) -> Result<(Box<HostModel>, AgreementReport), ExportError> {
    let firmware = replay::decode(blob)?;
    let report = agreement_report(
        model,
        &firmware,
        points.inputs(),
        &carried(points, extension),
    );
    let noise = model.posterior.hyper.noise_std.min(NOISE_CAP) * model.output_scale;
    for (part, a) in [
        ("the training points", report.training),
        ("the trained range", report.grid_inside),
    ] {
        let limit = noise.max(F32_TOLERANCE * a.max_abs_host_mean);
        let mismatch = if !a.all_finite {
            Mismatch::NonFinite
        } else if a.n_fault > 0 {
            Mismatch::Faults {
                n: a.n_fault,
                of: a.n,
            }
        } else if a.max_abs_mean_diff > limit {
            Mismatch::Exceeds {
                diff: a.max_abs_mean_diff,
                limit,
            }
        } else {
            continue;
        };
        return Err(ExportError::Disagrees { part, mismatch });
    }
    Ok((firmware, report))
}

/// Size and static memory of a blob's model on the firmware.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct Footprint {
    /// Centres, inputs, prior-mean monomials.
    pub m: usize,
    /// Inputs.
    pub d: usize,
    /// Prior-mean monomials.
    pub p: usize,
    /// Blob size, bytes.
    pub blob_bytes: usize,
    /// Numbers in the flat array: 7d + p + 2 + m·d + m + m(m+1)/2.
    pub floats: usize,
    /// Static memory of `Model<d, p·d, floats>` on a 32-bit target, bytes:
    /// 4·floats + p·d + d, three 4-byte vector lengths and 12 bytes of dimensions, rounded up to 4.
    pub model_bytes: usize,
    /// Scratch the variance path needs: m f32, bytes.
    pub scratch_bytes: usize,
}

impl Footprint {
    /// The footprint of a model of `dims` in a blob of `blob_bytes`.
    pub fn of(dims: Dims, blob_bytes: usize) -> Self {
        let Dims { m, d, p } = dims;
        let floats = dims.floats();
        Self {
            m,
            d,
            p,
            blob_bytes,
            floats,
            model_bytes: (4 * floats + p * d + d + 3 * 4 + 12).div_ceil(4) * 4,
            scratch_bytes: 4 * m,
        }
    }
}

/// The footprint of a blob, for `trainer inspect`.
pub fn footprint(bytes: &[u8]) -> Result<Footprint, ExportError> {
    let header = blob::read_header(bytes).map_err(ExportError::Blob)?;
    Ok(Footprint::of(header.dims, bytes.len()))
}

#[cfg(test)]
mod tests;
