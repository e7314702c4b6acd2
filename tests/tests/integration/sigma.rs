//! The ±2σ the firmware emits is honest on held-out data (issue 44): a simulated gyro calibrated
//! by `trainer fit --points P --stream S --features auto`, replayed on a run of its own. Its σ
//! comes from the training data alone; where the model lacks an effect, the training stream's
//! residuals are the evidence of it. The simulated gyro's bias repeats exactly from one power-on
//! to the next, and the fit is told so as a datasheet would (`--repeatability 0`): the default
//! assumes a turn-on bias one power-on cannot show (docs/uncertainty.md), wider on this gyro.

use crate::{at, one, sim, trainer};

/// Simulates a table, a training and a held-out run with `effect`, fits, replays the held-out
/// run; returns (the fit's JSON, the replay's JSON).
fn calibrated(effect: &[&str], seed: u64, design: &str) -> (serde_json::Value, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let p = |name| at(dir.path(), name);
    let (s0, s1, s2) = (
        seed.to_string(),
        (seed + 1).to_string(),
        (seed + 2).to_string(),
    );
    sim(&[
        &["generate", "paper", "--seed", &s0, "--out", &p("p.csv")][..],
        effect,
    ]
    .concat())
    .unwrap();
    for (s, name) in [(&s1, "t.csv"), (&s2, "v.csv")] {
        let out = p(name);
        let args = [
            &["generate", "stream", "--seed", s, "--design", design][..],
            &["--out", &out],
            effect,
        ]
        .concat();
        sim(&args).unwrap();
    }
    trainer(&[
        "fit",
        "--points",
        &p("p.csv"),
        "--stream",
        &p("t.csv"),
        "--features",
        "auto",
        "--repeatability",
        "0",
        "--out",
        &p("m.bin"),
        "--json",
        &p("fit.json"),
        "-q",
    ])
    .unwrap();
    sim(&[
        "replay",
        "--model",
        &p("m.bin"),
        "--stream",
        &p("v.csv"),
        "--json",
        &p("r.json"),
        "-q",
    ])
    .unwrap();
    (one(p("fit.json")), one(p("r.json")))
}

fn assert_honest(what: &str, fit: &serde_json::Value, replay: &serde_json::Value) {
    for of in ["sigma_samples", "sigma_60s"] {
        let c = &replay[of];
        let within = c["within_2sigma"].as_f64().unwrap();
        assert!((0.85..=0.995).contains(&within), "{what} {of}: {c}");
        assert!(c["sharpness"].as_f64().unwrap() <= 1.5, "{what} {of}: {c}");
    }
    // Each blob states its own calibration, and the GP's σ alone was too small for it.
    let cal = &fit["calibration"];
    assert!(
        cal["coverage"]["within_2sigma"].as_f64().unwrap() >= 0.85,
        "{cal}"
    );
    assert!(
        cal["before"]["within_2sigma"].as_f64().unwrap()
            < cal["coverage"]["within_2sigma"].as_f64().unwrap(),
        "{cal}"
    );
}

#[test]
fn the_sigma_of_a_model_that_is_right_covers_a_run_of_its_own() {
    let (fit, replay) = calibrated(&[], 31, "chamber");
    assert_eq!(fit["shipped"], "static");
    assert_honest("no effect", &fit, &replay);
}

/// A warm-up transient in ramp runs: on this seed the shipped model is the static one, and the
/// training stream's own errors (the table's model never saw it) carry the transient into its σ.
#[test]
fn the_sigma_of_a_model_that_lacks_an_effect_covers_what_it_lacks() {
    let (fit, replay) = calibrated(&["--effect", "warm-up"], 21, "ramps");
    assert_honest("warm-up", &fit, &replay);
    if fit["shipped"] == "static" {
        let cal = &fit["calibration"];
        assert!(cal["floor_std"].as_f64().unwrap() > 5e-4, "{cal}");
    }
}
