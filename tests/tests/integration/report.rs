//! The main job in one command: `trainer demo` simulates a gyro with a hidden thermal-rate drift
//! and leaves every file of the chain it runs, the report among them: one self-contained page
//! that shows every figure it promises, and each figure as a file.

use trainer::report::FIGURES;

use crate::{at, json, trainer as run_trainer};

#[test]
fn the_demo_leaves_every_file_and_its_report_every_promised_figure() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name| at(dir.path(), name);
    run_trainer(&["demo", "--out", &p(""), "--quiet"]).unwrap();
    for name in [
        "points.csv",
        "train.csv",
        "valid.csv",
        "model.bin",
        "ext.bin",
        "investigate.json",
        "comp.csv",
        "replay.json",
        "reproduce.json",
        "report/report.html",
    ] {
        assert!(dir.path().join(name).is_file(), "{name} missing");
    }
    // The hidden effect is named from the training stream and the shipped blob is the one
    // replayed: the replay scores exactly what the investigation measured.
    let investigation = json(dir.path().join("investigate.json"));
    assert_eq!(investigation["diagnosis"]["causes"][0], "thermal-rate");
    let gain = investigation["gain"].as_f64().unwrap();
    assert!(gain > 3.0, "gain {gain}");
    let replay = json(dir.path().join("replay.json"));
    assert_eq!(
        replay["rmse_60s_dps"],
        investigation["extended_score"]["rmse_60s_dps"]
    );

    let out = dir.path().join("report");
    let report = |points: &str| {
        run_trainer(&[
            "report",
            "--points",
            points,
            "--train-stream",
            &p("train.csv"),
            "--valid-stream",
            &p("valid.csv"),
            "--out",
            &out.display().to_string(),
            "--quiet",
        ])
    };
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(FIGURES.len() >= 6);
    for (name, caption) in FIGURES {
        let svg = std::fs::read_to_string(out.join(name)).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("<text"), "{name}");
        assert!(
            page.contains(&format!("href=\"{name}\"")),
            "{name} not linked"
        );
        assert!(page.contains(caption), "{name}: caption missing");
        // The page carries the figure itself, not only a link to it.
        assert!(page.contains(&svg), "{name} not inline");
    }
    // Axis labels with units, and the tables beside the figures.
    for text in [
        "reference rate (°/s)",
        "T (°C)",
        "LOO residual (°/s)",
        "error (°/h)",
        "filtered dT/dt (°C/min)",
        "Named causes: <b>thermal-rate</b>",
        "cluster time τ (s)",
        "Noise of the held-out stream",
        "GPR paper",
    ] {
        assert!(page.contains(text), "missing {text}");
    }
    // Self-contained: nothing fetched from elsewhere.
    for external in ["<script", "<link", "src=", "url("] {
        assert!(!page.contains(external), "{external}");
    }
    // An output never replaces an input: a rate table that happens to sit where a figure goes.
    let table = out.join("qq.svg");
    std::fs::copy(dir.path().join("points.csv"), &table).unwrap();
    let clash = report(&table.display().to_string());
    assert!(clash.is_err());
    assert_eq!(
        std::fs::read(&table).unwrap(),
        std::fs::read(dir.path().join("points.csv")).unwrap()
    );
}
