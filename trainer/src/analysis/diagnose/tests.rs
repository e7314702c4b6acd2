use super::regression::plateau_temperatures;
use super::*;

/// `n` values of a seeded uniform noise in [−1, 1).
fn noise(n: usize, seed: u64) -> Vec<f64> {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| rng.random::<f64>() * 2.0 - 1.0).collect()
}

#[test]
fn best_subset_names_a_pair_that_a_third_cause_imitates() {
    // Two slow, unlike signals (a decaying one and a switching one); the decoy follows their
    // sum closely but not exactly, and predicts more of it alone than either does.
    let n = 400;
    let a: Vec<f64> = (0..n).map(|i| (-((i % 100) as f64) / 15.0).exp()).collect();
    let b: Vec<f64> = (0..n)
        .map(|i| if (i / 37) % 2 == 0 { 1.0 } else { -1.0 })
        .collect();
    let (e1, e2) = (noise(n, 1), noise(n, 2));
    let decoy: Vec<f64> = (0..n)
        .map(|i| 0.8 * (a[i] + 0.5 * b[i]) + 0.25 * e1[i])
        .collect();
    let y: Vec<f64> = (0..n).map(|i| a[i] + 0.5 * b[i] + 0.05 * e2[i]).collect();
    let one = |x: &[f64]| -> Candidates { vec![(1.0, Some(x.to_vec()))] };
    let regressors = vec![
        (Cause::WarmUp, one(&a)),
        (Cause::Hysteresis, one(&b)),
        (Cause::ThermalRate, one(&decoy)),
        (Cause::TimeDrift, one(&noise(n, 3))),
    ];
    let single = |x: &[f64]| {
        let (sse, none) = split_sse(
            &y,
            Constant::Intercept,
            &[&one(x)],
            &interleaved_splits(n),
            false,
        );
        share(sse, none)
    };
    assert!(single(&decoy) > single(&a) && single(&decoy) > single(&b));
    let (named, steps) = select(&y, &regressors, None);
    let mut causes: Vec<Cause> = named.iter().map(|(c, _)| *c).collect();
    causes.sort();
    assert_eq!(causes, vec![Cause::WarmUp, Cause::Hysteresis], "{steps:?}");
    // Noise alone names nothing, and says what the best candidate did.
    let (named, steps) = select(&noise(n, 4), &regressors, None);
    assert!(named.is_empty());
    assert!(!steps[0].added && steps[0].score < MIN_SCORE, "{steps:?}");
}

#[test]
fn a_state_is_named_only_for_what_the_plateau_constants_cannot_follow() {
    // A stream sweeping a soaked table's span up and down; the residual is a static curve
    // that is off at the table's plateaus, which a constant per plateau follows exactly.
    let n = 400;
    let temp: Vec<f64> = (0..n)
        .map(|i| {
            let u = (i % 100) as f64 / 50.0;
            -30.0 + 90.0 * if u < 1.0 { u } else { 2.0 - u }
        })
        .collect();
    let heating: Vec<f64> = (0..n)
        .map(|i| if i % 100 < 50 { 1.0 } else { -1.0 })
        .collect();
    let knots = vec![-30.0, -10.0, 10.0, 30.0, 60.0];
    let plateaus = Plateaus {
        weights: temp.iter().map(|&t| hat_weights(&knots, t)).collect(),
        knots,
    };
    let off = [1.0, -1.0, 0.5, -0.5, 1.0];
    let curve: Vec<f64> = (0..n)
        .map(|i| plateaus.weights[i].iter().map(|&(j, w)| w * off[j]).sum())
        .collect();
    let e = noise(n, 5);
    let one = |x: &[f64]| -> Candidates { vec![(1.0, Some(x.to_vec()))] };
    let regressors = vec![
        (Cause::Hysteresis, one(&heating)),
        (Cause::TimeDrift, one(&noise(n, 6))),
    ];
    let y: Vec<f64> = (0..n).map(|i| curve[i] + 0.05 * e[i]).collect();
    let (named, steps) = select(&y, &regressors, Some(&plateaus));
    assert!(named.is_empty(), "{steps:?}");
    let state = steps[0].state_share.unwrap();
    assert!(
        steps[0].score >= MIN_SCORE && state[0] < MIN_SCORE,
        "{steps:?}"
    );
    // A heating/cooling offset beside it is named.
    let y: Vec<f64> = (0..n)
        .map(|i| curve[i] + 0.3 * heating[i] + 0.05 * e[i])
        .collect();
    let (named, steps) = select(&y, &regressors, Some(&plateaus));
    assert_eq!(named.len(), 1, "{steps:?}");
    assert_eq!(named[0].0, Cause::Hysteresis);
    assert!(steps[0].state_share.unwrap()[1] >= MIN_SCORE, "{steps:?}");
}

#[test]
fn hat_weights_interpolate_and_hold_at_the_ends() {
    let knots = [-30.0, -20.0, 0.0];
    let w = |t| hat_weights(&knots, t);
    assert_eq!(w(-40.0)[0], (0, 1.0));
    assert_eq!(w(5.0)[0], (2, 1.0));
    assert_eq!(w(-25.0), [(0, 0.5), (1, 0.5)]);
    assert_eq!(w(-5.0), [(1, 0.25), (2, 0.75)]);
    assert_eq!(w(0.0)[0], (2, 1.0));
}

#[test]
fn plateau_temperatures_are_means_ascending() {
    let t = plateau_temperatures(&[20.1, -9.9, 19.9, -10.1, 40.0]);
    assert_eq!(t.len(), 3);
    assert!((t[0] + 10.0).abs() < 1e-12 && (t[1] - 20.0).abs() < 1e-12 && t[2] == 40.0);
}

#[test]
fn a_regressor_flat_where_a_test_scores_is_not_seen_there() {
    // A warm-up exp(−t/τ) over 300 blocks, τ 15: gone before the later half.
    let decay: Vec<f64> = (0..300).map(|b| (-f64::from(b) / 15.0).exp()).collect();
    let later: Vec<usize> = (150..300).collect();
    assert!(!sees(&decay, &later));
    let early: Vec<usize> = (0..150).collect();
    assert!(sees(&decay, &early));
    // A drift growing with time is seen in its later half.
    let drift: Vec<f64> = (0..300).map(f64::from).collect();
    assert!(sees(&drift, &later));
}

#[test]
fn forward_splits_train_on_the_past_only() {
    for (train, test) in forward_splits(80) {
        let last = *train.last().unwrap();
        assert!(test.iter().all(|&i| i > last));
        assert_eq!(train, (0..=last).collect::<Vec<_>>());
    }
    let tested: usize = forward_splits(80).iter().map(|(_, t)| t.len()).sum();
    assert_eq!(tested, 40);
}

#[test]
fn a_tail_the_forward_test_cannot_see_is_weighed_against_what_the_design_before_it_leaves() {
    let n = 80;
    let e = noise(n, 5);
    let blocks: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let decay = |tau: f64| -> Vec<f64> { blocks.iter().map(|i| (-i / tau).exp()).collect() };
    // Relative to the later blocks' own error: the ratio of the centred SSEs, as RMS.
    let later_worsening = |y: &[f64], design: &[&Candidates]| {
        let (sse, none) = split_sse(y, Constant::Intercept, design, &forward_splits(n), true);
        (sse / none).sqrt() - 1.0
    };
    // A decay gone by the first origin; the candidate's is slower, so its tail, fitted on the
    // earlier blocks, lies a little off the quiet later ones: harm against their own error, not
    // against the stream's.
    let quiet: Vec<f64> = decay(4.0)
        .iter()
        .zip(&e)
        .map(|(d, e)| d + 0.0005 * e)
        .collect();
    let slower: Candidates = vec![(8.0, Some(decay(8.0)))];
    assert!(!forward_sees(&quiet, Constant::Intercept, &[&slower]));
    assert!(later_worsening(&quiet, &[&slower]) > 0.1);
    let none = |y: &[f64]| Before::new(y, Constant::Intercept, &[]);
    assert!(!blind_harm(
        &quiet,
        Constant::Intercept,
        &[&slower],
        &none(&quiet)
    ));
    // A decline that turns into a rise at the first origin: on all blocks a decay fits it, which
    // has died out in the later blocks; on the earlier blocks alone a line does, whose tail
    // falls where the stream rises.
    let turning: Vec<f64> = blocks
        .iter()
        .zip(&e)
        .map(|(&i, e)| {
            let v = if i < 40.0 {
                1.0 - i / 40.0
            } else {
                0.5 * (i - 40.0) / 40.0
            };
            v + 0.002 * e
        })
        .collect();
    let line: Vec<f64> = blocks.iter().map(|i| 1.0 - i / 80.0).collect();
    let either: Candidates = vec![(12.0, Some(decay(12.0))), (0.0, Some(line))];
    assert!(!forward_sees(&turning, Constant::Intercept, &[&either]));
    assert!(blind_harm(
        &turning,
        Constant::Intercept,
        &[&either],
        &none(&turning)
    ));
    // The same turn beside a warm-up fifty times its size, which the first cause explains: the
    // second cause's tail is small beside the static residual, but not beside what the warm-up
    // leaves, which the design before it is judged on.
    let warm: Candidates = vec![(4.0, Some(decay(4.0)))];
    let beside: Vec<f64> = decay(4.0)
        .iter()
        .zip(&turning)
        .map(|(d, t)| 50.0 * d + t)
        .collect();
    let pair: [&Candidates; 2] = [&warm, &either];
    assert!(!forward_sees(&beside, Constant::Intercept, &pair));
    assert!(!blind_harm(
        &beside,
        Constant::Intercept,
        &pair,
        &none(&beside)
    ));
    let after_warm = Before::new(&beside, Constant::Intercept, &[&warm]);
    assert!(blind_harm(&beside, Constant::Intercept, &pair, &after_warm));
}
