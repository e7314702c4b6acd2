//! Extending a static model with the inputs a diagnosed cause calls for, fitted on a stream that
//! excites them.
//!
//! Structure (DESIGN §5's measured lesson): the static GP stays as it was fitted on the soaked
//! points; the new inputs enter as an additive term learned from the training stream's residual
//! under that GP — linear in each new input, whose own parameter (filter, lag, decay time constant,
//! play width) is chosen by grid on the same residual — plus an offset. A sensor lag is corrected
//! where it arises: the temperature input becomes a coil-temperature estimate with the fitted lag,
//! and the GP is evaluated there. All inputs are computed by firmware-core's feature pipeline, so
//! the blob runs on the gyro as it was fitted.
//!
//! What it costs in accuracy, and what was chosen: the stream enters as 60 s block means (the
//! residual regressions of [`crate::diagnose`]); a regression of one to three coefficients needs no
//! more, and the block means cost nothing against the 1 Hz noise they average. Refitting one GP on
//! (T, V, new input) over the points plus the stream's block means was measured in DESIGN §5 to
//! generalize worse (held-out 0.1–1.0× against 4–20× for the additive form).

use firmware_core::Feature;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::cause::Cause;
use crate::diagnose::{self, CauseFit, Residual};
use crate::export::{Extension, HostModel, Term};
use crate::stream::Stream;

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
    #[error("the training stream has {0} scored 60 s blocks; an extension needs at least 30")]
    TooShort(usize),
    /// A cause whose input does not apply to this model (a lag without a temperature input).
    #[error("{0} does not apply to this model (it has no temperature input)")]
    NotApplicable(Cause),
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
#[derive(Debug, Clone, Serialize)]
pub struct Fitted {
    /// What the blob adds.
    pub extension: Extension,
    /// Each cause fitted alone on the training residual.
    pub fits: Vec<CauseFit>,
    /// RMS of the training residual's block means before and after, °/s.
    pub train_rmse_60s_dps: [f64; 2],
}

/// Fits the inputs for `causes` on `stream`'s residual under the static model `fw`.
pub fn fit(fw: &HostModel, stream: &Stream, causes: &[Cause]) -> Result<Fitted, ExtendError> {
    let res = Residual::new(fw, stream);
    if res.len() < 30 {
        return Err(ExtendError::TooShort(res.len()));
    }
    let mut y = res.r.clone();
    let mut extension = Extension::default();
    let mut fits = Vec::new();
    let mut columns: Vec<(Feature, Vec<f64>)> = Vec::new();
    for &cause in causes.iter().filter(|c| **c != Cause::None) {
        let fit = diagnose::fit_cause(&res, cause).ok_or(ExtendError::NotApplicable(cause))?;
        let p = fit.parameter as f32;
        let feature = diagnose::feature_for(cause, p).ok_or(ExtendError::NotApplicable(cause))?;
        if cause == Cause::SensorLag {
            // r = f(T_s) − f(T_c) ≈ −x: the coil estimate removes x from the residual itself.
            let lag = best_lag(&res).ok_or(ExtendError::NotApplicable(cause))?;
            let x = res
                .regressor(cause, lag)
                .ok_or(ExtendError::NotApplicable(cause))?;
            y.iter_mut().zip(&x).for_each(|(y, x)| *y += x);
            extension.temperature = diagnose::feature_for(cause, lag);
        } else {
            let x = res
                .regressor(cause, p)
                .ok_or(ExtendError::NotApplicable(cause))?;
            columns.push((feature, x));
        }
        fits.push(fit);
    }
    // Joint least squares of the residual on [1, x_1 … x_k]; the model subtracts the fit.
    let n = y.len();
    let mut a = DMatrix::from_element(n, columns.len() + 1, 1.0);
    for (j, (_, x)) in columns.iter().enumerate() {
        a.set_column(j + 1, &DVector::from_column_slice(x));
    }
    let b = DVector::from_column_slice(&y);
    let beta = a
        .clone()
        .svd(true, true)
        .solve(&b, 1e-12)
        .unwrap_or_else(|_| DVector::zeros(columns.len() + 1));
    let after = &b - &a * &beta;
    extension.offset = -beta[0];
    for (j, (feature, _)) in columns.iter().enumerate() {
        extension.terms.push(Term {
            feature: *feature,
            coefficient: -beta[j + 1],
            range: res.range(*feature),
        });
    }
    Ok(Fitted {
        extension,
        fits,
        train_rmse_60s_dps: [res.rmse_60s(), (after.norm_squared() / n as f64).sqrt()],
    })
}

/// The coil lag whose estimate best removes the residual (least squares with an offset).
fn best_lag(res: &Residual<'_>) -> Option<f32> {
    diagnose::LAG_TAUS_S
        .iter()
        .filter_map(|&tau| {
            let x = res.regressor(Cause::SensorLag, tau)?;
            let z: Vec<f64> = res.r.iter().zip(&x).map(|(r, x)| r + x).collect();
            let m = z.iter().sum::<f64>() / z.len() as f64;
            Some((tau, z.iter().map(|v| (v - m).powi(2)).sum::<f64>()))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(tau, _)| tau)
}
