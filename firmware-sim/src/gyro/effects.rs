//! The hidden effects of docs/design.md §5: what a soak-calibrated static model cannot see.
//!
//! Each effect adds a bias to the rate the coil senses, or (sensor lag) makes the coil feel a
//! temperature other than the one the sensor reads. Magnitudes come from PHYSICS.md ("Candidate
//! hidden effects" and the simulator table). [`range`] keeps the part of each published range
//! where the effect stands above the gyro's own noise after 60 s averaging (about 1.5 °/h for the
//! nominal unit: bias instability, ARW and RRW) by enough that removing it can cut a 60 s RMSE
//! threefold on the default stream (effect RMS ≳ 3× the noise: measured, docs/simulator.md), and
//! [`Effect::draw`] draws from it. Weaker effects exist; below the noise there is nothing to
//! compensate and `none` is the right diagnosis.
//!
//! | id | physical model (this simulator) | strength S | range of S | source |
//! |---|---|---|---|---|
//! | `thermal-rate` | b = k·dT_c/dt (thermal stress, Mohr; Shupe) | k, (°/h)/(°C/min) | 10–25 | PHYSICS §1, table: k_Ṫ 0.1–20, k_g ≈ 30 unsymmetrized |
//! | `sensor-lag` | coil follows housing with τ_c; sensor on housing | τ_c, min | 5–20 | PHYSICS table: housing→coil lag 5–20 min |
//! | `warm-up` | b = A·exp(−t_on/τ_w), at every power-on | A, °/h (τ_w drawn 10–30 min) | 30–50 | PHYSICS: A 10–50 °/h, τ_w 5–30 min |
//! | `hysteresis` | b = k_h·h, h relaxes to ±1 while the coil heats/cools (τ 10 min), holds in soaks | k_h, °/h | 5–30 | PHYSICS effect 4: 5–30 °/h |
//! | `time-drift` | b = k_d·τ_d·(1 − exp(−t_on/τ_d)), τ_d = 20 h: near-linear in-run drift | k_d, (°/h)/h | 4–10 | estimate: a few °/h per hour, above RRW 0.3–1 (°/h)/√h |
//!
//! The simulator's forms are deliberately not the feature forms the trainer fits (the hysteresis
//! state relaxes rather than switching; the drift saturates), so a diagnosis that works here does
//! not work only because it mirrors the plant.

use firmware_core::units::SECONDS_PER_HOUR;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use fog_data::cause::Cause;

/// Relaxation time of the hysteresis state while the coil temperature moves, s.
const HYSTERESIS_TAU_S: f64 = 600.0;
/// Coil temperature rate above which the hysteresis state moves, °C/min.
const HYSTERESIS_MIN_RATE_C_PER_MIN: f64 = 0.05;
/// Time constant of the in-run drift's saturation, s.
const DRIFT_TAU_S: f64 = 20.0 * SECONDS_PER_HOUR;

/// One hidden effect with its magnitude.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(tag = "id", rename_all = "kebab-case")]
pub enum Effect {
    /// No effect: the residual of a good static model is noise.
    None,
    /// Bias proportional to the coil's temperature rate.
    ThermalRate {
        /// (°/h) per (°C/min).
        k_dph_per_c_per_min: f64,
    },
    /// The coil lags the housing (where the sensor sits) by a first-order time constant.
    SensorLag {
        /// Coil time constant, min.
        tau_min: f64,
    },
    /// Bias decaying exponentially after every power-on.
    WarmUp {
        /// Amplitude at power-on, °/h.
        amplitude_dph: f64,
        /// Time constant, min.
        tau_min: f64,
    },
    /// Bias offset set by the direction of the last temperature excursion.
    Hysteresis {
        /// Offset at a fully heated (+) or cooled (−) state, °/h.
        offset_dph: f64,
    },
    /// Slow in-run drift with time since power-on.
    TimeDrift {
        /// Initial slope, (°/h) per hour.
        dph_per_h: f64,
    },
}

/// A strength that is not valid for its effect.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("strength {strength} is not valid for {cause}: {why}")]
pub struct StrengthError {
    /// The effect.
    pub cause: Cause,
    /// Strength given.
    pub strength: f64,
    /// Why not.
    pub why: &'static str,
}

/// The documented range of a cause's strength S (module table); `None` for `none`.
pub fn range(cause: Cause) -> Option<(f64, f64)> {
    match cause {
        Cause::None => None,
        Cause::ThermalRate => Some((10.0, 25.0)),
        Cause::SensorLag => Some((5.0, 20.0)),
        Cause::WarmUp => Some((30.0, 50.0)),
        Cause::Hysteresis => Some((5.0, 30.0)),
        Cause::TimeDrift => Some((4.0, 10.0)),
    }
}

/// Where a drawn strength comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum Strength {
    /// The documented range ([`range`]).
    Documented,
    /// Below it: from [`WEAK_SHARE`] of its lower end to the lower end, where the effect may sit
    /// in the noise and `none` can be the honest answer.
    Weak,
}

/// Lowest weak strength, as a share of the documented range's lower end.
pub const WEAK_SHARE: f64 = 0.3;

/// Nominal warm-up time constant, min.
const WARM_UP_TAU_MIN: f64 = 15.0;

impl Effect {
    /// `cause` at strength `s` (secondary parameters nominal); `None` with no strength for `none`.
    pub fn new(cause: Cause, strength: Option<f64>) -> Result<Effect, StrengthError> {
        let s = match (cause, strength) {
            (Cause::None, None) => return Ok(Effect::None),
            (Cause::None, Some(s)) => {
                return Err(StrengthError {
                    cause,
                    strength: s,
                    why: "`none` has no strength",
                });
            }
            (_, None) => range(cause).map_or(0.0, |(lo, hi)| 0.5 * (lo + hi)),
            (_, Some(s)) => s,
        };
        if !(s.is_finite() && s > 0.0) {
            return Err(StrengthError {
                cause,
                strength: s,
                why: "it must be a finite positive number",
            });
        }
        Ok(Self::build(cause, s, WARM_UP_TAU_MIN))
    }

    /// `cause` with its strength (and the warm-up's time constant, 10–30 min) drawn uniformly from
    /// the documented ranges by `seed`.
    pub fn draw(cause: Cause, seed: u64) -> Effect {
        Self::draw_in(cause, seed, Strength::Documented)
    }

    /// As [`Self::draw`], the strength drawn from the range `strength` names.
    pub fn draw_in(cause: Cause, seed: u64, strength: Strength) -> Effect {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6566_6665_6374);
        let mut uniform = |lo: f64, hi: f64| lo + (hi - lo) * rng.random::<f64>();
        match range(cause) {
            Some((lo, hi)) => {
                let (lo, hi) = match strength {
                    Strength::Documented => (lo, hi),
                    Strength::Weak => (WEAK_SHARE * lo, lo),
                };
                let s = uniform(lo, hi);
                Self::build(cause, s, uniform(10.0, 30.0))
            }
            None => Effect::None,
        }
    }

    fn build(cause: Cause, s: f64, warm_up_tau_min: f64) -> Effect {
        match cause {
            Cause::None => Effect::None,
            Cause::ThermalRate => Effect::ThermalRate {
                k_dph_per_c_per_min: s,
            },
            Cause::SensorLag => Effect::SensorLag { tau_min: s },
            Cause::WarmUp => Effect::WarmUp {
                amplitude_dph: s,
                tau_min: warm_up_tau_min,
            },
            Cause::Hysteresis => Effect::Hysteresis { offset_dph: s },
            Cause::TimeDrift => Effect::TimeDrift { dph_per_h: s },
        }
    }

    /// The cause id.
    pub fn cause(&self) -> Cause {
        match self {
            Effect::None => Cause::None,
            Effect::ThermalRate { .. } => Cause::ThermalRate,
            Effect::SensorLag { .. } => Cause::SensorLag,
            Effect::WarmUp { .. } => Cause::WarmUp,
            Effect::Hysteresis { .. } => Cause::Hysteresis,
            Effect::TimeDrift { .. } => Cause::TimeDrift,
        }
    }

    /// The strength S of the module table (0 for `none`).
    pub fn strength(&self) -> f64 {
        match *self {
            Effect::None => 0.0,
            Effect::ThermalRate {
                k_dph_per_c_per_min,
            } => k_dph_per_c_per_min,
            Effect::SensorLag { tau_min } => tau_min,
            Effect::WarmUp { amplitude_dph, .. } => amplitude_dph,
            Effect::Hysteresis { offset_dph } => offset_dph,
            Effect::TimeDrift { dph_per_h } => dph_per_h,
        }
    }
}

/// The hidden effects of one gyro, acting together (none, one, or several of distinct causes):
/// a lag sets the temperature the coil feels, and the biases add.
#[derive(Debug, Clone, Default, PartialEq, Serialize, schemars::JsonSchema)]
#[serde(transparent)]
pub struct Hidden(pub Vec<Effect>);

impl From<Effect> for Hidden {
    fn from(e: Effect) -> Self {
        Self(if e == Effect::None {
            Vec::new()
        } else {
            vec![e]
        })
    }
}

/// Effects that cannot act together.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum HiddenError {
    /// A strength that is not valid for its effect.
    #[error(transparent)]
    Strength(#[from] StrengthError),
    /// One cause twice, or `none` beside another.
    #[error("{0}: each cause at most once, and `none` alone")]
    Repeated(String),
    /// Strengths given for some effects but not others.
    #[error("{strengths} strengths for {effects} effects: give one per effect, joined by +")]
    Count {
        /// Effects given.
        effects: usize,
        /// Strengths given.
        strengths: usize,
    },
}

impl Hidden {
    /// The effects of `causes` at `strengths` (one per cause, or none for the middle of each
    /// range).
    pub fn new(causes: &[Cause], strengths: &[f64]) -> Result<Self, HiddenError> {
        let ids = || causes.iter().map(|c| c.id()).collect::<Vec<_>>().join("+");
        let mut sorted = causes.to_vec();
        sorted.sort();
        sorted.dedup();
        if sorted.len() != causes.len() || (causes.len() > 1 && causes.contains(&Cause::None)) {
            return Err(HiddenError::Repeated(ids()));
        }
        if !strengths.is_empty() && strengths.len() != causes.len() {
            return Err(HiddenError::Count {
                effects: causes.len(),
                strengths: strengths.len(),
            });
        }
        let effects = causes
            .iter()
            .enumerate()
            .map(|(k, &c)| Effect::new(c, strengths.get(k).copied()))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self(
            effects.into_iter().filter(|e| *e != Effect::None).collect(),
        ))
    }

    /// The effects of `causes`, each drawn by `seed` from the range `strength` names.
    pub fn draw(causes: &[Cause], seed: u64, strength: Strength) -> Self {
        Self(
            causes
                .iter()
                .enumerate()
                .map(|(k, &c)| {
                    Effect::draw_in(c, seed.wrapping_add(1_000_003 * k as u64), strength)
                })
                .filter(|e| *e != Effect::None)
                .collect(),
        )
    }

    /// The causes, in order.
    pub fn causes(&self) -> Vec<Cause> {
        self.0.iter().map(Effect::cause).collect()
    }
}

/// The effects' state as the gyro runs: coil temperature and hysteresis state.
#[derive(Debug, Clone, PartialEq)]
pub struct EffectPlant {
    effects: Vec<Effect>,
    coil_c: f64,
    coil_rate_c_per_min: f64,
    hysteresis: f64,
}

impl EffectPlant {
    /// A gyro stored long at `temp_c` (coil there, hysteresis relaxed).
    pub fn new(hidden: impl Into<Hidden>, temp_c: f64) -> Self {
        Self {
            effects: hidden.into().0,
            coil_c: temp_c,
            coil_rate_c_per_min: 0.0,
            hysteresis: 0.0,
        }
    }

    /// Coil temperature, °C.
    pub fn coil_c(&self) -> f64 {
        self.coil_c
    }

    /// Advances `dt_s` seconds with the housing at `housing_c`; returns the coil temperature.
    pub fn step(&mut self, housing_c: f64, dt_s: f64) -> f64 {
        let before = self.coil_c;
        let lag = self.effects.iter().find_map(|e| match e {
            Effect::SensorLag { tau_min } => Some(*tau_min),
            _ => None,
        });
        self.coil_c = match lag {
            Some(tau_min) => {
                let a = 1.0 - (-dt_s / (tau_min * 60.0)).exp();
                before + a * (housing_c - before)
            }
            None => housing_c,
        };
        self.coil_rate_c_per_min = (self.coil_c - before) / dt_s * 60.0;
        if self.coil_rate_c_per_min.abs() > HYSTERESIS_MIN_RATE_C_PER_MIN {
            let target = self.coil_rate_c_per_min.signum();
            let a = 1.0 - (-dt_s / HYSTERESIS_TAU_S).exp();
            self.hysteresis += a * (target - self.hysteresis);
        }
        self.coil_c
    }

    /// Soaked at `temp_c` after a ramp that heated (`true`) or cooled it: coil there, rate zero,
    /// hysteresis state saturated by the excursion.
    pub fn soak(&mut self, temp_c: f64, heated: bool) {
        self.coil_c = temp_c;
        self.coil_rate_c_per_min = 0.0;
        self.hysteresis = if heated { 1.0 } else { -1.0 };
    }

    /// Extra bias, °/s, at `t_on_s` seconds after power-on: the sum of the effects'.
    pub fn bias_dps(&self, t_on_s: f64) -> f64 {
        self.effects.iter().map(|e| self.bias_of(*e, t_on_s)).sum()
    }

    /// One effect's bias, °/s.
    fn bias_of(&self, effect: Effect, t_on_s: f64) -> f64 {
        let dph = match effect {
            Effect::None | Effect::SensorLag { .. } => 0.0,
            Effect::ThermalRate {
                k_dph_per_c_per_min,
            } => k_dph_per_c_per_min * self.coil_rate_c_per_min,
            Effect::WarmUp {
                amplitude_dph,
                tau_min,
            } => amplitude_dph * (-t_on_s / (tau_min * 60.0)).exp(),
            Effect::Hysteresis { offset_dph } => offset_dph * self.hysteresis,
            Effect::TimeDrift { dph_per_h } => {
                dph_per_h * DRIFT_TAU_S / SECONDS_PER_HOUR * (1.0 - (-t_on_s / DRIFT_TAU_S).exp())
            }
        };
        dph / SECONDS_PER_HOUR
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_stay_in_the_documented_range() {
        for cause in Cause::ALL {
            for seed in 0..20 {
                let e = Effect::draw(cause, seed);
                assert_eq!(e.cause(), cause);
                if let Some((lo, hi)) = range(cause) {
                    assert!((lo..=hi).contains(&e.strength()), "{e:?}");
                }
            }
        }
        assert!(Effect::new(Cause::SensorLag, Some(-1.0)).is_err());
        assert!(Effect::new(Cause::SensorLag, Some(f64::NAN)).is_err());
        assert!(Effect::new(Cause::None, Some(1.0)).is_err());
        assert_eq!(Effect::new(Cause::None, None), Ok(Effect::None));
    }

    #[test]
    fn thermal_rate_bias_follows_the_coil_rate() {
        let e = Effect::new(Cause::ThermalRate, Some(10.0)).unwrap();
        let mut plant = EffectPlant::new(e, 20.0);
        for k in 1..=120 {
            plant.step(20.0 + f64::from(k) / 60.0, 1.0);
        }
        // 1 °C/min × 10 (°/h)/(°C/min) = 10 °/h.
        assert!((plant.bias_dps(0.0) * SECONDS_PER_HOUR - 10.0).abs() < 1e-9);
    }

    #[test]
    fn lagged_coil_trails_a_ramp_by_its_time_constant() {
        let e = Effect::SensorLag { tau_min: 10.0 };
        let mut plant = EffectPlant::new(e, 0.0);
        for k in 1..=7200 {
            plant.step(f64::from(k) / 60.0, 1.0);
        }
        // After 12 time constants of a 1 °C/min ramp the coil is τ·rate = 10 °C behind.
        assert!((120.0 - plant.coil_c() - 10.0).abs() < 0.01);
    }

    #[test]
    fn hysteresis_state_persists_through_a_soak() {
        let e = Effect::Hysteresis { offset_dph: 10.0 };
        let mut plant = EffectPlant::new(e, 0.0);
        for k in 1..=1800 {
            plant.step(f64::from(k) / 60.0, 1.0);
        }
        let heated = plant.bias_dps(0.0) * SECONDS_PER_HOUR;
        for _ in 0..7200 {
            plant.step(30.0, 1.0);
        }
        assert!(heated > 9.0);
        assert_eq!(plant.bias_dps(0.0) * SECONDS_PER_HOUR, heated);
    }

    #[test]
    fn two_effects_act_together_and_parse_from_their_ids() {
        let both = Hidden::new(&[Cause::WarmUp, Cause::ThermalRate], &[30.0, 10.0]).unwrap();
        assert_eq!(both.causes(), vec![Cause::WarmUp, Cause::ThermalRate]);
        let mut plant = EffectPlant::new(both, 20.0);
        for k in 1..=120 {
            plant.step(20.0 + f64::from(k) / 60.0, 1.0);
        }
        // Warm-up 30 °/h at power-on plus 1 °C/min × 10 (°/h)/(°C/min).
        assert!((plant.bias_dps(0.0) * SECONDS_PER_HOUR - 40.0).abs() < 1e-9);
        assert!(Hidden::new(&[Cause::WarmUp, Cause::WarmUp], &[]).is_err());
        assert!(Hidden::new(&[Cause::None, Cause::WarmUp], &[]).is_err());
        assert!(Hidden::new(&[Cause::WarmUp, Cause::Hysteresis], &[30.0]).is_err());
        assert_eq!(Hidden::new(&[Cause::None], &[]).unwrap(), Hidden::default());
        let weak = Hidden::draw(&[Cause::Hysteresis, Cause::TimeDrift], 3, Strength::Weak);
        assert_eq!(weak.causes(), vec![Cause::Hysteresis, Cause::TimeDrift]);
        for e in &weak.0 {
            let (lo, _) = range(e.cause()).unwrap();
            assert!((WEAK_SHARE * lo..=lo).contains(&e.strength()), "{e:?}");
        }
    }

    #[test]
    fn warm_up_decays_and_drift_grows_with_time_on() {
        let w = EffectPlant::new(
            Effect::WarmUp {
                amplitude_dph: 30.0,
                tau_min: 10.0,
            },
            20.0,
        );
        assert!((w.bias_dps(0.0) * SECONDS_PER_HOUR - 30.0).abs() < 1e-12);
        assert!(w.bias_dps(3600.0) * SECONDS_PER_HOUR < 0.1);
        let d = EffectPlant::new(Effect::TimeDrift { dph_per_h: 3.0 }, 20.0);
        let two_hours = d.bias_dps(7200.0) * SECONDS_PER_HOUR;
        assert!((5.5..6.0).contains(&two_hours), "{two_hours}");
    }
}
