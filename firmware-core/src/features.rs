//! The feature pipeline: one raw sample (time, temperature, gyro output) → the model's inputs, in
//! the order of the blob's feature spec.
//!
//! Why here: the trainer builds its training inputs with this same code, so what the firmware
//! computes on the gyro is what the model was fitted on (no train/serve skew, DESIGN §2).
//!
//! Stateful inputs keep their memory in [`FeatureState`], which the caller owns: one per gyro
//! channel, created (or [`FeatureState::reset`]) at power-on. The first sample after that is the
//! power-on instant. With T the sensor reading and Δt the time since the previous sample, each
//! first-order filter advances exactly for that Δt (a = 1 − exp(−Δt/τ)), so a changed sample
//! rate changes nothing but the noise:
//!
//! | feature | state | output |
//! |---|---|---|
//! | `TemperatureRate {τ}` | y ← y + a(T − y) | (T − y)/τ · 60, °C/min: the derivative through a first-order low-pass of τ |
//! | `CoilTemperature {τ}` | y ← y + a(T − y) | y, °C: a coil that follows the sensor with lag τ |
//! | `PowerOnDecay {τ}` | — | exp(−t_on/τ) |
//! | `TimeOn` | — | t_on / 3600, h |
//! | `ThermalState {w}` | p ← clamp(p, T − w, T + w) | (T − p)/w ∈ [−1, 1]: +1 after heating, −1 after cooling, kept through a soak |
//!
//! Filters start at the first reading (rate 0, coil at the sensor, play centred). Temperature and
//! gyro output pass through unchanged.

use crate::blob::Feature;
use crate::model::MAX_INPUTS;

/// Seconds per hour.
const HOUR_S: f64 = 3600.0;

/// One raw sample as the gyro electronics see it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample {
    /// Time since power-on, s. f64: after a day an f32 second count resolves only 8 ms.
    pub time_s: f64,
    /// Temperature-sensor reading, °C.
    pub temp_c: f32,
    /// Gyro output: volts for an analog FOG, counts or a rate for a digital one.
    pub output: f32,
}

/// Memory of the stateful features between samples: the power-on time, the previous sample's time
/// and one filter state per input.
#[derive(Debug, Clone, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FeatureState {
    /// (power-on time, previous sample time), once a sample has been seen.
    times: Option<(f64, f64)>,
    filters: [f32; MAX_INPUTS],
}

impl FeatureState {
    /// Forgets everything: the next sample is a power-on.
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

/// First-order filter gain for a step of `dt_s` with time constant `tau_s`.
fn gain(dt_s: f32, tau_s: f32) -> f32 {
    1.0 - libm::expf(-dt_s / tau_s)
}

/// Computes the inputs for `features` from `sample` into `out` (its first `features.len()`
/// entries) and advances `state`; returns false, leaving both untouched, when `out` is too short
/// or there are more features than [`MAX_INPUTS`].
pub fn compute(
    features: &[Feature],
    sample: &Sample,
    state: &mut FeatureState,
    out: &mut [f32],
) -> bool {
    if out.len() < features.len() || features.len() > MAX_INPUTS {
        return false;
    }
    let t = sample.temp_c;
    let first = state.times.is_none();
    let (on, previous) = state.times.unwrap_or((sample.time_s, sample.time_s));
    // A clock that stands still or runs backwards gives no step; the caller decides whether that
    // is a new power-on (`reset`).
    let dt = (sample.time_s - previous).max(0.0) as f32;
    let t_on = (sample.time_s - on).max(0.0);
    state.times = Some((on, sample.time_s.max(previous)));
    for ((slot, feature), y) in out.iter_mut().zip(features).zip(&mut state.filters) {
        *slot = match *feature {
            Feature::Temperature => t,
            Feature::Voltage => sample.output,
            Feature::TemperatureRate { tau_s } => {
                if first {
                    *y = t;
                }
                *y += gain(dt, tau_s) * (t - *y);
                (t - *y) / tau_s * 60.0
            }
            Feature::CoilTemperature { tau_s } => {
                if first {
                    *y = t;
                }
                *y += gain(dt, tau_s) * (t - *y);
                *y
            }
            Feature::PowerOnDecay { tau_s } => libm::exp(-t_on / f64::from(tau_s)) as f32,
            Feature::TimeOn => (t_on / HOUR_S) as f32,
            Feature::ThermalState { width_c } => {
                if first {
                    *y = t;
                }
                *y = y.clamp(t - width_c, t + width_c);
                (t - *y) / width_c
            }
        };
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(time_s: f64, temp_c: f32) -> Sample {
        Sample {
            time_s,
            temp_c,
            output: -0.25,
        }
    }

    #[test]
    fn inputs_follow_the_feature_order() {
        let mut out = [0.0f32; 3];
        let mut state = FeatureState::default();
        let features = [Feature::Voltage, Feature::Temperature];
        assert!(compute(&features, &at(3.0, 21.5), &mut state, &mut out));
        assert_eq!(out, [-0.25, 21.5, 0.0]);
        assert!(!compute(
            &features,
            &at(3.0, 21.5),
            &mut state,
            &mut out[..1]
        ));
    }

    /// Runs a 1 Hz ramp of `rate` °C/min from 20 °C for `n` samples; returns the last inputs.
    fn ramp(features: &[Feature], rate: f32, n: u32) -> [f32; 4] {
        let mut state = FeatureState::default();
        let mut out = [0.0f32; 4];
        for k in 0..n {
            let s = at(100.0 + f64::from(k), 20.0 + rate * k as f32 / 60.0);
            assert!(compute(features, &s, &mut state, &mut out));
        }
        out
    }

    #[test]
    fn temperature_rate_settles_on_the_ramp_rate() {
        let out = ramp(&[Feature::TemperatureRate { tau_s: 60.0 }], 0.8, 1200);
        // The 1 s steps lag the continuous filter by half a step: 0.8·(1 − 0.5/60).
        assert!((out[0] - 0.8 * (1.0 - 0.5 / 60.0)).abs() < 1e-3, "{out:?}");
        // Started at rest.
        let out = ramp(&[Feature::TemperatureRate { tau_s: 60.0 }], 0.8, 1);
        assert_eq!(out[0], 0.0);
    }

    #[test]
    fn coil_estimate_trails_a_ramp_by_its_lag() {
        let out = ramp(
            &[
                Feature::CoilTemperature { tau_s: 300.0 },
                Feature::Temperature,
            ],
            1.0,
            3600,
        );
        // 1 °C/min for 5 min of lag: 5 °C behind.
        assert!((out[1] - out[0] - 5.0).abs() < 0.01, "{out:?}");
    }

    #[test]
    fn time_features_count_from_the_first_sample() {
        let f = [Feature::PowerOnDecay { tau_s: 600.0 }, Feature::TimeOn];
        let out = ramp(&f, 0.0, 1801);
        assert!((out[0] - (-3.0f32).exp()).abs() < 1e-6, "{out:?}");
        assert!((out[1] - 0.5).abs() < 1e-6);
    }

    #[test]
    fn thermal_state_remembers_the_last_excursion_through_a_soak() {
        let f = [Feature::ThermalState { width_c: 2.0 }];
        let mut state = FeatureState::default();
        let mut out = [0.0f32; 1];
        let mut feed = |time: f64, temp: f32, out: &mut [f32; 1]| {
            assert!(compute(&f, &at(time, temp), &mut state, out));
        };
        feed(0.0, 20.0, &mut out);
        assert_eq!(out[0], 0.0);
        feed(1.0, 30.0, &mut out);
        assert_eq!(out[0], 1.0);
        feed(5000.0, 30.0, &mut out);
        assert_eq!(out[0], 1.0, "heated state kept through a soak");
        feed(5001.0, 29.0, &mut out);
        assert_eq!(out[0], 0.5);
        feed(5002.0, 10.0, &mut out);
        assert_eq!(out[0], -1.0);
    }

    #[test]
    fn reset_makes_the_next_sample_a_power_on() {
        let f = [Feature::TimeOn, Feature::TemperatureRate { tau_s: 30.0 }];
        let mut state = FeatureState::default();
        let mut out = [0.0f32; 2];
        assert!(compute(&f, &at(0.0, 20.0), &mut state, &mut out));
        assert!(compute(&f, &at(3600.0, 25.0), &mut state, &mut out));
        assert_eq!(out[0], 1.0);
        state.reset();
        assert!(compute(&f, &at(7200.0, 25.0), &mut state, &mut out));
        assert_eq!(out, [0.0, 0.0]);
    }
}
