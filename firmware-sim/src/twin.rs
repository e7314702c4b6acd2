//! A twin of a real gyro: the simulator's parameters identified from measured data, what the
//! simulation still gets wrong, and the hidden effects that close the gap.
//!
//! The twin is the simulator's own output map ([`crate::gyro::plant`]) with the parameters that
//! reproduce the measurements, written as a unit file that `generate paper|stream --unit FILE`
//! simulates. Identification is a weighted nonlinear least-squares fit (Levenberg–Marquardt) of
//! the measured output against the map at the measured temperature and reference rate, over the
//! parameters the data can determine; the others keep their nominal values, each with the reason
//! (a static log shows no scale factor, a table without fast rates no sine compression, …).
//!
//! What the twin gets wrong is the measured output minus the twin's, replayed over the measured
//! protocol. The simulator's hidden effects ([`crate::gyro::effects`]) are the candidate causes:
//! each is added to the twin with its strength fitted (a lag by a search over its time constant,
//! the biases as linear terms of the same fit), and kept only when it improves a forward test
//! inside the training data (rolling origin: fitted on its first two, three and four fifths,
//! scored on the fifth after each). Up to three are kept, one at a time while each helps by
//! [`MIN_GAIN`]. The data's last third in time is held out from all of this and scored once,
//! before and after: the twin's fidelity. With a rate table and a stream, the map comes from the
//! table (soaked points are its own data) and the stream adds the effects and its own bias offset
//! (a run's turn-on bias), so that no effect has to stand in for that offset.
//!
//! Fidelity is the RMS of the rate-equivalent difference, (measured − twin) / S(T), in °/h: per
//! point for a rate table, over 60 s block means for a stream (as the replay scores), where the
//! white noise would otherwise hide everything else.

use std::path::Path;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::storage::Owned;
use nalgebra::{DMatrix, DVector, Dyn};
use serde::{Deserialize, Serialize};

use crate::allan;
use crate::cause::Cause;
use crate::data::columns::{self, ColumnMap, DataError};
use crate::data::stream::{BLOCK_S, GAP_FACTOR, Stream, typical_step};
use crate::gyro::effects::{Effect, EffectPlant};
use crate::gyro::plant::GyroParams;

/// Seconds per hour.
const HOUR_S: f64 = 3600.0;
/// Share of the forward score an added effect must remove to be kept.
pub const MIN_GAIN: f64 = 0.1;
/// Most effects added to a twin.
pub const MAX_EFFECTS: usize = 3;
/// Parts of the training data for the rolling-origin forward test.
const FOLDS: usize = 5;
/// Sensor-lag time constants tried, min.
const LAG_GRID_MIN: [f64; 12] = [
    0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 8.0, 12.0, 20.0, 30.0,
];
/// The bias effects whose strength enters the output linearly, fitted with the map.
const LINEAR: [Cause; 4] = [
    Cause::ThermalRate,
    Cause::WarmUp,
    Cause::Hysteresis,
    Cause::TimeDrift,
];

/// A simulated gyro: its parameters and hidden effects. The unit file's format.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Unit {
    /// The output map, temperature dependence and noise.
    pub params: GyroParams,
    /// Effects acting on it, with their fitted strengths.
    pub effects: Vec<Effect>,
}

/// A unit file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum UnitError {
    /// Unreadable.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not a unit file.
    #[error("{path}: not a unit file ({source})")]
    Format {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: serde_json::Error,
    },
    /// A number that no gyro has.
    #[error("{path}: {what} is {value}, which no gyro has")]
    Invalid {
        /// The file.
        path: std::path::PathBuf,
        /// Which parameter.
        what: &'static str,
        /// Its value.
        value: f64,
    },
}

impl Unit {
    /// Reads and checks a unit file (`identify --out`).
    pub fn load(path: &Path) -> Result<Self, UnitError> {
        let text = std::fs::read_to_string(path).map_err(|source| UnitError::Io {
            path: path.to_owned(),
            source,
        })?;
        let unit: Unit = serde_json::from_str(&text).map_err(|source| UnitError::Format {
            path: path.to_owned(),
            source,
        })?;
        let p = &unit.params;
        let checks: [(&'static str, f64, bool); 8] = [
            (
                "scale_factor_v_per_dps",
                p.scale_factor_v_per_dps,
                p.scale_factor_v_per_dps != 0.0,
            ),
            ("sagnac_k_s", p.sagnac_k_s, p.sagnac_k_s > 0.0),
            ("arw_dpsqrth", p.arw_dpsqrth, p.arw_dpsqrth >= 0.0),
            (
                "bias_instability_dph",
                p.bias_instability_dph,
                p.bias_instability_dph >= 0.0,
            ),
            (
                "bias_instability_tau_s",
                p.bias_instability_tau_s,
                p.bias_instability_tau_s > 0.0,
            ),
            (
                "rrw_dph_per_sqrth",
                p.rrw_dph_per_sqrth,
                p.rrw_dph_per_sqrth >= 0.0,
            ),
            ("temp_noise_c", p.temp_noise_c, p.temp_noise_c >= 0.0),
            (
                "adc_bits",
                f64::from(p.adc_bits),
                (1..=30).contains(&p.adc_bits),
            ),
        ];
        for (what, value, ok) in checks {
            if !(ok && value.is_finite()) {
                return Err(UnitError::Invalid {
                    path: path.to_owned(),
                    what,
                    value,
                });
            }
        }
        for e in &unit.effects {
            let lag = match *e {
                Effect::SensorLag { tau_min } | Effect::WarmUp { tau_min, .. } => tau_min,
                _ => 1.0,
            };
            if !(e.strength().is_finite() && lag.is_finite() && lag > 0.0) {
                return Err(UnitError::Invalid {
                    path: path.to_owned(),
                    what: "an effect's strength or time constant",
                    value: if lag > 0.0 { e.strength() } else { lag },
                });
            }
        }
        Ok(unit)
    }
}

/// One measurement: a rate-table point or a stream sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Record {
    /// When, s (a stream's clock, or a time-ordered table's); `None` for a table without one.
    pub time_s: Option<f64>,
    /// Temperature-sensor reading, °C.
    pub temp_c: f64,
    /// Gyro output (V, counts, °/s …).
    pub output: f64,
    /// Reference rate, °/s.
    pub rate_dps: f64,
}

/// Measured data of one kind, in time (or file) order.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// What it is, for the report: `points` or `stream`.
    pub kind: Kind,
    /// The measurements.
    pub records: Vec<Record>,
    /// The chamber's setpoint of each measurement, °C, where the file has one (a simulated rate
    /// table's `setpoint_c`): the sensor's reading above it, soaked, is the self-heating.
    pub setpoint_c: Option<Vec<f64>>,
}

/// The kind of a [`Source`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Kind {
    /// Averaged rate-table points.
    Points,
    /// A stream of samples.
    Stream,
}

impl Source {
    fn timed(&self) -> bool {
        self.records.iter().all(|r| r.time_s.is_some())
    }
}

/// What identification could not do.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// Neither points nor a stream.
    #[error("nothing to identify from: give --points, --stream or both")]
    NoData,
    /// Too few measurements for the fit and its held-out test.
    #[error("{0} measurements: identification needs at least 12 (a third is held out)")]
    TooFew(usize),
    /// Every reference rate is zero and no scale factor was given.
    #[error(
        "every reference rate is (near) zero, so the data show no scale factor: give the gyro's \
         nominal one (--scale-factor K, output units per °/s), as for a static log"
    )]
    NoScaleFactor,
    /// The fit produced numbers that are not finite.
    #[error("the fit diverged (non-finite parameters); check the --map units")]
    Diverged,
}

/// One parameter as identified.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Parameter {
    /// Name, as in the unit file.
    pub name: String,
    /// Value in the unit file.
    pub value: f64,
    /// One-sigma uncertainty from the fit's covariance, where fitted.
    pub std_error: Option<f64>,
    /// Whether the data determined it.
    pub determined: bool,
    /// Where it comes from, or why it is nominal.
    pub why: String,
}

/// A candidate effect, tried on the forward test inside the training data.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// The cause.
    pub cause: Cause,
    /// Round of the search (1 = first effect added).
    pub round: usize,
    /// Fitted strength (the effect's unit, `generate --strength`).
    pub strength: f64,
    /// Forward score with it, °/h (the training data's last third).
    pub forward_dph: f64,
    /// Forward score without it, °/h.
    pub baseline_dph: f64,
    /// Kept in the twin.
    pub kept: bool,
}

/// What `identify --json` writes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Identification {
    /// The twin (fitted on all the data, with the effects the training data chose).
    pub unit: Unit,
    /// Every parameter: value, uncertainty, determined or why not.
    pub parameters: Vec<Parameter>,
    /// The noise terms read from the stream's residual Allan deviation.
    pub noise: Option<allan::Terms>,
    /// The data whose last third is held out.
    pub held_out: Kind,
    /// Measurements fitted on / held out.
    pub n_train: usize,
    /// Held out.
    pub n_held_out: usize,
    /// The twin without effects, held out, °/h.
    pub fidelity_before_dph: f64,
    /// With the effects kept, held out, °/h.
    pub fidelity_after_dph: f64,
    /// Effects added, strongest first (`none` when none helped).
    pub causes: Vec<Cause>,
    /// Every candidate tried.
    pub candidates: Vec<Candidate>,
    /// The held-out residual before and after, for the figure: (time or index, °/h, °/h).
    #[serde(skip)]
    pub residual: Vec<(f64, f64, f64)>,
    /// Where the held-out part starts on that axis.
    #[serde(skip)]
    pub split_at: f64,
}

/// The static parameters identification may fit, in the order of its vector.
const STATIC: [&str; 10] = [
    "scale_factor_v_per_dps",
    "sf_tc_per_c",
    "sf_tc2_per_c2",
    "sagnac_k_s",
    "sf_asymmetry",
    "bias_poly_dph[0]",
    "bias_poly_dph[1]",
    "bias_poly_dph[2]",
    "bias_poly_dph[3]",
    "output_offset_v",
];

fn get(p: &GyroParams, j: usize) -> f64 {
    match j {
        0 => p.scale_factor_v_per_dps,
        1 => p.sf_tc_per_c,
        2 => p.sf_tc2_per_c2,
        3 => p.sagnac_k_s,
        4 => p.sf_asymmetry,
        9 => p.output_offset_v,
        _ => p.bias_poly_dph[j - 5],
    }
}

fn set(p: &mut GyroParams, j: usize, v: f64) {
    match j {
        0 => p.scale_factor_v_per_dps = v,
        1 => p.sf_tc_per_c = v,
        2 => p.sf_tc2_per_c2 = v,
        3 => p.sagnac_k_s = v,
        4 => p.sf_asymmetry = v,
        9 => p.output_offset_v = v,
        _ => p.bias_poly_dph[j - 5] = v,
    }
}

/// Linear bias terms of a row: the effects of [`LINEAR`], then the run's offset.
const TERMS: usize = LINEAR.len() + 1;
/// The term of a stream's bias offset against the rate table's, 1 °/h: the run-to-run bias
/// repeatability of every gyro datasheet, fitted whenever the map comes from a table so that no
/// effect has to absorb it.
const OFFSET: usize = LINEAR.len();

/// A record as the fit sees it: the coil temperature and the unit-strength bias of each linear
/// effect, from replaying the effects over the record's source.
#[derive(Debug, Clone, Copy)]
struct Row {
    coil_c: f64,
    rate_dps: f64,
    output: f64,
    unit_bias_dps: [f64; TERMS],
}

/// The best candidate of a round: its cause, forward score and strength, and the twin's lag and
/// linear effects with it.
struct Tried {
    cause: Cause,
    score: f64,
    strength: f64,
    lag: Option<f64>,
    linear: Vec<usize>,
}

/// Which parameters a fit frees: static ones by index, and the linear effects present.
#[derive(Debug, Clone)]
struct Free {
    statics: Vec<usize>,
    linear: Vec<usize>,
}

/// The Levenberg–Marquardt problem: scaled offsets from a start, weighted rate-unit residuals.
struct Fit<'a> {
    start: GyroParams,
    free: &'a Free,
    rows: &'a [Row],
    x: DVector<f64>,
    /// |S| of the start: residuals in °/s.
    s_ref: f64,
}

/// Scale of each static parameter's step, and of a linear effect's strength.
fn scale(j: usize, s_ref: f64) -> f64 {
    match j {
        0 => s_ref * 1e-3,
        1 => 1e-4,
        2 => 1e-6,
        3 => 0.01,
        4 => 1e-4,
        9 => s_ref * 1e-2,
        _ => 1.0,
    }
}

impl Fit<'_> {
    fn params(&self, x: &DVector<f64>) -> (GyroParams, [f64; TERMS]) {
        let mut p = self.start.clone();
        for (k, &j) in self.free.statics.iter().enumerate() {
            set(&mut p, j, get(&self.start, j) + x[k] * scale(j, self.s_ref));
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
fn model(p: &GyroParams, strengths: &[f64; TERMS], r: &Row) -> f64 {
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
struct Fitted {
    params: GyroParams,
    strengths: [f64; TERMS],
    std_errors: Vec<f64>,
}

/// Fits the free parameters from `start` on `rows`.
fn fit(start: &GyroParams, free: &Free, rows: &[Row]) -> Result<Fitted, IdentifyError> {
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
                    let unit = free.statics.get(k).map_or(1.0, |&j| scale(j, s_ref));
                    (inv[(k, k)] * sigma2).max(0.0).sqrt() * unit
                })
                .collect()
        })
        .unwrap_or_else(|| vec![f64::NAN; n_params]);
    Ok(Fitted {
        params,
        strengths,
        std_errors,
    })
}

/// The rows of one source with `effects` replayed over it: the lag sets the coil temperature, and
/// each linear effect's bias at unit strength is a column. Power-ons are the start and every gap
/// of more than [`GAP_FACTOR`] typical steps.
fn rows(source: &Source, lag_min: Option<f64>, linear: &[usize]) -> Vec<Row> {
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
        Kind::Points => recs.iter().map(|r| r.temp_c).collect(),
        Kind::Stream => {
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
        EffectPlant::new(
            crate::gyro::effects::Hidden(lag.into_iter().chain(extra).collect()),
            first_t,
        )
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
                    b[OFFSET] = 1.0 / HOUR_S;
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
fn residual_dph(f: &Fitted, rows: &[Row]) -> Vec<f64> {
    rows.iter()
        .map(|r| {
            (r.output - model(&f.params, &f.strengths, r)) / f.params.scale_factor(r.coil_c)
                * HOUR_S
        })
        .collect()
}

/// Fidelity, °/h: RMS per point for a table, of 60 s block means for a stream.
fn fidelity(kind: Kind, records: &[Record], residual: &[f64]) -> f64 {
    let values: Vec<f64> = match kind {
        Kind::Points => residual.to_vec(),
        Kind::Stream => {
            let mut blocks: Vec<(f64, f64, usize)> = Vec::new();
            let t0 = records.first().and_then(|r| r.time_s).unwrap_or(0.0);
            for (r, e) in records.iter().zip(residual) {
                let b = ((r.time_s.unwrap_or(t0) - t0) / BLOCK_S).floor();
                match blocks.last_mut() {
                    Some(last) if last.0 == b => {
                        last.1 += e;
                        last.2 += 1;
                    }
                    _ => blocks.push((b, *e, 1)),
                }
            }
            blocks.iter().map(|(_, s, n)| s / *n as f64).collect()
        }
    };
    (values.iter().map(|v| v * v).sum::<f64>() / values.len().max(1) as f64).sqrt()
}

/// What the data can determine, from the training records: the free static parameters and a
/// reason for each that is not.
fn determinable(records: &[&Record]) -> (Vec<usize>, Vec<(usize, String)>) {
    let rated: Vec<&&Record> = records.iter().filter(|r| r.rate_dps.abs() > 0.5).collect();
    let span = |rs: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = rs.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
            (lo.min(t), hi.max(t))
        });
        if hi >= lo { hi - lo } else { 0.0 }
    };
    let rated_span = span(&mut rated.iter().map(|r| r.temp_c));
    let all_span = span(&mut records.iter().map(|r| r.temp_c));
    let distinct = |v: &mut dyn Iterator<Item = i64>| {
        let mut v: Vec<i64> = v.collect();
        v.sort_unstable();
        v.dedup();
        v.len()
    };
    let temps = distinct(&mut rated.iter().map(|r| r.temp_c.round() as i64));
    let rates = distinct(
        &mut rated
            .iter()
            .map(|r| (r.rate_dps.abs() * 2.0).round() as i64),
    );
    let max_rate = rated.iter().map(|r| r.rate_dps.abs()).fold(0.0, f64::max);
    let both_signs =
        rated.iter().any(|r| r.rate_dps > 0.0) && rated.iter().any(|r| r.rate_dps < 0.0);
    let mut free = Vec::new();
    let mut fixed = Vec::new();
    let mut rule = |j: usize, ok: bool, why: String| {
        if ok {
            free.push(j);
        } else {
            fixed.push((j, why));
        }
    };
    let has_rates = rated.len() >= 3;
    let no_rates =
        || "every reference rate is (near) zero: the data show no scale factor".to_owned();
    rule(0, has_rates, no_rates());
    rule(
        1,
        has_rates && rated_span >= 5.0,
        format!("needs rates at temperatures ≥ 5 °C apart (the data span {rated_span:.1} °C)"),
    );
    rule(
        2,
        has_rates && rated_span >= 20.0 && temps >= 3,
        format!(
            "needs rates at ≥ 3 temperatures over ≥ 20 °C (the data: {temps} over {rated_span:.1} °C)"
        ),
    );
    rule(
        3,
        has_rates && max_rate >= 20.0 && rates >= 3,
        format!(
            "needs ≥ 3 rate magnitudes up to ≥ 20 °/s to show the sine's compression (the data: \
             {rates} up to {max_rate:.1} °/s)"
        ),
    );
    rule(
        4,
        has_rates && both_signs,
        "needs rates of both signs".to_owned(),
    );
    // An offset at the output and a bias differ only in how the sine's compression treats them
    // (the bias passes through it: S·b·cos(K′ω)), so the offset is known where the sine is.
    rule(
        9,
        has_rates && max_rate >= 20.0 && rates >= 3,
        "not separable from the bias without the sine's compression: 0, the bias carries it"
            .to_owned(),
    );
    // The bias polynomial's degree follows the temperature span: a cubic needs 40 °C of it, a
    // quadratic 20 (over less, its curvature is fitted to noise and run-to-run offsets, and it
    // extrapolates wildly past the trained span).
    let degree = match all_span {
        s if s >= 40.0 => 3,
        s if s >= 20.0 => 2,
        s if s >= 2.0 => 1,
        _ => 0,
    };
    for i in 0..4 {
        rule(
            5 + i,
            i <= degree,
            format!(
                "degree {i} of the bias needs a wider temperature span (the data span \
                 {all_span:.1} °C: degree {degree}); set to 0"
            ),
        );
    }
    (free, fixed)
}

/// Identifies a twin from `points` and/or `stream`; `scale_factor` (output units per °/s) stands
/// in for a scale factor the data cannot show (a static log). `progress` is told each step.
pub fn identify(
    points: Option<&Source>,
    stream: Option<&Source>,
    scale_factor: Option<f64>,
    mut progress: impl FnMut(&str),
) -> Result<Identification, IdentifyError> {
    // Untimed table points hold out every third point (their file order is the protocol's, not
    // time); anything with a clock holds out its last third.
    let interleaved;
    let (primary, other) = match (stream, points) {
        (Some(s), other) => (s, other),
        (None, Some(p)) if !p.timed() => {
            let (train, test): (Vec<usize>, Vec<usize>) =
                (0..p.records.len()).partition(|i| i % 3 != 2);
            interleaved = Source {
                kind: p.kind,
                records: train.iter().chain(&test).map(|&i| p.records[i]).collect(),
                setpoint_c: None,
            };
            (&interleaved, None)
        }
        (None, Some(p)) => (p, None),
        (None, None) => return Err(IdentifyError::NoData),
    };
    let n = primary.records.len();
    if n < 12 {
        return Err(IdentifyError::TooFew(n));
    }
    let train_end = (n as f64 * 2.0 / 3.0).round() as usize;

    // The static map comes from the rate table where there is one (soaked points are the map's
    // own data), else from the training part of the one source. What those records determine,
    // and the start: a straight line through the small rates gives the scale factor, the
    // zero-rate output a first bias.
    let map_records: Vec<&Record> = match other {
        Some(o) => o.records.iter().collect(),
        None => primary.records[..train_end].iter().collect(),
    };
    let (free_statics, fixed) = determinable(&map_records);
    let mut start = GyroParams::nominal();
    start.bias_poly_dph = [0.0; 4];
    start.output_offset_v = 0.0;
    let rated: Vec<&&Record> = map_records
        .iter()
        .filter(|r| r.rate_dps.abs() > 0.5)
        .collect();
    let max_rate = rated.iter().map(|r| r.rate_dps.abs()).fold(0.0, f64::max);
    let small: Vec<&&&Record> = rated
        .iter()
        .filter(|r| r.rate_dps.abs() <= 0.3 * max_rate.max(1.0) + 1.0)
        .collect();
    let (s0, c0) = if free_statics.contains(&0) {
        line(small.iter().map(|r| (r.rate_dps, r.output)))
    } else {
        let k = scale_factor.ok_or(IdentifyError::NoScaleFactor)?;
        let mean = map_records
            .iter()
            .map(|r| r.output - k * r.rate_dps)
            .sum::<f64>()
            / map_records.len() as f64;
        (k, mean)
    };
    start.scale_factor_v_per_dps = s0;
    start.bias_poly_dph[0] = c0 / s0 * HOUR_S;
    for j in [1, 2] {
        if free_statics.contains(&j) {
            set(&mut start, j, 0.0);
        }
    }
    // Effects act along time: a source without it (soaked table points) keeps its readings.
    let timed = primary.timed();

    // A fit of the twin on `train` (rows of the primary source) with the linear effects
    // `linear`: with a table, the map fitted on it is held and only the effects' strengths are
    // fitted on the stream; without, everything on `train`.
    let table_fit = match other {
        Some(o) => {
            let free = Free {
                statics: free_statics.clone(),
                linear: Vec::new(),
            };
            Some(fit(&start, &free, &rows(o, None, &[]))?)
        }
        None => None,
    };
    let fit_on = |train: &[Row], linear: &[usize]| -> Result<Fitted, IdentifyError> {
        match &table_fit {
            Some(t) => {
                let free = Free {
                    statics: Vec::new(),
                    linear: linear.iter().copied().chain([OFFSET]).collect(),
                };
                let f = fit(&t.params, &free, train)?;
                Ok(Fitted {
                    std_errors: t.std_errors.clone(),
                    ..f
                })
            }
            None => {
                let free = Free {
                    statics: free_statics.clone(),
                    linear: linear.to_vec(),
                };
                fit(&start, &free, train)
            }
        }
    };

    // The forward test inside the training data, rolling origin: fit on its first two, three,
    // four fifths, score the fifth after each; the score is their RMS.
    let forward = |lag: Option<f64>, linear: &[usize]| -> Result<(f64, Fitted), IdentifyError> {
        let rows = rows(primary, lag, linear);
        let fifth = train_end / FOLDS;
        let mut squares = 0.0;
        let mut last = None;
        for k in 2..FOLDS {
            let (a, b) = (
                k * fifth,
                if k + 1 == FOLDS {
                    train_end
                } else {
                    (k + 1) * fifth
                },
            );
            let f = fit_on(&rows[..a], linear)?;
            let e = residual_dph(&f, &rows[a..b]);
            let score = fidelity(primary.kind, &primary.records[a..b], &e);
            squares += score * score;
            last = Some(f);
        }
        let f = last.ok_or(IdentifyError::TooFew(n))?;
        Ok(((squares / (FOLDS - 2) as f64).sqrt(), f))
    };

    progress("the static twin");
    let (mut baseline, _) = forward(None, &[])?;
    let mut lag: Option<f64> = None;
    let mut linear: Vec<usize> = Vec::new();
    let mut causes: Vec<(Cause, f64)> = Vec::new();
    let mut candidates = Vec::new();
    if timed {
        for round in 1..=MAX_EFFECTS {
            let mut best: Option<Tried> = None;
            for cause in [Cause::SensorLag].into_iter().chain(LINEAR) {
                if causes.iter().any(|(c, _)| *c == cause) {
                    continue;
                }
                progress(&format!("round {round}: {}", cause.id()));
                let (score, strength, try_lag, try_linear) = if cause == Cause::SensorLag {
                    let mut top: Option<(f64, f64)> = None;
                    for tau in LAG_GRID_MIN {
                        let (s, _) = forward(Some(tau), &linear)?;
                        if top.is_none_or(|(b, _)| s < b) {
                            top = Some((s, tau));
                        }
                    }
                    let (mut s, mut tau) = top.unwrap_or((f64::INFINITY, 1.0));
                    // Then finer, between the grid's neighbours (golden section in log τ).
                    let at = LAG_GRID_MIN.iter().position(|&g| g == tau).unwrap_or(0);
                    let lo = LAG_GRID_MIN[at.saturating_sub(1)].ln();
                    let hi = LAG_GRID_MIN[(at + 1).min(LAG_GRID_MIN.len() - 1)].ln();
                    let (mut a, mut b) = (lo, hi);
                    let g = (5f64.sqrt() - 1.0) / 2.0;
                    for _ in 0..10 {
                        let (c, d) = (b - g * (b - a), a + g * (b - a));
                        let (sc, _) = forward(Some(c.exp()), &linear)?;
                        let (sd, _) = forward(Some(d.exp()), &linear)?;
                        if sc < sd {
                            b = d;
                        } else {
                            a = c;
                        }
                        for (sv, t) in [(sc, c.exp()), (sd, d.exp())] {
                            if sv < s {
                                (s, tau) = (sv, t);
                            }
                        }
                    }
                    (s, tau, Some(tau), linear.clone())
                } else {
                    let l = LINEAR.iter().position(|c| *c == cause).unwrap_or(0);
                    let with: Vec<usize> = linear.iter().copied().chain([l]).collect();
                    let (s, f) = forward(lag, &with)?;
                    (s, f.strengths[l], lag, with)
                };
                candidates.push(Candidate {
                    cause,
                    round,
                    strength,
                    forward_dph: score,
                    baseline_dph: baseline,
                    kept: false,
                });
                if best.as_ref().is_none_or(|b| score < b.score) {
                    best = Some(Tried {
                        cause,
                        score,
                        strength,
                        lag: try_lag,
                        linear: try_linear,
                    });
                }
            }
            match best {
                Some(Tried {
                    cause,
                    score,
                    strength,
                    lag: try_lag,
                    linear: try_linear,
                }) if score < (1.0 - MIN_GAIN) * baseline => {
                    if let Some(c) = candidates
                        .iter_mut()
                        .rev()
                        .find(|c| c.cause == cause && c.round == round)
                    {
                        c.kept = true;
                    }
                    causes.push((cause, strength));
                    baseline = score;
                    lag = try_lag;
                    linear = try_linear;
                }
                _ => break,
            }
        }
    }

    // Held out, once: the twin fitted on all the training data, without and with the effects.
    progress("the held-out test");
    let held = |lag: Option<f64>, linear: &[usize]| -> Result<(Vec<f64>, f64), IdentifyError> {
        let rows = rows(primary, lag, linear);
        let f = fit_on(&rows[..train_end], linear)?;
        let e = residual_dph(&f, &rows[train_end..]);
        Ok((
            e.clone(),
            fidelity(primary.kind, &primary.records[train_end..], &e),
        ))
    };
    let (before_e, before) = held(None, &[])?;
    let (after_e, after) = held(lag, &linear)?;
    let axis = |i: usize| primary.records[i].time_s.unwrap_or(i as f64);
    let residual = (train_end..n)
        .zip(before_e.iter().zip(&after_e))
        .map(|(i, (b, a))| (axis(i), *b, *a))
        .collect();

    // The unit: refitted on all the data with the effects chosen, noise from the stream.
    progress("the unit, on all the data");
    let f = fit_on(&rows(primary, lag, &linear), &linear)?;
    let free = Free {
        statics: free_statics.clone(),
        linear: linear.clone(),
    };
    let mut params = f.params.clone();
    let mut parameters: Vec<Parameter> = Vec::new();
    for (j, name) in STATIC.iter().enumerate() {
        let (determined, std_error, why) = match free.statics.iter().position(|&k| k == j) {
            Some(k) => {
                let se = f.std_errors.get(k).copied();
                let why = if se.is_some_and(|e| e > get(&params, j).abs()) {
                    "fitted, but its uncertainty exceeds its value: the data barely tell it from \
                     the parameters it trades with (an offset and the bias, at zero rate)"
                } else {
                    "fitted"
                };
                (true, se, why.to_owned())
            }
            None => (
                false,
                None,
                fixed
                    .iter()
                    .find(|(k, _)| *k == j)
                    .map_or_else(String::new, |(_, w)| w.clone()),
            ),
        };
        parameters.push(Parameter {
            name: (*name).to_owned(),
            value: get(&params, j),
            std_error,
            determined,
            why,
        });
    }
    // Noise from a static log only: where the reference steps, the residual's Allan deviation
    // shows the map's small errors per rate (a hump at the rate hold), not the noise.
    let static_log = stream.filter(|s| {
        let first = s.records.first().map_or(0.0, |r| r.rate_dps);
        s.records.iter().all(|r| (r.rate_dps - first).abs() < 0.1)
    });
    let noise = static_log.map(|s| {
        let rows = rows(s, lag, &linear);
        let e: Vec<f64> = residual_dph(&f, &rows).iter().map(|v| v / HOUR_S).collect();
        noise_terms(s, &e)
    });
    let nominal = GyroParams::nominal();
    match noise.and_then(|t| Some((t, t.arw_deg_per_sqrt_h?))) {
        Some((t, arw)) => {
            params.arw_dpsqrth = arw;
            parameters.push(Parameter {
                name: "arw_dpsqrth".to_owned(),
                value: arw,
                std_error: None,
                determined: true,
                why: "the stream residual's Allan deviation, slope −½ at 1 s".to_owned(),
            });
            let (bi, why) = match t.bias_instability_deg_per_h {
                Some(b) => (
                    gauss_markov_sigma(arw, b, nominal.bias_instability_tau_s),
                    format!(
                        "the Gauss–Markov σ (T = {:.0} s) whose Allan curve bottoms at the \
                         measured {b:.3} °/h × 0.664",
                        nominal.bias_instability_tau_s
                    ),
                ),
                None => (
                    nominal.bias_instability_dph,
                    "the Allan deviation shows no bottom (log too short): nominal".to_owned(),
                ),
            };
            params.bias_instability_dph = bi;
            parameters.push(Parameter {
                name: "bias_instability_dph".to_owned(),
                value: bi,
                std_error: None,
                determined: t.bias_instability_deg_per_h.is_some(),
                why,
            });
            let (rrw, why) = match t.rrw_deg_per_h_per_sqrt_h {
                Some(k) => (k, "slope +½ at 3 s".to_owned()),
                None => (
                    nominal.rrw_dph_per_sqrth,
                    "no slope +½ in the Allan deviation (log too short): nominal".to_owned(),
                ),
            };
            params.rrw_dph_per_sqrth = rrw;
            parameters.push(Parameter {
                name: "rrw_dph_per_sqrth".to_owned(),
                value: rrw,
                std_error: None,
                determined: t.rrw_deg_per_h_per_sqrt_h.is_some(),
                why,
            });
        }
        None => {
            for (name, value) in [
                ("arw_dpsqrth", nominal.arw_dpsqrth),
                ("bias_instability_dph", nominal.bias_instability_dph),
                ("rrw_dph_per_sqrth", nominal.rrw_dph_per_sqrth),
            ] {
                parameters.push(Parameter {
                    name: name.to_owned(),
                    value,
                    std_error: None,
                    determined: false,
                    why: if stream.is_some() {
                        "needs a static log: where the reference steps, the residual's Allan \
                         deviation shows the map's errors per rate, not the noise: nominal"
                    } else {
                        "needs a static log (2-minute means average the noise away): nominal"
                    }
                    .to_owned(),
                });
            }
        }
    }
    if let Some(s) = stream {
        let t: Vec<f64> = s.records.iter().map(|r| r.temp_c).collect();
        let d: Vec<f64> = t.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]).collect();
        // The second difference removes a ramp; white sensor noise σ gives √6 σ.
        let sigma =
            (d.iter().map(|v| v * v).sum::<f64>() / d.len().max(1) as f64).sqrt() / 6f64.sqrt();
        params.temp_noise_c = sigma;
        parameters.push(Parameter {
            name: "temp_noise_c".to_owned(),
            value: sigma,
            std_error: None,
            determined: true,
            why: "the stream's temperature, second differences".to_owned(),
        });
    }
    // Soaked table points read the chamber's setpoint plus the electronics' self-heating.
    let soaked = points.and_then(|p| {
        let set = p.setpoint_c.as_ref()?;
        let n = set.len().max(1) as f64;
        Some(
            p.records
                .iter()
                .zip(set)
                .map(|(r, s)| r.temp_c - s)
                .sum::<f64>()
                / n,
        )
    });
    if let Some(heat) = soaked {
        params.self_heating_c = heat;
        parameters.push(Parameter {
            name: "self_heating_c".to_owned(),
            value: heat,
            std_error: None,
            determined: true,
            why: "the soaked points' readings above the chamber's setpoint".to_owned(),
        });
    }
    for (name, why) in [
        (
            "self_heating_c",
            "needs the chamber's setpoint beside the sensor reading (a setpoint_c column): nominal",
        ),
        (
            "latitude_deg",
            "the earth rate is inside the fitted bias where the reference lacks it: nominal",
        ),
        (
            "bias_instability_tau_s",
            "the Gauss–Markov correlation time is not read from the curve: nominal",
        ),
        (
            "adc_bits",
            "a logger's resolution is not in its means: nominal",
        ),
    ] {
        if name == "self_heating_c" && soaked.is_some() {
            continue;
        }
        parameters.push(Parameter {
            name: name.to_owned(),
            value: match name {
                "self_heating_c" => nominal.self_heating_c,
                "latitude_deg" => nominal.latitude_deg,
                "bias_instability_tau_s" => nominal.bias_instability_tau_s,
                _ => f64::from(nominal.adc_bits),
            },
            std_error: None,
            determined: false,
            why: why.to_owned(),
        });
    }
    let mut effects: Vec<Effect> = Vec::new();
    if let Some(tau_min) = lag {
        effects.push(Effect::SensorLag { tau_min });
    }
    for &l in &linear {
        let s = f.strengths[l];
        effects.push(match LINEAR[l] {
            Cause::ThermalRate => Effect::ThermalRate {
                k_dph_per_c_per_min: s,
            },
            Cause::WarmUp => Effect::WarmUp {
                amplitude_dph: s,
                tau_min: 15.0,
            },
            Cause::Hysteresis => Effect::Hysteresis { offset_dph: s },
            _ => Effect::TimeDrift { dph_per_h: s },
        });
    }
    let n_train = train_end + other.map_or(0, |s| s.records.len());
    Ok(Identification {
        unit: Unit { params, effects },
        parameters,
        noise,
        held_out: primary.kind,
        n_train,
        n_held_out: n - train_end,
        fidelity_before_dph: before,
        fidelity_after_dph: after,
        causes: if causes.is_empty() {
            vec![Cause::None]
        } else {
            causes.iter().map(|(c, _)| *c).collect()
        },
        candidates,
        residual,
        split_at: axis(train_end.min(n - 1)),
    })
}

/// Least-squares line y = a·x + b.
fn line(xy: impl Iterator<Item = (f64, f64)>) -> (f64, f64) {
    let pts: Vec<(f64, f64)> = xy.collect();
    let n = pts.len().max(1) as f64;
    let (mx, my) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let sxy: f64 = pts.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = pts.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    let a = if sxx > 0.0 { sxy / sxx } else { 1.0 };
    (a, my - a * mx)
}

/// The noise terms of a stream's residual (°/s), over its longest run without a gap.
fn noise_terms(stream: &Source, residual_dps: &[f64]) -> allan::Terms {
    let t: Vec<f64> = stream
        .records
        .iter()
        .map(|r| r.time_s.unwrap_or(0.0))
        .collect();
    allan::Analysis::of("the twin's residual", &t, residual_dps).terms
}

/// The Gauss–Markov σ (°/h, correlation time `corr_s`) whose Allan curve, with white noise of
/// ARW `arw` (°/√h), bottoms at `b` × 0.664 (°/h): the simulator's bias instability from a
/// measured one (bisection; the bottom grows with σ).
pub fn gauss_markov_sigma(arw: f64, b: f64, corr_s: f64) -> f64 {
    let bottom = |sigma: f64| {
        let curve = |tau: f64| {
            (allan::white_avar(arw / 60.0, tau)
                + allan::gauss_markov_avar(sigma / HOUR_S, corr_s, tau))
            .sqrt()
        };
        let grid: Vec<f64> = (0..5000)
            .map(|i| 10f64.powf(f64::from(i) / 1000.0))
            .collect();
        grid.windows(2)
            .find(|w| curve(w[1]) >= curve(w[0]))
            .map_or_else(|| curve(1e5), |w| curve(w[0]))
            / allan::FLICKER_FLOOR
            * HOUR_S
    };
    let (mut lo, mut hi) = (0.0, 100.0 * b.max(1e-6));
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if bottom(mid) < b {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Loads a rate-table points CSV as identification reads it: `temp_c`, `voltage_v`, `rate_dps`,
/// and `time_s` where `--map` gives one (a table recorded in time order).
pub fn load_points(path: &Path, maps: &[ColumnMap]) -> Result<Source, DataError> {
    let timed = maps.iter().any(|m| m.name == "time_s");
    let mut numeric = vec!["temp_c", "voltage_v", "rate_dps"];
    if timed {
        numeric.push("time_s");
    }
    // A simulated table carries the chamber's setpoint; a real one may, under that name.
    let header = std::fs::read_to_string(path)
        .ok()
        .and_then(|t| t.lines().next().map(str::to_owned));
    let with_setpoint = maps.iter().any(|m| m.name == "setpoint_c")
        || header.is_some_and(|h| h.split([',', '\t']).any(|c| c.trim() == "setpoint_c"));
    if with_setpoint {
        numeric.push("setpoint_c");
    }
    let c = columns::read_columns(path, &numeric, &[], &[], maps)?;
    let time = timed.then(|| c.get("time_s"));
    Ok(Source {
        kind: Kind::Points,
        records: (0..c.len())
            .map(|i| Record {
                time_s: time.map(|t| t[i]),
                temp_c: c.get("temp_c")[i],
                output: c.get("voltage_v")[i],
                rate_dps: c.get("rate_dps")[i],
            })
            .collect(),
        setpoint_c: with_setpoint.then(|| c.get("setpoint_c").to_vec()),
    })
}

impl From<&Stream> for Source {
    /// The samples with a reference rate (those without, e.g. where the unit was handled, say
    /// nothing of the map).
    fn from(s: &Stream) -> Self {
        Source {
            kind: Kind::Stream,
            records: s
                .referenced()
                .into_iter()
                .map(|i| Record {
                    time_s: Some(s.time_s[i]),
                    temp_c: s.temp_c[i],
                    output: s.voltage_v[i],
                    rate_dps: s.rate_dps[i],
                })
                .collect(),
            setpoint_c: None,
        }
    }
}

/// A stream's held-out residual as one-minute means, time in hours from its start: what the
/// figure draws (single samples are the white noise).
pub fn minute_means(residual: &[(f64, f64, f64)]) -> Vec<(f64, f64, f64)> {
    let t0 = residual.first().map_or(0.0, |r| r.0);
    let mut out: Vec<(f64, f64, f64, f64, usize)> = Vec::new();
    for &(t, b, a) in residual {
        let block = ((t - t0) / BLOCK_S).floor();
        match out.last_mut() {
            Some(last) if last.0 == block => {
                last.1 += t;
                last.2 += b;
                last.3 += a;
                last.4 += 1;
            }
            _ => out.push((block, t, b, a, 1)),
        }
    }
    out.iter()
        .map(|&(_, t, b, a, n)| {
            let n = n as f64;
            ((t / n - t0) / HOUR_S, b / n, a / n)
        })
        .collect()
}

/// The identification as text: every parameter, the effects and the fidelity.
pub fn summary(id: &Identification) -> String {
    let mut s = String::from("parameter                      value          ± 1σ       source\n");
    for p in &id.parameters {
        s.push_str(&format!(
            "{:<28} {:>14.6e} {:>12} {}\n",
            p.name,
            p.value,
            p.std_error
                .map_or_else(|| "—".to_owned(), |e| format!("{e:.2e}")),
            if p.determined {
                p.why.clone()
            } else {
                format!("not determined: {}", p.why)
            }
        ));
    }
    for c in &id.candidates {
        s.push_str(&format!(
            "round {} {:<13} strength {:>10.4}  forward {:>9.3} °/h (without {:>9.3}){}\n",
            c.round,
            c.cause.id(),
            c.strength,
            c.forward_dph,
            c.baseline_dph,
            if c.kept { "  kept" } else { "" }
        ));
    }
    let held = match id.held_out {
        Kind::Stream => "the stream's last third in time, 60 s means",
        Kind::Points => "the table's last third (in time where it has one, else every third point)",
    };
    s.push_str(&format!(
        "effects: {}; held out ({held}, {} of {} measurements): {:.3} °/h static → {:.3} °/h with them",
        id.causes.iter().map(|c| c.id()).collect::<Vec<_>>().join(" + "),
        id.n_held_out,
        id.n_held_out + id.n_train,
        id.fidelity_before_dph,
        id.fidelity_after_dph
    ));
    s
}
