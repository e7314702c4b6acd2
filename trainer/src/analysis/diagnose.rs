//! Diagnosis (docs/design.md §5): replay a stream through a static model, study the residual
//! r = ω̂ − ω_ref, rank the candidate physical causes by evidence, name up to three.
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
//! data it was not fitted on.
//!
//! Interleaved chunks let a slow trend look predictive: a drift fitted on the chunks around a
//! test chunk interpolates it, while the model must extrapolate it on the gyro. So each cause is
//! scored a second time, forward in time (rolling origin): fitted on the blocks before 50%,
//! 62.5%, 75% and 87.5% of the stream, it predicts the blocks up to the next origin, again
//! against an intercept fitted on the same earlier blocks. A cause is named only when it
//! predicts at least [`MIN_SCORE`] of the variance on both tests; otherwise the answer is `none`,
//! with what the best candidate did on each.
//!
//! **A test that cannot see a cause abstains.** The forward test predicts the stream's later half;
//! a warm-up after the one power-on at the start of a log has died out there, so fitted on the
//! earlier blocks it predicts nothing, which is no evidence against it. Where none of a design's
//! regressors moves in those blocks by [`VISIBLE`] of its spread over the whole stream, the
//! forward test abstains: it neither names the design nor refuses it, and the design is ranked by
//! the interleaved test alone. It still refuses what it can measure: a design that makes the later
//! blocks worse by more than [`HARM`] (RMS) is not named.
//!
//! **A static model fitted on the stream itself** (no rate table) has already absorbed the part of
//! an effect that its temperature input can follow: a thermal-rate bias on a one-way ramp looks
//! like a temperature curve. Adding a term on top then finds only the rest. So there the static and
//! the transient parts are fitted together: t = f(T) + c·x, f the GP at its fitted hyperparameters,
//! whose smoother S is linear in the targets. c is estimated as in a partially linear model
//! (Speckman 1988): (I − S)t, the static residual up to sign, regressed on (I − S)x, the part of
//! the regressor the GP could have absorbed taken out. Every regressor but a lag's (already a
//! difference of the GP's own predictions) is replaced by (I − S)x here, and
//! [`crate::analysis::extend`] conditions the GP again on t − c·x. The static curve itself was
//! fitted on every block, so here the forward score is forward for the causes' parameters and
//! coefficients only; the extension's own forward check ([`crate::analysis::investigate`]) fits the
//! static curve again on the earlier part.
//!
//! **A static model fitted on a soaked table** carries the heating/cooling state each plateau was
//! soaked in (the chamber reached −30 °C by cooling and every later setpoint by heating): its GP
//! absorbed that state's offset there, so wherever the stream's state differs the residual holds
//! the table's offset too, as a function of temperature. A heating/cooling state is therefore
//! fitted with a constant per plateau in place of the intercept ([`Constant`]), as the extension
//! fits it. Without them, a temperature rate beside a hysteresis was never named as a pair (0 of 3
//! in the challenge): fitted on the earlier blocks, the play's coefficient followed the −28 °C
//! soak's table offset and the pair predicted the later blocks 1.6–4× worse than one cause alone.
//! The plateau constants can also follow a static curve that is simply off at the table's
//! temperatures, which named a state on a gyro with none; so the state must also predict its own
//! share of what the design's other causes and the plateau constants alone leave
//! ([`Step::state_share`]). Where the next larger design predicts more but its state fails that
//! test, the state is redundant beside the larger design's other causes, and they take the place
//! of the design with the state (a temperature rate beside a lag looked as good as a state until
//! all three were fitted together).
//!
//! **Several causes.** Real logs mix effects, and mixed effects can imitate a third: a warm-up
//! after a power-on that heats the housing plus a heating/cooling offset follow dT/dt better than
//! either alone. Adding causes one at a time would lock in the imitation. So the selection is by
//! best subset (at most [`MAX_CAUSES`]; five causes make 25 designs): for one, two, then three
//! causes, every design is scored with all its parameters chosen again inside every training
//! split, and the best one is taken when it predicts at least [`MIN_SCORE`] (one cause) or
//! [`MIN_NEXT_SCORE`] (more) of what the design taken before it left, on both tests; it need not
//! contain that design's causes. Best means the most predicted on the two tests together: both
//! are out-of-sample estimates of the same share, and look-alikes split them (a weak hysteresis
//! predicted 61% on interleaved chunks and 80% forward where a temperature rate predicted 63% and
//! 62%; ranked on the interleaved chunks alone, the rate was named). The first size that finds none ends it. [`MIN_SCORE`] tells an
//! effect from autocorrelated noise; what a true first cause leaves is noise plus the next
//! effect, hence the lower bar. On the simulator, with none hidden beside the first, the best
//! further cause predicts 0–1% of what is left; a hidden second effect of the documented
//! strengths predicts 20% or more.
//!
//! Causes that look alike are told apart by this comparison itself, because their regressors
//! differ where the physics differs: a lag error follows ∂ω/∂T and changes with every rate step
//! while a thermal-rate bias does not; a hysteresis offset persists through soaks where a
//! thermal-rate bias is zero; a warm-up decays within minutes of each power-on where a drift keeps
//! growing. The runner-up and its score are reported beside the named cause.

use firmware_core::{Feature, FeatureState, Status};
use firmware_sim::cause::Cause;
use firmware_sim::data::stream::Stream;
use firmware_sim::replay::HostModel;
use firmware_sim::replay::{self, Compensated};
use itertools::Itertools;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::data::points::{Points, plateaus};
use crate::models::gp::GpModel;

/// Seconds per hour.
const HOUR_S: f64 = 3600.0;
/// Smallest score that names a cause.
pub const MIN_SCORE: f64 = 0.25;
/// Blocks per chunk of the cross-validation (10 minutes of 60 s blocks).
const CHUNK_BLOCKS: usize = 10;
/// Folds of the cross-validation.
const FOLDS: usize = 5;
/// Origins of the forward test, as fractions of the blocks (module doc).
const FORWARD_ORIGINS: [f64; 4] = [0.5, 0.625, 0.75, 0.875];
/// Share of a regressor's spread over the whole stream that it must show in the blocks a test
/// scores for the test to see it (module doc: below, the test abstains).
pub const VISIBLE: f64 = 0.2;
/// Worsening of the RMS error, as a fraction, that a test which cannot see a cause still counts
/// as harm (module doc; [`crate::analysis::investigate`] keeps the same rule).
pub const HARM: f64 = 0.02;
/// Fewest training blocks a split needs to be scored.
const MIN_TRAIN_BLOCKS: usize = 5;
/// Most causes named at once.
pub const MAX_CAUSES: usize = 3;
/// Smallest share of what the causes named so far leave that a further cause must predict, on
/// both tests (module doc).
pub const MIN_NEXT_SCORE: f64 = 0.1;

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
    /// Where the gyro was powered on (the feature state goes through a power-on).
    restarts: Vec<bool>,
    /// The static GP and its inputs, where it was fitted on these very blocks (module doc).
    absorbed_by: Option<(&'a GpModel, &'a DMatrix<f64>)>,
    /// The soaked table's plateaus, where the static GP was fitted on one (module doc).
    plateaus: Option<Plateaus>,
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
            absorbed_by: None,
            plateaus: None,
        }
    }

    /// The static GP `gp` was fitted on `points`. Where they are these blocks' own means (a
    /// static model from the stream itself, no rate table), regressors become the part of each
    /// input that the GP could not have absorbed; where they are a soaked table, a heating/cooling
    /// state is fitted with a constant per plateau (module doc).
    pub fn fitted_on(mut self, gp: &'a GpModel, points: &'a Points) -> Self {
        let temps = self.temperature();
        if points.soaked && !points.is_empty() {
            let knots = plateau_temperatures(&points.temp_c);
            let weights = temps.iter().map(|&t| hat_weights(&knots, t)).collect();
            self.plateaus = Some(Plateaus { knots, weights });
        }
        let same = !points.soaked
            && points.len() == temps.len()
            && points
                .temp_c
                .iter()
                .zip(&temps)
                .all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs().max(1.0));
        if same {
            self.absorbed_by = Some((gp, points.inputs()));
        }
        self
    }

    /// The soaked table's plateau temperatures, ascending (empty where the static GP was not
    /// fitted on one).
    pub fn plateau_knots(&self) -> &[f64] {
        self.plateaus.as_ref().map_or(&[], |p| &p.knots)
    }

    /// The constant of a regression on this residual with `causes` ([`Constant`]).
    pub(crate) fn constant(&self, causes: &[Cause]) -> Constant<'_> {
        Constant::of(self.plateaus.as_ref(), causes.contains(&Cause::Hysteresis))
    }

    /// Whether the static GP was fitted on these blocks ([`Self::fitted_on`]).
    pub fn is_self_fitted(&self) -> bool {
        self.absorbed_by.is_some()
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

    /// One feature along the stream, as the firmware computes it (state through power-ons);
    /// NaN at a sample the firmware refuses (no block holds one).
    fn series(&self, feature: Feature) -> Vec<f64> {
        let mut state = FeatureState::default();
        let mut out = [0.0f32; 1];
        (0..self.stream.len())
            .map(|i| {
                if self.restarts[i] {
                    state.power_on();
                }
                let s = replay::sample(self.stream, i);
                match firmware_core::features::compute(&[feature], &s, &mut state, &mut out) {
                    Status::Fault => f64::NAN,
                    _ => f64::from(out[0]),
                }
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
    /// not apply (no temperature input for a lag). Where the static GP was fitted on these blocks,
    /// the part of x it could have absorbed is taken out: x − S·x, S the GP's smoother.
    pub fn regressor(&self, cause: Cause, p: f32) -> Option<Vec<f64>> {
        let x = self.raw_regressor(cause, p)?;
        match &self.absorbed_by {
            Some((gp, inputs)) if cause != Cause::SensorLag => {
                let smoothed = gp
                    .refit_targets(inputs, &DVector::from_column_slice(&x))
                    .ok()?;
                Some(
                    x.iter()
                        .enumerate()
                        .map(|(i, v)| {
                            let row: Vec<f64> = inputs.row(i).iter().copied().collect();
                            v - smoothed.predict(&row).mean
                        })
                        .collect(),
                )
            }
            _ => Some(x),
        }
    }

    /// The regressor x of `cause` at parameter `p` as the firmware computes it, as block means.
    pub fn raw_regressor(&self, cause: Cause, p: f32) -> Option<Vec<f64>> {
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
                    state.iter_mut().for_each(FeatureState::power_on);
                }
                let s = replay::sample(self.stream, i);
                let health = [
                    firmware_core::features::compute(features, &s, &mut state[0], &mut x0),
                    firmware_core::features::compute(&lagged, &s, &mut state[1], &mut x1),
                ];
                if health.contains(&Status::Fault) {
                    return f64::NAN;
                }
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

/// A soaked table's plateaus as the blocks see them: the plateau temperatures and each block's
/// piecewise-linear interpolation weights between them.
pub struct Plateaus {
    knots: Vec<f64>,
    weights: Vec<[(usize, f64); 2]>,
}

/// The constant part of a regression on the residual. An intercept; or, for a design with a
/// heating/cooling state over a soaked table, a piecewise-linear function of temperature over
/// the table's plateaus: the table was soaked in one state per temperature, whichever way the
/// chamber reached it, and the static GP absorbed that state's offset there, so the stream's
/// residual carries minus that offset wherever its state differs
/// ([`crate::analysis::extend::fit`] takes it out of the points the same way). Neighbouring
/// plateau constants are tied by a weak penalty, so a plateau the blocks do not visit takes its
/// neighbours' value.
#[derive(Clone, Copy)]
pub enum Constant<'a> {
    /// One intercept.
    Intercept,
    /// One constant per plateau.
    Plateaus(&'a Plateaus),
}

impl<'a> Constant<'a> {
    /// The constant of a design, with or without a heating/cooling state, over `plateaus` (a
    /// soaked table's, if any).
    fn of(plateaus: Option<&'a Plateaus>, with_state: bool) -> Self {
        match plateaus {
            Some(p) if with_state => Self::Plateaus(p),
            _ => Self::Intercept,
        }
    }

    /// Columns the constant takes.
    pub(crate) fn columns(self) -> usize {
        match self {
            Self::Intercept => 1,
            Self::Plateaus(p) => p.knots.len(),
        }
    }

    /// The constant's value at block `i` under coefficients `beta`.
    fn at(self, beta: &[f64], i: usize) -> f64 {
        match self {
            Self::Intercept => beta[0],
            Self::Plateaus(p) => p.weights[i].iter().map(|&(j, w)| w * beta[j]).sum(),
        }
    }
}

/// Weight of a difference between neighbouring plateau constants against one 60 s block's
/// residual: weak, so that it only decides constants the blocks do not visit.
const PENALTY_WEIGHT: f64 = 1.0;

/// Least squares of y on [constant, x₁ … x_k] over the blocks `idx`: the coefficients (the
/// constant's first) and the SSE over those blocks. SVD, so a regressor that is constant or
/// repeats another costs nothing.
pub(crate) fn ols(
    constant: Constant<'_>,
    xs: &[&[f64]],
    y: &[f64],
    idx: &[usize],
) -> (Vec<f64>, f64) {
    let c = constant.columns();
    let k = c + xs.len();
    let m = idx.len();
    let penalties = c - 1;
    let mut a = DMatrix::zeros(m + penalties, k);
    let mut b = DVector::zeros(m + penalties);
    for (r, &i) in idx.iter().enumerate() {
        match constant {
            Constant::Intercept => a[(r, 0)] = 1.0,
            Constant::Plateaus(p) => {
                for &(j, w) in &p.weights[i] {
                    a[(r, j)] += w;
                }
            }
        }
        for (j, x) in xs.iter().enumerate() {
            a[(r, c + j)] = x[i];
        }
        b[r] = y[i];
    }
    for j in 0..penalties {
        a[(m + j, j)] = PENALTY_WEIGHT;
        a[(m + j, j + 1)] = -PENALTY_WEIGHT;
    }
    let beta = a
        .clone()
        .svd(true, true)
        .solve(&b, 1e-12)
        .unwrap_or_else(|_| DVector::zeros(k));
    let sse = (&b - &a * &beta).rows(0, m).norm_squared();
    (beta.iter().copied().collect(), sse)
}

/// Prediction of [`ols`] coefficients at block `i`.
fn predict(constant: Constant<'_>, beta: &[f64], xs: &[&[f64]], i: usize) -> f64 {
    constant.at(beta, i)
        + xs.iter()
            .zip(&beta[constant.columns()..])
            .map(|(x, b)| b * x[i])
            .sum::<f64>()
}

/// Mean temperature of each of the points' plateaus, ascending.
fn plateau_temperatures(temps: &[f64]) -> Vec<f64> {
    let id = plateaus(temps);
    let count = id.iter().max().map_or(0, |m| m + 1);
    let mut sum = vec![(0.0, 0usize); count];
    for (&p, &t) in id.iter().zip(temps) {
        sum[p].0 += t;
        sum[p].1 += 1;
    }
    sum.into_iter().map(|(s, n)| s / n as f64).collect()
}

/// Piecewise-linear interpolation weights of `t` on ascending `knots` (held constant beyond the
/// ends): two (index, weight) pairs summing to one.
pub(crate) fn hat_weights(knots: &[f64], t: f64) -> [(usize, f64); 2] {
    let last = knots.len() - 1;
    let j = knots.partition_point(|&k| k <= t);
    if j == 0 {
        [(0, 1.0), (0, 0.0)]
    } else if j > last {
        [(last, 1.0), (last, 0.0)]
    } else {
        let w = (t - knots[j - 1]) / (knots[j] - knots[j - 1]);
        [(j - 1, 1.0 - w), (j, w)]
    }
}

/// A training/test split of the blocks.
type Split = (Vec<usize>, Vec<usize>);

/// The interleaved splits: 10-minute chunks, chunk k in fold k mod 5 (module doc).
fn interleaved_splits(n: usize) -> Vec<Split> {
    let folds: Vec<usize> = (0..n).map(|b| (b / CHUNK_BLOCKS) % FOLDS).collect();
    (0..FOLDS)
        .map(|f| {
            (
                (0..n).filter(|&i| folds[i] != f).collect(),
                (0..n).filter(|&i| folds[i] == f).collect(),
            )
        })
        .collect()
}

/// The forward splits (rolling origin): the blocks before each origin in [`FORWARD_ORIGINS`]
/// train, the blocks up to the next origin (or the end) test.
fn forward_splits(n: usize) -> Vec<Split> {
    let cut = |f: f64| ((f * n as f64).round() as usize).min(n);
    FORWARD_ORIGINS
        .iter()
        .enumerate()
        .map(|(k, &o)| {
            let end = FORWARD_ORIGINS.get(k + 1).map_or(n, |&e| cut(e));
            ((0..cut(o)).collect(), (cut(o)..end).collect())
        })
        .collect()
}

/// Test-set SSE of a design (the causes' candidate regressors, in order) and of the intercept
/// alone, summed over `splits`. On each split's training blocks alone, each cause's parameter is
/// chosen by grid in turn, given those chosen before it, and the coefficients by least squares.
/// `centred` takes each model's mean test residual out per split: what a test that cannot see a
/// design judges harm on (module doc).
fn split_sse(
    y: &[f64],
    constant: Constant<'_>,
    design: &[&Candidates],
    splits: &[Split],
    centred: bool,
) -> (f64, f64) {
    let sum_sq = |r: &[f64]| {
        let m = if centred {
            r.iter().sum::<f64>() / r.len().max(1) as f64
        } else {
            0.0
        };
        r.iter().map(|v| (v - m).powi(2)).sum::<f64>()
    };
    let mut sse = 0.0;
    let mut sse_none = 0.0;
    for (train, test) in splits {
        if train.len() < MIN_TRAIN_BLOCKS || test.is_empty() {
            continue;
        }
        let xs = choose(y, constant, design, train);
        let (beta, _) = ols(constant, &xs, y, train);
        let (mean, _) = ols(Constant::Intercept, &[], y, train);
        let r: Vec<f64> = test
            .iter()
            .map(|&i| y[i] - predict(constant, &beta, &xs, i))
            .collect();
        let r0: Vec<f64> = test.iter().map(|&i| y[i] - mean[0]).collect();
        sse += sum_sq(&r);
        sse_none += sum_sq(&r0);
    }
    (sse, sse_none)
}

/// Each cause's regressor at the parameter that best fits `idx`, chosen in design order, each
/// given those before it; a cause without a regressor (`none`) adds nothing.
fn choose<'c>(
    y: &[f64],
    constant: Constant<'_>,
    design: &[&'c Candidates],
    idx: &[usize],
) -> Vec<&'c [f64]> {
    let mut xs: Vec<&[f64]> = Vec::new();
    for candidates in design {
        let best = candidates
            .iter()
            .filter_map(|(_, x)| x.as_deref())
            .map(|x| {
                let mut with = xs.clone();
                with.push(x);
                (x, ols(constant, &with, y, idx).1)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((x, _)) = best {
            xs.push(x);
        }
    }
    xs
}

/// The parameter of the last cause of `design` chosen on every block, given the others.
fn chosen_parameter(y: &[f64], constant: Constant<'_>, design: &[&Candidates]) -> f32 {
    let all: Vec<usize> = (0..y.len()).collect();
    let xs = choose(y, constant, design, &all);
    let (Some(last), Some(x)) = (design.last(), xs.last()) else {
        return 0.0;
    };
    last.iter()
        .find(|(_, c)| c.as_deref().is_some_and(|c| std::ptr::eq(c, *x)))
        .map_or(0.0, |(p, _)| *p)
}

/// Whether `values` moves in `scored` (indices) by at least [`VISIBLE`] of its spread over all
/// of them: whether a test scoring `scored` can see what `values` carries.
pub fn sees(values: &[f64], scored: &[usize]) -> bool {
    let sd = |v: &mut dyn Iterator<Item = f64>| {
        let v: Vec<f64> = v.collect();
        let n = v.len().max(1) as f64;
        let m = v.iter().sum::<f64>() / n;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt()
    };
    let all = sd(&mut values.iter().copied());
    let part = sd(&mut scored.iter().filter_map(|&i| values.get(i).copied()));
    all > 0.0 && part >= VISIBLE * all
}

/// Whether a share of the SSE (1 − SSE/SSE_ref) is a worsening of the RMS error beyond [`HARM`].
fn harms(share: f64) -> bool {
    (1.0 - share).sqrt() - 1.0 > HARM
}

/// Whether a design the forward test cannot see still harms there: fitted on the earlier blocks,
/// worse on the later ones than the intercept alone by more than [`HARM`], each with its mean
/// over the later blocks taken out (the design's intercept, fitted beside a transient on the
/// earlier blocks alone, is not the one fitted on the whole stream; module doc).
fn blind_harm(y: &[f64], constant: Constant<'_>, design: &[&Candidates]) -> bool {
    let (sse, none) = split_sse(y, constant, design, &forward_splits(y.len()), true);
    harms(share(sse, none))
}

/// Whether the forward test sees `design`: some cause's regressor, at its parameter chosen on all
/// blocks, moves in the blocks the test predicts (module doc).
fn forward_sees(y: &[f64], constant: Constant<'_>, design: &[&Candidates]) -> bool {
    let n = y.len();
    let all: Vec<usize> = (0..n).collect();
    let tested: Vec<usize> = forward_splits(n)
        .into_iter()
        .flat_map(|(_, test)| test)
        .collect();
    choose(y, constant, design, &all)
        .iter()
        .any(|x| sees(x, &tested))
}

/// 1 − SSE/SSE_reference, 0 where the reference is 0.
fn share(sse: f64, reference: f64) -> f64 {
    if reference > 0.0 {
        1.0 - sse / reference
    } else {
        0.0
    }
}

/// One cause fitted to a residual.
#[derive(Debug, Clone, Serialize)]
pub struct CauseFit {
    /// The cause.
    pub id: Cause,
    /// Out-of-sample fraction of the residual variance it predicts on interleaved chunks (module
    /// doc).
    pub score: f64,
    /// The same on the forward test: fitted on earlier blocks, predicting later ones.
    pub forward_score: f64,
    /// Whether its regressor moves in the blocks the forward test predicts; where it does not,
    /// the forward test abstains (module doc).
    pub forward_sees: bool,
    /// Its parameter fitted on all blocks: filter or lag or decay time constant (s), play
    /// half-width (°C); 0 where there is none.
    pub parameter: f64,
    /// Intercept a, °/s (the plateau constants' mean over the blocks, where they replace it:
    /// [`Constant`]).
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
            (c, beta[cols].abs() * (sxx / n as f64).sqrt() * HOUR_S)
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

/// One step of the selection: the best design of one more cause than the step before.
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    /// Its causes, strongest first.
    pub causes: Vec<Cause>,
    /// Their parameters, chosen on all blocks (filter, lag or decay time constant, s; play
    /// half-width, °C; 0 where there is none).
    pub parameters: Vec<f64>,
    /// Share of what the design before it left that it predicts on interleaved chunks.
    pub score: f64,
    /// The same on the forward test.
    pub forward_score: f64,
    /// Whether the forward test could see the design (module doc): where it could not, it
    /// abstained, and only harm beyond [`HARM`] counted.
    pub forward_sees: bool,
    /// With a heating/cooling state over a soaked table: the share of what the design's other
    /// causes and the table's plateau constants alone leave that the state predicts, on
    /// interleaved chunks and forward ([`Constant`]; it must pass the same bar itself).
    pub state_share: Option<[f64; 2]>,
    /// The heating/cooling state this design takes the place of: a larger design showed it
    /// redundant beside this design's causes (module doc).
    pub replaces: Option<Cause>,
    /// Whether it was taken.
    pub added: bool,
}

/// One design tried by [`select`].
#[derive(Clone)]
struct Try {
    /// Its causes, as indices.
    idx: Vec<usize>,
    /// Test-set SSE, interleaved and forward.
    sse: [f64; 2],
    /// Share of what the design before it left, interleaved and forward.
    share: [f64; 2],
    /// [`Step::state_share`].
    state_share: Option<[f64; 2]>,
    /// [`Step::forward_sees`].
    sees: bool,
    /// Where the forward test cannot see it: whether it harms there all the same
    /// ([`blind_harm`]).
    blind_harm: bool,
}

impl Try {
    /// What it predicts on the tests that could see it, on the scale of both tests together.
    fn rank(&self) -> f64 {
        if self.sees {
            self.share[0] + self.share[1]
        } else {
            2.0 * self.share[0]
        }
    }
}

/// The diagnosis of one stream (docs/design.md §6 `diagnose` JSON).
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// The first named cause (`none` when nothing is named).
    pub cause: Cause,
    /// Every named cause, strongest first: the first predicts at least [`MIN_SCORE`] of the
    /// residual, each further one at least [`MIN_NEXT_SCORE`] of what those before it left, on
    /// interleaved chunks and forward in time.
    pub causes: Vec<Cause>,
    /// Every candidate alone, best first.
    pub candidates: Vec<CauseFit>,
    /// The best try of each selection step (added or the reason to stop).
    pub steps: Vec<Step>,
    /// RMS of the residual's 60 s block means, °/s.
    pub residual_rmse_60s_dps: f64,
    /// 60 s blocks used.
    pub n_blocks: usize,
    /// The runner-up (best candidate other than the named cause).
    pub runner_up: Option<Cause>,
    /// What the model gets wrong and why, in words.
    pub explanation: String,
    /// The input the first cause calls for, with its fitted parameter.
    pub add_feature: Option<Feature>,
    /// The inputs every named cause calls for, in order.
    pub add_features: Vec<Feature>,
}

/// Diagnoses `stream` against `model`.
pub fn diagnose(model: &HostModel, stream: &Stream) -> Diagnosis {
    let res = Residual::new(model, stream);
    diagnose_residual(&res)
}

/// Diagnoses `stream` against `model`, the firmware form of the static GP `gp` fitted on
/// `points` ([`Residual::fitted_on`]).
pub fn diagnose_fitted(
    model: &HostModel,
    gp: &GpModel,
    points: &Points,
    stream: &Stream,
) -> Diagnosis {
    let res = Residual::new(model, stream).fitted_on(gp, points);
    diagnose_residual(&res)
}

/// Diagnoses a residual already computed.
pub fn diagnose_residual(res: &Residual<'_>) -> Diagnosis {
    let regressors: Vec<(Cause, Candidates)> = Cause::ALL
        .into_iter()
        .map(|c| (c, candidates(res, c)))
        .collect();
    let mut candidates: Vec<CauseFit> = regressors
        .iter()
        .filter_map(|(c, x)| fit_candidates(res, *c, x))
        .collect();
    candidates.sort_by(|a, b| b.score.total_cmp(&a.score));
    let (selected, steps) = select(&res.r, &regressors, res.plateaus.as_ref());
    let causes: Vec<Cause> = selected.iter().map(|(c, _)| *c).collect();
    let cause = causes.first().copied().unwrap_or(Cause::None);
    let runner_up = candidates.iter().map(|c| c.id).find(|id| *id != cause);
    let named = candidates.iter().find(|c| c.id == cause);
    let other = candidates.iter().find(|c| Some(c.id) == runner_up);
    let explanation = explain(cause, named, other, &steps, res.rmse_60s());
    let add_features: Vec<Feature> = selected
        .iter()
        .filter_map(|(c, p)| feature_for(*c, *p))
        .collect();
    Diagnosis {
        cause,
        causes,
        add_feature: add_features.first().copied(),
        add_features,
        candidates,
        steps,
        residual_rmse_60s_dps: res.rmse_60s(),
        n_blocks: res.len(),
        runner_up,
        explanation,
    }
}

/// Best-subset selection (module doc): for one, two, then three causes, the design that predicts
/// the most of what the design taken before it left on both tests together, among those that
/// predict at least [`MIN_SCORE`] (first step) or [`MIN_NEXT_SCORE`] (later steps) of it there and
/// forward in time; the first step that finds none ends the selection. Returns the named causes,
/// strongest first, with their parameters, and the best design of each step.
fn select(
    y: &[f64],
    regressors: &[(Cause, Candidates)],
    plateaus: Option<&Plateaus>,
) -> (Vec<(Cause, f32)>, Vec<Step>) {
    let n = y.len();
    let mut steps = Vec::new();
    if n < 2 * FOLDS {
        return (Vec::new(), steps);
    }
    let real: Vec<(Cause, &Candidates)> = regressors
        .iter()
        .filter(|(c, x)| *c != Cause::None && !x.is_empty())
        .map(|(c, x)| (*c, x))
        .collect();
    let splits = [interleaved_splits(n), forward_splits(n)];
    let state = |i: usize| real[i].0 == Cause::Hysteresis;
    let constant = |idx: &[usize]| Constant::of(plateaus, idx.iter().any(|&i| state(i)));
    let sse_with = |idx: &[usize], constant: Constant<'_>| {
        let design: Vec<&Candidates> = idx.iter().map(|&i| real[i].1).collect();
        [0, 1].map(|k| split_sse(y, constant, &design, &splits[k], false).0)
    };
    let sse = |idx: &[usize]| sse_with(idx, constant(idx));
    let without_state =
        |idx: &[usize]| -> Vec<usize> { idx.iter().copied().filter(|&i| !state(i)).collect() };
    let sees = |idx: &[usize]| {
        let design: Vec<&Candidates> = idx.iter().map(|&i| real[i].1).collect();
        forward_sees(y, constant(idx), &design)
    };
    let step = |idx: &[usize], share: [f64; 2], state_share, replaces, added| {
        let design: Vec<&Candidates> = idx.iter().map(|&i| real[i].1).collect();
        Step {
            causes: idx.iter().map(|&i| real[i].0).collect(),
            parameters: parameters(y, constant(idx), &design)
                .into_iter()
                .map(f64::from)
                .collect(),
            score: share[0],
            forward_score: share[1],
            forward_sees: sees(idx),
            state_share,
            replaces,
            added,
        }
    };
    // The plateau constants come with a heating/cooling state; they can also follow a static
    // curve that is off at the table's temperatures, so the state must predict by itself.
    let state_share = |idx: &[usize], s: &[f64; 2]| {
        let p = plateaus.filter(|_| idx.iter().any(|&i| state(i)))?;
        let without = sse_with(&without_state(idx), Constant::Plateaus(p));
        Some([0, 1].map(|k| share(s[k], without[k])))
    };
    let least = |size: usize| if size == 1 { MIN_SCORE } else { MIN_NEXT_SCORE };
    let mut taken: Vec<usize> = Vec::new();
    let mut current = sse(&[]);
    let mut before_taken = current;
    for size in 1..=MAX_CAUSES.min(real.len()) {
        // The forward test counts where it sees the design; where it does not, only its harm.
        let bar = |g: &[f64; 2]| g[0] >= least(size) && g[1] >= least(size);
        let bar_seen = |t: &Try| {
            if t.sees {
                bar(&t.share)
            } else {
                t.share[0] >= least(size) && !t.blind_harm
            }
        };
        let passes = |t: &Try| bar_seen(t) && t.state_share.as_ref().is_none_or(bar);
        let tries: Vec<Try> = (0..real.len())
            .combinations(size)
            .map(|idx| {
                let s = sse(&idx);
                let seen = sees(&idx);
                let design: Vec<&Candidates> = idx.iter().map(|&i| real[i].1).collect();
                Try {
                    share: [0, 1].map(|k| share(s[k], current[k])),
                    state_share: state_share(&idx, &s),
                    sees: seen,
                    blind_harm: !seen && blind_harm(y, constant(&idx), &design),
                    idx,
                    sse: s,
                }
            })
            .collect();
        let by_score = |a: &&Try, b: &&Try| a.rank().total_cmp(&b.rank());
        let Some(best) = tries
            .iter()
            .filter(|t| passes(t))
            .max_by(by_score)
            .or_else(|| tries.iter().max_by(by_score))
            .cloned()
        else {
            break;
        };
        let added = passes(&best);
        let idx = strongest_first(best.idx.clone(), best.sse[0], &sse);
        steps.push(step(&idx, best.share, best.state_share, None, added));
        if !added {
            // It predicts more, but its state is redundant beside its other causes: those take
            // the place of the design taken, if they passed that design's own bar.
            let rest = without_state(&idx);
            let swapped = bar_seen(&best)
                && rest.len() == taken.len()
                && taken.iter().any(|&i| state(i))
                && best.state_share.is_some_and(|g| !bar(&g));
            let g = swapped.then(|| {
                let s = sse(&rest);
                [0, 1].map(|k| share(s[k], before_taken[k]))
            });
            if let Some(g) = g.filter(|g| g[0] >= least(size - 1) && g[1] >= least(size - 1)) {
                steps.push(step(&rest, g, None, Some(Cause::Hysteresis), true));
                taken = rest;
            }
            break;
        }
        taken = idx;
        before_taken = current;
        current = best.sse;
    }
    let design: Vec<&Candidates> = taken.iter().map(|&i| real[i].1).collect();
    let named = taken
        .iter()
        .map(|&i| real[i].0)
        .zip(parameters(y, constant(&taken), &design))
        .collect();
    (named, steps)
}

/// The causes of a design ordered by what leaving each out costs on interleaved chunks, most
/// first; `sse` scores a design, `full` is the whole design's score.
fn strongest_first(
    mut idx: Vec<usize>,
    full: f64,
    sse: &dyn Fn(&[usize]) -> [f64; 2],
) -> Vec<usize> {
    if idx.len() < 2 {
        return idx;
    }
    let cost: Vec<(usize, f64)> = idx
        .iter()
        .map(|&i| {
            let rest: Vec<usize> = idx.iter().copied().filter(|&j| j != i).collect();
            (i, sse(&rest)[0] - full)
        })
        .collect();
    idx.sort_by(|a, b| {
        let c = |i: &usize| cost.iter().find(|(j, _)| j == i).map_or(0.0, |(_, c)| *c);
        c(b).total_cmp(&c(a))
    });
    idx
}

/// Each cause's parameter of `design` chosen on all blocks of `y`, in design order, each given
/// those before it.
fn parameters(y: &[f64], constant: Constant<'_>, design: &[&Candidates]) -> Vec<f32> {
    (1..=design.len())
        .map(|k| chosen_parameter(y, constant, &design[..k]))
        .collect()
}

fn explain(
    cause: Cause,
    named: Option<&CauseFit>,
    other: Option<&CauseFit>,
    steps: &[Step],
    rmse: f64,
) -> String {
    let rival = other.map_or(String::new(), |o| {
        format!(
            "; runner-up {} predicts {:.0}%",
            o.id,
            100.0 * o.score.max(0.0)
        )
    });
    let more: String = steps
        .windows(2)
        .map(|w| {
            let (before, s) = (&w[0], &w[1]);
            if let Some(state) = s.replaces {
                format!(
                    "; so {} takes the place of the design with {state} (it predicted {:.0}% of \
                     what the design before left, {:.0}% forward)",
                    joined(&s.causes),
                    100.0 * s.score,
                    100.0 * s.forward_score
                )
            } else if s.added {
                format!(
                    "; with more, {} predicts {:.0}% of what {} left ({:.0}% forward)",
                    joined(&s.causes),
                    100.0 * s.score,
                    joined(&before.causes),
                    100.0 * s.forward_score
                )
            } else {
                format!("; nothing more: {}", refusal(s))
            }
        })
        .collect();
    let Some(c) = named.filter(|_| cause != Cause::None) else {
        let why = steps
            .first()
            .map_or(String::new(), |s| format!(" ({})", refusal(s)));
        return format!(
            "residual {:.2} °/h RMS (60 s means) is noise: no candidate predicts {:.0}% of it out \
             of sample, on interleaved chunks and forward in time{why}{rival}; the static model \
             needs nothing more",
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
    let forward = if c.forward_sees {
        format!("{:.0}% forward in time", 100.0 * c.forward_score)
    } else {
        "forward in time it cannot be seen: its input barely moves in the later half, so that \
         test abstains"
            .to_owned()
    };
    format!(
        "{what}. It predicts {share:.0}% of the residual variance out of sample \
         ({forward}){rival}{more}"
    )
}

/// Cause ids joined by " + ".
pub fn joined(causes: &[Cause]) -> String {
    causes
        .iter()
        .map(|c| c.id())
        .collect::<Vec<_>>()
        .join(" + ")
}

/// Why a step's design was not taken, in words.
fn refusal(s: &Step) -> String {
    let forward = if !s.forward_sees {
        "could not be seen forward in time (its input barely moves in the later blocks)".to_owned()
    } else if s.forward_score < 0.0 {
        format!(
            "made the later blocks worse by {:.0}%",
            100.0 * ((1.0 - s.forward_score).sqrt() - 1.0)
        )
    } else {
        format!(
            "predicted {:.0}% of the later blocks",
            100.0 * s.forward_score
        )
    };
    let state = s.state_share.map_or(String::new(), |g| {
        format!(
            "; the heating/cooling state itself, over a constant per plateau of the table, \
             predicted {:.0}% ({:.0}% forward)",
            100.0 * g[0],
            100.0 * g[1]
        )
    });
    format!(
        "{} predicted {:.0}% on interleaved chunks and, fitted on earlier blocks, \
         {forward}{state}",
        joined(&s.causes),
        100.0 * s.score
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` values of a seeded uniform noise in [−1, 1).
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| rng.random::<f64>() * 2.0 - 1.0).collect()
    }

    #[test]
    fn best_subset_names_a_pair_that_a_third_cause_imitates() {
        // Two slow, unlike signals (a decaying one and a switching one); the decoy follows their
        // sum closely but not exactly, and predicts more of it alone than either does.
        let n = 400;
        let a: Vec<f64> = (0..n).map(|i| (-((i % 100) as f64) / 15.0).exp()).collect();
        let b: Vec<f64> = (0..n)
            .map(|i| if (i / 37) % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let (e1, e2) = (noise(n, 1), noise(n, 2));
        let decoy: Vec<f64> = (0..n)
            .map(|i| 0.8 * (a[i] + 0.5 * b[i]) + 0.25 * e1[i])
            .collect();
        let y: Vec<f64> = (0..n).map(|i| a[i] + 0.5 * b[i] + 0.05 * e2[i]).collect();
        let one = |x: &[f64]| -> Candidates { vec![(1.0, Some(x.to_vec()))] };
        let regressors = vec![
            (Cause::WarmUp, one(&a)),
            (Cause::Hysteresis, one(&b)),
            (Cause::ThermalRate, one(&decoy)),
            (Cause::TimeDrift, one(&noise(n, 3))),
        ];
        let single = |x: &[f64]| {
            let (sse, none) = split_sse(
                &y,
                Constant::Intercept,
                &[&one(x)],
                &interleaved_splits(n),
                false,
            );
            share(sse, none)
        };
        assert!(single(&decoy) > single(&a) && single(&decoy) > single(&b));
        let (named, steps) = select(&y, &regressors, None);
        let mut causes: Vec<Cause> = named.iter().map(|(c, _)| *c).collect();
        causes.sort();
        assert_eq!(causes, vec![Cause::WarmUp, Cause::Hysteresis], "{steps:?}");
        // Noise alone names nothing, and says what the best candidate did.
        let (named, steps) = select(&noise(n, 4), &regressors, None);
        assert!(named.is_empty());
        assert!(!steps[0].added && steps[0].score < MIN_SCORE, "{steps:?}");
    }

    #[test]
    fn a_state_is_named_only_for_what_the_plateau_constants_cannot_follow() {
        // A stream sweeping a soaked table's span up and down; the residual is a static curve
        // that is off at the table's plateaus, which a constant per plateau follows exactly.
        let n = 400;
        let temp: Vec<f64> = (0..n)
            .map(|i| {
                let u = (i % 100) as f64 / 50.0;
                -30.0 + 90.0 * if u < 1.0 { u } else { 2.0 - u }
            })
            .collect();
        let heating: Vec<f64> = (0..n)
            .map(|i| if i % 100 < 50 { 1.0 } else { -1.0 })
            .collect();
        let knots = vec![-30.0, -10.0, 10.0, 30.0, 60.0];
        let plateaus = Plateaus {
            weights: temp.iter().map(|&t| hat_weights(&knots, t)).collect(),
            knots,
        };
        let off = [1.0, -1.0, 0.5, -0.5, 1.0];
        let curve: Vec<f64> = (0..n)
            .map(|i| plateaus.weights[i].iter().map(|&(j, w)| w * off[j]).sum())
            .collect();
        let e = noise(n, 5);
        let one = |x: &[f64]| -> Candidates { vec![(1.0, Some(x.to_vec()))] };
        let regressors = vec![
            (Cause::Hysteresis, one(&heating)),
            (Cause::TimeDrift, one(&noise(n, 6))),
        ];
        let y: Vec<f64> = (0..n).map(|i| curve[i] + 0.05 * e[i]).collect();
        let (named, steps) = select(&y, &regressors, Some(&plateaus));
        assert!(named.is_empty(), "{steps:?}");
        let state = steps[0].state_share.unwrap();
        assert!(
            steps[0].score >= MIN_SCORE && state[0] < MIN_SCORE,
            "{steps:?}"
        );
        // A heating/cooling offset beside it is named.
        let y: Vec<f64> = (0..n)
            .map(|i| curve[i] + 0.3 * heating[i] + 0.05 * e[i])
            .collect();
        let (named, steps) = select(&y, &regressors, Some(&plateaus));
        assert_eq!(named.len(), 1, "{steps:?}");
        assert_eq!(named[0].0, Cause::Hysteresis);
        assert!(steps[0].state_share.unwrap()[1] >= MIN_SCORE, "{steps:?}");
    }

    #[test]
    fn hat_weights_interpolate_and_hold_at_the_ends() {
        let knots = [-30.0, -20.0, 0.0];
        let w = |t| hat_weights(&knots, t);
        assert_eq!(w(-40.0)[0], (0, 1.0));
        assert_eq!(w(5.0)[0], (2, 1.0));
        assert_eq!(w(-25.0), [(0, 0.5), (1, 0.5)]);
        assert_eq!(w(-5.0), [(1, 0.25), (2, 0.75)]);
        assert_eq!(w(0.0)[0], (2, 1.0));
    }

    #[test]
    fn plateau_temperatures_are_means_ascending() {
        let t = plateau_temperatures(&[20.1, -9.9, 19.9, -10.1, 40.0]);
        assert_eq!(t.len(), 3);
        assert!((t[0] + 10.0).abs() < 1e-12 && (t[1] - 20.0).abs() < 1e-12 && t[2] == 40.0);
    }

    #[test]
    fn a_regressor_flat_where_a_test_scores_is_not_seen_there() {
        // A warm-up exp(−t/τ) over 300 blocks, τ 15: gone before the later half.
        let decay: Vec<f64> = (0..300).map(|b| (-f64::from(b) / 15.0).exp()).collect();
        let later: Vec<usize> = (150..300).collect();
        assert!(!sees(&decay, &later));
        let early: Vec<usize> = (0..150).collect();
        assert!(sees(&decay, &early));
        // A drift growing with time is seen in its later half.
        let drift: Vec<f64> = (0..300).map(f64::from).collect();
        assert!(sees(&drift, &later));
    }

    #[test]
    fn forward_splits_train_on_the_past_only() {
        for (train, test) in forward_splits(80) {
            let last = *train.last().unwrap();
            assert!(test.iter().all(|&i| i > last));
            assert_eq!(train, (0..=last).collect::<Vec<_>>());
        }
        let tested: usize = forward_splits(80).iter().map(|(_, t)| t.len()).sum();
        assert_eq!(tested, 40);
    }
}
