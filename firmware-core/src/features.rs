//! The feature pipeline: one raw sample (time, temperature, gyro output) → the model's inputs, in
//! the order of the blob's feature spec.
//!
//! Why here: the trainer builds its training inputs with this same code, so what the firmware
//! computes on the gyro is what the model was fitted on (no train/serve skew, DESIGN §2). Stateful
//! inputs (a temperature rate needs the previous samples) keep their memory in [`FeatureState`],
//! which the caller owns: one per gyro channel, reset at power-on. Temperature and gyro output are
//! passed through unchanged and need no state.

use crate::blob::Feature;

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

/// Memory of the stateful features between samples. The features of this format version are
/// all stateless, so the state is empty; it is part of the interface so that adding one does not
/// change the calls.
#[derive(Debug, Clone, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FeatureState {}

/// Computes the inputs for `features` from `sample` into `out` (its first `features.len()`
/// entries); returns false, leaving `out` untouched, when `out` is too short.
pub fn compute(
    features: &[Feature],
    sample: &Sample,
    _state: &mut FeatureState,
    out: &mut [f32],
) -> bool {
    if out.len() < features.len() {
        return false;
    }
    for (slot, feature) in out.iter_mut().zip(features) {
        *slot = match feature {
            Feature::Temperature => sample.temp_c,
            Feature::Voltage => sample.output,
        };
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inputs_follow_the_feature_order() {
        let s = Sample {
            time_s: 3.0,
            temp_c: 21.5,
            output: -0.25,
        };
        let mut out = [0.0f32; 3];
        let mut state = FeatureState::default();
        assert!(compute(
            &[Feature::Voltage, Feature::Temperature],
            &s,
            &mut state,
            &mut out
        ));
        assert_eq!(out, [-0.25, 21.5, 0.0]);
        assert!(!compute(
            &[Feature::Voltage, Feature::Temperature],
            &s,
            &mut state,
            &mut out[..1]
        ));
    }
}
