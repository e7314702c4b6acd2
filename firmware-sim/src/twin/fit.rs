//! The twin's least-squares fit: the rows a source gives once its effects are replayed over it,
//! the Levenberg–Marquardt problem over the free parameters, and the residuals and fidelity of a
//! fitted twin.

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::storage::Owned;
use nalgebra::{DMatrix, DVector, Dyn};

use crate::gyro::effects::{Effect, EffectPlant, Hidden};
use crate::gyro::plant::GyroParams;
use firmware_core::units::SECONDS_PER_HOUR;
use fog_data::blocks::{self, BLOCK_S};
use fog_data::cause::Cause;
use fog_data::stats::rms;
use fog_data::stream::{GAP_FACTOR, typical_step};

use super::error::IdentifyError;
use super::params::Static;
use super::source::{Measured, Record, SourceKind};

/// The bias effects whose strength enters the output linearly, fitted with the map.
pub(super) const LINEAR: [Cause; 4] = [
    Cause::ThermalRate,
    Cause::WarmUp,
    Cause::Hysteresis,
    Cause::TimeDrift,
];

/// Linear bias terms of a row: the effects of [`LINEAR`], then the run's offset.
pub(super) const TERMS: usize = LINEAR.len() + 1;
/// The term of a stream's bias offset against the rate table's, 1 °/h: the run-to-run bias
/// repeatability of every gyro datasheet, fitted whenever the map comes from a table so that no
/// effect has to absorb it.
pub(super) const OFFSET: usize = LINEAR.len();

/// A record as the fit sees it: the coil temperature and the unit-strength bias of each linear
/// effect, from replaying the effects over the record's source.
#[derive(Debug, Clone, Copy)]
pub(super) struct Row {
    coil_c: f64,
    rate_dps: f64,
    output: f64,
    unit_bias_dps: [f64; TERMS],
}

/// Which parameters a fit frees: static ones by index, and the linear effects present.
#[derive(Debug, Clone)]
pub(super) struct Free {
    pub(super) statics: Vec<Static>,
    pub(super) linear: Vec<usize>,
}

/// The Levenberg–Marquardt problem: scaled offsets from a start, weighted rate-unit residuals.
pub(super) struct Fit<'a> {
    start: GyroParams,
    free: &'a Free,
    rows: &'a [Row],
    x: DVector<f64>,
    /// |S| of the start: residuals in °/s.
    s_ref: f64,
}

impl Fit<'_> {
    fn params(&self, x: &DVector<f64>) -> (GyroParams, [f64; TERMS]) {
        let mut p = self.start.clone();
        for (k, &j) in self.free.statics.iter().enumerate() {
            j.set(&mut p, j.get(&self.start) + x[k] * j.step(self.s_ref));
        }
        let mut strengths = [0.0; TERMS];
        for (k, &l) in self.free.linear.iter().enumerate() {
            strengths[l] = x[self.free.statics.len() + k];
        }
        (p, strengths)
    }

    fn residuals_at(&self, x: &DVector<f64>) -> DVector<f64> {
        let (p, strengths) = self.params(x);
        DVector::from_iterator(
            self.rows.len(),
            self.rows
                .iter()
                .map(|r| (model(&p, &strengths, r) - r.output) / self.s_ref),
        )
    }
}

/// The twin's output for a row.
pub(super) fn model(p: &GyroParams, strengths: &[f64; TERMS], r: &Row) -> f64 {
    let extra: f64 = strengths
        .iter()
        .zip(&r.unit_bias_dps)
        .map(|(s, b)| s * b)
        .sum();
    p.output_voltage(r.coil_c, r.rate_dps + p.bias_dps(r.coil_c) + extra)
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Fit<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        Some(self.residuals_at(&self.x))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        // Central differences: the map is smooth in every parameter but the asymmetry's sign,
        // which does not move with them.
        let mut j = DMatrix::zeros(self.rows.len(), self.x.len());
        for k in 0..self.x.len() {
            let h = 1e-4 * self.x[k].abs().max(1.0);
            let mut up = self.x.clone();
            up[k] += h;
            let mut down = self.x.clone();
            down[k] -= h;
            let d = (self.residuals_at(&up) - self.residuals_at(&down)) / (2.0 * h);
            j.set_column(k, &d);
        }
        Some(j)
    }
}

/// A fitted twin: parameters, linear effect strengths, and the one-sigma errors of the free ones.
#[derive(Debug, Clone)]
pub(super) struct TwinFit {
    pub(super) params: GyroParams,
    pub(super) strengths: [f64; TERMS],
    pub(super) std_errors: Vec<f64>,
}

/// Fits the free parameters from `start` on `rows`.
pub(super) fn fit(start: &GyroParams, free: &Free, rows: &[Row]) -> Result<TwinFit, IdentifyError> {
    let n_params = free.statics.len() + free.linear.len();
    let s_ref = start.scale_factor_v_per_dps.abs();
    let problem = Fit {
        start: start.clone(),
        free,
        rows,
        x: DVector::zeros(n_params),
        s_ref,
    };
    let (problem, _) = LevenbergMarquardt::new()
        .with_patience(200)
        .minimize(problem);
    let (params, strengths) = problem.params(&problem.x);
    if !problem.x.iter().all(|v| v.is_finite()) {
        return Err(IdentifyError::Diverged);
    }
    // Covariance (JᵀJ)⁻¹ σ², σ² the weighted residual variance, inflated by (1 + ρ)/(1 − ρ) for
    // the lag-one correlation ρ of the residuals in time order: a bias instability correlates
    // neighbouring measurements, which then know less than independent ones would.
    let r = problem.residuals_at(&problem.x);
    let dof = rows.len().saturating_sub(n_params).max(1) as f64;
    let rho = (r
        .rows(1, r.len().saturating_sub(1))
        .dot(&r.rows(0, r.len().saturating_sub(1)))
        / r.norm_squared().max(f64::MIN_POSITIVE))
    .clamp(0.0, 0.95);
    let sigma2 = r.norm_squared() / dof * (1.0 + rho) / (1.0 - rho);
    let std_errors = problem
        .jacobian()
        .and_then(|j| (j.transpose() * j).try_inverse())
        .map(|inv| {
            (0..n_params)
                .map(|k| {
                    let unit = free.statics.get(k).map_or(1.0, |j| j.step(s_ref));
                    (inv[(k, k)] * sigma2).max(0.0).sqrt() * unit
                })
                .collect()
        })
        .unwrap_or_else(|| vec![f64::NAN; n_params]);
    Ok(TwinFit {
        params,
        strengths,
        std_errors,
    })
}

/// The rows of one source with `effects` replayed over it: the lag sets the coil temperature, and
/// each linear effect's bias at unit strength is a column. Power-ons are the start and every gap
/// of more than [`GAP_FACTOR`] typical steps.
pub(super) fn rows(source: &Measured, lag_min: Option<f64>, linear: &[usize]) -> Vec<Row> {
    let recs = &source.records;
    let times: Vec<f64> = recs.iter().filter_map(|r| r.time_s).collect();
    let typical = typical_step(&times);
    let lag = lag_min.map(|tau_min| Effect::SensorLag { tau_min });
    let unit_effect = |l: usize| match LINEAR[l] {
        Cause::ThermalRate => Effect::ThermalRate {
            k_dph_per_c_per_min: 1.0,
        },
        Cause::WarmUp => Effect::WarmUp {
            amplitude_dph: 1.0,
            tau_min: 15.0,
        },
        Cause::Hysteresis => Effect::Hysteresis { offset_dph: 1.0 },
        _ => Effect::TimeDrift { dph_per_h: 1.0 },
    };
    // A stream's temperature is sampled each second with the sensor's white noise, whose
    // derivative would swamp a ramp of 1 °C/min (and a fit against a noisy regressor shrinks its
    // coefficient): the effects see it averaged over a centred minute, within one power-on (a
    // window across a power-off would mix the temperatures on either side of it). A table's
    // points are already means.
    let run: Vec<usize> = recs
        .iter()
        .scan((0usize, None::<f64>), |(id, prev), r| {
            if let (Some(p), Some(t)) = (*prev, r.time_s)
                && t - p > GAP_FACTOR * typical
            {
                *id += 1;
            }
            *prev = r.time_s;
            Some(*id)
        })
        .collect();
    let temps: Vec<f64> = match source.kind {
        SourceKind::Points => recs.iter().map(|r| r.temp_c).collect(),
        SourceKind::Stream => {
            let half = ((BLOCK_S / 2.0) / typical).round().max(0.0) as usize;
            let mut sum = vec![0.0; recs.len() + 1];
            for (i, r) in recs.iter().enumerate() {
                sum[i + 1] = sum[i] + r.temp_c;
            }
            (0..recs.len())
                .map(|i| {
                    let mut a = i.saturating_sub(half);
                    while run[a] != run[i] {
                        a += 1;
                    }
                    let mut b = (i + half + 1).min(recs.len());
                    while run[b - 1] != run[i] {
                        b -= 1;
                    }
                    (sum[b] - sum[a]) / (b - a) as f64
                })
                .collect()
        }
    };
    let first_t = temps.first().copied().unwrap_or(0.0);
    let plant_with = |extra: Option<Effect>| {
        EffectPlant::new(Hidden(lag.into_iter().chain(extra).collect()), first_t)
    };
    let mut coil_plant = plant_with(None);
    let mut plants: Vec<(usize, EffectPlant)> = linear
        .iter()
        .map(|&l| (l, plant_with(Some(unit_effect(l)))))
        .collect();
    let mut t_on = 0.0;
    let mut previous: Option<f64> = None;
    recs.iter()
        .zip(&temps)
        .map(|(r, &temp_c)| {
            let (coil_c, unit_bias_dps) = match r.time_s {
                Some(t) => {
                    let dt = previous.map_or(0.0, |p| t - p);
                    previous = Some(t);
                    if dt > GAP_FACTOR * typical {
                        t_on = 0.0;
                    } else {
                        t_on += dt;
                    }
                    let dt = dt.max(1e-9);
                    let coil = coil_plant.step(temp_c, dt);
                    let mut b = [0.0; TERMS];
                    b[OFFSET] = 1.0 / SECONDS_PER_HOUR;
                    for (l, p) in &mut plants {
                        p.step(temp_c, dt);
                        b[*l] = p.bias_dps(t_on);
                    }
                    (coil, b)
                }
                None => (r.temp_c, [0.0; TERMS]),
            };
            Row {
                coil_c,
                rate_dps: r.rate_dps,
                output: r.output,
                unit_bias_dps,
            }
        })
        .collect()
}

/// Rate-equivalent residuals, °/h, of `rows` under a fitted twin.
pub(super) fn residual_dph(f: &TwinFit, rows: &[Row]) -> Vec<f64> {
    rows.iter()
        .map(|r| {
            (r.output - model(&f.params, &f.strengths, r)) / f.params.scale_factor(r.coil_c)
                * SECONDS_PER_HOUR
        })
        .collect()
}

/// Fidelity, °/h: RMS per point for a table, of 60 s block means for a stream.
pub(super) fn fidelity(kind: SourceKind, records: &[Record], residual: &[f64]) -> f64 {
    let values: Vec<f64> = match kind {
        SourceKind::Points => residual.to_vec(),
        SourceKind::Stream => {
            let t0 = records.first().and_then(|r| r.time_s).unwrap_or(0.0);
            let time: Vec<f64> = records.iter().map(|r| r.time_s.unwrap_or(t0)).collect();
            blocks::means(
                residual,
                &blocks::group(&time, &(0..time.len()).collect::<Vec<_>>()),
            )
        }
    };
    rms(&values)
}
