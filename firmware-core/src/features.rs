//! The feature pipeline: one raw sample (time, temperature, gyro output) → the model's inputs, in
//! the order of the blob's feature spec.
//!
//! Why here: the trainer builds its training inputs with this same code, so what the firmware
//! computes on the gyro is what the model was fitted on (no train/serve skew, docs/design.md §2).
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
//!
//! # Power cycles
//!
//! A coil and its hysteresis do not forget their temperature history when the electronics are
//! switched off: after a short power-off in a soak the coil is still degrees warmer than the
//! housing the sensor reads, and a reset filter that starts the coil at the sensor is wrong by that
//! much for three lags (on the simulated gyro, 0.9 °C RMS over a day with three power-offs, and at
//! 80 °/s every °C is tens of °/h through the scale factor). So the state can be kept: stored at
//! power-down (it is plain data: `serde`, or the bytes of the C interface's `FogState`), restored
//! at boot, then [`FeatureState::power_on`]. The next sample is then a power-on for the time
//! inputs (t_on starts again: a warm-up and a time drift begin at every power-on), while the coil
//! estimate crosses the time off as a gap: exactly, for a temperature that moved in a straight line
//! from the last reading before the power-off to the first after it (y ← T₁ − (T₁ − T₀)·τ/Δt·a +
//! (y − T₀)(1 − a)), and the play operator takes the new reading (exact for any monotone change).
//! On the simulated day this leaves the coil estimate 0.03 °C RMS from the coil. The temperature
//! rate starts again from rest, as after a reset: two readings minutes apart give the mean slope
//! of the time off, not the rate at its end (the housing cools and warms again with the
//! self-heating, not in a straight line), and carried through, that slope left a residual after
//! each power-on which a heating/cooling state took up (docs/diagnosis.md). It needs a clock
//! that ran while the gyro was off (a real-time clock, or the host's time); a sample time no later
//! than the last one (no time off) says it did not, and the state starts again as after a reset, its outputs
//! `Degraded` until the filters have settled. So pass a time that keeps running through power-offs
//! (the sample's `time_s`); a time since power-on is right only where the state is reset, not
//! kept, at every power-on.
//!
//! # Sensor faults
//!
//! [`compute`] returns the health of its inputs as a [`Status`]; the model takes the worse of it
//! and its own (`Extrapolating` beyond the trained range). Each fault has one behaviour, and the
//! state always recovers (tests below, one per scenario):
//!
//! | what the sample shows | status | state |
//! |---|---|---|
//! | time, temperature or output NaN or infinite; temperature outside −100…200 °C | `Fault` | untouched: the next good sample continues from the last good one |
//! | time running backwards (counter wrap, reset without power-on) | `Degraded` | the time base re-synchronizes: t_on advances by the last regular step |
//! | time jumping ahead by more than max(60 s, 20 steps) (lost samples, a stalled logger) | `Degraded` | filters advance exactly over the gap, for a temperature moving in a straight line across it |
//! | temperature bit-identical for 600 s (a stuck sensor; real ones show their noise) | `Degraded` while stuck | filters follow the stuck reading |
//! | a changed sample rate | `Valid` | filters advance by the actual Δt: exact |
//! | after [`FeatureState::power_on`], a time no later than the last one (the clock passed stopped while the gyro was off: a time since power-on, a counter that restarted) | `Degraded` until the filters settle | starts again from this sample, as after a reset (the time off is unknown) |
//!
//! After a time anomaly (and a power-on with the state kept, after more than such a jump), and
//! after a stuck sensor frees itself, outputs stay `Degraded` for three time constants of the
//! slowest filter (temperature rate, coil estimate), until the filters have forgotten the gap.

use serde::{Deserialize, Serialize};

use crate::blob::Feature;
use crate::status::Status;
use crate::units::SECONDS_PER_HOUR;

/// Most model inputs the pipeline computes and any evaluator accepts, whatever its capacity: the
/// evaluator's kernel loop is compiled for each input count up to this.
pub const MAX_INPUTS: usize = 8;
/// Most features one pipeline computes: a unit's channels share theirs (their temperature inputs,
/// each computed once per sample, [`crate::unit`]), so one state holds more filters than one
/// model has inputs.
pub const MAX_FEATURES: usize = 16;

/// Temperatures a FOG's sensor can read, °C; beyond them the reading is a fault.
const TEMP_RANGE_C: core::ops::RangeInclusive<f32> = -100.0..=200.0;
/// A step longer than this, s, and [`JUMP_STEPS`] regular steps, is a time jump.
pub const JUMP_MIN_S: f64 = 60.0;
/// Regular steps in a time jump (with [`JUMP_MIN_S`]).
pub const JUMP_STEPS: f64 = 20.0;
/// A temperature reading unchanged (bit for bit) this long, s, is a stuck sensor.
const STUCK_S: f64 = 600.0;
/// Time constants of the slowest filter during which outputs stay degraded after an anomaly.
const SETTLE_TAUS: f32 = 3.0;

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
/// and one filter state per input, with what the fault checks need (module doc).
///
/// Plain data (`serde`): to keep it through a power cycle, store it at power-down and call
/// [`FeatureState::power_on`] on it at boot (module doc).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FeatureState {
    /// (power-on time, previous sample time), once a sample has been seen.
    times: Option<(f64, f64)>,
    /// The last regular step between samples, s (0 until there is one).
    step_s: f64,
    /// The last temperature reading's bits, and the time since power-on from which it has held.
    held: (u32, f64),
    /// Outputs are degraded until this time since power-on, s.
    settle_until_s: f64,
    /// The gyro went through a power cycle with this state kept ([`FeatureState::power_on`]).
    powered_off: bool,
    filters: [f32; MAX_FEATURES],
    /// The heating/cooling play's position, °C ([`FeatureState::leg`]).
    play: f32,
    /// The samples are of the calibration's own power-on ([`FeatureState::calibration_run`]).
    calibration_run: bool,
}

impl FeatureState {
    /// Forgets everything: the next sample is a power-on, the filters start again from it.
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// The gyro was switched off and on again and this state kept through it: the next sample is
    /// a power-on (time since power-on starts again and so does the temperature rate), and the
    /// coil estimate and the play cross the time off from the last sample before it (module doc).
    /// On a state that has seen no sample, as [`Self::reset`].
    pub fn power_on(&mut self) {
        self.powered_off = self.times.is_some();
        self.calibration_run = false;
    }

    /// The samples to come are of the power-on the model was calibrated on (its held-out part,
    /// on the rig): its turn-on bias and scale are in the model, so the model error leaves out the
    /// terms for another power-on's ([`crate::blob::ErrorModel::turn_on_var`],
    /// [`crate::blob::ErrorModel::scale_var`]) until the next power-on or reset. In service every
    /// power-on is another, and nothing calls this.
    pub fn calibration_run(&mut self) {
        self.calibration_run = true;
    }

    /// Whether the last sample was of the calibration's own power-on
    /// ([`Self::calibration_run`]).
    pub fn in_calibration_run(&self) -> bool {
        self.calibration_run
    }

    /// Time since power-on of the last sample computed, s (0 before the first): what the model
    /// error's time terms read ([`crate::blob::ErrorModel`]).
    pub fn time_on_s(&self) -> f64 {
        self.times.map_or(0.0, |(on, last)| (last - on).max(0.0))
    }

    /// The heating/cooling state of the last sample computed, in [−1, 1]: a play of half-width
    /// [`LEG_WIDTH_C`] on the temperature reading, as the `ThermalState` input (+1 after heating,
    /// −1 after cooling, kept through a soak; 0 before the first sample). What the model error's
    /// leg term reads ([`crate::blob::ErrorModel`]), whatever the model's inputs.
    pub fn leg(&self) -> f32 {
        match self.times {
            Some(_) => self.leg_of(f32::from_bits(self.held.0)),
            None => 0.0,
        }
    }

    fn leg_of(&self, t: f32) -> f32 {
        ((t - self.play) / LEG_WIDTH_C).clamp(-1.0, 1.0)
    }
}

/// Half-width of the play that tells a heating leg from a cooling one, °C: wider than a
/// temperature sensor's noise and quantization (0.0625 °C steps on the common digital ones), and
/// narrow against a thermal cycle's swing, so a leg is known within a degree of its turn.
pub const LEG_WIDTH_C: f32 = 1.0;

/// First-order filter gain for a step of `dt_s` with time constant `tau_s`.
fn gain(dt_s: f32, tau_s: f32) -> f32 {
    1.0 - libm::expf(-dt_s / tau_s)
}

/// Seconds the outputs stay degraded after an anomaly: [`SETTLE_TAUS`] time constants of the
/// slowest filter among `features` (0 without filters).
fn settle_s(features: &[Feature]) -> f64 {
    let slowest = features.iter().fold(0.0f32, |m, f| match *f {
        Feature::TemperatureRate { tau_s } | Feature::CoilTemperature { tau_s } => m.max(tau_s),
        _ => m,
    });
    f64::from(SETTLE_TAUS * slowest)
}

/// Computes the inputs for `features` from `sample` into `out` (its first `features.len()`
/// entries) and advances `state`; returns the health of the inputs (module doc). `Fault` leaves
/// both untouched, as does an `out` too short or more features than [`MAX_FEATURES`].
pub fn compute(
    features: &[Feature],
    sample: &Sample,
    state: &mut FeatureState,
    out: &mut [f32],
) -> Status {
    let t = sample.temp_c;
    if out.len() < features.len()
        || features.len() > MAX_FEATURES
        || !sample.time_s.is_finite()
        || !sample.output.is_finite()
        || !TEMP_RANGE_C.contains(&t)
    {
        return Status::Fault;
    }
    let warm = core::mem::take(&mut state.powered_off);
    let mut restarted = false;
    if let (true, Some((_, previous))) = (warm, state.times) {
        if sample.time_s <= previous {
            // No time off: the clock did not run through the power-off (a time since power-on, or a reset
            // counter): the time off is unknown, so the state starts again from this reading,
            // and the outputs say so until its filters have settled (module doc).
            state.reset();
            restarted = true;
        } else {
            // A power-on: time since power-on starts again here; what held before it is over.
            state.times = Some((sample.time_s, previous));
            state.held.1 = 0.0;
            state.settle_until_s = 0.0;
        }
    }
    let first = state.times.is_none();
    let warm = warm && !first;
    let (mut on, previous) = state.times.unwrap_or((sample.time_s, sample.time_s));
    let raw_dt = sample.time_s - previous;
    let jump = raw_dt > JUMP_MIN_S.max(JUMP_STEPS * state.step_s);
    // A power-on with the state kept is no anomaly; its filters settle as after one (below).
    let anomaly = !first && !warm && (raw_dt < 0.0 || jump);
    let step = if raw_dt < 0.0 {
        // The origin moves so that time since power-on advances by one regular step.
        on += raw_dt - state.step_s;
        state.step_s
    } else {
        if !anomaly && !warm && raw_dt > 0.0 {
            state.step_s = raw_dt;
        }
        raw_dt
    };
    let dt = step as f32;
    // A gap the filters did not see: crossed along a straight line between the readings either
    // side of it (module doc). Between regular samples the reading is held over the step.
    let across = (warm || (anomaly && raw_dt > 0.0)) && dt > 0.0;
    let before = f32::from_bits(state.held.0);
    let advance = |y: &mut f32, tau_s: f32| {
        let a = gain(dt, tau_s);
        if across {
            *y = t - (t - before) * (tau_s / dt) * a + (*y - before) * (1.0 - a);
        } else {
            *y += a * (t - *y);
        }
    };
    let t_on = (sample.time_s - on).max(0.0);
    state.play = if first {
        t
    } else {
        state.play.clamp(t - LEG_WIDTH_C, t + LEG_WIDTH_C)
    };
    state.times = Some((on, sample.time_s));
    let settle = settle_s(features);
    if first || t.to_bits() != state.held.0 {
        if !first && t_on - state.held.1 >= STUCK_S {
            // A stuck sensor freed: the filters have followed a constant reading.
            state.settle_until_s = state.settle_until_s.max(t_on + settle);
        }
        state.held = (t.to_bits(), t_on);
    }
    if anomaly || (warm && jump) || restarted {
        state.settle_until_s = t_on + settle;
    }
    let health =
        if anomaly || restarted || t_on - state.held.1 >= STUCK_S || t_on < state.settle_until_s {
            Status::Degraded
        } else {
            Status::Valid
        };
    for ((slot, feature), y) in out.iter_mut().zip(features).zip(&mut state.filters) {
        *slot = match *feature {
            Feature::Temperature => t,
            Feature::Voltage => sample.output,
            Feature::TemperatureRate { tau_s } => {
                if first || warm {
                    // At a power-on the rate starts again from rest (module doc).
                    *y = t;
                } else {
                    advance(y, tau_s);
                }
                (t - *y) / tau_s * 60.0
            }
            Feature::CoilTemperature { tau_s } => {
                if first {
                    *y = t;
                }
                advance(y, tau_s);
                *y
            }
            Feature::PowerOnDecay { tau_s } => libm::exp(-t_on / f64::from(tau_s)) as f32,
            Feature::TimeOn => (t_on / SECONDS_PER_HOUR) as f32,
            Feature::ThermalState { width_c } => {
                if first {
                    *y = t;
                }
                *y = y.clamp(t - width_c, t + width_c);
                (t - *y) / width_c
            }
        };
    }
    health
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
        assert_eq!(
            compute(&features, &at(3.0, 21.5), &mut state, &mut out),
            Status::Valid
        );
        assert_eq!(out, [-0.25, 21.5, 0.0]);
        assert_eq!(
            compute(&features, &at(3.0, 21.5), &mut state, &mut out[..1]),
            Status::Fault
        );
    }

    /// Runs a 1 Hz ramp of `rate` °C/min from 20 °C for `n` samples; returns the last inputs.
    fn ramp(features: &[Feature], rate: f32, n: u32) -> [f32; 4] {
        let mut state = FeatureState::default();
        let mut out = [0.0f32; 4];
        for k in 0..n {
            let s = at(100.0 + f64::from(k), 20.0 + rate * k as f32 / 60.0);
            assert_ne!(compute(features, &s, &mut state, &mut out), Status::Fault);
        }
        out
    }

    #[test]
    fn the_leg_follows_heating_and_cooling_whatever_the_inputs() {
        let mut state = FeatureState::default();
        let mut out = [0.0f32; 1];
        assert_eq!(state.leg(), 0.0);
        let mut run = |state: &mut FeatureState, from: u32, temps: &[f32]| {
            for (k, t) in temps.iter().enumerate() {
                let s = at(f64::from(from) + k as f64, *t);
                assert_eq!(
                    compute(&[Feature::Voltage], &s, state, &mut out),
                    Status::Valid
                );
            }
        };
        run(&mut state, 0, &[20.0, 20.5, 21.0, 22.0, 23.0]);
        assert_eq!(state.leg(), 1.0);
        // A turn: half the play's width back is half-way, its full width a cooling leg.
        run(&mut state, 5, &[22.5]);
        assert_eq!(state.leg(), 0.5);
        run(&mut state, 6, &[21.5, 21.0]);
        assert_eq!(state.leg(), -1.0);
        // A soak keeps it.
        run(&mut state, 8, &[21.0; 20]);
        assert_eq!(state.leg(), -1.0);
        // Kept through a power cycle, as the play of the ThermalState input.
        state.power_on();
        run(&mut state, 100, &[21.0]);
        assert_eq!(state.leg(), -1.0);
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
            assert_ne!(compute(&f, &at(time, temp), &mut state, out), Status::Fault);
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
        assert_eq!(
            compute(&f, &at(0.0, 20.0), &mut state, &mut out),
            Status::Valid
        );
        // An hour without samples is a time jump.
        assert_eq!(
            compute(&f, &at(3600.0, 25.0), &mut state, &mut out),
            Status::Degraded
        );
        assert_eq!(out[0], 1.0);
        state.reset();
        assert_eq!(
            compute(&f, &at(7200.0, 25.0), &mut state, &mut out),
            Status::Valid
        );
        assert_eq!(out, [0.0, 0.0]);
    }

    /// An hour of heating at 1 °C/min from 20 °C at 1 Hz through `f`: the state at its end.
    fn heated(f: &[Feature]) -> FeatureState {
        let mut state = FeatureState::default();
        let mut out = [0.0f32; 3];
        for k in 0..=3600 {
            let s = at(f64::from(k), 20.0 + k as f32 / 60.0);
            assert_eq!(compute(f, &s, &mut state, &mut out), Status::Valid);
        }
        state
    }

    const KEPT: [Feature; 3] = [
        Feature::CoilTemperature { tau_s: 600.0 },
        Feature::TimeOn,
        Feature::ThermalState { width_c: 1.0 },
    ];

    /// The exact answer of [`KEPT`]'s 600 s lag, from its estimate in `heated` (80 °C at 3600 s),
    /// after a straight line to `t1` over `dt_s`.
    fn lag_across(heated: &FeatureState, dt_s: f64, t1: f64) -> f64 {
        let mut last = [0.0f32; 3];
        // The last sample again: no time passes.
        assert_eq!(
            compute(&KEPT, &at(3600.0, 80.0), &mut heated.clone(), &mut last),
            Status::Valid
        );
        let (tau, t0) = (600.0, 80.0);
        let e = (-dt_s / tau).exp();
        t1 - (t1 - t0) * tau / dt_s * (1.0 - e) + (f64::from(last[0]) - t0) * e
    }

    #[test]
    fn a_kept_state_crosses_a_power_off_along_a_straight_line() {
        let state = heated(&KEPT);
        let mut out = [0.0f32; 3];
        // Off for 20 minutes; back on 5 °C cooler than the last reading (80 °C).
        let back = at(3600.0 + 1200.0, 75.0);
        let mut kept = state.clone();
        kept.power_on();
        assert_eq!(compute(&KEPT, &back, &mut kept, &mut out), Status::Degraded);
        assert_eq!(out[1], 0.0, "time since power-on starts again");
        // From the coil 10 °C (less the half-step lag) behind the ramp.
        let exact = lag_across(&state, 1200.0, 75.0);
        assert!(
            (f64::from(out[0]) - exact).abs() < 1e-3,
            "{out:?} against {exact}"
        );
        assert!(
            out[0] > 75.0,
            "the coil kept warming towards the sensor, then passed it"
        );
        assert_eq!(out[2], -1.0, "5 °C of cooling moved the play");
        // Degraded for three lags, then valid.
        let statuses: std::vec::Vec<Status> = (1..=1900)
            .map(|k| {
                let s = at(4800.0 + f64::from(k), 75.0 + k as f32 * 1e-3);
                compute(&KEPT, &s, &mut kept, &mut out)
            })
            .collect();
        assert!(all(&statuses, 0, 1799, Status::Degraded));
        assert!(all(&statuses, 1799, 1900, Status::Valid));
        // A reset state starts the coil at the sensor and the play centred.
        let mut cold = state;
        cold.reset();
        assert_eq!(compute(&KEPT, &back, &mut cold, &mut out), Status::Valid);
        assert_eq!(out, [75.0, 0.0, 0.0]);
    }

    #[test]
    fn lost_samples_are_crossed_along_a_straight_line() {
        let mut state = heated(&KEPT);
        let exact = lag_across(&state, 600.0, 70.0);
        let mut out = [0.0f32; 3];
        // Ten minutes lost, no power-off: 80 → 70 °C.
        assert_eq!(
            compute(&KEPT, &at(4200.0, 70.0), &mut state, &mut out),
            Status::Degraded
        );
        assert!(
            (f64::from(out[0]) - exact).abs() < 1e-3,
            "{out:?} against {exact}"
        );
        assert!(
            (out[1] - 4200.0 / 3600.0).abs() < 1e-6,
            "no power-on: t_on runs on"
        );
    }

    #[test]
    fn the_temperature_rate_starts_again_from_rest_at_a_power_on() {
        let f = [Feature::TemperatureRate { tau_s: 60.0 }];
        let mut state = heated(&f);
        state.power_on();
        let mut out = [0.0f32; 1];
        assert_eq!(
            compute(&f, &at(4800.0, 75.0), &mut state, &mut out),
            Status::Degraded
        );
        assert_eq!(out[0], 0.0);
    }

    #[test]
    fn a_clock_that_stopped_while_off_starts_the_state_again_and_says_so() {
        let mut kept = heated(&KEPT);
        kept.power_on();
        let mut out = [0.0f32; 3];
        // A time since power-on passed after a power-on with the state kept: it went back.
        assert_eq!(
            compute(&KEPT, &at(12.0, 30.0), &mut kept, &mut out),
            Status::Degraded
        );
        assert_eq!(out, [30.0, 0.0, 0.0]);
        // A power-on with no time off at all says the same.
        let mut same = heated(&KEPT);
        let last = same.times.unwrap().1;
        same.power_on();
        assert_eq!(
            compute(&KEPT, &at(last, 30.0), &mut same, &mut out),
            Status::Degraded
        );
        // Degraded while the restarted filters settle (three of the slowest τ), then valid.
        let settle = settle_s(&KEPT);
        let mut last = Status::Degraded;
        let mut t = 12.0;
        while t < 12.0 + settle + 2.0 {
            t += 1.0;
            // A reading that moves, as a real sensor's does (a fixed one is a stuck sensor).
            last = compute(&KEPT, &at(t, 30.0 + 1e-3 * t as f32), &mut kept, &mut out);
            if t < 12.0 + settle - 1.0 {
                assert_eq!(last, Status::Degraded, "{t}");
            }
        }
        assert_eq!(last, Status::Valid);
    }

    #[test]
    fn a_stored_state_is_the_state() {
        let state = heated(&KEPT);
        let mut buf = [0u8; 128];
        let bytes = postcard::to_slice(&state, &mut buf).unwrap();
        let back: FeatureState = postcard::from_bytes(bytes).unwrap();
        assert_eq!(back, state);
    }

    /// Feeds a 1 Hz ramp of 0.5 °C/min through `f` from `start`, with `sample` editing each
    /// sample (time, temperature) by its index; returns each sample's status and the last inputs.
    fn run(
        f: &[Feature],
        n: usize,
        mut sample: impl FnMut(usize, &mut Sample),
        state: &mut FeatureState,
    ) -> (std::vec::Vec<Status>, [f32; 2]) {
        let mut out = [0.0f32; 2];
        let statuses = (0..n)
            .map(|k| {
                let mut s = at(k as f64, 20.0 + 0.5 * k as f32 / 60.0);
                sample(k, &mut s);
                compute(f, &s, state, &mut out)
            })
            .collect();
        (statuses, out)
    }

    const RATE: [Feature; 2] = [Feature::TemperatureRate { tau_s: 60.0 }, Feature::TimeOn];

    /// Samples `from..to` of `statuses` all equal `want`.
    fn all(statuses: &[Status], from: usize, to: usize, want: Status) -> bool {
        statuses[from..to].iter().all(|s| *s == want)
    }

    #[test]
    fn non_finite_or_impossible_readings_are_faults_that_leave_the_state_alone() {
        for bad in [f32::NAN, f32::INFINITY, -300.0, 1e30] {
            let mut state = FeatureState::default();
            let (statuses, out) = run(
                &RATE,
                1200,
                |k, s| {
                    if (600..610).contains(&k) {
                        s.temp_c = bad;
                    }
                    if k == 620 {
                        s.output = f32::NAN;
                    }
                    if k == 630 {
                        s.time_s = f64::NAN;
                    }
                },
                &mut state,
            );
            assert!(all(&statuses, 600, 610, Status::Fault), "{bad}");
            assert_eq!(statuses[620], Status::Fault);
            assert_eq!(statuses[630], Status::Fault);
            // Ten lost seconds are no time jump: the filter continues, and the output is valid.
            assert!(all(&statuses, 610, 620, Status::Valid), "{bad}");
            assert!(all(&statuses, 631, 1200, Status::Valid));
            assert!((out[0] - 0.5).abs() < 0.01, "rate {} after {bad}", out[0]);
            assert!((out[1] - 1199.0 / 3600.0).abs() < 1e-6);
        }
    }

    #[test]
    fn a_clock_running_backwards_resynchronizes_and_settles() {
        let mut state = FeatureState::default();
        // At sample 500 the counter wraps: time restarts from 0 (no power-on).
        let (statuses, out) = run(
            &RATE,
            1500,
            |k, s| {
                if k >= 500 {
                    s.time_s -= 10_000.0;
                }
            },
            &mut state,
        );
        assert!(all(&statuses, 0, 500, Status::Valid));
        // Degraded for three filter time constants, then valid again.
        assert!(all(&statuses, 500, 680, Status::Degraded));
        assert!(all(&statuses, 680, 1500, Status::Valid));
        // Time since power-on ran on as if nothing happened.
        assert!((out[1] - 1499.0 / 3600.0).abs() < 1e-6, "{out:?}");
        assert!((out[0] - 0.5).abs() < 0.01, "{out:?}");
    }

    #[test]
    fn a_time_jump_is_degraded_until_the_filters_settle() {
        let mut state = FeatureState::default();
        let (statuses, out) = run(
            &RATE,
            1500,
            |k, s| {
                if k >= 700 {
                    s.time_s += 3600.0;
                }
            },
            &mut state,
        );
        assert!(all(&statuses, 0, 700, Status::Valid));
        assert!(all(&statuses, 700, 880, Status::Degraded));
        assert!(all(&statuses, 880, 1500, Status::Valid));
        assert!((out[0] - 0.5).abs() < 0.01, "{out:?}");
        assert!((out[1] - (1499.0 + 3600.0) / 3600.0).abs() < 1e-6);
    }

    #[test]
    fn a_stuck_temperature_sensor_is_flagged_and_recovers() {
        let mut state = FeatureState::default();
        // The sensor freezes at sample 300 for 20 minutes, then reads again.
        let (statuses, out) = run(
            &RATE,
            3000,
            |k, s| {
                if (300..1500).contains(&k) {
                    s.temp_c = 20.0 + 0.5 * 300.0 / 60.0;
                }
            },
            &mut state,
        );
        assert!(all(&statuses, 0, 900, Status::Valid));
        assert!(all(&statuses, 900, 1500, Status::Degraded));
        assert!(all(&statuses, 1500, 1680, Status::Degraded));
        assert!(all(&statuses, 1680, 3000, Status::Valid));
        assert!((out[0] - 0.5).abs() < 0.01, "{out:?}");
    }

    #[test]
    fn a_changed_sample_rate_is_followed_exactly() {
        let mut state = FeatureState::default();
        // 1 Hz, then 10 Hz, then one sample every 20 s: the filter advances by the actual step.
        let time = |k: usize| match k {
            0..600 => k as f64,
            600..6600 => 600.0 + (k - 600) as f64 * 0.1,
            _ => 1200.0 + (k - 6600) as f64 * 20.0,
        };
        let mut out = [0.0f32; 2];
        for k in 0..6700 {
            let t = time(k);
            let s = at(t, 20.0 + 0.5 * (t / 60.0) as f32);
            assert_eq!(
                compute(&RATE, &s, &mut state, &mut out),
                Status::Valid,
                "{k}"
            );
            if k == 6599 || k == 6699 {
                // Past the first filter time constants, the rate is the ramp's (less the lag of
                // half a step at 20 s steps).
                assert!((out[0] - 0.5).abs() < 0.1, "{k}: {out:?}");
            }
        }
    }
}
