//! What every model that decodes must do, whatever its blob held: shared by the mutated-blob test
//! and the fuzz target (`firmware-core/fuzz`), which include this file.

// Test code: the firmware's no-panic lints guard data paths; here a failed check is the point.
#![allow(
    clippy::indexing_slicing,
    clippy::expect_used,
    clippy::panic,
    clippy::unwrap_used
)]

use firmware_core::{FeatureState, Model, Sample};

/// Capacities roomy enough that a mutated blob is refused for what it holds, not for its size.
pub type Roomy = Model<8, 1320, 4096>;

/// Makes the header's payload length and CRC agree with the payload again, so that a mutation
/// reaches the decoder behind the integrity check.
pub use firmware_core::blob::reseal;

/// Input values probed: inside and beyond any trained range, absurd, and not numbers.
const PROBES: [f32; 14] = [
    -1e30,
    -1e4,
    -30.0,
    -3.0,
    -0.5,
    0.0,
    0.4,
    3.0,
    25.0,
    60.0,
    1e4,
    1e30,
    f32::NAN,
    f32::INFINITY,
];

/// Predicts at probe inputs and along a short sample stream; panics if a mean or variance is not
/// finite or a variance is negative. Returns the number of predictions checked.
pub fn exercise(model: &Roomy) -> usize {
    let d = model.dims().d;
    let mut scratch = [0.0f32; 4096];
    let mut checked = 0;
    let mut check = |mean: f32, variance: f32, what: &dyn core::fmt::Debug| {
        assert!(mean.is_finite(), "mean {mean} at {what:?}");
        assert!(
            variance.is_finite() && variance >= 0.0,
            "variance {variance} at {what:?}"
        );
        checked += 1;
    };
    for (i, _) in PROBES.iter().enumerate() {
        let x: Vec<f32> = (0..d).map(|k| PROBES[(i + 3 * k) % PROBES.len()]).collect();
        let mean = model.predict_mean(&x).mean;
        let p = model
            .predict(&x, &mut scratch)
            .expect("scratch holds every centre");
        check(mean, 0.0, &x);
        check(p.mean, p.variance(), &x);
    }
    let mut state = FeatureState::default();
    for (k, &t) in PROBES.iter().enumerate() {
        let sample = Sample {
            time_s: k as f64 * 1.5,
            temp_c: t,
            output: PROBES[(k + 5) % PROBES.len()],
        };
        let p = model
            .compensate(&sample, &mut state, &mut scratch)
            .expect("scratch holds every centre");
        check(p.mean, p.variance(), &sample);
    }
    checked
}
