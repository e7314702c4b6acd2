//! The real binary as a script sees it: exit status, where results and errors go, and the help.

use std::path::Path;
use std::process::{Command, Output};

fn trainer(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trainer"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// A small rate table: 6 temperatures × 8 rates of a gyro with a temperature-dependent bias and
/// scale factor, and a deterministic ripple for noise.
fn rate_table(dir: &Path) {
    let mut csv = String::from("temp_c,voltage_v,rate_dps\n");
    for (i, t) in [-30.0, -10.0, 10.0, 25.0, 40.0, 60.0].iter().enumerate() {
        for (j, w) in [-80.0, -40.0, -10.0, -5.0, 5.0, 10.0, 40.0, 80.0]
            .iter()
            .enumerate()
        {
            let v = 0.0385 * w * (1.0 + 1e-4 * t) + 2e-3 * t + 1e-4 * ((3 * i + j) as f64).sin();
            csv.push_str(&format!("{t},{v},{w}\n"));
        }
    }
    std::fs::write(dir.join("p.csv"), csv).unwrap();
}

#[test]
fn bad_input_exits_one_with_the_location_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("p.csv"),
        "temp_c,voltage_v,rate_dps\n0,0.1,1\n20,x,2\n",
    )
    .unwrap();
    let out = trainer(&["fit", "--points", "p.csv", "--out", "m.bin"], dir.path());
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("p.csv line 3, column voltage_v: 'x' is not a number"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
    assert!(!dir.path().join("m.bin").exists());
    let missing = trainer(
        &["fit", "--points", "nope.csv", "--out", "m.bin"],
        dir.path(),
    );
    assert_eq!(missing.status.code(), Some(1));
    let err = String::from_utf8_lossy(&missing.stderr);
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
}

#[test]
fn a_fit_that_stops_short_says_so_on_stderr_and_in_the_json_and_still_writes_its_model() {
    let dir = tempfile::tempdir().unwrap();
    rate_table(dir.path());
    let out = trainer(
        &[
            "fit",
            "--points",
            "p.csv",
            "--out",
            "m.bin",
            "--json",
            "f.json",
            "--max-iters",
            "1",
            "-q",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(0));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("warning: the hyperparameter search converged from no start"),
        "{err}"
    );
    assert!(dir.path().join("m.bin").exists());
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("f.json")).unwrap()).unwrap();
    assert_eq!(
        json["channels"][0]["optimization"]["outcome"], "stopped-early",
        "{json}"
    );
    assert_eq!(
        json["channels"][0]["warnings"].as_array().map(Vec::len),
        Some(1),
        "{json}"
    );
    let clean = trainer(
        &["fit", "--points", "p.csv", "--out", "m.bin", "-q"],
        dir.path(),
    );
    assert!(
        clean.stderr.is_empty(),
        "{:?}",
        String::from_utf8_lossy(&clean.stderr)
    );
}

#[test]
fn a_malformed_command_line_exits_two() {
    let dir = tempfile::tempdir().unwrap();
    for args in [
        &["fit", "--points"][..],
        &["fit", "--bogus"],
        &["loo", "--points", "p.csv", "--quiet", "--verbose"],
        &["nonsense"],
        // A flag a command has no use for is refused before anything is read.
        &[
            "investigate",
            "--points",
            "p.csv",
            "--group",
            "g",
            "--offsets",
            "--stream",
            "a.csv",
            "--valid-stream",
            "b.csv",
        ],
        &[
            "report",
            "--points",
            "p.csv",
            "--group",
            "g",
            "--offsets",
            "--out",
            "r",
        ],
    ] {
        let out = trainer(args, dir.path());
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
}

#[test]
fn results_go_to_stdout_json_alone_under_json_dash_and_nothing_under_quiet() {
    let dir = tempfile::tempdir().unwrap();
    rate_table(dir.path());
    let fit = &["fit", "--points", "p.csv", "--out", "m.bin"];
    let plain = trainer(fit, dir.path());
    assert_eq!(plain.status.code(), Some(0));
    let text = String::from_utf8_lossy(&plain.stdout);
    assert!(text.contains("wrote m.bin"), "{text}");
    // Piped: no progress bar, no stray text on stderr.
    assert!(plain.stderr.is_empty(), "{:?}", plain.stderr);

    let json = trainer(&[fit, &["--json", "-"][..]].concat(), dir.path());
    assert_eq!(json.status.code(), Some(0));
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).expect("stdout is JSON alone");
    assert_eq!(v["channels"][0]["n_train"], 48);
    assert!(!dir.path().join("-").exists());
    // An exact fit says nothing of this machine's speed: that is the benchmark's
    // (`examples/fit_timing.rs`), not every fit's.
    assert!(v.get("dense_floor").is_none(), "{v}");

    std::fs::remove_file(dir.path().join("m.bin")).unwrap();
    let quiet = trainer(&[fit, &["--quiet"][..]].concat(), dir.path());
    assert_eq!(quiet.status.code(), Some(0));
    assert!(quiet.stdout.is_empty() && quiet.stderr.is_empty());
    assert!(dir.path().join("m.bin").exists());

    let verbose = trainer(&[fit, &["-v"][..]].concat(), dir.path());
    let err = String::from_utf8_lossy(&verbose.stderr);
    assert!(
        err.contains("optimizer starts") && err.contains("convergence: "),
        "{err}"
    );
    let out = String::from_utf8_lossy(&verbose.stdout);
    assert!(out.contains("wrote m.bin"), "{out}");
}

#[test]
fn every_command_shows_an_example_in_its_help() {
    let dir = tempfile::tempdir().unwrap();
    for cmd in [
        "demo",
        "fit",
        "diagnose",
        "investigate",
        "inspect",
        "loo",
        "report",
        "reproduce",
        "challenge",
        "allan",
        "summarize",
    ] {
        let out = trainer(&[cmd, "--help"], dir.path());
        assert_eq!(out.status.code(), Some(0));
        let help = String::from_utf8_lossy(&out.stdout);
        assert!(help.contains(&format!("Example: trainer {cmd} ")), "{help}");
        assert!(
            help.contains("--quiet") && help.contains("--verbose"),
            "{help}"
        );
    }
}

#[test]
fn report_without_data_runs_on_the_simulated_gyro_and_points_alone_make_a_table_report() {
    let dir = tempfile::tempdir().unwrap();
    rate_table(dir.path());
    let alone = trainer(&["report", "--points", "p.csv", "--out", "t"], dir.path());
    assert_eq!(alone.status.code(), Some(0), "{alone:?}");
    let table = dir.path().join("t");
    assert!(table.join("report.html").exists() && table.join("loo_error.svg").exists());
    assert!(
        !table.join("replay.svg").exists(),
        "a table alone has no stream to replay"
    );
    let out = trainer(&["report", "--out", "r"], dir.path());
    assert_eq!(out.status.code(), Some(0), "{:?}", out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.starts_with("no data given: simulated"), "{text}");
    for name in [
        "data/points.csv",
        "data/valid.csv",
        "report.html",
        "replay.svg",
    ] {
        assert!(dir.path().join("r").join(name).exists(), "{name}");
    }
}

#[test]
fn a_static_log_where_the_unit_was_handled_says_where_and_leaves_it_out() {
    let dir = tempfile::tempdir().unwrap();
    // 30 minutes at 1 Hz warming 20 → 35 °C, bias 2e-3 °/s per °C plus a ripple for noise; from
    // 900 s to 960 s someone turns the unit by hand (tens of °/s).
    let mut csv = String::from("time_s,temp_c,voltage_v,rate_dps\n");
    for i in 0..1800u32 {
        let t = f64::from(i);
        let temp = 20.0 + 15.0 * t / 1800.0;
        let mut out = 2e-3 * temp + 1e-3 * (t * 1.7).sin();
        if (900..960).contains(&i) {
            out += 30.0 * (t * 0.2).sin();
        }
        csv.push_str(&format!("{t},{temp},{out},0\n"));
    }
    std::fs::write(dir.path().join("log.csv"), csv).unwrap();
    let out = trainer(
        &[
            "fit",
            "--stream",
            "log.csv",
            "--scale-factor",
            "1",
            "--out",
            "m.bin",
            "--json",
            "f.json",
        ],
        dir.path(),
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    // One line says what was left out and where (each window under -v and in the JSON).
    assert!(
        err.contains("1 minute where the unit was handled")
            && err.contains("between 900 and 959 s (line 902 on)"),
        "{err}"
    );
    assert_eq!(err.matches("handled").count(), 1, "{err}");
    let fit: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("f.json")).unwrap()).unwrap();
    assert_eq!(
        fit["channels"][0]["handled"].as_array().unwrap().len(),
        1,
        "{fit}"
    );
    assert_eq!(fit["channels"][0]["handled"][0]["n"], 60);
    // The static model was fitted on the 29 other minutes: 29 points.
    assert_eq!(fit["channels"][0]["n_train"], 29, "{fit}");
}

/// A turntable run in time order: 12 half-sweeps of 13 rates, 20 s per row, the temperature
/// swinging ±3 °C; the coil lags the sensor by 120 s and the scale factor follows the coil.
fn turntable(dir: &Path) {
    let mut csv = String::from("segment,half_sweep,temp_c,voltage_v,rate_dps\n");
    let (mut coil, mut t, mut segment) = (40.0f64, 0.0f64, 0);
    for sweep in 0..12 {
        for k in 0..13 {
            let w = if sweep % 2 == 0 { 10.0 } else { -10.0 } * f64::from(k);
            let temp = 40.0 + 3.0 * (t / 900.0).sin() + t / 3000.0;
            coil += (1.0 - (-20.0f64 / 120.0).exp()) * (temp - coil);
            let v = 0.05 * (1.0 - 5e-3 * (coil - 40.0)) * w
                + 1e-3 * (coil - 40.0)
                + 2e-4 * (f64::from(segment) * 1.7).sin();
            csv.push_str(&format!("{segment},{sweep},{temp},{v},{w}\n"));
            t += 20.0;
            segment += 1;
        }
    }
    std::fs::write(dir.join("t.csv"), csv).unwrap();
}

#[test]
fn a_table_in_time_order_is_diagnosed_and_its_transient_carried_to_the_blob() {
    let dir = tempfile::tempdir().unwrap();
    turntable(dir.path());
    let timed = [
        "--points",
        "t.csv",
        "--map",
        "time_s=segment*20",
        "--group",
        "half_sweep",
    ];
    let fit = |extra: &[&str]| {
        let mut args = vec!["fit", "--features", "auto", "--out", "m.bin", "--json", "-"];
        args.extend(extra);
        trainer(&args, dir.path())
    };
    let out = fit(&timed);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let d = &json["channels"][0]["table_diagnosis"];
    assert_eq!(d["shipped"], true, "{d}");
    assert_eq!(d["chosen"][0]["acts_on"], "scale-factor", "{d}");
    assert!(
        json["channels"][0]["features"]
            .to_string()
            .contains("TemperatureRate"),
        "{}",
        json["channels"][0]["features"]
    );

    // The same, evaluated: the choice redone inside every left-out half-sweep.
    let loo = |extra: &[&str]| {
        let mut args = vec!["loo", "--json", "-"];
        args.extend(timed);
        args.extend(extra);
        let out = trainer(&args, dir.path());
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let (plain, auto) = (loo(&[]), loo(&["--features", "auto"]));
    let rmse = |v: &serde_json::Value| v["group_rmse_dps"].as_f64().unwrap();
    assert!(
        rmse(&auto) < 0.5 * rmse(&plain),
        "{} vs {}",
        rmse(&auto),
        rmse(&plain)
    );
    assert_eq!(auto["diagnosis"]["per_group"].as_array().unwrap().len(), 12);

    // Without its time column the table cannot be diagnosed, and the error says what to give.
    let out = fit(&["--points", "t.csv", "--group", "half_sweep"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--map time_s="), "{err}");
}

/// A table of 12 half-sweeps whose temperature drifts from sweep to sweep, each sweep with its
/// own bias offset (a turn-on or a rig re-seat), on a smooth temperature response.
fn offset_sweeps(dir: &Path) {
    let mut csv = String::from("half_sweep,temp_c,voltage_v,rate_dps\n");
    for sweep in 0..12 {
        let offset = 2e-3 * (f64::from(sweep) * 2.3).sin();
        for k in 0..13 {
            let w = -60.0 + 10.0 * f64::from(k);
            let temp = 20.0 + 3.5 * f64::from(sweep) + 0.2 * f64::from(k);
            let v = 0.05 * (1.0 - 2e-3 * (temp - 40.0)) * w
                + 1e-3 * ((temp - 40.0) / 15.0).sin()
                + offset
                + 1e-4 * (f64::from(13 * sweep + k) * 1.7).sin();
            csv.push_str(&format!("{sweep},{temp},{v},{w}\n"));
        }
    }
    std::fs::write(dir.join("o.csv"), csv).unwrap();
}

#[test]
fn offsets_between_sweeps_are_fitted_as_a_variance_and_left_out_of_predictions() {
    let dir = tempfile::tempdir().unwrap();
    offset_sweeps(dir.path());
    let table = ["--points", "o.csv", "--group", "half_sweep"];
    let run = |args: &[&str]| {
        let out = trainer(args, dir.path());
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let loo = |extra: &[&str]| {
        let mut args = vec!["loo", "--json", "-"];
        args.extend(table);
        args.extend(extra);
        run(&args)
    };
    let (plain, offsets) = (loo(&[]), loo(&["--offsets"]));
    let rmse = |v: &serde_json::Value| v["group_rmse_dps"].as_f64().unwrap();
    assert!(
        rmse(&offsets) < rmse(&plain),
        "{} vs {}",
        rmse(&offsets),
        rmse(&plain)
    );
    assert!(offsets["parameters"]["offset_std"].as_f64().is_some());

    // The blob is written; the offsets' variance is reported, the firmware agrees with the host.
    let mut args = vec!["fit", "--offsets", "--out", "m.bin", "--json", "-"];
    args.extend(table);
    let fit = run(&args);
    let g = fit["channels"][0]["hyperparameters"]["offset_std"]
        .as_f64()
        .unwrap()
        * fit["channels"][0]["output_scale"].as_f64().unwrap();
    // The offsets are 1.4e-3 V RMS: 0.028 °/s at 0.05 V per °/s.
    assert!((0.01..0.06).contains(&g), "σ_g {g}");
    // The prior mean's basis is chosen with offsets too (on the bands' plain GPs: the module doc
    // of `analysis::basis`), and the model that ships, and `loo`'s, hold the basis reported.
    let channel = &fit["channels"][0];
    let choice = &channel["basis_choice"];
    assert!(choice["scores"].as_array().unwrap().len() >= 2, "{choice}");
    assert_eq!(channel["mean_basis"], choice["basis"], "{choice}");
    assert_eq!(offsets["basis_choice"]["basis"], choice["basis"]);

    // Without --group there is nothing to give an offset to; investigate does not take it.
    let out = trainer(&["loo", "--points", "o.csv", "--offsets"], dir.path());
    assert_eq!(out.status.code(), Some(2));
    let out = trainer(
        &[
            "investigate",
            "--points",
            "o.csv",
            "--group",
            "half_sweep",
            "--offsets",
            "--stream",
            "a.csv",
            "--valid-stream",
            "b.csv",
        ],
        dir.path(),
    );
    // Refused as the command line is read, before anything is loaded.
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("unexpected argument '--offsets'"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Other power-ons' tables are pooled by `fit`, `investigate` and `loo`; `report` refuses them as
/// its command line is read (no file named here exists: nothing is opened).
#[test]
fn run_is_refused_by_a_command_that_does_not_pool_runs_before_anything_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let out = trainer(
        &[
            "report", "--points", "o.csv", "--run", "p2.csv", "--out", "r",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("unexpected argument '--run'"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!dir.path().join("r").exists());
}

/// Held-out data are named one way: part of `--stream`'s log, or a log of its own, never both,
/// and never without the log they are held out of; refused as the command line is read.
#[test]
fn held_out_data_are_named_one_way_and_checked_before_anything_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let refused = |args: &[&str], says: &str| {
        let out = trainer(args, dir.path());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(says), "{stderr}");
    };
    refused(
        &[
            "investigate",
            "--stream",
            "a.csv",
            "--hold-out-from",
            "60",
            "--valid-stream",
            "b.csv",
        ],
        "cannot be used with",
    );
    refused(
        &[
            "report",
            "--points",
            "p.csv",
            "--hold-out-from",
            "60",
            "--out",
            "r",
        ],
        "--stream",
    );
    refused(
        &[
            "investigate",
            "--train-stream",
            "a.csv",
            "--valid-stream",
            "b.csv",
        ],
        "unexpected argument '--train-stream'",
    );
    assert!(!dir.path().join("r").exists());
}

#[test]
fn an_implausible_row_is_refused_or_with_the_option_left_out_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    rate_table(dir.path());
    let path = dir.path().join("p.csv");
    let mut csv = std::fs::read_to_string(&path).unwrap();
    csv.push_str("250,0.5,10\n");
    std::fs::write(&path, csv).unwrap();
    let fit = |extra: &[&str]| {
        let mut args = vec!["fit", "--points", "p.csv", "--out", "m.bin", "--json", "-"];
        args.extend(extra);
        trainer(&args, dir.path())
    };
    let out = fit(&[]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 50, column temp_c: 250"), "{err}");
    assert!(!dir.path().join("m.bin").exists());

    let out = fit(&["--exclude-implausible"]);
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("warning") && err.contains("left out (--exclude-implausible)"),
        "{err}"
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["channels"][0]["n_train"], 48, "{json}");
}

#[test]
fn flags_that_would_be_ignored_are_refused_and_a_test_that_cannot_run_is_skipped_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    rate_table(dir.path());
    // A stream beside --points is used only with --pool-stream or --features.
    let out = trainer(
        &[
            "fit", "--points", "p.csv", "--stream", "s.csv", "--out", "m.bin",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--stream would not be used"), "{err}");
    // Each other combination `fit` has no plan for is refused before anything is read or fitted:
    // named inputs on a table, inputs with no stream to fit them on, an unknown input.
    for (args, expected) in [
        (
            &["--points", "p.csv", "--features", "time-on"][..],
            "on a rate table the inputs are chosen by its diagnosis",
        ),
        (
            &[
                "--stream",
                "a.csv",
                "--stream",
                "b.csv",
                "--features",
                "auto",
            ][..],
            "2 streams given",
        ),
        (
            &[
                "--points",
                "p.csv",
                "--stream",
                "s.csv",
                "--features",
                "warp-drive",
            ][..],
            "warp-drive",
        ),
    ] {
        let out = trainer(
            &[&["fit"][..], args, &["--out", "m.bin"]].concat(),
            dir.path(),
        );
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expected), "{args:?}: {err}");
        assert!(!dir.path().join("m.bin").exists());
    }

    // A temperature drifting through the run: one group, nothing to leave out.
    let mut csv = String::from("temp_c,voltage_v,rate_dps\n");
    for i in 0..60 {
        let (t, w) = (20.0 + 0.2 * f64::from(i), f64::from(i % 6 - 3) * 20.0);
        csv.push_str(&format!("{t},{},{w}\n", 0.04 * w + 1e-3 * t));
    }
    std::fs::write(dir.path().join("d.csv"), csv).unwrap();
    // Point LOO runs; leaving a group out is skipped, in one line with the reason.
    let out = trainer(&["loo", "--points", "d.csv"], dir.path());
    assert_eq!(out.status.code(), Some(0));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("skipped: all 60 points fall in one group") && err.contains("--group"),
        "{err}"
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("leave-one-out RMSE"));
}

/// What a reading that cannot be true is, as `fit` is told: a rated range the training data
/// leave is refused before a blob is written, one outside −100…200 °C is no range, and a range
/// that holds the data ships in the blob, which then faults only beyond it.
#[test]
fn the_sensors_limits_are_checked_against_the_data_and_written_into_the_blob() {
    let dir = tempfile::tempdir().unwrap();
    rate_table(dir.path());
    let out = trainer(
        &[
            "fit",
            "--points",
            "p.csv",
            "--rated-temp",
            "-20:85",
            "--out",
            "m.bin",
            "-q",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("beyond the sensor's limits"), "{err}");
    assert!(!dir.path().join("m.bin").exists());
    for bad in ["-300:85", "85:-40", "cold:hot"] {
        let out = trainer(
            &[
                "fit",
                "--points",
                "p.csv",
                "--rated-temp",
                bad,
                "--out",
                "m.bin",
            ],
            dir.path(),
        );
        assert_eq!(out.status.code(), Some(2), "{bad}");
    }
    let out = trainer(
        &[
            "fit",
            "--points",
            "p.csv",
            "--rated-temp",
            "-40:85",
            "--full-scale",
            "5",
            "--beyond",
            "hold",
            "--out",
            "m.bin",
            "-q",
        ],
        dir.path(),
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let blob = std::fs::read(dir.path().join("m.bin")).unwrap();
    let model = fog_data::replay::decode(&blob).unwrap();
    let limits = model.limits();
    assert_eq!(
        (limits.temp_min_c, limits.temp_max_c, limits.full_scale),
        (-40.0, 85.0, 5.0)
    );
    assert_eq!(model.beyond(), firmware_core::Beyond::Hold);
    let mut scratch = vec![0.0f32; model.dims().m];
    let at = |t: f32, scratch: &mut [f32]| model.predict(&[t, 0.4], scratch).unwrap().status;
    assert_eq!(
        at(-38.0, &mut scratch),
        firmware_core::Status::Extrapolating
    );
    assert_eq!(at(-41.0, &mut scratch), firmware_core::Status::Fault);
}

/// Another run's table is held out by `loo --valid-points`, as a log by `--valid-stream`; the
/// flag's former name, `--test-points`, still does the same.
#[test]
fn loo_holds_out_another_table_by_either_name() {
    let dir = tempfile::tempdir().unwrap();
    rate_table(dir.path());
    std::fs::copy(dir.path().join("p.csv"), dir.path().join("q.csv")).unwrap();
    let cross = |flag: &str, json: &str| {
        let args = [
            "loo", "--points", "p.csv", flag, "q.csv", "--method", "two-step",
        ];
        let out = trainer(&[&args[..], &["--json", json, "-q"]].concat(), dir.path());
        assert_eq!(out.status.code(), Some(0), "{flag}: {out:?}");
        let text = std::fs::read_to_string(dir.path().join(json)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v["cross_run"].clone()
    };
    let valid = cross("--valid-points", "v.json");
    assert_eq!(valid["n"], 48, "{valid}");
    assert_eq!(cross("--test-points", "t.json"), valid);
}

/// A blob cut short is refused with its name and the firmware's reason, said once.
#[test]
fn inspect_names_a_blob_it_cannot_decode_and_why_once() {
    let dir = tempfile::tempdir().unwrap();
    rate_table(dir.path());
    let fit = trainer(
        &["fit", "--points", "p.csv", "--out", "m.bin", "-q"],
        dir.path(),
    );
    assert_eq!(fit.status.code(), Some(0), "{fit:?}");
    let blob = std::fs::read(dir.path().join("m.bin")).unwrap();
    std::fs::write(dir.path().join("cut.bin"), &blob[..blob.len() / 2]).unwrap();
    let out = trainer(&["inspect", "cut.bin"], dir.path());
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("decoding cut.bin: "), "{err}");
    assert_eq!(err.matches("truncated").count(), 1, "{err}");
}
