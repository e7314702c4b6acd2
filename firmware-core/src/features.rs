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
//! Whatever the model's inputs, the state also tracks what the model error reads
//! ([`crate::blob::ErrorModel`]): the time since power-on, the heating/cooling state
//! ([`FeatureState::leg`], a play of [`LEG_WIDTH_C`]) and the heating rate
//! ([`FeatureState::heating_rate`], a `TemperatureRate` of [`HEATING_TAU_S`]).
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
//! state always recovers (tests in `features/tests.rs`, one per scenario):
//!
//! | what the sample shows | status | state |
//! |---|---|---|
//! | time, temperature or output NaN or infinite; temperature outside −100…200 °C | `Fault` | untouched: the next good sample continues from the last good one |
//! | time running backwards (counter wrap, reset without power-on) | `Degraded` | the time base re-synchronizes: t_on advances by the last regular step |
//! | time jumping ahead by more than max(60 s, 20 steps) (lost samples, a stalled logger) | `Degraded` | filters advance exactly over the gap, for a temperature moving in a straight line across it |
//! | temperature bit-identical for 600 s (a stuck sensor; real ones show their noise) | `Degraded` while stuck | filters follow the stuck reading |
//! | a changed sample rate | `Valid` | filters advance by the actual Δt: exact |
//! | after [`FeatureState::power_on`], a time no later than the last one (the clock passed stopped while the gyro was off: a time since power-on, a counter that restarted) | `Degraded` until the filters settle | starts again from this sample, as after a reset (the time off is unknown), the calibration run still marked ([`FeatureState::calibration_run`]) |
//!
//! After a time anomaly (and a power-on with the state kept, after more than such a jump), and
//! after a stuck sensor frees itself, outputs stay `Degraded` for three time constants of the
//! slowest filter (temperature rate, coil estimate), until the filters have forgotten the gap.
//! A power-on with the state kept ends neither that nor a stuck reading: the settling goes on
//! across the time off, the stuck reading's count for the time it is read.

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
    /// Time, s: a clock that runs through power-offs where the state is kept through them
    /// ([`FeatureState::power_on`]), a time since power-on where it is reset at each (module
    /// doc). f64: after a day an f32 second count resolves only 8 ms.
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
    /// The last temperature reading's bits, and the time since power-on from which it has held:
    /// negative where it held before a power-on with the state kept, moved back by the time it
    /// was read then (the time off is not counted).
    held: (u32, f64),
    /// Outputs are degraded until this time since power-on, s.
    settle_until_s: f64,
    /// The gyro went through a power cycle with this state kept ([`FeatureState::power_on`]).
    powered_off: bool,
    filters: [f32; MAX_FEATURES],
    /// The heating/cooling play's position, °C ([`FeatureState::leg`]).
    play: f32,
    /// The temperature low-passed over [`HEATING_TAU_S`], °C ([`FeatureState::heating_rate`]).
    heating: f32,
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
    /// [`crate::blob::ErrorModel::scale_var`]) until the next power-on or reset (a power-on whose
    /// clock did not run, which starts the state again, keeps it marked: it was marked after
    /// that power-on). In service every power-on is another, and nothing calls this.
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

    /// The heating rate of the last sample computed, °C/min: the derivative of the temperature
    /// reading through a first-order low-pass of [`HEATING_TAU_S`], as the `TemperatureRate`
    /// input (starting again from rest at a power-on; 0 before the first sample). What the model
    /// error's heating term reads ([`crate::blob::ErrorModel`]), whatever the model's inputs.
    pub fn heating_rate(&self) -> f32 {
        match self.times {
            Some(_) => (f32::from_bits(self.held.0) - self.heating) / HEATING_TAU_S * 60.0,
            None => 0.0,
        }
    }

    /// The temperature reading and heating rate of the last sample computed (°C, °C/min), once
    /// the rate has settled after the power-on ([`HEATING_SETTLE_S`]; `None` before): what the
    /// model error's heating term reads. A rate that starts from rest reads a warm-up's first
    /// minutes as far slower than it is, a rate no lag turns into an error.
    pub fn heating(&self) -> Option<(f32, f32)> {
        (self.times.is_some() && self.time_on_s() >= HEATING_SETTLE_S)
            .then(|| (f32::from_bits(self.held.0), self.heating_rate()))
    }

    fn leg_of(&self, t: f32) -> f32 {
        ((t - self.play) / LEG_WIDTH_C).clamp(-1.0, 1.0)
    }
}

/// Half-width of the play that tells a heating leg from a cooling one, °C: wider than a
/// temperature sensor's noise and quantization (0.0625 °C steps on the common digital ones), and
/// narrow against a thermal cycle's swing, so a leg is known within a degree of its turn.
pub const LEG_WIDTH_C: f32 = 1.0;

/// Time constant of the heating rate the model error reads, s ([`FeatureState::heating_rate`]):
/// long against a temperature sensor's noise and quantization (0.0625 °C steps read over 2 min
/// are 0.03 °C/min), short against a warm-up's or a thermal ramp's change of rate.
pub const HEATING_TAU_S: f32 = 120.0;
/// Time since power-on from which the heating rate is read into the model error, s: three of its
/// time constants, after which a rate that started from rest is within 5 % of a ramp's.
pub const HEATING_SETTLE_S: f64 = 3.0 * HEATING_TAU_S as f64;

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
    if let (true, Some((on_before, previous))) = (warm, state.times) {
        if sample.time_s <= previous {
            // No time off: the clock did not run through the power-off (a time since power-on, or a reset
            // counter): the time off is unknown, so the state starts again from this reading,
            // and the outputs say so until its filters have settled (module doc).
            // The calibration's own power-on stays marked: it was marked after the power-on.
            let calibration_run = state.calibration_run;
            state.reset();
            state.calibration_run = calibration_run;
            restarted = true;
        } else {
            // A power-on: time since power-on starts again here. Filters settling before it go
            // on across the time off, which they cross; a reading held goes on for the time it
            // was read (the sensor was not read while off): both move to the new origin.
            state.times = Some((sample.time_s, previous));
            state.held.1 -= previous - on_before;
            state.settle_until_s = (state.settle_until_s - (sample.time_s - on_before)).max(0.0);
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
    if first || warm {
        // At a power-on the rate starts again from rest, as the `TemperatureRate` input's.
        state.heating = t;
    } else {
        advance(&mut state.heating, HEATING_TAU_S);
    }
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
mod tests;
