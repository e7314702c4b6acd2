use super::*;

#[test]
fn a_test_that_cannot_see_the_extension_abstains_but_still_refuses_harm() {
    let sight = |sees, centred| Sight {
        sees,
        centred_rmse_60s_dps: centred,
    };
    // Seen: a gain is needed.
    assert!(vote(1.0, 0.9, &sight(true, [1.0, 0.9]), 1.0));
    assert!(!vote(1.0, 1.01, &sight(true, [1.0, 1.01]), 1.0));
    // Not seen: worse by 1% (noise) is no evidence either way; by 5% in what it can measure,
    // harm. Its constant alone is not judged.
    assert!(vote(1.0, 1.01, &sight(false, [1.0, 1.01]), 1.0));
    assert!(vote(1.0, 1.6, &sight(false, [1.0, 1.0]), 1.0));
    assert!(!vote(1.0, 1.0, &sight(false, [1.0, 1.05]), 1.0));
    // Harm is weighed against the training stream's residual: 1.5× a quiet part's error, a
    // tenth of the residual, raises it by 0.6%; a tail off by a third of it, by 5%.
    assert!(vote(1.0, 1.0, &sight(false, [0.1, 0.15]), 1.0));
    assert!(!vote(
        1.0,
        1.0,
        &sight(false, [0.1, (0.1f64.powi(2) + 0.1).sqrt()]),
        1.0
    ));
    // Never stricter than the part's own error: twice the residual, 1% worse passes, 5% is harm.
    assert!(vote(1.0, 1.0, &sight(false, [2.0, 2.02]), 1.0));
    assert!(!vote(1.0, 1.0, &sight(false, [2.0, 2.1]), 1.0));
    // Figures that are not numbers are harm.
    assert!(!vote(1.0, 1.0, &sight(false, [1.0, f64::NAN]), 1.0));
}
