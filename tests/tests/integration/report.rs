//! The main job in one command: `trainer demo` simulates a gyro with a hidden thermal-rate drift
//! and leaves every file of the chain it runs, the report among them: one self-contained page
//! that shows every figure it promises, and each figure as a file.

use trainer::report::FIGURES;

use crate::{IMU_MAPS, at, imu, json, sim, trainer as run_trainer};

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
    let investigation = crate::one(dir.path().join("investigate.json"));
    assert_eq!(investigation["diagnosis"]["causes"][0], "thermal-rate");
    let gain = investigation["gain"].as_f64().unwrap();
    assert!(gain > 3.0, "gain {gain}");
    let replay = crate::one(dir.path().join("replay.json"));
    assert_eq!(
        replay["rmse_60s_dps"],
        investigation["extended_score"]["rmse_60s_dps"]
    );
    // A held-out log of its own is another power-on: its σ too is the replay's as in service.
    let median_sigma = |v: &serde_json::Value| v["sigma_60s"]["median_sigma"].as_f64().unwrap();
    assert_eq!(
        median_sigma(&replay),
        median_sigma(&investigation["extended_score"])
    );

    let out = dir.path().join("report");
    let report = |points: &str| {
        run_trainer(&[
            "report",
            "--points",
            points,
            "--stream",
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
    for (name, caption) in FIGURES.iter().filter(|f| f.0 != "bias_vs_temperature.svg") {
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
    // The figures behind the page as data: the cause it names and both models held out.
    assert_eq!(
        json(out.join("report.json"))["schema"]["name"],
        "trainer.report"
    );
    let figures = crate::one(out.join("report.json"));
    assert_eq!(figures["kind"], "full");
    let inv = &figures["held_out"]["investigation"];
    assert!(
        inv["diagnosis"].to_string().contains("thermal-rate"),
        "{inv}"
    );
    // The page's held-out figures are the investigation's, field for field.
    same_as_investigated(inv.clone(), investigation);
    assert!(figures["reproduction"].is_object());
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

/// Asserts that a report's held-out investigation (`paged`, from report.json) holds the same
/// figures as `investigate`'s JSON on the same data (`investigated`, one channel, whose name,
/// quantity and units the page gives elsewhere), timings aside: the same fields, each equal.
/// The calibration measures another power-on's bias on the training stream's power-ons, so a
/// held-out part scored as the other kind of power-on would differ in its σ.
fn same_as_investigated(paged: serde_json::Value, investigated: serde_json::Value) {
    let paged = crate::cli::without_timings(paged);
    let mut investigated = crate::cli::without_timings(investigated);
    let channel = investigated.as_object_mut().expect("a channel");
    for label in ["name", "quantity", "units"] {
        channel.remove(label);
    }
    let fields = paged.as_object().expect("an investigation");
    let keys =
        |o: &serde_json::Map<String, serde_json::Value>| o.keys().cloned().collect::<Vec<_>>();
    assert_eq!(keys(fields), keys(channel), "report vs investigate: fields");
    let calibration = &paged["calibration"];
    assert!(
        calibration["measured"]
            .as_array()
            .unwrap()
            .contains(&"turn-on".into()),
        "{paged}"
    );
    assert!(
        calibration["turn_on_std"].as_f64().unwrap() > 0.0,
        "{paged}"
    );
    for (field, value) in fields {
        assert_eq!(value, &channel[field], "report vs investigate: {field}");
    }
}

/// A report for every kind of data a user brings: a rate table alone, a table with one stream
/// (held out in time), and a static log alone (with a datasheet's figure). Each page starts with the data as loaded and
/// says what the data could and could not show, and draws only the figures its data support.
#[test]
fn a_report_for_a_table_alone_a_table_with_one_stream_and_a_static_log_alone() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name| at(dir.path(), name);
    sim(&[
        "generate",
        "paper",
        "--seed",
        "1",
        "--out",
        &p("points.csv"),
    ])
    .unwrap();
    sim(&["generate", "stream", "--seed", "2", "--out", &p("s.csv")]).unwrap();
    // The files as the loader sees them, before anything is fitted.
    run_trainer(&[
        "summarize",
        "--points",
        &p("points.csv"),
        "--stream",
        &p("s.csv"),
        "--json",
        &p("summary.json"),
        "--quiet",
    ])
    .unwrap();
    let summary = json(dir.path().join("summary.json"));
    assert_eq!(summary["schema"]["name"], "trainer.summarize");
    // Each file's one channel.
    let files = [&summary["files"][0][0], &summary["files"][1][0]];
    assert_eq!(files[0]["rows"], 140);
    assert_eq!(files[0]["plateaus"], 10);
    assert_eq!(files[1]["kind"], "stream");
    assert_eq!(files[1]["sample_interval_s"], 1.0);
    assert_eq!(files[1]["time_issues"].as_array().unwrap().len(), 3);
    let k = files[0]["scale_factor_estimate"].as_f64().unwrap();
    assert!((k / 0.038 - 1.0).abs() < 0.02, "{k}");
    let page =
        |out: &str| std::fs::read_to_string(dir.path().join(out).join("report.html")).unwrap();
    let figure = |out: &str, name: &str| dir.path().join(out).join(name).is_file();

    run_trainer(&[
        "report",
        "--points",
        &p("points.csv"),
        "--out",
        &p("table"),
        "--quiet",
    ])
    .unwrap();
    let table = page("table");
    for text in [
        "a rate table alone",
        "The data, as loaded",
        "10 temperature plateaus",
        "earth rate in the reference: seems included",
        "What these data could show",
        "Extrapolating",
        "transients",
        "GPR paper",
    ] {
        assert!(table.contains(text), "table report: missing {text}");
    }
    assert!(figure("table", "loo_error.svg") && !figure("table", "replay.svg"));

    run_trainer(&[
        "report",
        "--points",
        &p("points.csv"),
        "--stream",
        &p("s.csv"),
        "--out",
        &p("one"),
        "--quiet",
    ])
    .unwrap();
    let one = page("one");
    for text in [
        "a rate table and one stream",
        "last third in time",
        "Held out:",
        "Noise of the held-out stream",
        "Its prior mean: physics: each of 3 temperature bands",
    ] {
        assert!(one.contains(text), "table + stream report: missing {text}");
    }
    assert!(
        figure("one", "replay.svg")
            && figure("one", "allan.svg")
            && figure("one", "rate_table.svg")
    );
    // The stream's own last third is the calibration's power-on: the page scores it as
    // `investigate` does (which `real.rs` pins to `replay --calibration-run`), field for field.
    run_trainer(&[
        "investigate",
        "--points",
        &p("points.csv"),
        "--stream",
        &p("s.csv"),
        "--json",
        &p("inv.json"),
        "-q",
    ])
    .unwrap();
    let held_out = &json(dir.path().join("one").join("report.json"))["channels"][0]["held_out"];
    // The page's data say it too, not only its text.
    let split = held_out["split"].as_str().unwrap();
    assert!(split.contains("last third in time"), "{split}");
    same_as_investigated(held_out["investigation"].clone(), crate::one(p("inv.json")));

    let imu = imu();
    run_trainer(
        &[
            &[
                "report",
                "--stream",
                &imu,
                "--map",
                "voltage_v=imu.gyro.y*57.29577951",
            ][..],
            &IMU_MAPS,
            &["--scale-factor", "1", "--tempco", "0.001"],
            &["--out", &p("log"), "--quiet"],
        ]
        .concat(),
    )
    .unwrap();
    // The page's blobs state the datasheet's figure as `fit` and `investigate` do.
    let report = json(dir.path().join("log").join("report.json"));
    let calibration = &report["channels"][0]["held_out"]["investigation"]["calibration"];
    assert_eq!(calibration["tempco_per_c"], 0.001, "{calibration}");
    let log = page("log");
    for text in [
        "one log alone",
        "the constant 0",
        "heating and cooling apart",
        "the scale factor and its temperature dependence",
        "Noise of the held-out stream",
    ] {
        assert!(log.contains(text), "static-log report: missing {text}");
    }
    assert!(figure("log", "bias_vs_temperature.svg") && !figure("log", "rate_table.svg"));
}
