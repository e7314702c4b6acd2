//! A model fitted on one run and scored on another: another power-on, another day, for a rate
//! table the only held-out part unlike the training one. Beside the score it says what differs:
//! the test run's errors as an offset plus a share of the rate, the two run-to-run changes a
//! gyro's datasheet gives (bias and scale-factor repeatability). A bias term in the σ states the
//! first; only the second grows with the rate, so a run that differs in scale is missed most where
//! the rate is highest whatever the bias term says.

use firmware_core::units::DPH_PER_DPS;
use fog_data::sigma::Coverage;
use fog_data::stats::{mean, rms};
use serde::Serialize;

use super::{EvalConfig, EvalError, Method, MethodFit};
use crate::data::points::Points;
use crate::progress::Progress;

/// A model fitted on one run and tested on another, inside the range both cover.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct CrossRun {
    /// Method name.
    pub method: &'static str,
    /// Test points inside the shared range.
    pub n: usize,
    /// Test points outside it (not scored).
    pub n_outside: usize,
    /// Shared temperature range, °C.
    pub temp_range_c: (f64, f64),
    /// Largest |rate| both runs cover, °/s.
    pub max_abs_rate_dps: f64,
    /// RMSE on the shared range, °/s.
    pub rmse_dps: f64,
    /// Same, °/h.
    pub rmse_dph: f64,
    /// The GP's σ there, its error model measured on the training run alone, with another
    /// power-on's bias (`--repeatability`) and scale factor (`--scale-repeatability`), each
    /// assumed as `fit` assumes it where not stated (null for the methods that state no σ).
    pub sigma: Option<Coverage>,
    /// Another power-on's bias stated in `sigma`, output units (`--repeatability`, or assumed:
    /// `turn_on_assumed`; 0 where the training runs left out measured it; null without a σ).
    pub turn_on_std: Option<f64>,
    /// Whether `turn_on_std` is assumed (the difference of two power-ons as large as the model
    /// error's floor) rather than stated.
    pub turn_on_assumed: bool,
    /// The scale factor's repeatability in `sigma`, ppm (`--scale-repeatability`, or assumed:
    /// `scale_assumed`; null: none, the training run's rates barely moving or the bias it
    /// would be assumed as large as 0, runs pooled, whose floor holds it at the rates they hold,
    /// or no σ).
    pub scale_repeatability_ppm: Option<f64>,
    /// Whether `scale_repeatability_ppm` is assumed (the difference of two power-ons' scale
    /// factors as large as the training run's residual error in proportion to the rate, or where
    /// they show none, as large at their RMS rate as another power-on's bias) rather than
    /// stated.
    pub scale_assumed: bool,
    /// What differs between the runs, read off the test run's errors (null where its rates do
    /// not vary or fewer than three points are scored).
    pub difference: Option<RunDifference>,
}

/// The test run's errors (prediction − reference) fitted by least squares as `offset + scale ·
/// rate`: how the run differs from the one the model was fitted on. A description of the held-out
/// errors, fitted on them: no model and no σ uses it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct RunDifference {
    /// The offset, °/h: a bias that differs between the runs.
    pub offset_dph: f64,
    /// The share of the rate, ppm: a scale factor that differs between the runs.
    pub scale_ppm: f64,
    /// The RMSE left with the offset alone taken out (the errors' mean), °/h.
    pub without_offset_dph: f64,
    /// The RMSE left with both taken out, °/h.
    pub without_both_dph: f64,
}

impl RunDifference {
    /// The fit of `errors` (°/s) at `rates` (°/s); `None` where the rates do not vary.
    pub fn of(errors: &[f64], rates: &[f64]) -> Option<Self> {
        let (me, mr) = (mean(errors), mean(rates));
        let srr: f64 = rates.iter().map(|r| (r - mr).powi(2)).sum();
        if errors.len() < 3 || srr <= 0.0 {
            return None;
        }
        let sre: f64 = rates
            .iter()
            .zip(errors)
            .map(|(r, e)| (r - mr) * (e - me))
            .sum();
        let scale = sre / srr;
        let offset = me - scale * mr;
        let left = |f: &dyn Fn(f64) -> f64| {
            let e: Vec<f64> = rates.iter().zip(errors).map(|(r, e)| e - f(*r)).collect();
            rms(&e) * DPH_PER_DPS
        };
        Some(Self {
            offset_dph: offset * DPH_PER_DPS,
            scale_ppm: scale * 1e6,
            without_offset_dph: left(&|_| me),
            without_both_dph: left(&|r| offset + scale * r),
        })
    }
}

/// Fits `method` on `train` and scores it on the points of `test` inside the temperature range
/// and the |rate| range both runs cover (a model is not asked to extrapolate here). The GP's σ is
/// its error model measured on `train`, with another power-on's bias (`stated.0`, a datasheet's
/// bias repeatability) and scale factor (`stated.1`, a datasheet's scale-factor repeatability in
/// ppm), each assumed where nothing states it and `train`'s runs do not measure it.
pub fn score(
    train: &Points,
    test: &Points,
    method: Method,
    cfg: &EvalConfig,
    stated: (Option<f64>, Option<f64>),
    bar: &dyn Progress,
) -> Result<CrossRun, EvalError> {
    let (bias, scale_ppm) = stated;
    let range = |p: &Points| {
        let lo = p.temp_c.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = p.temp_c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let w = p.rate_dps.iter().fold(0.0f64, |m, r| m.max(r.abs()));
        (lo, hi, w)
    };
    let (a, b) = (range(train), range(test));
    let (lo, hi, w) = (a.0.max(b.0), a.1.min(b.1), a.2.min(b.2));
    let inside: Vec<usize> = (0..test.len())
        .filter(|&i| {
            (lo..=hi).contains(&test.temp_c[i]) && test.rate_dps[i].abs() <= w * (1.0 + 1e-9)
        })
        .collect();
    if inside.is_empty() {
        return Err(EvalError::NoOverlap);
    }
    bar.expect(1);
    bar.stage(&format!(
        "{}: fit on one run, test on the other",
        method.name()
    ));
    let m = MethodFit::fit(train, method, cfg)?;
    let mut calibration = m.calibration(train, cfg)?;
    if let Some(c) = calibration.as_mut() {
        c.turn_on(bias);
        c.scale(scale_ppm);
    }
    bar.advance(1);
    let (e, sigmas): (Vec<f64>, Vec<f64>) = inside
        .iter()
        .map(|&i| {
            let (p, sigma) = m.predict_with_sigma(test, i, calibration.as_ref());
            (p - test.rate_dps[i], sigma)
        })
        .unzip();
    let rates: Vec<f64> = inside.iter().map(|&i| test.rate_dps[i]).collect();
    let r = rms(&e);
    Ok(CrossRun {
        method: method.name(),
        n: inside.len(),
        n_outside: test.len() - inside.len(),
        temp_range_c: (lo, hi),
        max_abs_rate_dps: w,
        rmse_dps: r,
        rmse_dph: r * DPH_PER_DPS,
        sigma: calibration.as_ref().map(|_| Coverage::of(&e, &sigmas)),
        turn_on_std: calibration.as_ref().map(|c| c.turn_on_std),
        turn_on_assumed: calibration
            .as_ref()
            .is_some_and(|c| c.assumed.contains(&"turn-on")),
        scale_repeatability_ppm: scale_ppm.or(calibration
            .as_ref()
            .map(|c| c.scale_repeatability_ppm)
            .filter(|ppm| *ppm > 0.0)),
        scale_assumed: calibration
            .as_ref()
            .is_some_and(|c| c.assumed.contains(&"scale")),
        difference: RunDifference::of(&e, &rates),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Errors made of a known offset and scale, plus a wiggle uncorrelated with the rate, give
    /// them back, and what is left is the wiggle.
    #[test]
    fn an_offset_and_a_scale_are_read_off_the_errors() {
        let rates: Vec<f64> = (-20..=20).map(|k| 5.0 * f64::from(k)).collect();
        let wiggle = |k: usize| if k.is_multiple_of(2) { 1e-3 } else { -1e-3 };
        let errors: Vec<f64> = rates
            .iter()
            .enumerate()
            .map(|(k, r)| 0.01 + 800e-6 * r + wiggle(k))
            .collect();
        let d = RunDifference::of(&errors, &rates).unwrap();
        assert!((d.offset_dph - 36.0).abs() < 0.5, "{d:?}");
        assert!((d.scale_ppm - 800.0).abs() < 1.0, "{d:?}");
        assert!((d.without_both_dph - 3.6).abs() < 0.1, "{d:?}");
        assert!(d.without_offset_dph > 40.0 * d.without_both_dph, "{d:?}");
        assert_eq!(RunDifference::of(&errors, &vec![1.0; errors.len()]), None);
    }
}
