//! What every model that decodes must do, whatever its blob held: shared by the mutated-blob test
//! and the fuzz target (`firmware-core/fuzz`), which include this file.

// Test code: the firmware's no-panic lints guard data paths; here a failed check is the point.
#![allow(
    clippy::indexing_slicing,
    clippy::expect_used,
    clippy::panic,
    clippy::unwrap_used
)]

use firmware_core::model::Conditions;
use firmware_core::{Evaluation, FeatureState, Mean, Model, Prediction, Prepared, Sample};

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
/// finite or a variance is negative, or if the same samples evaluated side by side (the host's
/// `Model::evaluate` and `Model::means`) differ from them by a bit. Returns the number of
/// predictions checked.
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
    // The same predictions side by side, as a host replays them ([`same`]).
    let mut prepared = Vec::new();
    let mut expected = Vec::new();
    for (i, _) in PROBES.iter().enumerate() {
        let x: Vec<f32> = (0..d).map(|k| PROBES[(i + 3 * k) % PROBES.len()]).collect();
        let mean = model.predict_mean(&x);
        let p = model
            .predict(&x, &mut scratch)
            .expect("scratch holds every centre");
        check(mean.mean, 0.0, &x);
        check(p.mean, p.variance(), &x);
        let inputs = Prepared::inputs(&x, Conditions::at_hours(0.0));
        prepared.push(inputs);
        expected.push((p, mean, model.mean_of(&inputs).1));
    }
    same(model, &prepared, &expected);
    let (mut state, mut twin) = (FeatureState::default(), FeatureState::default());
    let (mut prepared, mut expected) = (Vec::new(), Vec::new());
    for (k, &t) in PROBES.iter().enumerate() {
        let sample = Sample {
            time_s: k as f64 * 1.5,
            temp_c: t,
            output: PROBES[(k + 5) % PROBES.len()],
        };
        let (mean, excess2) = model.compensate_mean(&sample, &mut state.clone());
        let p = model
            .compensate(&sample, &mut state, &mut scratch)
            .expect("scratch holds every centre");
        check(p.mean, p.variance(), &sample);
        prepared.push(model.prepare(&sample, &mut twin));
        expected.push((p, mean, excess2));
    }
    same(model, &prepared, &expected);
    checked
}

/// Each evaluation side by side, and each mean path side by side (`Model::means`), is bit for
/// bit the prediction and mean path of its sample alone.
fn same<const D: usize, const E: usize, const N: usize>(
    model: &Model<D, E, N>,
    prepared: &[Prepared<D>],
    expected: &[(Prediction, Mean, f32)],
) {
    let mut lanes = vec![0.0f32; model.evaluate_scratch_len()];
    let mut evaluations = vec![Evaluation::NONE; prepared.len()];
    model
        .evaluate(prepared, &mut lanes, &mut evaluations)
        .expect("the scratch is sized for it");
    let mut means = vec![(Mean::FAULT, 0.0); prepared.len()];
    model.means(prepared, &mut means);
    let bits = |p: &Prediction| {
        (
            p.mean.to_bits(),
            p.bias_variance.to_bits(),
            p.noise_variance.to_bits(),
            p.status,
        )
    };
    for ((e, (mean, excess2)), (p, m, alone)) in evaluations.iter().zip(&means).zip(expected) {
        assert_eq!(bits(&e.prediction), bits(p), "{e:?} vs {p:?}");
        for (batched, what) in [(e.mean, "evaluate"), (*mean, "means")] {
            assert_eq!(
                (batched.mean.to_bits(), batched.status),
                (m.mean.to_bits(), m.status),
                "{what}: {batched:?} vs {m:?}"
            );
        }
        for batched in [*excess2, e.excess2] {
            assert_eq!(batched.to_bits(), alone.to_bits(), "e(x)² of {m:?}");
        }
    }
}
