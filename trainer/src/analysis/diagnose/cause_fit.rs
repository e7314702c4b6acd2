//! Each cause fitted to a residual alone ([`fit_cause`]): its regressor over a grid of its
//! parameter ([`candidates`]), and what it predicts out of sample on both tests. The selection of
//! several causes together ([`super::diagnose_residual`]) starts from these grids. Apart from the
//! selection because each candidate alone is reported whatever the selection takes (the
//! diagnosis' `candidates`), and the extension fits a cause's grid again on its own data.

use firmware_core::units::SECONDS_PER_HOUR;
use fog_data::cause::Cause;
use fog_data::selection::share;
use serde::Serialize;

use super::evidence::{
    FOLDS, Split, choose, chosen_parameter, forward_sees, forward_splits, interleaved_splits,
    split_sse,
};
use super::regression::{Candidates, ols};
use super::residual::Residual;

/// Filter time constants tried for the temperature rate, s.
const RATE_TAUS_S: [f32; 5] = [30.0, 60.0, 120.0, 240.0, 480.0];
/// Coil lags tried, s.
pub const LAG_TAUS_S: [f32; 16] = [
    60.0, 90.0, 120.0, 180.0, 240.0, 300.0, 360.0, 420.0, 510.0, 600.0, 720.0, 840.0, 960.0,
    1200.0, 1500.0, 1800.0,
];
/// Warm-up time constants tried, s: about 20% apart over the documented 5–30 min and beyond, so a
/// hidden one is within 10% of the grid (a coarser grid left a residual after each power-on that a
/// heating/cooling state then took up).
const WARM_UP_TAUS_S: [f32; 12] = [
    180.0, 240.0, 300.0, 420.0, 600.0, 750.0, 900.0, 1050.0, 1200.0, 1500.0, 1800.0, 2700.0,
];
/// Play half-widths tried, °C.
const PLAY_WIDTHS_C: [f32; 9] = [0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0];

/// The parameter grid of a cause (one dummy value for those without a parameter).
fn grid(cause: Cause) -> &'static [f32] {
    match cause {
        Cause::ThermalRate => &RATE_TAUS_S,
        Cause::SensorLag => &LAG_TAUS_S,
        Cause::WarmUp => &WARM_UP_TAUS_S,
        Cause::Hysteresis => &PLAY_WIDTHS_C,
        Cause::None | Cause::TimeDrift => &[0.0],
    }
}

/// One cause fitted to a residual.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct CauseFit {
    /// The cause.
    pub id: Cause,
    /// Out-of-sample fraction of the residual variance it predicts on interleaved chunks (the
    /// diagnosis' module doc).
    pub score: f64,
    /// The same on the forward test: fitted on earlier blocks, predicting later ones.
    pub forward_score: f64,
    /// Whether its regressor moves in the blocks the forward test predicts; where it does not,
    /// the forward test abstains (the diagnosis' module doc).
    pub forward_sees: bool,
    /// Its parameter fitted on all blocks: filter or lag or decay time constant (s), play
    /// half-width (°C); 0 where there is none.
    pub parameter: f64,
    /// Intercept a, °/s (the plateau constants' mean over the blocks, where they replace it).
    pub intercept_dps: f64,
    /// Slope b, °/s per unit of the regressor.
    pub slope: f64,
    /// Correlation of the residual with the regressor.
    pub correlation: f64,
    /// RMS of the fitted term b·x around its mean, °/h.
    pub amplitude_dph: f64,
}

/// The regressors of `cause` over its parameter grid.
pub fn candidates(res: &Residual<'_>, cause: Cause) -> Candidates {
    if cause == Cause::None {
        return vec![(0.0, None)];
    }
    grid(cause)
        .iter()
        .filter_map(|&p| res.regressor(cause, p).map(|x| (p, Some(x))))
        .collect()
}

/// Fits `cause` on all blocks and scores it out of sample.
pub fn fit_cause(res: &Residual<'_>, cause: Cause) -> Option<CauseFit> {
    fit_candidates(res, cause, &candidates(res, cause))
}

/// [`fit_cause`] over regressors already computed by [`candidates`].
pub fn fit_candidates(
    res: &Residual<'_>,
    cause: Cause,
    candidates: &Candidates,
) -> Option<CauseFit> {
    let n = res.len();
    if candidates.is_empty() || n < 2 * FOLDS {
        return None;
    }
    let y = &res.r;
    let constant = res.constant(&[cause]);
    let score = |splits: &[Split]| {
        let (sse, none) = split_sse(y, constant, &[candidates], splits, false);
        share(sse, none)
    };
    let all: Vec<usize> = (0..n).collect();
    let xs = choose(y, constant, &[candidates], &all);
    let (beta, _) = ols(constant, &xs, y, &all);
    let p = chosen_parameter(y, constant, &[candidates]);
    let cols = constant.columns();
    let (correlation, amplitude) = match xs.first() {
        Some(x) => {
            let mx = x.iter().sum::<f64>() / n as f64;
            let my = y.iter().sum::<f64>() / n as f64;
            let sxy: f64 = x.iter().zip(y).map(|(u, v)| (u - mx) * (v - my)).sum();
            let sxx: f64 = x.iter().map(|u| (u - mx).powi(2)).sum();
            let syy: f64 = y.iter().map(|v| (v - my).powi(2)).sum();
            let c = if sxx > 0.0 && syy > 0.0 {
                sxy / (sxx * syy).sqrt()
            } else {
                0.0
            };
            (
                c,
                beta[cols].abs() * (sxx / n as f64).sqrt() * SECONDS_PER_HOUR,
            )
        }
        None => (0.0, 0.0),
    };
    Some(CauseFit {
        id: cause,
        score: score(&interleaved_splits(n)),
        forward_score: score(&forward_splits(n)),
        forward_sees: forward_sees(y, constant, &[candidates]),
        parameter: f64::from(p),
        intercept_dps: all.iter().map(|&i| constant.at(&beta, i)).sum::<f64>() / n as f64,
        slope: beta.get(cols).copied().unwrap_or(0.0),
        correlation,
        amplitude_dph: amplitude,
    })
}
