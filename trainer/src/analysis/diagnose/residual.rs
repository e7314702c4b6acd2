//! The residual a diagnosis studies: a stream replayed through a static model, in 60 s blocks,
//! and each candidate cause's input along it as the firmware would compute it.

use firmware_core::model::Conditions;
use firmware_core::{Feature, FeatureState, Mean, Prepared, Status};
use fog_data::blocks;
use fog_data::cause::Cause;
use fog_data::replay;
use fog_data::replay::HostModel;
use fog_data::stats::{rms, spread};
use fog_data::stream::Stream;
use nalgebra::{DMatrix, DVector};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use super::regression::{Constant, Plateaus, hat_weights, plateau_temperatures};
use crate::data::points::Points;
use crate::models::gp::GpModel;

/// A stream replayed through a static model, reduced to 60 s blocks.
pub struct Residual<'a> {
    pub(super) model: &'a HostModel,
    pub(super) stream: &'a Stream,
    /// Sample indices of each block.
    pub(super) blocks: Vec<Vec<usize>>,
    /// Block means of the residual, °/s.
    pub r: Vec<f64>,
    /// Where the gyro was powered on (the feature state goes through a power-on).
    pub(super) restarts: Vec<bool>,
    /// The static GP and its inputs, where it was fitted on these very blocks (module doc).
    pub(super) absorbed_by: Option<(&'a GpModel, &'a DMatrix<f64>)>,
    /// The soaked table's plateaus, where the static GP was fitted on one (module doc).
    pub(super) plateaus: Option<Plateaus>,
    /// The static model's mean at each sample a block holds (NaN elsewhere and at a fault),
    /// computed once: a lag's regressor is the model at lagged inputs minus it, for every lag a
    /// search tries.
    base_mean: OnceLock<Vec<f32>>,
    /// Each lag's regressor (block means), by the lag's bits, once computed: a diagnosis, the fit
    /// of its candidates and the lag search ask for the same lags about four times over, and each
    /// costs the model's mean at every sample a block holds.
    lag_regressors: Mutex<HashMap<u32, Vec<f64>>>,
}

impl<'a> Residual<'a> {
    /// The RMS of its 60 s means about their mean: what the harm a test that cannot see a design
    /// counts is weighed against ([`super::raises`]).
    pub fn spread_60s(&self) -> f64 {
        spread(&self.r)
    }

    /// Replays `stream` through `model` and keeps the blocks of scored, non-fault samples.
    pub fn new(model: &'a HostModel, stream: &'a Stream) -> Self {
        let m = replay::means(model, stream);
        Self::from_replay(model, stream, (&m.rate_dps, &m.status))
    }

    /// As [`Self::new`] with the replay already done: its compensated rates and statuses.
    pub fn from_replay(
        model: &'a HostModel,
        stream: &'a Stream,
        (rate_dps, status): (&[f32], &[Status]),
    ) -> Self {
        let blocks = stream.half_filled_blocks(&replay::scored_samples(stream, status));
        let r = replay::block_errors(stream, rate_dps, &blocks);
        Self {
            model,
            stream,
            blocks,
            r,
            restarts: replay::restarts(stream),
            absorbed_by: None,
            plateaus: None,
            base_mean: OnceLock::new(),
            lag_regressors: Mutex::default(),
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
        blocks::means(x, &self.blocks)
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

    /// The static model's mean with inputs `features` at each sample a block holds, as the
    /// firmware computes it; NaN elsewhere and where the firmware refuses the inputs.
    fn mean_along(&self, features: &[Feature]) -> Vec<f32> {
        let mut wanted = vec![false; self.stream.len()];
        self.blocks.iter().flatten().for_each(|&i| wanted[i] = true);
        let mut state = FeatureState::default();
        let mut x = vec![0.0f32; features.len()];
        // The inputs along the stream first (the feature state runs through every sample), then
        // the model's mean at all of them, side by side (`Model::means`).
        let (mut at, mut inputs) = (Vec::new(), Vec::new());
        for (i, &wanted) in wanted.iter().enumerate() {
            if self.restarts[i] {
                state.power_on();
            }
            let s = replay::sample(self.stream, i);
            let health = firmware_core::features::compute(features, &s, &mut state, &mut x);
            if health != Status::Fault && wanted {
                at.push(i);
                inputs.push(Prepared::inputs(&x, Conditions::at_hours(0.0)));
            }
        }
        let mut means = vec![(Mean::FAULT, 0.0); inputs.len()];
        self.model.means(&inputs, &mut means);
        let mut out = vec![f32::NAN; self.stream.len()];
        for (&i, (m, _)) in at.iter().zip(&means) {
            out[i] = m.mean;
        }
        out
    }

    /// Range of a feature over the samples the blocks hold (not a window's history before them,
    /// nor minutes left out), widened by 10% of its span each side: the trained range of an
    /// additive input.
    pub fn range(&self, feature: Feature) -> (f64, f64) {
        let x = self.series(feature);
        let fitted = || self.blocks.iter().flatten().map(|&i| x[i]);
        let lo = fitted().fold(f64::INFINITY, f64::min);
        let hi = fitted().fold(f64::NEG_INFINITY, f64::max);
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
                            v - smoothed.predict_mean(&row)
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
        let known = self.lag_regressors.lock().ok();
        if let Some(x) = known.and_then(|m| m.get(&p.to_bits()).cloned()) {
            return Some(x);
        }
        // f(inputs with the coil estimate in place of the sensor) − f(inputs), evaluated only
        // where a block reads it (the features still run through every sample: they carry state).
        let features = self.model.features();
        let k = features.iter().position(|f| *f == Feature::Temperature)?;
        let mut lagged = features.to_vec();
        lagged[k] = feature;
        let base = self.base_mean.get_or_init(|| self.mean_along(features));
        let diff: Vec<f64> = self
            .mean_along(&lagged)
            .iter()
            .zip(base)
            .map(|(b, a)| f64::from(*b) - f64::from(*a))
            .collect();
        let x = self.block_means(&diff);
        if let Ok(mut m) = self.lag_regressors.lock() {
            m.insert(p.to_bits(), x.clone());
        }
        Some(x)
    }
}

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
