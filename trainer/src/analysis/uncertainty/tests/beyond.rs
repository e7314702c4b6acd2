//! The growth beyond the trained range: what residuals near its edge can and cannot say of it.

use super::*;
use crate::analysis::uncertainty::terms::extrapolation_shows;

#[test]
fn residuals_just_beyond_the_range_cannot_rule_out_a_growth_far_beyond_it() {
    // A warm-up's temperature split: hundreds of residuals, all within a tenth of a width of the
    // range, none larger there. A growth of the prior's size (0.03 per width) would add 1e-5 to
    // their 2.5e-3 at most: they cannot tell it from none, so the prior is assumed, not a zero.
    let prior = Prior {
        floor_var: 0.0,
        extrapolation_var: 9e-4,
        extrapolation_parts: (9e-4, 0.0),
        ..Prior::NONE
    };
    let noise = SampleNoise {
        var: 1.0,
        interval_s: 1.0,
    };
    let near = |reach: f64| {
        let mut r = residuals(400, 5, |_, _| 0.05);
        for (i, x) in r.iter_mut().enumerate() {
            x.excess2 = (reach * (i % 10) as f64 / 9.0).powi(2);
        }
        [Series {
            source: ResidualSource::Temperature,
            residuals: r,
        }]
    };
    let c = calibrate(&near(0.1), noise, prior);
    assert_eq!(c.error_model.extrapolation_var, 9e-4, "{c:?}");
    assert_eq!(c.assumed, vec!["extrapolation"]);
    assert!(!c.fitted_terms.contains(&"extrapolation"), "{c:?}");
    // The same errors reaching two widths out do show that no such growth is there: the fit
    // stands, below the prior.
    let c = calibrate(&near(2.0), noise, prior);
    assert!(c.error_model.extrapolation_var < 9e-4, "{c:?}");
    assert!(c.assumed.is_empty(), "{c:?}");
    assert!(c.fitted_terms.contains(&"extrapolation"), "{c:?}");
    // But they were scored as the GP follows beyond the range: for a blob that holds there they
    // say nothing of its miss, and the prior is assumed.
    let held = Prior {
        follows: false,
        ..prior
    };
    let c = calibrate(&near(2.0), noise, held);
    assert_eq!(c.error_model.extrapolation_var, 9e-4, "{c:?}");
    assert_eq!(c.assumed, vec!["extrapolation"]);
    assert!(!c.fitted_terms.contains(&"extrapolation"), "{c:?}");
    // With no prior to assume (a model without a temperature input), the term fitted stands.
    let none = Prior {
        follows: false,
        ..Prior::NONE
    };
    let c = calibrate(&near(2.0), noise, none);
    assert!(c.fitted_terms.contains(&"extrapolation"), "{c:?}");
    assert!(c.assumed.is_empty(), "{c:?}");
}

#[test]
fn residuals_a_tenth_of_a_width_out_cannot_lower_the_growth_a_width_out() {
    // Precise residuals a tenth of a width beyond the range, none larger there: a growth of the
    // prior's size would be many standard errors above them, so they do tell it from none, and
    // fit less. That holds near the edge; a width out, where the prior is stated, they were not.
    let prior = Prior {
        floor_var: 0.0,
        extrapolation_var: 9e-4,
        extrapolation_parts: (4e-4, 1e-6),
        rule_share: 0.8,
        ..Prior::NONE
    };
    let noise = SampleNoise {
        var: 1e-6,
        interval_s: 1.0,
    };
    let precise = |reach: f64| {
        let mut r = residuals(400, 7, |_, _| 1e-3);
        for (i, x) in r.iter_mut().enumerate() {
            x.excess2 = (reach * (i % 10) as f64 / 9.0).powi(2);
            x.base_var = 1e-6;
        }
        [Series {
            source: ResidualSource::Temperature,
            residuals: r,
        }]
    };
    assert!(extrapolation_shows(&precise(0.1), &[0.0; TERMS], 9e-4));
    let c = calibrate(&precise(0.1), noise, prior);
    assert_eq!(c.error_model.extrapolation_var, 4e-4, "{c:?}");
    assert_eq!(c.error_model.extrapolation_scale_var, 1e-6, "{c:?}");
    assert_eq!(c.extrapolation_share, 0.8);
    assert_eq!(c.assumed, vec!["extrapolation"]);
    assert!(!c.fitted_terms.contains(&"extrapolation"), "{c:?}");
    assert!(c.fitted_terms.contains(&"floor"), "{c:?}");
    // Fitted, not abstained: the fit is kept and said.
    let near = c.extrapolation_fitted_std.expect("the fit below the prior");
    assert!(
        c.describe("°/s")
            .contains(&format!("fitted {near:.3e} °/s: a growth near"))
    );
    // A growth near the edge, below the prior: a datasheet that states less ships it, as fitted;
    // one that states more ships instead.
    let mut growing = precise(0.1);
    for x in growing[0].residuals.iter_mut() {
        x.error *= (1.0 + 3e-4 * x.excess2 / 1e-6).sqrt();
    }
    let c = calibrate(&growing, noise, prior);
    let near = c.extrapolation_fitted_std.expect("the fit below the prior");
    assert!(near > 0.01, "{c:?}");
    let mut less = c.clone();
    less.set_tempco(1e-3, 5.0, true);
    assert_eq!(less.extrapolation_std, near);
    assert!(less.fitted_terms.contains(&"extrapolation"), "{less:?}");
    // The part in proportion to the output stays assumed: no bias figure states it.
    assert!(less.assumed.contains(&"extrapolation"), "{less:?}");
    assert!((less.extrapolation_scale_ppm - 1000.0).abs() < 1e-6);
    assert_eq!(less.extrapolation_fitted_std, None);
    assert!(
        less.describe("°/s")
            .contains("fitted, larger than the datasheet's")
    );
    let mut more = c.clone();
    more.set_tempco(1e-2, 5.0, true);
    assert_eq!(more.extrapolation_std, 0.05);
    assert!(!more.fitted_terms.contains(&"extrapolation"), "{more:?}");
    // Under a rule that follows the model beyond the range, the datasheet's beside the growth
    // assumed, or the fit where it is larger.
    let mut followed = c.clone();
    followed.set_tempco(1e-3, 5.0, false);
    let beside = 5e-3f64.hypot(c.extrapolation_std);
    assert_eq!(followed.extrapolation_std, beside.max(near));
    // Reaching two widths out, they measured what the prior guesses: the fit stands.
    let c = calibrate(&precise(2.0), noise, prior);
    assert!(c.error_model.extrapolation_var < 9e-6, "{c:?}");
    assert!(c.assumed.is_empty(), "{c:?}");
    assert!(c.fitted_terms.contains(&"extrapolation"), "{c:?}");
    assert_eq!(c.extrapolation_fitted_std, None);
    // A width out is three residuals there; two are not.
    let reaching = |n: usize| {
        let mut s = precise(0.1);
        for x in s[0].residuals.iter_mut().take(n) {
            x.excess2 = 1.0;
        }
        calibrate(&s, noise, prior)
    };
    assert!(reaching(3).assumed.is_empty(), "{:?}", reaching(3));
    assert_eq!(reaching(2).assumed, vec!["extrapolation"]);
    // Residuals that grow faster than the prior a tenth of a width out raise it, however near.
    let mut steep = precise(0.1);
    for x in steep[0].residuals.iter_mut() {
        x.error *= 1.0 + 3e4 * x.excess2;
    }
    let c = calibrate(&steep, noise, prior);
    assert!(c.fitted_terms.contains(&"extrapolation"), "{c:?}");
    assert!(c.error_model.extrapolation_var > 9e-4, "{c:?}");
}
