//! Extending a static model with the inputs a diagnosed cause calls for, fitted on a stream that
//! excites them.
//!
//! Structure (docs/design.md §5's measured lesson): the static GP keeps the kernel it was fitted
//! with on the soaked points; the new inputs enter as an additive term learned from the training
//! stream's residual under that GP — linear in each new input, whose own parameter (filter, lag,
//! decay time constant, play width) is chosen by grid on the same residual — plus an offset. A
//! thermal state also corrects the points' targets for the state they were soaked in ([`fit`]). A
//! sensor lag is corrected where it arises: the temperature input becomes a coil-temperature
//! estimate with the fitted lag, and the GP is evaluated there. Without a rate table, where the
//! static GP was fitted on this stream's own blocks, the static and the transient parts are fitted
//! together instead ([`fit`]). All inputs are computed by firmware-core's feature pipeline, so the
//! blob runs on the gyro as it was fitted.
//!
//! What it costs in accuracy, and what was chosen: the stream enters as 60 s block means (the
//! residual regressions of [`crate::analysis::diagnose`]); a regression of one to three
//! coefficients needs no more, and the block means cost nothing against the 1 Hz noise they
//! average. Refitting one GP on (T, V, new input) over the points plus the stream's block means was
//! measured in docs/design.md §5 to generalize worse (held-out 0.1–1.0× against 4–20× for the
//! additive form).

use firmware_core::Feature;
use fog_data::cause::Cause;
use fog_data::stream::Stream;
use nalgebra::DVector;
use serde::Serialize;

use crate::analysis::diagnose::{self, Candidates, CauseFit, Residual};
use crate::data::points::Points;
use crate::firmware::export::{self, AgreementReport, ExportError, Extension, Term};
use crate::models::gp::{GpError, GpModel};
use fog_data::minimize::golden_section;

/// Names of the inputs `--features` accepts, with the cause each corrects.
pub const FEATURE_NAMES: [(&str, Cause); 5] = [
    ("temperature-rate", Cause::ThermalRate),
    ("coil-temperature", Cause::SensorLag),
    ("power-on-decay", Cause::WarmUp),
    ("thermal-state", Cause::Hysteresis),
    ("time-on", Cause::TimeDrift),
];

/// The input name for a cause.
pub fn feature_name(cause: Cause) -> Option<&'static str> {
    FEATURE_NAMES
        .iter()
        .find(|(_, c)| *c == cause)
        .map(|(n, _)| *n)
}

/// Errors of an extension.
#[derive(Debug, thiserror::Error)]
pub enum ExtendError {
    /// An input name that is not in [`FEATURE_NAMES`].
    #[error(
        "unknown input '{0}': expected auto or a list of temperature-rate, coil-temperature, \
         power-on-decay, thermal-state, time-on"
    )]
    UnknownFeature(String),
    /// The training stream has too little scored data.
    #[error("the training stream has {0} scored 60 s blocks; an extension needs at least {1}")]
    TooShort(usize, usize),
    /// A cause whose input does not apply to this model (a lag without a temperature input).
    #[error("{0} does not apply to this model (it has no temperature input)")]
    NotApplicable(Cause),
    /// Conditioning the GP on the corrected points failed.
    #[error(transparent)]
    Gp(#[from] GpError),
    /// The blob could not be built or read back.
    #[error(transparent)]
    Export(#[from] ExportError),
}

/// Parses a `--features` list (comma-separated input names) into causes.
pub fn parse_features(list: &str) -> Result<Vec<Cause>, ExtendError> {
    list.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|name| {
            FEATURE_NAMES
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, c)| *c)
                .ok_or_else(|| ExtendError::UnknownFeature(name.to_owned()))
        })
        .collect()
}

/// An extension and the fits behind it.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct ExtensionFit {
    /// What the blob adds.
    pub extension: Extension,
    /// Each cause fitted alone on the training residual.
    pub fits: Vec<CauseFit>,
    /// RMS of the training residual's block means before and after, °/s.
    pub train_rmse_60s_dps: [f64; 2],
    /// For a thermal state: the offset the points carried at each plateau temperature, removed
    /// from their targets before the GP was conditioned again (empty otherwise).
    pub point_offsets: Vec<PointOffset>,
}

/// The offset the static GP absorbed from the points at one plateau temperature.
#[derive(Debug, Clone, Copy, Serialize, schemars::JsonSchema)]
pub struct PointOffset {
    /// Plateau temperature, °C.
    pub temp_c: f64,
    /// Offset removed from the points' targets there, °/s.
    pub offset_dps: f64,
}

/// An extended model: the fit and its blob.
pub struct Extended {
    /// The fit.
    pub fitted: ExtensionFit,
    /// The extended model's blob.
    pub blob: Vec<u8>,
    /// How its f32 evaluation follows the host ([`export::verify`]).
    pub agreement: AgreementReport,
    /// The GP the blob holds (the static one, or refitted to the state's offsets), to check the
    /// blob again once its rule beyond the trained range is written.
    pub model: GpModel,
}

/// Fits the inputs for `causes` on the residual `res` of a stream under the static GP `model`
/// fitted on `points` (its firmware form's residual, [`Residual::fitted_on`] `model` and
/// `points`: the one a diagnosis of that stream studied), and builds the extended blob.
///
/// A thermal state needs one more step. The points were soaked in one state per temperature —
/// whichever way the chamber reached it — and the static GP absorbed that state's offset there; a
/// state term on top would count it twice where the points' state differs from the stream's. So
/// with a thermal state the constant of the regression becomes a piecewise-linear function of
/// temperature over the points' plateaus (hat functions, a weak penalty on neighbouring differences
/// where the stream leaves a plateau unvisited): at each plateau it is the offset the points
/// carried, which is taken out of their targets before the GP is conditioned again at the
/// hyperparameters the marginal likelihood chose. Points that are a stream's block means were not
/// soaked, and the GP fitted on them saw both states; where they are the blocks of this very
/// stream, the GP is conditioned again on its targets less the fitted terms instead (static and
/// transient parts together, [`crate::analysis::diagnose`]'s module doc), otherwise they keep a
/// plain offset.
pub fn fit(
    model: &GpModel,
    points: &Points,
    res: &Residual<'_>,
    causes: &[Cause],
) -> Result<Extended, ExtendError> {
    fit_on_residual(model, points, res, causes, MIN_BLOCKS)
}

/// Fewest scored 60 s blocks an extension is fitted on.
pub const MIN_BLOCKS: usize = 30;

/// [`fit`] on a stream of at least `min_blocks` scored 60 s blocks: fewer than [`MIN_BLOCKS`]
/// only for a check's split, whose fit is scored on the rest and never shipped.
pub fn fit_on_blocks(
    model: &GpModel,
    points: &Points,
    stream: &Stream,
    causes: &[Cause],
    min_blocks: usize,
) -> Result<Extended, ExtendError> {
    let blob = export::points_blob(model, points, &Extension::default())?;
    let fw = fog_data::replay::decode(&blob).map_err(ExportError::Blob)?;
    fit_on_residual(
        model,
        points,
        &Residual::new(&fw, stream).fitted_on(model, points),
        causes,
        min_blocks,
    )
}

/// [`fit`] on a residual of at least `min_blocks` blocks.
fn fit_on_residual(
    model: &GpModel,
    points: &Points,
    res: &Residual<'_>,
    causes: &[Cause],
    min_blocks: usize,
) -> Result<Extended, ExtendError> {
    if res.len() < min_blocks {
        return Err(ExtendError::TooShort(res.len(), min_blocks));
    }
    let mut y = res.r.clone();
    let mut extension = Extension::default();
    let mut fits = Vec::new();
    // Each column: the input, its parameter's cause, and its regressor (partialled where the
    // static GP was fitted on this stream: diagnose's module doc).
    let mut columns: Vec<Column> = Vec::new();
    for &cause in causes.iter().filter(|c| **c != Cause::None) {
        let candidates = diagnose::candidates(res, cause);
        let fit = diagnose::fit_candidates(res, cause, &candidates)
            .ok_or(ExtendError::NotApplicable(cause))?;
        if cause == Cause::SensorLag {
            // r = f(T_s) − f(T_c) ≈ −x: the coil estimate removes x from the residual itself.
            let (lag, x) =
                best_lag(res, &res.r, &candidates).ok_or(ExtendError::NotApplicable(cause))?;
            y.iter_mut().zip(&x).for_each(|(y, x)| *y += x);
            extension.temperature = diagnose::feature_for(cause, lag);
        } else {
            let p = fit.parameter as f32;
            let feature =
                diagnose::feature_for(cause, p).ok_or(ExtendError::NotApplicable(cause))?;
            let x = candidates
                .into_iter()
                .find(|(q, _)| *q == p)
                .and_then(|(_, x)| x)
                .ok_or(ExtendError::NotApplicable(cause))?;
            columns.push((feature, cause, p, x));
        }
        fits.push(fit);
    }
    // Least squares of the residual on [constant part, x_1 … x_k] (a constant per plateau of a
    // soaked table with a thermal state); the model subtracts the fit.
    let n = y.len();
    let constant = res.constant(causes);
    let k = constant.columns();
    let xs: Vec<&[f64]> = columns.iter().map(|(_, _, _, x)| x.as_slice()).collect();
    let all: Vec<usize> = (0..n).collect();
    let (beta, after) = diagnose::ols(constant, &xs, &y, &all);
    for (j, (feature, _, _, _)) in columns.iter().enumerate() {
        extension
            .terms
            .push(Term::bias(*feature, -beta[k + j], res.range(*feature)));
    }
    let (model, point_offsets) = condition(model, points, res, &columns, &beta, &mut extension)?;
    let blob = export::points_blob(&model, points, &extension)?;
    let (_, agreement) = export::verify(&model, &blob, points, &extension)?;
    Ok(Extended {
        fitted: ExtensionFit {
            extension,
            fits,
            train_rmse_60s_dps: [res.rmse_60s(), (after / n as f64).sqrt()],
            point_offsets,
        },
        blob,
        agreement,
        model,
    })
}

/// One regressor of an extension: the input, its parameter's cause and value, and the regressor
/// over the residual's blocks.
type Column = (Feature, Cause, f32, Vec<f64>);

/// The GP and the table's point offsets that go with the extension's least-squares fit `beta`
/// (the constant part's columns, then one per column of `columns`): where the static GP was
/// fitted on this stream, refitted to the targets with the transient taken out; else with the
/// constant part taken into `extension`'s offset (one constant) or the table's plateau offsets.
fn condition(
    model: &GpModel,
    points: &Points,
    res: &Residual<'_>,
    columns: &[Column],
    beta: &[f64],
    extension: &mut Extension,
) -> Result<(GpModel, Vec<PointOffset>), ExtendError> {
    let knots = res.plateau_knots();
    let k = beta.len() - columns.len();
    Ok(if res.is_self_fitted() && !columns.is_empty() {
        // Static and transient parts together: t = f + c·x with c = −β, so the GP is conditioned
        // on t + β·x at the raw inputs, and the GP's mean basis carries the constant.
        let mut target = points.target();
        for (j, (_, cause, p, _)) in columns.iter().enumerate() {
            let x = res
                .raw_regressor(*cause, *p)
                .ok_or(ExtendError::NotApplicable(*cause))?;
            for (t, x) in target.iter_mut().zip(x) {
                *t += beta[k + j] * x;
            }
        }
        (model.refit_targets(points.inputs(), &target)?, Vec::new())
    } else if k == 1 {
        extension.offset = -beta[0];
        (model.clone(), Vec::new())
    } else {
        let offsets = &beta[..k];
        let target =
            points
                .target()
                .zip_map(&DVector::from_column_slice(&points.temp_c), |w, t| {
                    w - diagnose::hat_weights(knots, t)
                        .iter()
                        .map(|&(j, h)| h * offsets[j])
                        .sum::<f64>()
                });
        let refit = model.refit_targets(points.inputs(), &target)?;
        let table = knots
            .iter()
            .zip(offsets)
            .map(|(&temp_c, &offset_dps)| PointOffset { temp_c, offset_dps })
            .collect();
        (refit, table)
    })
}

/// The coil lag whose estimate best removes the residual `r` (least squares with an offset),
/// with its regressor: the best of the grid, refined by golden-section search between its grid
/// neighbours. The grid alone is too coarse for the firmware: 30 s off on a 0.5 °C/min ramp puts
/// the coil estimate 0.25 °C off, tens of °/h at high rates through the scale factor's
/// temperature coefficient.
fn best_lag(res: &Residual<'_>, r: &[f64], candidates: &Candidates) -> Option<(f32, Vec<f64>)> {
    let (j, _) = candidates
        .iter()
        .enumerate()
        .filter_map(|(j, (_, x))| Some((j, centred_sse(r, x.as_deref()?))))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let grid = |k: usize| f64::from(candidates[k].0);
    let (lo, hi) = (
        grid(j.saturating_sub(1)),
        grid((j + 1).min(candidates.len() - 1)),
    );
    let sse = |tau: f64| {
        res.raw_regressor(Cause::SensorLag, tau as f32)
            .map(|x| centred_sse(r, &x))
            .ok_or(())
    };
    let refined = golden_section(sse, (lo, hi), grid(j), LAG_TOLERANCE, LAG_ITERS)
        .ok()
        .flatten();
    let tau = refined.map_or(grid(j), |(tau, _)| tau) as f32;
    let x = res.raw_regressor(Cause::SensorLag, tau)?;
    Some((tau, x))
}

/// Relative bracket width at which the lag search stops.
const LAG_TOLERANCE: f64 = 1e-3;
/// Most iterations of the lag search.
const LAG_ITERS: u32 = 40;

/// Sum of squares of r + x about its mean.
fn centred_sse(r: &[f64], x: &[f64]) -> f64 {
    let z: Vec<f64> = r.iter().zip(x).map(|(r, x)| r + x).collect();
    let m = z.iter().sum::<f64>() / z.len().max(1) as f64;
    z.iter().map(|v| (v - m).powi(2)).sum()
}
