//! Beyond the calibration: what ships stays safe where its data did not reach. A reading colder
//! (or hotter) than any trained is compensated, never a fault: its mean is the model's at the
//! trained range's edge (as PX4's clamp gives it), and its σ grows with the distance.

use crate::{at, imu, json, model_blob, one, sim, trainer};

/// A gyro calibrated on a 30-minute warm-up (24.9…28.3 °C) and replayed as it cools to 6.4 °C,
/// 18 °C colder than its coldest training point: every sample is compensated, the shipped model
/// is no worse than the static one held at the range's edge (the PX4-style clamp), and the σ,
/// with no out-of-sample residual to fit it on, is assumed and covers the held-out means, no
/// more than 3× wider than their RMS error (1.5× with the physics prior mean, whose error is 1.8×
/// larger). A datasheet's bias temperature coefficient
/// (`--tempco`) states the growth instead, narrower, and covers them as well.
#[test]
fn a_reading_far_colder_than_any_trained_is_compensated_never_a_fault() {
    let dir = tempfile::tempdir().unwrap();
    let (cal, held) = warm_up_then(dir.path(), "short");
    let (shipped, clamp) = (at(dir.path(), "ship.bin"), at(dir.path(), "static.bin"));
    let fit = at(dir.path(), "fit.json");
    let on_warm_up = |extra: &[&str], out: &str| {
        let base = ["fit", "--stream", &cal, "--window", ":1800"];
        trainer(&[&base[..], extra, &["--out", out, "-q"]].concat()).unwrap();
    };
    on_warm_up(&["--features", "auto", "--json", &fit], &shipped);
    on_warm_up(&[], &clamp);
    let calibration = &one(&fit)["calibration"];
    assert_eq!(calibration["residuals"], 0, "{calibration}");
    // No residual to fit on, a warm-up heats only and it is one power-on: the floor, the growth
    // beyond the range, the cooling leg, another power-on's bias and the sensor's lag are all
    // assumed, and said.
    assert_eq!(
        calibration["assumed"],
        serde_json::json!(["floor", "extrapolation", "leg", "turn-on", "heating"]),
        "{calibration}"
    );
    let replay = |model: &str, name: &str| {
        let out = at(dir.path(), name);
        sim(&[
            "replay", "--model", model, "--stream", &held, "--json", &out, "-q",
        ])
        .unwrap();
        one(&out)
    };
    let (s, c) = (replay(&shipped, "s.json"), replay(&clamp, "c.json"));
    let n = s["n"].as_u64().unwrap();
    assert_eq!(s["n_fault"], 0, "{s}");
    // Most of the cool-down lies beyond the trained range, and all of it is scored.
    assert!(s["n_extrapolating"].as_u64().unwrap() > n / 2, "{s}");
    assert_eq!(s["n_unscored"], 0, "{s}");
    let rmse = |r: &serde_json::Value| r["rmse_60s_dps"].as_f64().unwrap();
    assert!(
        rmse(&s).is_finite() && rmse(&s) <= rmse(&c) * 1.0001,
        "{s} {c}"
    );
    let coverage = s["sigma_60s"]["within_2sigma"].as_f64().unwrap();
    assert!(coverage >= 0.85, "{s}");
    // The growth assumed beyond the range is told apart by the rate (the warm-up's rates span
    // ±80 °/s): one number for every rate made the σ 3.25× its RMS error here, most of the
    // cool-down's means being at low rates. It is the model's trend over each half of its
    // range: its slope at the points, which follows the GP's wiggles between them, made the σ
    // 2.51× its error (1.23 now; the basis chosen, {1, t, v}: `basis`, misses 1.8× less than
    // physics, 0.70 with physics).
    assert!(
        calibration["extrapolation_scale_ppm"].as_f64().unwrap() > 0.0,
        "{calibration}"
    );
    assert_eq!(one(&fit)["mean_basis"], "poly1");
    assert!(s["sigma_60s"]["sharpness"].as_f64().unwrap() <= 1.5, "{s}");
    let physics = at(dir.path(), "physics.bin");
    on_warm_up(&["--features", "auto", "--mean", "physics"], &physics);
    let p = replay(&physics, "p.json");
    assert!(p["sigma_60s"]["sharpness"].as_f64().unwrap() <= 1.5, "{p}");
    assert!(
        p["sigma_60s"]["within_2sigma"].as_f64().unwrap() >= 0.85,
        "{p}"
    );

    // A datasheet's bias temperature coefficient stated (the simulated gyro's largest bias
    // slope over its −30…60 °C, in °/s per °C) takes the place of the bias part assumed from the
    // model's own trend: the σ at low rates, where the bias is all the error, narrows, and the
    // held-out means stay covered (the scale factor's part, still assumed, holds the rest).
    let poly = firmware_sim::gyro::plant::GyroParams::nominal().bias_poly_dph;
    let tempco = (-30..=60)
        .map(|t| {
            let u = (f64::from(t) - 25.0) / 45.0;
            (poly[1] + 2.0 * poly[2] * u + 3.0 * poly[3] * u * u).abs() / 45.0 / 3600.0
        })
        .fold(0.0, f64::max);
    let (stated, stated_fit) = (at(dir.path(), "tempco.bin"), at(dir.path(), "tempco.json"));
    let told = ["--features", "auto", "--tempco", &tempco.to_string()];
    on_warm_up(&[&told[..], &["--json", &stated_fit]].concat(), &stated);
    let told = &one(&stated_fit)["calibration"];
    let told_tempco = told["tempco_per_c"].as_f64().unwrap();
    assert!((told_tempco / tempco - 1.0).abs() < 1e-12, "{told}");
    // Per trained width: the coefficient times the width of the blob's temperature input.
    let fw = fog_data::replay::decode(&model_blob(&std::fs::read(&stated).unwrap())).unwrap();
    let [lo, hi] = fw.trained_range(0).unwrap();
    let width = f64::from(hi - lo);
    assert_eq!(told["trained_width_c"].as_f64().unwrap(), width, "{told}");
    let part = |c: &serde_json::Value| c["extrapolation_std"].as_f64().unwrap();
    assert!((part(told) / (tempco * width) - 1.0).abs() < 1e-9, "{told}");
    assert!(
        part(told) < part(calibration) / 10.0,
        "{told} {calibration}"
    );
    assert_eq!(
        told["extrapolation_scale_ppm"], calibration["extrapolation_scale_ppm"],
        "{told}"
    );
    let t = replay(&stated, "t.json");
    let (sigma, within) = (&t["sigma_60s"], &s["sigma_60s"]["within_2sigma"]);
    assert!(sigma["within_2sigma"].as_f64().unwrap() >= 0.85, "{t}");
    assert!(
        sigma["within_2sigma"].as_f64().unwrap() >= within.as_f64().unwrap() - 0.02,
        "{t} {s}"
    );
    let median = |r: &serde_json::Value| r["sigma_60s"]["median_sigma"].as_f64().unwrap();
    assert!(median(&t) < 0.5 * median(&s), "{t} {s}");
    // `investigate` states it in its blobs' σ alike.
    let report = at(dir.path(), "i.json");
    trainer(&[
        "investigate",
        "--stream",
        &cal,
        "--window",
        ":1800",
        "--tempco",
        &tempco.to_string(),
        "--scale-repeatability",
        "800",
        "--json",
        &report,
        "-q",
    ])
    .unwrap();
    let investigated = &one(&report)["calibration"];
    assert_eq!(
        investigated["scale_repeatability_ppm"], 800.0,
        "{investigated}"
    );
    // Its blob follows a tangent or the GP beyond its range (the rule's share under 1), which
    // moves on by the model's own slope too: that part adds to the datasheet's, still assumed.
    let width = investigated["trained_width_c"].as_f64().unwrap();
    assert!(
        investigated["extrapolation_share"].as_f64().unwrap() < 1.0,
        "{investigated}"
    );
    assert!(part(investigated) > tempco * width, "{investigated}");
    assert!(
        crate::assumes(investigated, "extrapolation"),
        "{investigated}"
    );
    for (bad, flag) in [
        ("--tempco=-1", "--tempco"),
        ("--tempco=NaN", "--tempco"),
        ("--hysteresis=-1", "--hysteresis"),
    ] {
        let refused = trainer(&["fit", "--stream", &cal, bad, "--out", &stated, "-q"]);
        let refused = refused.unwrap_err().to_string();
        assert!(
            refused.contains(&format!("{flag} must be a number")),
            "{refused}"
        );
    }
}

/// The same gyro calibrated on its whole three-hour warm-up (24.8…29.2 °C) and replayed on a
/// cool-down from 60 to −16 °C, up to ten trained widths beyond its range. The training data's
/// temperature split leaves residuals a tenth of a width beyond the range at most, which cannot
/// tell a growth there from none: the extrapolation term is assumed, and said, not fitted to
/// zero. Fitted to zero it covered 60 % of the held-out means at a σ 8× too narrow.
#[test]
fn residuals_just_beyond_the_range_leave_the_growth_far_beyond_it_assumed() {
    let dir = tempfile::tempdir().unwrap();
    let (cal, held) = warm_up_then(dir.path(), "cool-down");
    let (model, fit, replay) = (
        at(dir.path(), "m.bin"),
        at(dir.path(), "fit.json"),
        at(dir.path(), "r.json"),
    );
    trainer(&[
        "fit",
        "--stream",
        &cal,
        "--features",
        "auto",
        "--out",
        &model,
        "--json",
        &fit,
        "-q",
    ])
    .unwrap();
    let calibration = &one(&fit)["calibration"];
    let temperature = calibration["sources"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["source"] == "temperature")
        .expect("a temperature split");
    assert!(temperature["n"].as_u64().unwrap() >= 100, "{calibration}");
    let assumed = calibration["assumed"].as_array().unwrap();
    assert!(assumed.contains(&"extrapolation".into()), "{calibration}");
    assert!(calibration["extrapolation_std"].as_f64().unwrap() > 0.0);
    sim(&[
        "replay", "--model", &model, "--stream", &held, "--json", &replay, "-q",
    ])
    .unwrap();
    let r = one(&replay);
    assert_eq!(r["n_fault"], 0, "{r}");
    assert!(r["n_extrapolating"].as_u64().unwrap() > r["n"].as_u64().unwrap() / 2);
    let coverage = r["sigma_60s"]["within_2sigma"].as_f64().unwrap();
    assert!(coverage >= 0.85, "{r}");
    // Assumed, and in proportion to the rate where the rate moves: 2.09 with one number for
    // every rate, 1.06 told apart (1.30 with the model's slope at the points for its trend).
    assert!(r["sigma_60s"]["sharpness"].as_f64().unwrap() <= 1.5, "{r}");
}

/// The simulated gyro's 340-minute power-on log (seed 21) fitted on its later half (11…64 °C)
/// and replayed on its earlier half, which goes half a trained width colder (−16 °C). The
/// temperature split's residuals are precise enough to tell a growth of the prior's size a tenth
/// of a width out from none, and fit less: true there, not half a width out, where the held-out
/// error grows to 0.1–0.25 °/s. The prior stands: ±2σ covers 95 % of the held-out means; the fit
/// below it, shipped, covered 78 % at a σ 0.61× the error.
#[test]
fn residuals_that_see_less_growth_near_the_range_leave_the_prior_beyond_their_reach() {
    let dir = tempfile::tempdir().unwrap();
    let (log, model, fit, replay) = (
        at(dir.path(), "power-on.csv"),
        at(dir.path(), "m.bin"),
        at(dir.path(), "fit.json"),
        at(dir.path(), "r.json"),
    );
    sim(&[
        "generate", "stream", "--design", "power-on", "--seed", "21", "--out", &log,
    ])
    .unwrap();
    fit_auto(&["--stream", &log], "10200:", (&model, &fit), &[]);
    let calibration = &one(&fit)["calibration"];
    assert!(
        calibration["sources"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s["source"] == "temperature"),
        "{calibration}"
    );
    let assumed = calibration["assumed"].as_array().unwrap();
    assert!(assumed.contains(&"extrapolation".into()), "{calibration}");
    // Fitted below the prior, not abstained: what the residuals fitted is said beside it.
    let near = calibration["extrapolation_fitted_std"].as_f64();
    assert!(near.is_some_and(|n| n < 1e-3), "{calibration}");
    assert!(
        calibration["extrapolation_scale_ppm"].as_f64().unwrap() > 0.0,
        "{calibration}"
    );
    sim(&[
        "replay",
        "--model",
        &model,
        "--stream",
        &log,
        "--window",
        ":10200",
        "--calibration-run",
        "--json",
        &replay,
        "-q",
    ])
    .unwrap();
    let r = one(&replay);
    assert_eq!(r["n_fault"], 0, "{r}");
    assert!(r["n_extrapolating"].as_u64().unwrap() > r["n"].as_u64().unwrap() / 2);
    let means = &r["sigma_60s"];
    assert!(means["within_2sigma"].as_f64().unwrap() >= 0.9, "{means}");
    assert!(means["sharpness"].as_f64().unwrap() <= 1.5, "{means}");
}

/// A gyro drawn at random (unit seed 3) calibrated on a 30-minute warm-up, which turns its
/// ±80 °/s only near its warm end, and replayed as it cools 18 °C below it. The physics prior
/// mean's t·v and t²·v³ terms, fitted on those few points, carry the scale factor wrong wherever
/// the high rates come colder: the default chooses the basis on temperature bands left out, as
/// the firmware predicts them, and {1, t, v} ships, 13× nearer held out (115 against 1,503 °/h);
/// its σ covers the held-out means, more of them than physics's, 0.18× its error. The whole
/// three-hour warm-up, whose rates sweep its temperatures, keeps physics.
#[test]
fn a_warm_up_too_narrow_for_the_physics_prior_mean_chooses_a_simpler_one() {
    let dir = tempfile::tempdir().unwrap();
    let (cal, held) = (at(dir.path(), "cal.csv"), at(dir.path(), "held.csv"));
    for (shape, seed, out) in [("warm-up", "11", &cal), ("short", "12", &held)] {
        sim(&[
            "generate",
            "stream",
            "--design",
            shape,
            "--seed",
            seed,
            "--unit",
            "random",
            "--unit-seed",
            "3",
            "--out",
            out,
        ])
        .unwrap();
    }
    let fitted = |extra: &[&str], name: &str| {
        let (blob, json, replay) = (
            at(dir.path(), &format!("{name}.bin")),
            at(dir.path(), &format!("{name}.json")),
            at(dir.path(), &format!("{name}-replay.json")),
        );
        fit_auto(&["--stream", &cal], ":1800", (&blob, &json), extra);
        sim(&[
            "replay", "--model", &blob, "--stream", &held, "--json", &replay, "-q",
        ])
        .unwrap();
        (one(&json), one(&replay))
    };
    let (chosen, chosen_replay) = fitted(&[], "auto");
    let (physics, physics_replay) = fitted(&["--mean", "physics"], "physics");
    assert_eq!(chosen["mean_basis"], "poly1", "{}", chosen["basis_choice"]);
    assert_eq!(physics["mean_basis"], "physics");
    assert!(physics.get("basis_choice").is_none(), "{physics}");
    let scores = chosen["basis_choice"]["scores"].as_array().unwrap();
    let score = |basis: &str| {
        scores
            .iter()
            .find(|s| s["basis"] == basis)
            .and_then(|s| s["rmse"].as_f64())
            .unwrap()
    };
    assert!(score("poly1") < 0.9 * score("physics"), "{scores:?}");
    assert!(score("poly1") <= score("poly2"), "{scores:?}");
    let rmse = |r: &serde_json::Value| r["rmse_60s_dps"].as_f64().unwrap();
    assert!(
        rmse(&chosen_replay) * 5.0 < rmse(&physics_replay),
        "{chosen_replay} {physics_replay}"
    );
    let coverage = |r: &serde_json::Value| r["sigma_60s"]["within_2sigma"].as_f64().unwrap();
    assert!(coverage(&chosen_replay) >= 0.85, "{chosen_replay}");
    assert!(
        coverage(&chosen_replay) > coverage(&physics_replay),
        "{chosen_replay} {physics_replay}"
    );
    // The replay scores the means inside the trained range and beyond it apart: the cool-down
    // starts inside the warm-up's temperatures and ends far below them; the part inside is the
    // one `rmse_60s_in_range_dps` counts.
    let (inside, beyond) = (
        &chosen_replay["sigma_60s_in_range"],
        &chosen_replay["sigma_60s_beyond"],
    );
    let n = |c: &serde_json::Value| c["n"].as_u64().unwrap();
    assert!(n(inside) > 0 && n(beyond) > n(inside), "{inside} {beyond}");
    assert_eq!(
        inside["rmse"], chosen_replay["rmse_60s_in_range_dps"],
        "{chosen_replay}"
    );

    // The whole warm-up holds its last temperature for hours: two of its three bands are that
    // plateau, and the fold fitted on them predicts the ramp's band held tens of its widths
    // away, alike for every basis. The test abstains, says so, and the sensor's form ships.
    let whole = at(dir.path(), "whole.json");
    trainer(&[
        "fit",
        "--stream",
        &cal,
        "--out",
        &at(dir.path(), "whole.bin"),
        "--json",
        &whole,
        "-q",
    ])
    .unwrap();
    let whole = one(&whole);
    assert_eq!(whole["mean_basis"], "physics", "{}", whole["basis_choice"]);
    let choice = &whole["basis_choice"];
    assert!(choice["scores"].as_array().unwrap().is_empty(), "{choice}");
    let verdict = choice["verdict"].as_str().unwrap();
    assert!(
        verdict.contains("not chosen: with the coldest band left out"),
        "{verdict}"
    );
}

/// The MEMS log trained on ten minutes near its coldest (−17.3…−7.7 °C) and replayed over the
/// rest of its cycle, up to 74 °C: no channel's sample is a fault. Gyro y's bias turns over above
/// the band, which the model's own trend there cannot show: its σ covers under 85 % of the
/// held-out means. A datasheet's figures in the channels file, each channel's own, state what
/// the band cannot: a bias temperature coefficient on gyro y covers them, and the other channels
/// keep what they would have had.
#[test]
fn the_mems_log_trained_on_a_cold_band_compensates_its_whole_cycle() {
    let dir = tempfile::tempdir().unwrap();
    let channels = imu().replace("imu_raw_data.tsv", "imu.toml");
    let log = imu();
    let calibrated = |channels: &str, name: &str, extra: &[&str]| {
        let (blob, fit, out) = (
            at(dir.path(), &format!("{name}.bin")),
            at(dir.path(), &format!("{name}.json")),
            at(dir.path(), &format!("{name}-replay.json")),
        );
        let data = ["--stream", &log, "--channels", channels];
        fit_auto(&data, "1000:1660", (&blob, &fit), extra);
        sim(&[
            "replay",
            "--model",
            &blob,
            "--stream",
            &log,
            "--channels",
            channels,
            "--exclude",
            "1000:1660",
            "--json",
            &out,
            "-q",
        ])
        .unwrap();
        (blob, json(&fit), json(&out))
    };
    let (_, _, r) = calibrated(&channels, "band", &[]);
    let list = r["channels"].as_array().unwrap();
    assert_eq!(list.len(), 6);
    for ch in list {
        assert_eq!(ch["n_fault"], 0, "{ch}");
        assert!(ch["n_extrapolating"].as_u64().unwrap() > 6000, "{ch}");
        assert!(ch["rmse_60s_dps"].as_f64().unwrap().is_finite(), "{ch}");
        assert!(
            ch["sigma_60s"]["median_sigma"].as_f64().unwrap() > 0.0,
            "{ch}"
        );
    }
    let covered = |r: &serde_json::Value, k: usize| {
        r["channels"][k]["sigma_60s"]["within_2sigma"]
            .as_f64()
            .unwrap()
    };
    assert!(covered(&r, 1) < 0.85, "{r}");

    // Gyro y's datasheet states 0.03 °/s per °C, gyro x a full scale of 500 °/s.
    let text = std::fs::read_to_string(&channels).unwrap();
    let stated = text
        .replace(
            "output = \"imu.gyro.y\"",
            "output = \"imu.gyro.y\"\ntempco = 0.03",
        )
        .replace(
            "output = \"imu.gyro.x\"",
            "output = \"imu.gyro.x\"\nfull_scale = 500",
        );
    assert_ne!(stated, text);
    let sheet = at(dir.path(), "imu.toml");
    std::fs::write(&sheet, &stated).unwrap();
    let (blob, fit, told) = calibrated(&sheet, "stated", &[]);
    let tempco = |k: usize| fit["channels"][k]["calibration"]["tempco_per_c"].clone();
    assert_eq!(tempco(1), 0.03, "{fit}");
    for k in [0, 2, 3, 4, 5] {
        assert!(tempco(k).is_null(), "{fit}");
        assert_eq!(covered(&told, k), covered(&r, k), "{k}: {told}");
    }
    assert!(covered(&told, 1) >= 0.85, "{told}");
    let unit = fog_data::replay::decode_unit(&std::fs::read(&blob).unwrap()).unwrap();
    let full_scales: Vec<f32> = unit
        .channels()
        .iter()
        .map(|c| c.limits().full_scale)
        .collect();
    assert_eq!(full_scales, [500.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    // `investigate` takes each channel's alike (on half an hour: a forward split needs more
    // than the band's 11 blocks).
    let report = at(dir.path(), "i.json");
    trainer(&[
        "investigate",
        "--stream",
        &log,
        "--channels",
        &sheet,
        "--window",
        "1000:2800",
        "--json",
        &report,
        "-q",
    ])
    .unwrap();
    let investigated = json(&report);
    let tempco = |k: usize| investigated["channels"][k]["calibration"]["tempco_per_c"].clone();
    assert_eq!(tempco(1), 0.03, "{investigated}");
    assert!(tempco(0).is_null(), "{investigated}");
    // The three gyros alone read in one unit: a figure on the command line is each one's.
    let gyros = text[..text.find("name = \"acc.x\"").unwrap()]
        .trim_end()
        .trim_end_matches("[[channel]]");
    std::fs::write(&sheet, gyros).unwrap();
    let (_, fit, _) = calibrated(&sheet, "gyros", &["--tempco", "0.02"]);
    let list = fit["channels"].as_array().unwrap();
    assert_eq!(list.len(), 3, "{fit}");
    for ch in list {
        assert_eq!(ch["calibration"]["tempco_per_c"], 0.02, "{ch}");
    }
    // A figure that cannot be one is refused, naming its channel.
    std::fs::write(
        &sheet,
        text.replace("reference = \"0\"", "reference = \"0\"\ntempco = -1"),
    )
    .unwrap();
    let refused = trainer(&[
        "fit",
        "--stream",
        &log,
        "--channels",
        &sheet,
        "--out",
        &blob,
        "-q",
    ]);
    let refused = refused.unwrap_err().to_string();
    assert!(
        refused.contains("channel 'gyro.x': tempco must be a number not below 0"),
        "{refused}"
    );
}

/// A calibration on a heating leg alone (−26 → 62 °C) and a cool-down held out of another run of
/// the same gyro, which hides a hysteresis: the σ carries the leg the training did not hold,
/// assumed as large as the training data's own out-of-sample error, and covers the cooling leg's
/// 60 s means; without that term it covers under half of them. A datasheet's gap stated
/// (`--hysteresis`) takes the assumed term's place and covers them too.
#[test]
fn a_heating_only_calibration_states_a_sigma_that_covers_the_cooling_leg() {
    let dir = tempfile::tempdir().unwrap();
    let (cal, held) = (at(dir.path(), "r1.csv"), at(dir.path(), "r2.csv"));
    let truth = at(dir.path(), "truth.json");
    for (seed, out) in [("21", &cal), ("22", &held)] {
        sim(&[
            "generate",
            "stream",
            "--design",
            "ramps",
            "--seed",
            seed,
            "--effect",
            "hysteresis",
            "--out",
            out,
            "--json",
            &truth,
        ])
        .unwrap();
    }
    let fit_with = |name: &str, extra: &[&str]| {
        let (blob, fit) = (at(dir.path(), &format!("{name}.bin")), at(dir.path(), name));
        fit_auto(&["--stream", &cal], "15900:26700", (&blob, &fit), extra);
        (blob, one(&fit)["calibration"].clone())
    };
    let (blob, calibration) = fit_with("leg", &[]);
    let calibration = &calibration;
    // The window starts where the ramp turned from cooling: its first minutes hold the cooling
    // state at one temperature, not the cooling leg, which is trained no further than the centre.
    assert_eq!(
        calibration["legs_trained"][0].as_f64().unwrap(),
        0.0,
        "{calibration}"
    );
    assert!(crate::assumes(calibration, "leg"), "{calibration}");
    let cooling = |model: &str, name: &str| {
        let out = at(dir.path(), name);
        sim(&[
            "replay",
            "--model",
            model,
            "--stream",
            &held,
            "--exclude",
            ":29400",
            "--exclude",
            "40200:",
            "--json",
            &out,
            "-q",
        ])
        .unwrap();
        one(&out)["sigma_60s"]["within_2sigma"].as_f64().unwrap()
    };
    let with_leg = cooling(&blob, "r.json");
    assert!((0.85..=0.99).contains(&with_leg), "{with_leg}");
    // The datasheet's gap stated instead (twice the hidden offset, from one leg's to the
    // other's): the leg's term is that, no longer assumed, and it covers the cooling leg too.
    let offset_dph = json(&truth)["effect"]["offset_dph"].as_f64().unwrap();
    let band = 2.0 * offset_dph / 3600.0;
    let (stated, told) = fit_with("band", &["--hysteresis", &band.to_string()]);
    assert!(
        (told["leg_std"].as_f64().unwrap() / band - 1.0).abs() < 1e-9,
        "{told}"
    );
    assert!(!crate::assumes(&told, "leg"), "{told}");
    let covered = cooling(&stated, "s.json");
    assert!((0.85..=0.99).contains(&covered), "{covered}");
    // Its one channel's model, as a model blob of its own (still read), without the leg's term,
    // without another power-on's assumed bias and scale and without the assumed sensor lag: what
    // the run's residuals alone state.
    let mut bytes = model_blob(&std::fs::read(&blob).unwrap());
    let fw = fog_data::replay::decode(&bytes).unwrap();
    assert!(fw.error_model().turn_on_var > 0.0);
    let without = firmware_core::ErrorModel {
        leg_var: 0.0,
        turn_on_var: 0.0,
        scale_var: 0.0,
        heating_var: 0.0,
        heating_scale_var: 0.0,
        ..fw.error_model()
    };
    firmware_core::blob::set_error_model(&mut bytes, &without).unwrap();
    let bare = at(dir.path(), "bare.bin");
    std::fs::write(&bare, &bytes).unwrap();
    assert!(cooling(&bare, "b.json") < 0.5);
}

/// A gyro whose every power-on adds a constant bias of its own (a turn-on repeatability of
/// 80 °/h, beside a thermal swing of 60 °/h). Calibrated on three power-ons pooled, the σ is
/// measured on each run left out in turn and covers the 60 s means of a fourth; calibrated on one,
/// a datasheet's repeatability covers it too, and on the calibration's own power-on the replay
/// leaves that term out. Pooled logs recorded at different rates state one sample's noise at one
/// interval, as logs at one rate do.
#[test]
fn a_calibration_on_several_power_ons_covers_another() {
    let dir = tempfile::tempdir().unwrap();
    let unit_file = turn_on_unit(dir.path());
    let runs = generated(
        dir.path(),
        &unit_file,
        &["stream", "--design", "power-on"],
        31..=34,
    );
    let fit = |streams: &[String], extra: &[&str], name: &str| {
        let (blob, report) = (at(dir.path(), &format!("{name}.bin")), at(dir.path(), name));
        let mut args = vec!["fit"];
        for s in streams {
            args.extend(["--stream", s.as_str()]);
        }
        args.extend(extra);
        args.extend(["--out", &blob, "--json", &report, "-q"]);
        trainer(&args).unwrap();
        (blob, one(&report)["calibration"].clone())
    };
    let replay = |blob: &str, stream: &str, extra: &[&str]| {
        let out = at(dir.path(), "r.json");
        let mut args = vec![
            "replay", "--model", blob, "--stream", stream, "--json", &out,
        ];
        args.extend(extra);
        args.push("-q");
        sim(&args).unwrap();
        one(&out)["sigma_60s"].clone()
    };
    let within = |s: serde_json::Value| s["within_2sigma"].as_f64().unwrap();

    // One power-on and nothing stated: the bias of another is assumed (the difference of two
    // power-ons as large as the model error's floor), said, and it covers the fourth.
    let (assumed, calibration) = fit(&runs[..1], &[], "assumed");
    assert!(crate::assumes(&calibration, "turn-on"), "{calibration}");
    let std = |key: &str| calibration[key].as_f64().unwrap();
    assert!(
        (std("turn_on_std") * 2f64.sqrt() / std("floor_std") - 1.0).abs() < 1e-9,
        "{calibration}"
    );
    let another = replay(&assumed, &runs[3], &[]);
    assert!(
        (0.85..=0.99).contains(&within(another.clone())),
        "{another}"
    );
    assert!(another["sharpness"].as_f64().unwrap() <= 1.5, "{another}");

    let noise = |c: &serde_json::Value| {
        (
            c["sample_noise_std"].as_f64().unwrap(),
            c["sample_interval_s"].as_f64().unwrap(),
        )
    };
    let (one_noise, one_interval) = noise(&calibration);
    let (pooled, calibration) = fit(&runs[..3], &[], "three");
    // The pooled points are the streams' 60 s means, whose GP noise holds what the GP cannot
    // follow at a point; one sample's noise is the streams' own, as on one power-on.
    let (pooled_noise, pooled_interval) = noise(&calibration);
    assert_eq!(pooled_interval, one_interval, "{calibration}");
    assert!(
        (0.8..1.25).contains(&(pooled_noise / one_noise)),
        "{pooled_noise} against {one_noise}"
    );
    let sources: Vec<&str> = calibration["sources"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["source"].as_str().unwrap())
        .collect();
    assert_eq!(sources, ["runs"], "{calibration}");
    let another = within(replay(&pooled, &runs[3], &[]));
    assert!((0.85..=1.0).contains(&another), "{another}");

    // The same power-ons, the first and the third logged at a fifth of the rate (each sample the
    // mean of five): one sample's noise is stated at the interval of the log with the most
    // consecutive samples, the second's, as the 1 Hz logs state it, not at the first log's.
    let slow = [0, 2].map(|k| averaged(&runs[k], 5));
    let (mixed, calibration) = fit(
        &[slow[0].clone(), runs[1].clone(), slow[1].clone()],
        &[],
        "mixed",
    );
    let (mixed_noise, mixed_interval) = noise(&calibration);
    assert_eq!(mixed_interval, one_interval, "{calibration}");
    assert!(
        (0.9..1.1).contains(&(mixed_noise / pooled_noise)),
        "{mixed_noise} against {pooled_noise}"
    );
    let another = within(replay(&mixed, &runs[3], &[]));
    assert!((0.85..=1.0).contains(&another), "{another}");

    // One power-on and the datasheet's 80 °/h (1σ, in °/s).
    let (single, calibration) = fit(&runs[..1], &["--repeatability", "0.0222"], "one");
    assert!((calibration["turn_on_std"].as_f64().unwrap() - 0.0222).abs() < 1e-9);
    let another = within(replay(&single, &runs[3], &[]));
    assert!((0.85..=1.0).contains(&another), "{another}");
    let median = |extra: &[&str]| {
        replay(&single, &runs[0], extra)["median_sigma"]
            .as_f64()
            .unwrap()
    };
    assert!(median(&["--calibration-run"]) < 0.8 * median(&[]));
}

/// A rate table and a chamber stream of the gyro with a turn-on repeatability of 80 °/h: the
/// stream's four power-ons, each left out in turn, measure another power-on's bias, nothing
/// assumed, and the σ covers two other chamber streams' 60 s means.
#[test]
fn a_stream_of_several_power_ons_measures_another_ones_bias() {
    let dir = tempfile::tempdir().unwrap();
    let unit_file = turn_on_unit(dir.path());
    let table = generated(dir.path(), &unit_file, &["paper"], 41..=41);
    let streams = generated(
        dir.path(),
        &unit_file,
        &["stream", "--design", "chamber"],
        42..=44,
    );
    let (blob, report) = (at(dir.path(), "m.bin"), at(dir.path(), "m.json"));
    trainer(&[
        "fit",
        "--points",
        &table[0],
        "--stream",
        &streams[0],
        "--features",
        "auto",
        "--out",
        &blob,
        "--json",
        &report,
        "-q",
    ])
    .unwrap();
    let calibration = one(&report)["calibration"].clone();
    assert_eq!(calibration["power_ons_left_out"], 4, "{calibration}");
    assert_eq!(calibration["measured"][0], "turn-on", "{calibration}");
    assert!(!crate::assumes(&calibration, "turn-on"), "{calibration}");
    assert!(
        calibration["sources"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s["source"] == "power-on"),
        "{calibration}"
    );
    // Each power-on's mean taken out of its residuals is a number fitted on them, as the terms
    // are: the small-sample factor counts both. The terms fitted are those listed and those
    // whose fit a larger figure replaced (the Allan deviation's walk, the prior's growth).
    let number = |key: &str| calibration[key].as_f64().unwrap();
    let replaced = ["walk_fitted_std", "extrapolation_fitted_std"]
        .iter()
        .filter(|key| !calibration[**key].is_null())
        .count();
    let fitted = (calibration["fitted_terms"].as_array().unwrap().len() + replaced) as f64;
    let dof = (number("effective") - fitted - number("power_ons_left_out")).max(2.0);
    let factor = trainer::analysis::uncertainty::small_sample_factor(dof);
    assert!(
        (number("inflation") / factor - 1.0).abs() < 1e-9,
        "{calibration}"
    );
    // 80 °/h is 0.0222 °/s; four draws measure it within a factor of three.
    let measured = calibration["turn_on_std"].as_f64().unwrap();
    assert!((0.0074..0.067).contains(&measured), "{calibration}");
    for stream in &streams[1..] {
        let out = at(dir.path(), "r.json");
        sim(&[
            "replay", "--model", &blob, "--stream", stream, "--json", &out, "-q",
        ])
        .unwrap();
        let s = one(&out)["sigma_60s"].clone();
        assert!(s["within_2sigma"].as_f64().unwrap() >= 0.85, "{s}");
    }
}

/// Rate tables of three power-ons of a gyro with a turn-on repeatability of 80 °/h, pooled by
/// `fit --run`: the σ is measured on each run left out in turn (more points than the firmware
/// holds: each refitted sparse), `loo --run` leaves each out, and `report`, which would not use
/// them, refuses them.
#[test]
fn a_fit_on_several_tables_leaves_each_power_on_out() {
    let dir = tempfile::tempdir().unwrap();
    let unit_file = turn_on_unit(dir.path());
    let tables = generated(dir.path(), &unit_file, &["paper"], 31..=33);
    let report = at(dir.path(), "fit.json");
    trainer(&[
        "fit",
        "--points",
        &tables[0],
        "--run",
        &tables[1],
        "--run",
        &tables[2],
        "--out",
        &at(dir.path(), "m.bin"),
        "--json",
        &report,
        "-q",
    ])
    .unwrap();
    let fit = one(&report);
    assert_eq!(fit["n_train"], 420, "{fit}");
    let calibration = &fit["calibration"];
    assert_eq!(calibration["sources"][0]["source"], "runs", "{calibration}");
    assert_eq!(calibration["sources"][0]["n"], 420, "{calibration}");
    // The runs' offsets are in the model error: far above one soaked table's in-run error.
    assert!(
        calibration["floor_std"].as_f64().unwrap() > 20.0 / 3600.0,
        "{calibration}"
    );
    // `loo --run` leaves each power-on out in turn, with a σ that each fold measured on its own
    // two runs: it covers the run left out.
    let evaluation = at(dir.path(), "loo.json");
    trainer(&[
        "loo",
        "--points",
        &tables[0],
        "--run",
        &tables[1],
        "--run",
        &tables[2],
        "--json",
        &evaluation,
        "-q",
    ])
    .unwrap();
    let evaluation = json(&evaluation);
    assert_eq!(evaluation["calibration"]["sources"][0]["source"], "runs");
    let left_out = &evaluation["sigma_groups"];
    assert_eq!(left_out["n"], 420, "{left_out}");
    assert!(
        left_out["within_2sigma"].as_f64().unwrap() >= 0.85,
        "{left_out}"
    );
    let refused = trainer(&[
        "report",
        "--points",
        &tables[0],
        "--run",
        &tables[1],
        "--out",
        &at(dir.path(), "r"),
        "-q",
    ]);
    assert!(refused.is_err());
}

/// In `dir`, the nominal gyro with a turn-on repeatability of 80 °/h, as a unit file; its path.
fn turn_on_unit(dir: &std::path::Path) -> String {
    unit_file(
        dir,
        firmware_sim::gyro::plant::GyroParams {
            turn_on_bias_dph: 80.0,
            ..firmware_sim::gyro::plant::GyroParams::nominal()
        },
    )
}

/// In `dir`, a gyro of `params` without effects, as a unit file; its path.
fn unit_file(dir: &std::path::Path, params: firmware_sim::gyro::plant::GyroParams) -> String {
    let unit = firmware_sim::gyro::unit::Unit {
        params,
        effects: Vec::new(),
    };
    let path = at(dir, "unit.json");
    std::fs::write(&path, serde_json::to_string(&unit).unwrap()).unwrap();
    path
}

/// A gyro whose scale factor changes from one power-on to the next (800 ppm, 1σ), as the real
/// FOG runs' does (docs/real-data.md): a table fitted on one power-on and scored on another says
/// what differs, and it is the scale the simulator drew for each, to a few ppm, with no offset
/// beside it; between the nominal gyro's runs it finds no scale. The σ measured on one run covers
/// a quarter of the other's points; with the datasheet's 800 ppm stated, all but a few, and a
/// blob fitted with it carries it.
#[test]
fn a_run_whose_scale_factor_differs_is_told_apart_and_a_stated_repeatability_covers_it() {
    use firmware_sim::gyro::plant::GyroParams;
    let dir = tempfile::tempdir().unwrap();
    let scaled = GyroParams {
        turn_on_scale_ppm: 800.0,
        ..GyroParams::nominal()
    };
    let tables = generated(
        dir.path(),
        &unit_file(dir.path(), scaled.clone()),
        &["paper"],
        1..=2,
    );
    let nominal = generated(
        dir.path(),
        &unit_file(dir.path(), GyroParams::nominal()),
        &["paper"],
        3..=4,
    );
    let across = |tables: &[String], extra: &[&str]| {
        let out = at(dir.path(), "loo.json");
        let mut args = vec![
            "loo",
            "--points",
            &tables[0],
            "--valid-points",
            &tables[1],
            "--method",
            "gpr",
            "--json",
            &out,
            "-q",
        ];
        args.extend(extra);
        trainer(&args).unwrap();
        json(&out)["cross_run"].clone()
    };
    let drawn = (scaled.turn_on(2, 0).scale - scaled.turn_on(1, 0).scale) * 1e6;
    assert!(drawn.abs() > 100.0, "{drawn} ppm: seeds that show nothing");
    let found = across(&tables, &[]);
    let get = |d: &serde_json::Value, k: &str| d[k].as_f64().unwrap();
    let difference = &found["difference"];
    assert!(
        (get(difference, "scale_ppm") - drawn).abs() < 20.0,
        "{found} against {drawn} ppm"
    );
    assert!(get(difference, "offset_dph").abs() < 5.0, "{found}");
    assert!(
        get(difference, "without_offset_dph") > 5.0 * get(difference, "without_both_dph"),
        "{found}"
    );
    assert!(get(&found["sigma"], "within_2sigma") < 0.5, "{found}");
    // One table cannot show another power-on's bias: it is assumed, and said; a datasheet's
    // figure stands in its place.
    assert_eq!(found["turn_on_assumed"], true, "{found}");
    assert!(get(&found, "turn_on_std") > 0.0, "{found}");
    // Nor its scale: the soaked table's residuals do not grow with the rate, so it is assumed as
    // large at their RMS rate as the bias, a few ppm, far from the 800 drawn.
    assert_eq!(found["scale_assumed"], true, "{found}");
    assert!(get(&found, "scale_repeatability_ppm") < 20.0, "{found}");
    let stated = across(&tables, &["--scale-repeatability", "800"]);
    assert!(get(&stated["sigma"], "within_2sigma") > 0.95, "{stated}");
    let bias = across(&tables, &["--repeatability", "0.001"]);
    assert_eq!(bias["turn_on_assumed"], false, "{bias}");
    assert_eq!(get(&bias, "turn_on_std"), 0.001, "{bias}");
    let none = across(&nominal, &[]);
    assert!(get(&none["difference"], "scale_ppm").abs() < 20.0, "{none}");

    // `fit` writes it into the blob: twice its variance (the calibration's power-on was a draw
    // too), in proportion to the output².
    let (blob, report) = (at(dir.path(), "m.bin"), at(dir.path(), "fit.json"));
    let fit = |extra: &[&str]| {
        let mut args = vec![
            "fit", "--points", &tables[0], "--out", &blob, "--json", &report,
        ];
        args.extend(extra);
        args.push("-q");
        trainer(&args)
    };
    fit(&["--scale-repeatability", "800"]).unwrap();
    let calibration = one(&report)["calibration"].clone();
    assert_eq!(
        calibration["scale_repeatability_ppm"], 800.0,
        "{calibration}"
    );
    let fw = fog_data::replay::decode(&model_blob(&std::fs::read(&blob).unwrap())).unwrap();
    let var = f64::from(fw.error_model().scale_var);
    assert!(
        (var / (2.0 * 800e-6f64.powi(2)) - 1.0).abs() < 1e-6,
        "{var}"
    );
    for bad in ["--scale-repeatability=-1", "--scale-repeatability=NaN"] {
        let refused = fit(&[bad]).unwrap_err().to_string();
        assert!(refused.contains("must be a σ in ppm"), "{refused}");
        let loo = [
            "loo",
            "--points",
            &tables[0],
            "--valid-points",
            &tables[1],
            bad,
            "-q",
        ];
        let refused = trainer(&loo).unwrap_err().to_string();
        assert!(refused.contains("must be a σ in ppm"), "{refused}");
    }
    let loo = |extra: &[&str]| {
        let mut args = vec!["loo", "--points", &tables[0], "--valid-points", &tables[1]];
        args.extend(extra);
        args.push("-q");
        trainer(&args).unwrap_err().to_string()
    };
    let refused = loo(&["--repeatability=-1"]);
    assert!(refused.contains("must be a σ"), "{refused}");
    let refused = loo(&["--repeatability", "0.001", "--method", "poly"]);
    assert!(refused.contains("only the GP"), "{refused}");
}

/// The simulated gyro's three-hour warm-up (seed 11) and a held-out stream of `design` (seed 12),
/// generated in `dir`: their paths.
fn warm_up_then(dir: &std::path::Path, design: &str) -> (String, String) {
    let (cal, held) = (at(dir, "cal.csv"), at(dir, "held.csv"));
    for (shape, seed, out) in [("warm-up", "11", &cal), (design, "12", &held)] {
        sim(&[
            "generate", "stream", "--design", shape, "--seed", seed, "--out", out,
        ])
        .unwrap();
    }
    (cal, held)
}

/// The stream CSV at `path` as a sensor `k` times slower logs it, each sample the mean of `k`
/// (a slower output data rate's samples average the faster ones): the path of the copy beside it.
fn averaged(path: &str, k: usize) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let mut out = vec![lines.next().unwrap().to_owned()];
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    for block in rows.chunks_exact(k) {
        let mean = (0..block[0].len())
            .map(|j| (block.iter().map(|r| r[j]).sum::<f64>() / k as f64).to_string())
            .collect::<Vec<_>>();
        out.push(mean.join(","));
    }
    let slow = path.replace(".csv", &format!("-every-{k}.csv"));
    std::fs::write(&slow, out.join("\n") + "\n").unwrap();
    slow
}

/// `trainer fit --features auto` on `data` (its `--stream`, and `--channels` where a unit's) in
/// `window`, the blob and the JSON written to `out`, with `extra` flags.
fn fit_auto(data: &[&str], window: &str, (blob, json): (&str, &str), extra: &[&str]) {
    let fixed = ["--window", window, "--features", "auto"];
    let written = ["--out", blob, "--json", json, "-q"];
    trainer(&[&["fit"][..], data, &fixed, &written, extra].concat()).unwrap();
}

/// `firmware-sim generate KIND…` of `unit_file`, one file in `dir` per seed: their paths.
fn generated(
    dir: &std::path::Path,
    unit_file: &str,
    kind: &[&str],
    seeds: std::ops::RangeInclusive<u64>,
) -> Vec<String> {
    seeds
        .map(|seed| {
            let out = at(dir, &format!("run{seed}.csv"));
            let seed = seed.to_string();
            let args = [
                &["generate"][..],
                kind,
                &["--unit", unit_file, "--seed", &seed, "--out", &out],
            ]
            .concat();
            sim(&args).unwrap();
            out
        })
        .collect()
}

/// A log longer than a firmware model's centres (the 340-minute power-on log: 340 blocks) is
/// investigated on its own, as `fit` fits it: a sparse GP of the size chosen on held-out
/// points, said in `centres_choice`. It used to stop at "model too large to export".
#[test]
fn a_log_longer_than_a_firmware_model_holds_is_investigated_alone() {
    let dir = tempfile::tempdir().unwrap();
    let logs = generated(
        dir.path(),
        "nominal",
        &["stream", "--design", "power-on"],
        5..=6,
    );
    let report = at(dir.path(), "inv.json");
    trainer(&[
        "investigate",
        "--stream",
        &logs[0],
        "--valid-stream",
        &logs[1],
        "--json",
        &report,
        "-q",
    ])
    .unwrap();
    let inv = one(&report);
    let choice = &inv["centres_choice"];
    assert_eq!(choice["n"], 340, "{choice}");
    assert!(choice["chosen"].as_u64().is_some(), "{choice}");
    assert_eq!(
        inv["extended_score"]["n_fault"], 0,
        "{}",
        inv["extended_score"]
    );
}

/// A log that sweeps the table's rates, calibrated alone: its 60 s means each hold the whole
/// sweep, so their residuals cannot show an error in proportion to the rate, yet another
/// power-on's scale factor differs as its bias does. It is assumed, as large at the outputs'
/// RMS as that bias, not left out.
#[test]
fn a_log_calibrated_alone_assumes_another_power_ons_scale() {
    let dir = tempfile::tempdir().unwrap();
    let logs = generated(
        dir.path(),
        "nominal",
        &["stream", "--design", "short"],
        5..=5,
    );
    let (blob, report) = (at(dir.path(), "m.bin"), at(dir.path(), "m.json"));
    trainer(&[
        "fit", "--stream", &logs[0], "--out", &blob, "--json", &report, "-q",
    ])
    .unwrap();
    let calibration = one(&report)["calibration"].clone();
    assert!(crate::assumes(&calibration, "scale"), "{calibration}");
    let rms = calibration["output_rms"].as_f64().unwrap();
    assert!((1.0..80.0).contains(&rms), "{calibration}");
    let ppm = calibration["scale_repeatability_ppm"].as_f64().unwrap();
    let bias = calibration["turn_on_std"].as_f64().unwrap();
    assert!(
        (ppm / (bias / rms * 1e6) - 1.0).abs() < 1e-6,
        "{calibration}"
    );
}
