//! Diagnosis (DESIGN §5): replay a stream through a static model, study the residual
//! r = ω̂ − ω_ref, rank the candidate physical causes by evidence, name one.
//!
//! Each cause is a hypothesis about the form of the residual, written with the input the
//! firmware would need to correct it (computed by firmware-core's feature pipeline, so a cause
//! found here can be compensated on the gyro as it was measured):
//!
//! | cause | residual ≈ a + b·x, x = | parameter (grid) |
//! |---|---|---|
//! | `thermal-rate` | filtered dT/dt of the sensor, °C/min | filter τ |
//! | `sensor-lag` | f(T̂_c, …) − f(T, …): what the model would say on a coil temperature lagging the sensor by τ; it scales with the model's ∂ω/∂T and so with \|ω\| | lag τ |
//! | `warm-up` | exp(−t_on/τ) | τ |
//! | `hysteresis` | heating/cooling state (play operator of half-width w) | w |
//! | `time-drift` | time since power-on | — |
//! | `none` | (a alone) | — |
//!
//! **Evidence.** The residual is autocorrelated (bias instability, random walk), so neither the
//! samples nor the 60 s block means are independent and an in-sample fit always "explains"
//! something. The score is out of sample: the 60 s block means are cut into 10-minute chunks,
//! chunk k goes to fold k mod 5, and each fold is predicted by the hypothesis fitted on the other
//! four — its parameter chosen by grid and its coefficients by least squares, on those four only.
//! Interleaved chunks rather than a plain split in time because a one-time event (the warm-up
//! after a single power-on) must appear in training and test folds alike; 10 minutes is twice the
//! bias instability's correlation time, so noise shared across the cut is small. Score =
//! 1 − SSE_cause / SSE_none: the fraction of the residual's variance the cause predicts on
//! data it was not fitted on. A cause is named when its score reaches [`MIN_SCORE`]; otherwise
//! `none`.
//!
//! Causes that look alike are told apart by this comparison itself, because their regressors
//! differ where the physics differs: a lag error follows ∂ω/∂T and changes with every rate step
//! while a thermal-rate bias does not; a hysteresis offset persists through soaks where a
//! thermal-rate bias is zero; a warm-up decays within minutes of each power-on where a drift keeps
//! growing. The runner-up and its score are reported beside the named cause.

use firmware_core::{Feature, FeatureState, Status};
use serde::Serialize;

use crate::cause::Cause;
use crate::export::HostModel;
use crate::replay::{self, Compensated};
use crate::stream::Stream;

/// Seconds per hour.
const HOUR_S: f64 = 3600.0;
/// Smallest score that names a cause.
pub const MIN_SCORE: f64 = 0.25;
/// Blocks per chunk of the cross-validation (10 minutes of 60 s blocks).
const CHUNK_BLOCKS: usize = 10;
/// Folds of the cross-validation.
const FOLDS: usize = 5;

/// Filter time constants tried for the temperature rate, s.
const RATE_TAUS_S: [f32; 5] = [30.0, 60.0, 120.0, 240.0, 480.0];
/// Coil lags tried, s.
pub const LAG_TAUS_S: [f32; 16] = [
    60.0, 90.0, 120.0, 180.0, 240.0, 300.0, 360.0, 420.0, 510.0, 600.0, 720.0, 840.0, 960.0,
    1200.0, 1500.0, 1800.0,
];
/// Warm-up time constants tried, s.
const WARM_UP_TAUS_S: [f32; 7] = [180.0, 300.0, 600.0, 900.0, 1200.0, 1800.0, 2700.0];
/// Play half-widths tried, °C.
const PLAY_WIDTHS_C: [f32; 9] = [0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0];

/// What the model lacks for each cause: the input that corrects it, at parameter `p`.
pub fn feature_for(cause: Cause, p: f32) -> Option<Feature> {
    match cause {
        Cause::None => None,
        Cause::ThermalRate => Some(Feature::TemperatureRate { tau_s: p }),
        Cause::SensorLag => Some(Feature::CoilTemperature { tau_s: p }),
        Cause::WarmUp => Some(Feature::PowerOnDecay { tau_s: p }),
        Cause::Hysteresis => Some(Feature::ThermalState { width_c: p }),
        Cause::TimeDrift => Some(Feature::TimeOn),
    }
}

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

/// A stream replayed through a static model, reduced to 60 s blocks.
pub struct Residual<'a> {
    model: &'a HostModel,
    stream: &'a Stream,
    /// Sample indices of each block.
    blocks: Vec<Vec<usize>>,
    /// Block means of the residual, °/s.
    pub r: Vec<f64>,
    /// Where the firmware restarts its feature state.
    restarts: Vec<bool>,
}

impl<'a> Residual<'a> {
    /// Replays `stream` through `model` and keeps the blocks of scored, non-fault samples.
    pub fn new(model: &'a HostModel, stream: &'a Stream) -> Self {
        let comp = replay::replay(model, stream);
        Self::from_replay(model, stream, &comp)
    }

    /// As [`Self::new`] with the replay already done.
    pub fn from_replay(model: &'a HostModel, stream: &'a Stream, comp: &Compensated) -> Self {
        let scored: Vec<usize> = (0..stream.len())
            .filter(|&i| stream.rate_dps[i].is_finite() && comp.status[i] != Status::Fault)
            .collect();
        let blocks = replay::blocks(stream, &scored);
        let r = blocks
            .iter()
            .map(|b| {
                b.iter()
                    .map(|&i| f64::from(comp.rate_dps[i]) - stream.rate_dps[i])
                    .sum::<f64>()
                    / b.len() as f64
            })
            .collect();
        Self {
            model,
            stream,
            blocks,
            r,
            restarts: replay::restarts(stream),
        }
    }

    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.r.len()
    }

    /// Whether no block was scored.
    pub fn is_empty(&self) -> bool {
        self.r.is_empty()
    }

    /// RMS of the block means, °/s.
    pub fn rmse_60s(&self) -> f64 {
        rms(&self.r)
    }

    /// Block means of a per-sample series.
    fn block_means(&self, x: &[f64]) -> Vec<f64> {
        self.blocks
            .iter()
            .map(|b| b.iter().map(|&i| x[i]).sum::<f64>() / b.len() as f64)
            .collect()
    }

    /// Block means of the sensor temperature, °C.
    pub fn temperature(&self) -> Vec<f64> {
        self.block_means(&self.stream.temp_c)
    }

    /// One feature along the stream, as the firmware computes it (state restarted at restarts).
    fn series(&self, feature: Feature) -> Vec<f64> {
        let mut state = FeatureState::default();
        let mut out = [0.0f32; 1];
        (0..self.stream.len())
            .map(|i| {
                if self.restarts[i] {
                    state.reset();
                }
                let s = replay::sample(self.stream, i);
                firmware_core::features::compute(&[feature], &s, &mut state, &mut out);
                f64::from(out[0])
            })
            .collect()
    }

    /// Range of a feature along the stream, widened by 10% of its span each side: the trained
    /// range of an additive input.
    pub fn range(&self, feature: Feature) -> (f64, f64) {
        let x = self.series(feature);
        let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let pad = 0.1 * (hi - lo);
        (lo - pad, hi + pad)
    }

    /// The regressor x of `cause` at parameter `p`, as block means; `None` where the cause does
    /// not apply (no temperature input for a lag).
    pub fn regressor(&self, cause: Cause, p: f32) -> Option<Vec<f64>> {
        let feature = feature_for(cause, p)?;
        if cause != Cause::SensorLag {
            return Some(self.block_means(&self.series(feature)));
        }
        // f(inputs with the coil estimate in place of the sensor) − f(inputs).
        let features = self.model.features();
        let k = features.iter().position(|f| *f == Feature::Temperature)?;
        let mut lagged = features.to_vec();
        lagged[k] = feature;
        let mut state = [FeatureState::default(), FeatureState::default()];
        let d = features.len();
        let mut x0 = vec![0.0f32; d];
        let mut x1 = vec![0.0f32; d];
        let diff: Vec<f64> = (0..self.stream.len())
            .map(|i| {
                if self.restarts[i] {
                    state.iter_mut().for_each(FeatureState::reset);
                }
                let s = replay::sample(self.stream, i);
                firmware_core::features::compute(features, &s, &mut state[0], &mut x0);
                firmware_core::features::compute(&lagged, &s, &mut state[1], &mut x1);
                let a = self.model.predict_mean(&x0).mean;
                let b = self.model.predict_mean(&x1).mean;
                f64::from(b) - f64::from(a)
            })
            .collect();
        Some(self.block_means(&diff))
    }
}

fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt()
}

/// Least squares of y on [1, x] over the blocks `idx`: (intercept, slope, SSE).
fn ols(x: Option<&[f64]>, y: &[f64], idx: &[usize]) -> (f64, f64, f64) {
    let n = idx.len() as f64;
    let my = idx.iter().map(|&i| y[i]).sum::<f64>() / n.max(1.0);
    let Some(x) = x else {
        let sse = idx.iter().map(|&i| (y[i] - my).powi(2)).sum();
        return (my, 0.0, sse);
    };
    let mx = idx.iter().map(|&i| x[i]).sum::<f64>() / n.max(1.0);
    let sxx: f64 = idx.iter().map(|&i| (x[i] - mx).powi(2)).sum();
    let sxy: f64 = idx.iter().map(|&i| (x[i] - mx) * (y[i] - my)).sum();
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let a = my - b * mx;
    let sse = idx.iter().map(|&i| (y[i] - a - b * x[i]).powi(2)).sum();
    (a, b, sse)
}

/// One cause fitted to a residual.
#[derive(Debug, Clone, Serialize)]
pub struct CauseFit {
    /// The cause.
    pub id: Cause,
    /// Out-of-sample fraction of the residual variance it predicts (module doc).
    pub score: f64,
    /// Its parameter fitted on all blocks: filter or lag or decay time constant (s), play
    /// half-width (°C); 0 where there is none.
    pub parameter: f64,
    /// Intercept a, °/s.
    pub intercept_dps: f64,
    /// Slope b, °/s per unit of the regressor.
    pub slope: f64,
    /// Correlation of the residual with the regressor.
    pub correlation: f64,
    /// RMS of the fitted term b·x around its mean, °/h.
    pub amplitude_dph: f64,
}

/// A cause's regressor at each parameter of its grid (one absent regressor for `none`).
pub type Candidates = Vec<(f32, Option<Vec<f64>>)>;

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
    let folds: Vec<usize> = (0..n).map(|b| (b / CHUNK_BLOCKS) % FOLDS).collect();
    if candidates.is_empty() || n < 2 * FOLDS {
        return None;
    }
    let y = &res.r;
    let best_on = |idx: &[usize]| {
        candidates
            .iter()
            .map(|(p, x)| (*p, x.as_deref(), ols(x.as_deref(), y, idx)))
            .min_by(|a, b| a.2.2.total_cmp(&b.2.2))
    };
    let mut sse_cause = 0.0;
    let mut sse_none = 0.0;
    for f in 0..FOLDS {
        let train: Vec<usize> = (0..n).filter(|&i| folds[i] != f).collect();
        let test: Vec<usize> = (0..n).filter(|&i| folds[i] == f).collect();
        let (_, x, (a, b, _)) = best_on(&train)?;
        let (m, _, _) = ols(None, y, &train);
        for &i in &test {
            let pred = a + b * x.map_or(0.0, |x| x[i]);
            sse_cause += (y[i] - pred).powi(2);
            sse_none += (y[i] - m).powi(2);
        }
    }
    let all: Vec<usize> = (0..n).collect();
    let (p, x, (a, b, _)) = best_on(&all)?;
    let (correlation, amplitude) = match x {
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
            (c, b.abs() * (sxx / n as f64).sqrt() * HOUR_S)
        }
        None => (0.0, 0.0),
    };
    Some(CauseFit {
        id: cause,
        score: if sse_none > 0.0 {
            1.0 - sse_cause / sse_none
        } else {
            0.0
        },
        parameter: f64::from(p),
        intercept_dps: a,
        slope: b,
        correlation,
        amplitude_dph: amplitude,
    })
}

/// The diagnosis of one stream (DESIGN §6 `diagnose` JSON).
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// The named cause.
    pub cause: Cause,
    /// Every candidate, best first.
    pub candidates: Vec<CauseFit>,
    /// RMS of the residual's 60 s block means, °/s.
    pub residual_rmse_60s_dps: f64,
    /// 60 s blocks used.
    pub n_blocks: usize,
    /// The runner-up (best candidate other than the named cause).
    pub runner_up: Option<Cause>,
    /// What the model gets wrong and why, in words.
    pub explanation: String,
    /// The input the cause calls for, with its fitted parameter.
    pub add_feature: Option<Feature>,
}

/// Diagnoses `stream` against `model`.
pub fn diagnose(model: &HostModel, stream: &Stream) -> Diagnosis {
    let res = Residual::new(model, stream);
    diagnose_residual(&res)
}

/// Diagnoses a residual already computed.
pub fn diagnose_residual(res: &Residual<'_>) -> Diagnosis {
    let mut candidates: Vec<CauseFit> = Cause::ALL
        .into_iter()
        .filter_map(|c| fit_cause(res, c))
        .collect();
    candidates.sort_by(|a, b| b.score.total_cmp(&a.score));
    let best = candidates
        .iter()
        .find(|c| c.id != Cause::None)
        .filter(|c| c.score >= MIN_SCORE);
    let cause = best.map_or(Cause::None, |c| c.id);
    let runner_up = candidates.iter().map(|c| c.id).find(|id| *id != cause);
    let named = candidates.iter().find(|c| c.id == cause);
    let other = candidates.iter().find(|c| Some(c.id) == runner_up);
    let explanation = explain(cause, named, other, res.rmse_60s());
    Diagnosis {
        cause,
        add_feature: named.and_then(|c| feature_for(cause, c.parameter as f32)),
        candidates,
        residual_rmse_60s_dps: res.rmse_60s(),
        n_blocks: res.len(),
        runner_up,
        explanation,
    }
}

fn explain(cause: Cause, named: Option<&CauseFit>, other: Option<&CauseFit>, rmse: f64) -> String {
    let rival = other.map_or(String::new(), |o| {
        format!(
            "; runner-up {} predicts {:.0}%",
            o.id,
            100.0 * o.score.max(0.0)
        )
    });
    let Some(c) = named.filter(|_| cause != Cause::None) else {
        return format!(
            "residual {:.2} °/h RMS (60 s means) is noise: no candidate predicts {:.0}% of it out \
             of sample{rival}; the static model needs nothing more",
            rmse * HOUR_S,
            100.0 * MIN_SCORE
        );
    };
    let share = 100.0 * c.score;
    let minutes = c.parameter / 60.0;
    let what = match cause {
        Cause::ThermalRate => format!(
            "residual follows dT/dt (r = {:.2}, {:.1} (°/h)/(°C/min), filter {minutes:.0} min) \
             whatever the rate: Shupe/thermal-stress drift; add a temperature-rate input",
            c.correlation,
            c.slope * HOUR_S
        ),
        Cause::SensorLag => format!(
            "residual follows the model's ∂ω/∂T·dT/dt (r = {:.2}) and grows with |ω|: the coil lags \
             the temperature sensor by about {minutes:.0} min; add a lag-compensated coil temperature",
            c.correlation
        ),
        Cause::WarmUp => format!(
            "residual decays after each power-on (r = {:.2}, {:.1} °/h at power-on, τ ≈ {minutes:.0} \
             min): warm-up transient; add a time-since-power-on input",
            c.correlation,
            c.slope * HOUR_S
        ),
        Cause::Hysteresis => format!(
            "residual differs after heating vs cooling by {:.1} °/h and keeps it through soaks \
             (r = {:.2}): thermal hysteresis; add a heating/cooling state input",
            2.0 * c.slope.abs() * HOUR_S,
            c.correlation
        ),
        Cause::TimeDrift => format!(
            "residual drifts steadily with time on, {:.2} (°/h)/h (r = {:.2}): in-run drift; add a \
             time input",
            c.slope * HOUR_S,
            c.correlation
        ),
        Cause::None => String::new(),
    };
    format!("{what}. It predicts {share:.0}% of the residual variance out of sample{rival}")
}
