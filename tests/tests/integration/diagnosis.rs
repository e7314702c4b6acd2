//! Hidden effects: the simulator hides one effect, or two together, drawn from the documented
//! ranges (or below them) by seed, in the points and two streams of one gyro; the investigation
//! sees only the CSV files. For one effect it must name the hidden cause and nothing else and,
//! for a real effect, cut the held-out `rmse_60s_dps` threefold; for `none` it must name `none`
//! and change nothing that matters. For two it must name both and gain at least 70% of what an
//! oracle told the true causes gains; for a weak one it may say `none`, but never a wrong name,
//! and never ship a model that does worse.

use firmware_sim::gyro::effects::Strength;
use firmware_sim::gyro::stream::StreamConfig;
use fog_data::cause::Cause;
use rand::{RngExt, SeedableRng};
use trainer::analysis::challenge::{SERVICE, run_case, run_lab, run_service};

fn check(cause: Cause, seed: u64) {
    let case = run_case(&[cause], seed, Strength::Documented, false).unwrap();
    assert_eq!(case.named_cause(), cause, "{case:?}");
    assert!(case.wrong_names().is_empty(), "{case:?}");
    match cause {
        Cause::None => assert!(case.gain > 1.0 / 1.1, "{case:?}"),
        _ => assert!(case.gain > 3.0, "{case:?}"),
    }
}

#[test]
fn none_is_named_none_and_the_model_is_left_alone() {
    for seed in [7, 8] {
        check(Cause::None, seed);
    }
}

#[test]
fn thermal_rate_is_found_and_compensated() {
    for seed in [7, 8] {
        check(Cause::ThermalRate, seed);
    }
}

#[test]
fn sensor_lag_is_found_and_compensated() {
    for seed in [7, 8] {
        check(Cause::SensorLag, seed);
    }
}

#[test]
fn warm_up_is_found_and_compensated() {
    for seed in [7, 8] {
        check(Cause::WarmUp, seed);
    }
}

#[test]
fn hysteresis_is_found_and_compensated() {
    for seed in [7, 8] {
        check(Cause::Hysteresis, seed);
    }
}

#[test]
fn time_drift_is_found_and_compensated() {
    for seed in [7, 8] {
        check(Cause::TimeDrift, seed);
    }
}

#[test]
fn an_effect_drawn_by_seed_is_named() {
    // The cause is drawn here and only the simulated CSV files reach the investigation.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20261122);
    let cause = Cause::ALL[rng.random_range(0..Cause::ALL.len())];
    check(cause, 31);
}

/// Two effects hidden together must both be named, with nothing else, and gain at least 70% of
/// what an oracle told the true causes gains. Four of the challenge's pairs (docs/diagnosis.md),
/// one test each so that they run side by side.
fn check_pair(pair: [Cause; 2], seed: u64) {
    let case = run_case(&pair, seed, Strength::Documented, true).unwrap();
    assert!(
        case.all_named() && case.wrong_names().is_empty(),
        "{case:?}"
    );
    let oracle = case.oracle_gain.unwrap();
    assert!(case.gain >= 0.7 * oracle && case.gain > 2.0, "{case:?}");
}

#[test]
fn a_rate_beside_a_warm_up_are_both_named_near_an_oracle() {
    check_pair([Cause::ThermalRate, Cause::WarmUp], 1010);
}

/// Told apart only with the table's plateau constants.
#[test]
fn a_rate_beside_a_hysteresis_are_both_named_near_an_oracle() {
    check_pair([Cause::ThermalRate, Cause::Hysteresis], 1010);
}

/// A state looked as good as the rate until all three were fitted together.
#[test]
fn a_rate_beside_a_lag_are_both_named_near_an_oracle() {
    check_pair([Cause::ThermalRate, Cause::SensorLag], 1010);
}

/// Seen only since the coil estimate is carried through power cycles.
#[test]
fn a_lag_beside_a_drift_are_both_named_near_an_oracle() {
    check_pair([Cause::SensorLag, Cause::TimeDrift], 1000);
}

#[test]
fn weak_effects_are_never_misnamed_and_never_made_worse() {
    for (cause, seed) in [(Cause::Hysteresis, 7), (Cause::TimeDrift, 8)] {
        let case = run_case(&[cause], seed, Strength::Weak, false).unwrap();
        assert!(case.wrong_names().is_empty(), "{case:?}");
        assert!(case.gain >= 1.0, "{case:?}");
    }
}

/// Issue 45: the commonest calibration log, one power-on at its start, with a warm-up hidden
/// (τ 22 min here). The forward tests predict the later part of the log, where the warm-up is
/// over: they cannot see it and abstain, so the warm-up is named and shipped, and gains what an
/// investigation told the truth gains. With no effect the same log names nothing.
#[test]
fn a_warm_up_after_the_one_power_on_of_a_log_is_named_and_shipped() {
    let case = run_lab(("power-on", StreamConfig::power_on), 1020, true).unwrap();
    assert_eq!(case.named, vec![Cause::WarmUp], "{case:?}");
    assert!(case.shipped_extension, "{}", case.verdict);
    assert!(case.gain > 3.0, "{case:?}");
    assert!(case.gain >= 0.95 * case.oracle_gain.unwrap(), "{case:?}");
    let none = run_lab(("power-on", StreamConfig::power_on), 1020, false).unwrap();
    assert!(none.named.is_empty(), "{none:?}");
}

/// Issue 54: 60-minute logs of a soak and a ramp, each a warm-up hidden. Their later half is the
/// ramp, where the decay barely moves and the static model leaves the noise of a 60 s mean, so
/// the tests that score it cannot see the warm-up and judge only harm. Seed 1060 (38 °/h, τ 13.5
/// min): the warm-up's tail, fitted on the earlier blocks, leaves those blocks 1.21× the static
/// model's error, +0.3 % on the stream's residual; weighed against the later blocks alone the
/// diagnosis named nothing (1.00×). Seed 2010 (30 °/h, τ 17 min): named, the investigation's
/// forward check found 1.20× there and shipped the static model (1.00×, its oracle 8.80×).
/// Weighed against the stream, each is named and shipped, near what its oracle gains.
#[test]
fn a_warm_up_whose_tail_misses_a_quiet_later_half_is_still_named_and_shipped() {
    for seed in [1060, 2010] {
        let case = run_lab(("short", StreamConfig::short), seed, true).unwrap();
        assert_eq!(case.named.first(), Some(&Cause::WarmUp), "{case:?}");
        assert!(case.shipped_extension, "{}", case.verdict);
        assert!(case.gain > 3.0, "{case:?}");
        assert!(case.gain >= 0.85 * case.oracle_gain.unwrap(), "{case:?}");
    }
}

/// Issue 54: a random unit whose every power-on adds its own bias and scale, calibrated on one
/// log alone and held out on another power-on of another shape (`challenge --kind service`):
/// a warm-up's plateau and a cool-down to −20 °C, a cooling leg and a heating one, the same
/// 340-minute log (more blocks than a firmware model holds: the investigation chooses a sparse
/// GP's size as `fit` does) and a log with four power-ons. No sample of the held-out logs is a
/// fault, nothing is named where nothing is hidden, and the shipped σ covers at least 85 % of
/// the held-out 60 s means: never too narrow. (It is too wide on all: docs/uncertainty.md.)
#[test]
fn a_unit_held_out_where_its_calibration_did_not_reach_is_covered_and_never_a_fault() {
    for condition in SERVICE {
        let case = run_service(condition, 1000).unwrap();
        assert_eq!(case.faults, 0, "{case:?}");
        assert!(case.named.is_empty(), "{case:?}");
        assert!(case.sigma_60s.n >= 30, "{case:?}");
        assert!(case.sigma_60s.within_2sigma >= 0.85, "{case:?}");
        assert!(case.sigma_60s.sharpness.is_finite(), "{case:?}");
    }
}

/// `trainer challenge --kind service` as a user runs it: every case's σ scored, each counted
/// once as on target, too narrow or too wide, and nothing called a fault.
#[test]
fn the_service_challenge_counts_every_case_s_sigma_once() {
    let dir = tempfile::tempdir().unwrap();
    let out = crate::at(dir.path(), "c.json");
    crate::trainer(&[
        "challenge",
        "--kind",
        "service",
        "--seeds",
        "1",
        "--json",
        &out,
        "-q",
    ])
    .unwrap();
    let report = crate::json(&out);
    let summary = &report["summary"];
    assert_eq!(summary["cases"], 4, "{summary}");
    let counted: u64 = ["sigma_on_target", "sigma_narrow", "sigma_wide"]
        .iter()
        .map(|k| summary[k].as_u64().unwrap())
        .sum();
    assert_eq!(counted, 4, "{summary}");
    assert_eq!(summary["sigma_narrow"], 0, "{summary}");
    assert_eq!(summary["faults"], 0, "{summary}");
    let cases = report["cases"].as_array().unwrap();
    assert!(cases.iter().all(|c| c["condition"].is_string()), "{report}");
    // Each case says where its σ falls, as the summary counts it.
    let wide = cases
        .iter()
        .filter(|c| c["sigma_verdict"] == "wide")
        .count();
    assert_eq!(summary["sigma_wide"], wide as u64, "{report}");
}
