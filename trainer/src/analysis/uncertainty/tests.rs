use super::streams::{hours_from, hours_on};
use super::terms::{calibrate, effective};
use super::*;
use firmware_core::model::Conditions;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal as Gauss};

mod beyond;
mod heating;
mod power_ons;
mod scale;
mod streams;
mod walk;

fn residuals(n: usize, seed: u64, sd: impl Fn(f64, f64) -> f64) -> Vec<Residual> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    (0..n)
        .map(|i| {
            let hours = i as f64 / n as f64;
            let excess2 = if i % 4 == 0 { 1.0 } else { 0.0 };
            Residual {
                error: sd(excess2, hours) * unit.sample(&mut rng),
                base_var: 1e-4,
                excess2,
                output2: 0.0,
                output: 0.0,
                hours,
            }
        })
        .collect()
}

#[test]
fn the_terms_the_residuals_show_are_found_and_the_others_stay_near_zero() {
    // Model error 0.1 everywhere and 0.5 one width beyond the range; no time growth.
    let r = residuals(4000, 1, |e2, _| (0.01 + 0.25 * e2 + 1e-4f64).sqrt());
    let series = [Series {
        source: ResidualSource::Forward,
        residuals: r,
    }];
    let noise = SampleNoise {
        var: 4e-4,
        interval_s: 1.0,
    };
    let c = calibrate(&series, noise, Prior::NONE);
    assert!((c.floor_std - 0.1).abs() < 0.02, "{c:?}");
    assert!((c.extrapolation_std - 0.5).abs() < 0.05, "{c:?}");
    assert!(
        c.walk_std_per_sqrt_h < 0.05 && c.trend_std_per_h < 0.05,
        "{c:?}"
    );
    assert!((c.inflation - 1.0).abs() < 0.01);
    let cov = c.coverage.unwrap();
    assert!((cov.within_2sigma - 0.954).abs() < 0.02, "{cov:?}");
    assert_eq!(c.error_model.sample_noise_var, 4e-4);
    assert!(c.before.unwrap().within_2sigma < 0.5);
}

#[test]
fn a_term_whose_covariate_does_not_move_abstains() {
    let mut r = residuals(500, 2, |_, h| (0.01 + 0.04 * h).sqrt());
    for x in &mut r {
        x.excess2 = 0.0;
    }
    let c = calibrate(
        &[Series {
            source: ResidualSource::Groups,
            residuals: r,
        }],
        SampleNoise {
            var: 0.0,
            interval_s: 0.0,
        },
        Prior::NONE,
    );
    assert_eq!(c.extrapolation_std, 0.0);
    assert_eq!(c.fitted_terms, vec!["table floor", "walk", "trend"]);
    assert!(c.walk_std_per_sqrt_h > 0.1, "{c:?}");
}

#[test]
fn few_correlated_residuals_widen_the_sigma() {
    // 12 residuals of a slow drift: worth about two independent ones.
    let r: Vec<Residual> = (0..12)
        .map(|i| Residual {
            error: 0.1 * (f64::from(i) / 12.0 - 0.5),
            base_var: 1e-6,
            excess2: 0.0,
            output2: 0.0,
            output: 0.0,
            hours: 0.0,
        })
        .collect();
    let z: Vec<f64> = r.iter().map(|x| x.error).collect();
    assert!(effective(&z) < 3.0);
    let c = calibrate(
        &[Series {
            source: ResidualSource::Forward,
            residuals: r,
        }],
        SampleNoise {
            var: 0.0,
            interval_s: 0.0,
        },
        Prior::NONE,
    );
    assert!(c.inflation > 2.0, "{c:?}");
}

/// An assumed floor, and a growth beyond the range with a part in proportion to the output.
const PRIOR: Prior = Prior {
    floor_var: 4e-6,
    extrapolation_var: 9e-4,
    extrapolation_parts: (5e-4, 2e-7),
    ..Prior::NONE
};

#[test]
fn what_the_residuals_cannot_show_is_assumed_never_zero() {
    let prior = PRIOR;
    let noise = SampleNoise {
        var: 1.0,
        interval_s: 1.0,
    };
    // No residual at all: the prior's floor and extrapolation, said.
    let c = calibrate(&[], noise, prior);
    assert!(c.note.is_some());
    assert_eq!(c.error_model.floor_var, 4e-6);
    // The prior's growth, told apart into its bias and scale parts.
    assert_eq!(c.error_model.extrapolation_var, 5e-4);
    assert_eq!(c.error_model.extrapolation_scale_var, 2e-7);
    assert_eq!(c.assumed, vec!["floor", "extrapolation"]);
    assert!(c.describe("°/s").contains("assumed model error"));
    // Residuals that never leave the range: the floor is measured, the extrapolation assumed.
    let mut r = residuals(500, 4, |_, _| 0.05);
    for x in &mut r {
        x.excess2 = 0.0;
    }
    let series = [Series {
        source: ResidualSource::Forward,
        residuals: r,
    }];
    let c = calibrate(&series, noise, prior);
    assert!((c.floor_std - 0.049).abs() < 0.005, "{c:?}");
    assert_eq!(c.error_model.extrapolation_var, 5e-4);
    assert_eq!(c.error_model.extrapolation_scale_var, 2e-7);
    assert_eq!(c.assumed, vec!["extrapolation"]);
    assert!(
        c.describe("°/s")
            .contains("assumed, the data could not show it: extrapolation")
    );
}

#[test]
fn the_assumed_growth_is_the_share_of_holdings_miss_the_rule_shipped_missed() {
    use crate::analysis::beyond::BeyondChoice;
    use firmware_core::blob::Beyond;
    let prior = PRIOR;
    let tested = |rule, scored, rmse| BeyondChoice {
        rule,
        inside_c: Some((10.0, 30.0)),
        scored,
        rmse,
        verdict: String::new(),
    };
    // The tangent missed a quarter of what holding missed on 8 points beyond the inner fit: a
    // sixteenth of the variance, widened for 7 degrees of freedom; both parts alike.
    let p = prior.for_rule(&tested(Beyond::Tangent, 8, Some([0.4, 0.1, 0.2])));
    let k2 = 0.0625 * small_sample_factor(7.0);
    assert!((p.rule_share - k2.sqrt()).abs() < 1e-12, "{p:?}");
    assert!(p.rule_share > 0.25 && p.rule_share < 0.35, "{p:?}");
    assert!((p.extrapolation_var - 9e-4 * k2).abs() < 1e-15, "{p:?}");
    assert!((p.extrapolation_parts.0 - 5e-4 * k2).abs() < 1e-15, "{p:?}");
    assert!((p.extrapolation_parts.1 - 2e-7 * k2).abs() < 1e-18, "{p:?}");
    assert_eq!(p.floor_var, 4e-6);
    // Fewer points, less narrowing.
    let few = prior.for_rule(&tested(Beyond::Tangent, 4, Some([0.4, 0.1, 0.2])));
    assert!(few.rule_share > p.rule_share, "{few:?}");
    let c = calibrate(
        &[],
        SampleNoise {
            var: 1.0,
            interval_s: 1.0,
        },
        p,
    );
    assert_eq!(c.extrapolation_share, p.rule_share);
    assert_eq!(c.error_model.extrapolation_var, (5e-4 * k2) as f32);
    assert!(
        c.describe("°/s")
            .contains("the share of holding's miss the rule shipped missed")
    );
    // Held; a rule not tested (asked for, or too few points); a rule that missed more (asked for
    // against the test); a test that gave no number; a share the few points widen past 1:
    // holding's miss as it is, never wider.
    for choice in [
        tested(Beyond::Hold, 8, Some([0.4, 0.1, 0.2])),
        tested(Beyond::Follow, 0, None),
        tested(Beyond::Follow, 8, Some([0.4, 0.1, 0.8])),
        tested(Beyond::Tangent, 8, Some([0.0, 0.0, 0.2])),
        tested(Beyond::Follow, 4, Some([0.4, 0.1, 0.36])),
    ] {
        let follows = choice.rule == Beyond::Follow;
        assert_eq!(
            prior.for_rule(&choice),
            Prior { follows, ..prior },
            "{:?}",
            choice.rmse
        );
    }
    assert!(!p.follows && !prior.for_rule(&tested(Beyond::Hold, 0, None)).follows);
}

/// `n` samples `step_s` apart of a log at rest at 20 °C, without a fault.
fn at_rest(n: usize, step_s: f64) -> Stream {
    Stream {
        time_s: (0..n).map(|i| i as f64 * step_s).collect(),
        temp_c: vec![20.0; n],
        voltage_v: vec![0.0; n],
        rate_dps: vec![0.0; n],
        lines: (2..n as u64 + 2).collect(),
        step_s,
        time_issues: vec![],
        handled: vec![],
        history: 0,
        after_s: None,
    }
}

#[test]
fn the_sample_noise_is_the_white_part_of_the_errors() {
    let n = 20_000;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    // White noise of 0.02 on a drift of 1 per 1,000 samples.
    let error: Vec<f64> = (0..n)
        .map(|i| 1e-3 * i as f64 + 0.02 * unit.sample(&mut rng))
        .collect();
    let stream = at_rest(n, 1.0);
    let noise = SampleNoise::from_streams(&[(&stream, &error)]).unwrap();
    assert!((noise.var.sqrt() - 0.02).abs() < 0.001, "{noise:?}");
    assert_eq!(noise.of_mean(60.0), noise.var / 60.0);
    let fitted: Vec<usize> = (0..100).collect();
    let h = hours_from(&stream, &fitted);
    assert!(h[50].is_nan());
    assert!((h[3699] - 1.0).abs() < 1e-12);
    assert_eq!(hours_on(&stream)[3600], 1.0);
}

#[test]
fn an_output_quantized_coarser_than_its_noise_still_states_its_noise() {
    // White noise of 0.3 LSB, quantized: most consecutive samples are alike, and the median of
    // their differences' deviations is 0.
    let n = 20_000;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    let lsb = 1e-3;
    let error: Vec<f64> = (0..n)
        .map(|_| (0.3_f64 * unit.sample(&mut rng)).round() * lsb)
        .collect();
    let alike = error.windows(2).filter(|w| w[0] == w[1]).count();
    assert!(alike > n / 2, "{alike}");
    let stream = at_rest(n, 1.0);
    let noise = SampleNoise::from_streams(&[(&stream, &error)]).unwrap();
    // The quantized output's own spread: white, so a sample's noise.
    let own = fog_data::stats::spread(&error);
    assert!(
        (noise.var.sqrt() / own - 1.0).abs() < 0.05,
        "{noise:?} against {own}"
    );
}

#[test]
fn streams_at_other_rates_pool_their_noise_as_a_density() {
    // One sensor's white noise, 0.02 a sample at 1 s: 0.02·√2 at 0.5 s, each in its own log.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    let log = |n: usize, step_s: f64, sd: f64, rng: &mut rand_chacha::ChaCha8Rng| {
        let stream = at_rest(n, step_s);
        let error: Vec<f64> = (0..n).map(|_| sd * unit.sample(rng)).collect();
        (stream, error)
    };
    let slow = log(5_000, 1.0, 0.02, &mut rng);
    let fast = log(20_000, 0.5, 0.02 * 2f64.sqrt(), &mut rng);
    // At the interval of the log with the most samples, whatever order they come in, and the
    // same density whichever that is: each log alone would be off by √2 in σ.
    for (parts, interval_s, sd) in [
        ([&slow, &fast], 0.5, 0.02 * 2f64.sqrt()),
        ([&fast, &slow], 0.5, 0.02 * 2f64.sqrt()),
        ([&slow, &slow], 1.0, 0.02),
    ] {
        let parts: Vec<(&Stream, &[f64])> = parts.iter().map(|(s, e)| (s, e.as_slice())).collect();
        let noise = SampleNoise::from_streams(&parts).unwrap();
        assert_eq!(noise.interval_s, interval_s);
        assert!((noise.var.sqrt() / sd - 1.0).abs() < 0.03, "{noise:?}");
    }
    let more_slow = log(40_000, 1.0, 0.02, &mut rng);
    let noise =
        SampleNoise::from_streams(&[(&more_slow.0, &more_slow.1), (&fast.0, &fast.1)]).unwrap();
    assert_eq!(noise.interval_s, 1.0);
    assert!((noise.var.sqrt() / 0.02 - 1.0).abs() < 0.03, "{noise:?}");
}

#[test]
fn points_of_streams_take_their_samples_noise_and_leave_the_rest_to_the_model_error() {
    use super::tables::{StreamPoints, table_calibration, table_noise};
    use crate::data::points::Points;
    use crate::models::gp::{GpConfig, GpModel};
    // A table whose rows scatter about a smooth curve by 0.01, in ten groups.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    let (mut t, mut v, mut w, mut g) = (vec![], vec![], vec![], vec![]);
    for k in 0..40 {
        let temp = -20.0 + 2.0 * k as f64;
        for rate in [-10.0, 10.0] {
            t.push(temp);
            w.push(rate);
            v.push(0.05 * rate + 1e-3 * temp + 0.01 * 0.05 * unit.sample(&mut rng));
            g.push((k / 4).to_string());
        }
    }
    let points = Points::new(t, v, w, g, None, true, None);
    let model = GpModel::fit(points.inputs(), &points.target(), &GpConfig::default()).unwrap();
    let gp_var = table_noise(&points, &model).var;
    let noise = SampleNoise {
        var: 1.0,
        interval_s: 0.1,
    };
    let with = |point_var: Option<f64>| {
        let s = StreamPoints {
            noise,
            point_var: vec![point_var; points.len()],
        };
        table_calibration(&points, &model, None, Some(&s)).unwrap()
    };
    let table = table_calibration(&points, &model, None, None).unwrap();
    // Rows at the GP's level, or a table's rows (None): the table's own calibration, but for
    // the sample noise the blob states.
    for same in [with(Some(gp_var)), with(None)] {
        assert!(
            (same.floor_std - table.floor_std).abs() <= 1e-9 * gp_var.sqrt(),
            "{} {}",
            same.floor_std,
            table.floor_std
        );
        assert_eq!(same.error_model.sample_noise_var, 1.0);
        assert_eq!(same.error_model.sample_interval_s, 0.1);
    }
    // Points whose own noise is a hundredth of what the GP took: the rest is model error.
    let less = with(Some(gp_var / 100.0));
    assert!(
        less.floor_std.powi(2) > 0.5 * gp_var,
        "{} against the GP's noise {}",
        less.floor_std,
        gp_var.sqrt()
    );
}

#[test]
fn a_calibration_on_one_leg_assumes_the_other_and_on_both_needs_no_leg_term() {
    let r = residuals(400, 5, |_, _| 0.05);
    let series = [Series {
        source: ResidualSource::Forward,
        residuals: r,
    }];
    let noise = SampleNoise {
        var: 1e-6,
        interval_s: 1.0,
    };
    let mut heating = calibrate(&series, noise, Prior::NONE);
    // Heating from 20 to 30 °C.
    let states: Vec<(f32, f64)> = (0..1000)
        .map(|i| (0.2 + 0.8 * (i as f32 / 999.0), 20.0 + 0.01 * f64::from(i)))
        .collect();
    heating.set_legs(&states);
    let (lo, hi) = heating.legs_trained.unwrap();
    assert!((lo - 0.204).abs() < 0.01 && hi > 0.99, "{lo} {hi}");
    // The other leg misses as much again as the model's out-of-sample residuals.
    let rmse = heating.sources[0].rmse;
    assert!((heating.leg_std - rmse).abs() < 1e-12, "{heating:?}");
    assert!(heating.assumed.contains(&"leg"));
    assert!(heating.describe("°/s").contains("heating/cooling leg"));
    let e = heating.error_model;
    assert_eq!((e.leg_min, e.leg_max), (lo, hi));
    // A full cooling state lies (0.204 + 1)/2 of a swing beyond the states trained.
    let at = |leg| Conditions {
        leg: Some(leg),
        ..Conditions::at_hours(0.0)
    };
    let added = e.model_error(0.0, 0.0, at(-1.0)) - e.model_error(0.0, 0.0, at(0.5));
    let share = f64::from(lo + 1.0) / 2.0;
    assert!(
        (f64::from(added).sqrt() / (share * heating.leg_std) - 1.0).abs() < 1e-3,
        "{added} {}",
        heating.leg_std
    );
    // Up and down the same 10 °C: both legs, each over all of it.
    let mut both = calibrate(&series, noise, Prior::NONE);
    let states: Vec<(f32, f64)> = (0..1000)
        .map(|i| {
            let up = i % 200 < 100;
            let t = 20.0 + 0.1 * f64::from(if up { i % 100 } else { 99 - i % 100 });
            (if up { 1.0 } else { -1.0 }, t)
        })
        .collect();
    both.set_legs(&states);
    assert_eq!(both.error_model.leg_var, 0.0);
    assert!(both.assumed.is_empty(), "{both:?}");
    // Heating that starts where a cooling leg turned: three minutes of its state at one
    // temperature are not the leg, which is assumed as from a start at rest.
    let mut turned = calibrate(&series, noise, Prior::NONE);
    let mut states: Vec<(f32, f64)> = (0..180).map(|_| (-0.8, 20.0)).collect();
    states.extend((0..6000).map(|i| (1.0, 20.0 + 0.002 * f64::from(i))));
    turned.set_legs(&states);
    assert_eq!(turned.legs_trained, Some((0.0, 1.0)));
    assert!(turned.assumed.contains(&"leg") && turned.error_model.leg_var > 0.0);
    // A datasheet's heating/cooling gap takes the assumed term's place on one leg, and on both
    // there is still none to take.
    let mut stated = heating.clone();
    stated.set_hysteresis(0.01);
    assert_eq!(stated.leg_std, 0.01);
    assert!((f64::from(stated.error_model.leg_var) - 1e-4).abs() < 1e-10);
    assert!(!stated.assumed.contains(&"leg"), "{stated:?}");
    assert!(
        stated
            .describe("°/s")
            .contains("(the datasheet's heating/cooling gap)")
    );
    both.set_hysteresis(0.01);
    assert_eq!(both.error_model.leg_var, 0.0);
    assert_eq!(both.leg_std, 0.0);
    assert!(
        both.describe("°/s")
            .contains("held both heating and cooling")
    );
    // Where the training's states are not known (a table's soaks), no leg term
    // either, and the σ line says the figure went unused.
    let mut unknown = calibrate(&series, noise, Prior::NONE);
    unknown.set_hysteresis(0.01);
    assert_eq!(unknown.error_model.leg_var, 0.0);
    assert_eq!(unknown.hysteresis, Some(0.01));
    assert!(unknown.describe("°/s").contains("not known"), "{unknown:?}");
}

#[test]
fn runs_left_out_measure_another_power_ons_bias_and_a_datasheet_states_it() {
    let noise = SampleNoise {
        var: 1e-6,
        interval_s: 1.0,
    };
    let series = |source| {
        [Series {
            source,
            residuals: residuals(400, 7, |_, _| 0.05),
        }]
    };
    let mut one = calibrate(&series(ResidualSource::Forward), noise, Prior::NONE);
    assert!(!one.runs_measured());
    one.set_turn_on(0.02);
    assert!(
        one.describe("°/s")
            .contains("another power-on's bias 2.000e-2")
    );
    // In every sample's variance, but for the calibration's own power-on.
    let e = one.error_model;
    let mut own = Conditions::at_hours(0.0);
    own.another_power_on = false;
    let added = e.model_error(0.0, 0.0, Conditions::at_hours(0.0)) - e.model_error(0.0, 0.0, own);
    // Twice its variance: the calibration's own power-on was a draw too.
    assert!((f64::from(added) / (2.0 * 0.02f64.powi(2)) - 1.0).abs() < 1e-3);
    let runs = calibrate(&series(ResidualSource::Runs), noise, Prior::NONE);
    assert!(runs.runs_measured());
    assert!(
        runs.describe("°/s")
            .contains("measured on the runs left out")
    );
}

#[test]
fn one_power_on_assumes_another_ones_bias_as_large_as_the_floor() {
    let noise = SampleNoise {
        var: 1e-6,
        interval_s: 1.0,
    };
    let series = |source, error: f64| {
        [Series {
            source,
            residuals: residuals(400, 7, move |_, _| error),
        }]
    };
    let mut one = calibrate(&series(ResidualSource::Forward, 0.05), noise, Prior::NONE);
    assert!(one.floor_std > 0.0, "{one:?}");
    one.assume_turn_on();
    // The blob carries the floor's variance once: twice that of a repeatability of floor/√2.
    let e = one.error_model;
    assert!((f64::from(e.turn_on_var) / f64::from(e.floor_var) - 1.0).abs() < 1e-6);
    assert_eq!(one.assumed, ["turn-on"]);
    assert!(
        one.describe("°/s")
            .contains("as large as the model error's floor")
    );
    // Once: asked again, nothing changes.
    let again = one.clone();
    one.assume_turn_on();
    assert_eq!(
        (one.turn_on_std, &one.assumed),
        (again.turn_on_std, &again.assumed)
    );
    // A datasheet's figure replaces the assumption, and the σ line says which.
    one.set_turn_on(0.02);
    assert!(one.assumed.is_empty(), "{one:?}");
    assert!(one.describe("°/s").contains("(--repeatability)"));
    // Measured by runs left out, nothing is assumed.
    let mut runs = calibrate(&series(ResidualSource::Runs, 0.05), noise, Prior::NONE);
    runs.assume_turn_on();
    assert_eq!((runs.turn_on_std, runs.assumed.len()), (0.0, 0));
    // A floor fitted to 0 (residuals the model's own σ already explains): the smallest RMS of a
    // residual series stands in, and the line says so.
    let mut bare = calibrate(&series(ResidualSource::Forward, 0.003), noise, Prior::NONE);
    assert_eq!(bare.floor_std, 0.0, "{bare:?}");
    bare.assume_turn_on();
    let rmse = bare.sources[0].rmse;
    assert!(
        (bare.turn_on_std * 2f64.sqrt() / rmse - 1.0).abs() < 1e-9,
        "{bare:?}"
    );
    assert!(bare.describe("°/s").contains("the floor fitted 0"));
}

/// The prior's growth is the model's trend next to the range's edges: a bias model fitted on 60
/// points over 20 °C, the trend over each half of the range per width (`Prior::of`).
#[test]
fn the_priors_growth_is_the_models_trend_next_to_the_edges() {
    use crate::models::gp::GpConfig;
    use crate::models::prior::MeanBasis;
    let t: Vec<f64> = (0..60).map(|i| 10.0 + f64::from(i) / 59.0 * 20.0).collect();
    let prior = |bias: &dyn Fn(f64) -> f64| {
        let rate: Vec<f64> = t.iter().map(|t| bias(*t)).collect();
        let points = Points::new(
            t.clone(),
            vec![0.0; t.len()],
            rate,
            vec![String::new(); t.len()],
            Some(1.0),
            false,
            None,
        );
        let cfg = GpConfig {
            mean: MeanBasis::Poly(1),
            ..GpConfig::default()
        };
        let model = GpModel::fit(points.inputs(), &points.target(), &cfg).unwrap();
        Prior::of(&model, &points).extrapolation_var.sqrt()
    };
    // A straight bias: its change over the width, 1e-3 per °C over 20 °C.
    let straight = prior(&|t| 1e-3 * t);
    assert!((straight / 2e-2 - 1.0).abs() < 0.05, "{straight}");
    // The same trend with wiggles across the range: holding at the edge misses the trend, not
    // the wiggles, which no bias continues beyond the range. A chord through each half's ends
    // would read their phase there (up to ±40 % with those two and a half times as steep as the
    // trend); the half's least-squares slope reads it far less. With wiggles ten times as steep
    // as the trend, at a period that does not divide the halves, it stays within 15 %, where a
    // chord per half gives about a third of the trend and the former slope at the points over
    // a tenth of the range more than 1.2× it.
    for (amplitude, period, phase, within) in [
        (2e-3, 5.0, 0.0, 0.25),
        (2e-3, 4.4, 0.0, 0.25),
        (2e-3, 4.4, 1.3, 0.25),
        (2e-3, 6.1, 2.9, 0.25),
        (8e-3, 4.4, 0.0, 0.15),
    ] {
        let wiggles =
            prior(&|t| 1e-3 * t + amplitude * (std::f64::consts::TAU * t / period + phase).sin());
        assert!(
            (wiggles / 2e-2 - 1.0).abs() < within,
            "{wiggles} at {amplitude} and a period of {period} °C"
        );
    }
    // A bias that turns over in the middle of the range: no change from end to end, but each
    // half holds it, and beyond either edge it goes on rising: 1e-4 (t − 20)² changes by 1e-2
    // over each half, 2e-2 per width.
    let turning = prior(&|t| 1e-4 * (t - 20.0).powi(2));
    assert!((turning / 2e-2 - 1.0).abs() < 0.05, "{turning}");
}

#[test]
fn the_priors_growth_is_told_apart_by_the_output_where_the_outputs_move() {
    // Changes drawn with variance a + b·y² at rates from −80 to 80 °/s: the split finds both
    // parts, the bias part near a, not the mean over every rate (ten times a).
    let (a, b) = (1e-3, 4e-6);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    let y: Vec<f64> = (0..2000).map(|i| f64::from(i % 161) - 80.0).collect();
    let c2: Vec<f64> = y
        .iter()
        .map(|v| (a + b * v * v) * f64::powi(unit.sample(&mut rng), 2))
        .collect();
    let (fa, fb) = split_by_output(&c2, &y, 1e-3);
    assert!((fa / a - 1.0).abs() < 0.3, "{fa} against {a}");
    assert!((fb / b - 1.0).abs() < 0.2, "{fb} against {b}");
    let mean = c2.iter().sum::<f64>() / c2.len() as f64;
    assert!(fa < 0.2 * mean, "{fa} {mean}");
    // A log at rest: one reference value (gravity on an accelerometer's axis), or outputs that
    // move less than ten times the noise; the bias part takes it all.
    let at_rest = vec![9.81; 2000];
    assert_eq!(split_by_output(&c2, &at_rest, 1e-3), (mean, 0.0));
    let noise: Vec<f64> = y.iter().map(|v| 5e-3 * v / 80.0).collect();
    assert_eq!(split_by_output(&c2, &noise, 1e-3), (mean, 0.0));
    // A table at ±80 °/s alone: every output² alike, the likelihood flat in the split, and the
    // bias part keeps it all (a tie once gave it to the scale part, 10⁴ × too narrow at rest).
    let two: Vec<f64> = y.iter().map(|v| 80.0f64.copysign(*v)).collect();
    assert_eq!(split_by_output(&c2, &two, 1e-3), (mean, 0.0));
    // Changes that do not grow with the rate: no split.
    let alike: Vec<f64> = y
        .iter()
        .map(|_| a * f64::powi(unit.sample(&mut rng), 2))
        .collect();
    let alike_mean = alike.iter().sum::<f64>() / alike.len() as f64;
    assert_eq!(split_by_output(&alike, &y, 1e-3), (alike_mean, 0.0));
    // What is not a number is left out.
    let mut holed = c2.clone();
    holed[7] = f64::NAN;
    let (ha, hb) = split_by_output(&holed, &y, 1e-3);
    assert!(ha.is_finite() && hb.is_finite() && hb > 0.0, "{ha} {hb}");
}

#[test]
fn the_sigma_line_says_whose_noise_it_states() {
    let line = |interval_s: f64| {
        let noise = SampleNoise {
            var: 1e-4,
            interval_s,
        };
        Calibration::assumed(noise, Prior::NONE, String::new()).noise_in_words()
    };
    assert_eq!(line(1.0), "one sample's noise 1.000e-2");
    assert_eq!(line(0.0), "a point's noise 1.000e-2 (no sample's is known)");
}

#[test]
fn a_stated_tempco_replaces_the_assumed_growth_and_raises_a_smaller_fitted_one() {
    let noise = SampleNoise {
        var: 1.0,
        interval_s: 1.0,
    };
    // Assumed (no residual), with a part in proportion to the output: the bias part becomes the
    // datasheet's slope over the trained width (0.002 per °C over 5 °C: 0.01 per width), the
    // scale part stays, assumed, and the σ line names the flag.
    let mut c = calibrate(&[], noise, PRIOR);
    c.set_tempco(0.002, 5.0, true);
    assert!((c.extrapolation_std - 0.01).abs() < 1e-12, "{c:?}");
    assert!((f64::from(c.error_model.extrapolation_var) - 1e-4).abs() < 1e-10);
    assert_eq!(c.error_model.extrapolation_scale_var, 2e-7);
    assert_eq!(c.assumed, vec!["floor", "extrapolation"]);
    assert!(
        c.describe("°/s")
            .contains("datasheet: the bias at 2.000e-3"),
        "{}",
        c.describe("°/s")
    );
    // Without a scale part, nothing of the growth is assumed any more.
    let bias_only = Prior {
        extrapolation_parts: (5e-4, 0.0),
        ..PRIOR
    };
    let mut c = calibrate(&[], noise, bias_only);
    c.set_tempco(0.002, 5.0, true);
    assert_eq!(c.assumed, vec!["floor"]);
    // A mean that follows the GP beyond the range moves on by the model's own slope as well: the
    // part assumed for its rule adds to the datasheet's, in quadrature, and stays said.
    let mut followed = calibrate(&[], noise, bias_only);
    followed.set_tempco(0.002, 5.0, false);
    let both = (0.01f64 * 0.01 + 5e-4).sqrt();
    assert!(
        (followed.extrapolation_std - both).abs() < 1e-12,
        "{followed:?}"
    );
    assert_eq!(followed.assumed, vec!["floor", "extrapolation"]);
    assert!(
        followed
            .describe("°/s")
            .contains("and the model's own change")
    );
    // A datasheet's 0 is stated, not left out: no growth of the bias beyond the range.
    let mut c = calibrate(&[], noise, bias_only);
    c.set_tempco(0.0, 5.0, true);
    assert_eq!(c.tempco_per_c, Some(0.0));
    assert_eq!(c.error_model.extrapolation_var, 0.0);
    assert!(c.describe("°/s").contains("datasheet: the bias at 0.000e0"));
    // Fitted on residuals that grow to 0.5 one width out: the larger of the fit and the
    // datasheet.
    let r = residuals(4000, 1, |e2, _| (0.01 + 0.25 * e2 + 1e-4f64).sqrt());
    let series = [Series {
        source: ResidualSource::Temperature,
        residuals: r,
    }];
    let fitted = calibrate(&series, noise, PRIOR);
    assert!(fitted.fitted_terms.contains(&"extrapolation"), "{fitted:?}");
    assert!(fitted.extrapolation_std > 0.4, "{fitted:?}");
    let mut small = fitted.clone();
    small.set_tempco(0.0, 5.0, true);
    assert_eq!(small.extrapolation_std, fitted.extrapolation_std);
    assert!(
        small
            .describe("°/s")
            .contains("fitted, larger than the datasheet's")
    );
    let mut large = fitted.clone();
    large.set_tempco(1.0, 5.0, true);
    assert_eq!(large.extrapolation_std, 5.0);
    assert_eq!(large.error_model.extrapolation_var, 25.0);
    assert!(
        large
            .describe("°/s")
            .contains("(datasheet: the bias at 1.000e0")
    );
}
