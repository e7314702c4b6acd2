//! The command line end to end, and its manners with bad input.

use super::{at, json, one, sim, trainer};

/// A temporary directory holding `points.csv`: the paper protocol on the nominal unit.
fn paper_points(seed: &str) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let points = at(dir.path(), "points.csv");
    sim(&["generate", "paper", "--seed", seed, "--out", &points]).unwrap();
    (dir, points)
}

#[test]
fn generate_fit_loo_reproduce_end_to_end() {
    let (dir, points) = paper_points("3");
    let again = at(dir.path(), "again.csv");
    sim(&["generate", "paper", "--seed", "3", "--out", &again]).unwrap();
    let bytes = std::fs::read(&points).unwrap();
    assert_eq!(
        bytes,
        std::fs::read(&again).unwrap(),
        "same seed, same bytes"
    );
    assert_eq!(bytes.iter().filter(|&&b| b == b'\n').count(), 141);

    let (model, fit) = (at(dir.path(), "model.bin"), at(dir.path(), "fit.json"));
    trainer(&["fit", "--points", &points, "--out", &model, "--json", &fit]).unwrap();
    let whole = json(&fit);
    // Every JSON names its contract first (fog_terminal::schema).
    assert_eq!(
        whole["schema"],
        serde_json::json!({"name": "trainer.fit", "version": 3})
    );
    let f = one(&fit);
    assert_eq!(f["name"], "rate");
    assert_eq!(f["n_train"], 140);
    assert_eq!(f["features"], serde_json::json!(["temp_c", "voltage_v"]));
    assert!(f["log_marginal_likelihood"].as_f64().unwrap().is_finite());
    assert_eq!(
        f["hyperparameters"]["length_scales"]
            .as_array()
            .unwrap()
            .len(),
        2
    );
    assert!(f["fit_seconds"].as_f64().unwrap() > 0.0);
    let blob = std::fs::read(&model).unwrap();
    // One channel's model, in a unit blob of one entry.
    assert_eq!(&blob[..4], &firmware_core::blob::unit::MAGIC[..]);
    assert_eq!(whole["blob_bytes"], blob.len());
    let agreement = &f["firmware_agreement"]["grid_inside"];
    assert!(agreement["max_abs_mean_diff"].as_f64().unwrap() < 1e-5);
    let inspect = at(dir.path(), "inspect.json");
    trainer(&["inspect", &model, "--json", &inspect]).unwrap();
    let whole = json(&inspect);
    assert_eq!(whole["schema"]["name"], "trainer.inspect");
    let [name, i] = [&whole["channels"][0][0], &whole["channels"][0][1]];
    assert_eq!(name, "rate");
    assert_eq!(
        (i["m"].as_u64(), i["d"].as_u64(), i["p"].as_u64()),
        (Some(140), Some(2), Some(7))
    );
    assert_eq!(i["floats"], 7 * 2 + 7 + 2 + 140 * 2 + 140 + 140 * 141 / 2);

    let mut rmse = std::collections::HashMap::new();
    for method in ["gpr", "lssvr", "two-step"] {
        let out = at(dir.path(), &format!("loo-{method}.json"));
        trainer(&[
            "loo", "--points", &points, "--method", method, "--json", &out,
        ])
        .unwrap();
        let l = json(&out);
        assert_eq!(l["schema"]["name"], "trainer.loo");
        let per_t = l["per_temperature"].as_array().unwrap();
        assert_eq!(per_t.len(), 10);
        assert!(
            per_t
                .iter()
                .all(|g| g["temp_c"].is_number() && g["rmse_dps"].is_number())
        );
        rmse.insert(method, l["rmse_dps"].as_f64().unwrap());
        // `loo` ships no blob and states no sensor lag: no heating band either (`fit` on the
        // same table states its soaks').
        if method == "gpr" {
            let heating = &l["calibration"]["heating"];
            assert!(
                heating["band"].is_null() && heating["sensor_lag_s"].is_null(),
                "{heating}"
            );
        }
    }
    // The paper's ordering on its own kind of data: GPR well below the two-step model.
    assert!(rmse["gpr"] < 1.5e-3, "GPR LOO {}", rmse["gpr"]);
    assert!(rmse["two-step"] > 10.0 * rmse["gpr"], "{rmse:?}");

    let rep = at(dir.path(), "reproduce.json");
    trainer(&["reproduce", "--points", &points, "--json", &rep]).unwrap();
    let r = json(&rep);
    assert_eq!(r["schema"]["name"], "trainer.reproduce");
    assert!(r["fig2"]["worst"]["worst_mv"].as_f64().unwrap() > 1.0);
    assert!(r["gpr"]["qq_correlation"].as_f64().unwrap() > 0.9);
}

fn bad_points(contents: &str) -> (tempfile::TempDir, String, String) {
    let dir = tempfile::tempdir().unwrap();
    let points = at(dir.path(), "bad.csv");
    std::fs::write(&points, contents).unwrap();
    let out = at(dir.path(), "model.bin");
    (dir, points, out)
}

fn fit_error(contents: &str) -> String {
    let (_dir, points, out) = bad_points(contents);
    let e = trainer(&["fit", "--points", &points, "--out", &out]).unwrap_err();
    assert!(
        !std::path::Path::new(&out).exists(),
        "nothing written on error"
    );
    format!("{e:#}")
}

#[test]
fn bad_input_is_refused_with_file_line_and_column() {
    let good = "temp_c,voltage_v,rate_dps\n-10,0.1,2\n20,0.2,5\n";
    let e = fit_error(&format!("{good}40,abc,3\n"));
    assert!(
        e.contains("bad.csv line 4, column voltage_v: 'abc' is not a number"),
        "{e}"
    );
    let e = fit_error(&format!("{good}40,0.1\n"));
    assert!(e.contains("line 4: 2 fields, but the header has 3"), "{e}");
    let e = fit_error("temp_c,voltage_v\n1,2\n");
    assert!(e.contains("missing column 'rate_dps'"), "{e}");
    let e = fit_error(&format!("{good}40,NaN,3\n"));
    assert!(
        e.contains("line 4, column voltage_v: NaN is not a finite number"),
        "{e}"
    );
    let e = fit_error("");
    assert!(e.contains("empty file"), "{e}");
    let e = fit_error("temp_c,voltage_v,rate_dps\n20,0.1,1\n20.02,0.2,2\n20.01,0.3,3\n");
    assert!(e.contains("temperatures span only 0.020 °C"), "{e}");
    let e = fit_error("temp_c,voltage_v,rate_dps\n0,0.1,1\n20,0.1,2\n40,0.1,3\n");
    assert!(e.contains("column voltage_v: constant (0.1)"), "{e}");
    let e = fit_error("temp_c,voltage_v,rate_dps\n0,0.1,1\n20,0.2,1\n40,0.3,1\n");
    assert!(
        e.contains("every reference rate is 1 °/s") && e.contains("--scale-factor K"),
        "{e}"
    );
}

#[test]
fn a_command_never_writes_over_its_input() {
    let (_dir, points, _) = bad_points("temp_c,voltage_v,rate_dps\n0,0.1,1\n20,0.2,2\n");
    let e = trainer(&["fit", "--points", &points, "--out", &points]).unwrap_err();
    assert!(format!("{e:#}").contains("it is also an input"), "{e:#}");
    assert!(
        std::fs::read_to_string(&points)
            .unwrap()
            .starts_with("temp_c")
    );
}

#[test]
fn mapped_columns_and_tabs_load_like_canonical_ones() {
    let (dir, points) = paper_points("5");
    // The same data with other names, millivolts and tabs.
    let text = std::fs::read_to_string(&points).unwrap();
    let mut mapped = String::from("T\tout_mv\tw\n");
    for line in text.lines().skip(1) {
        let f: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        mapped.push_str(&format!("{}\t{}\t{}\n", f[0], f[1] * 1e3, f[2]));
    }
    let tsv = at(dir.path(), "points.tsv");
    std::fs::write(&tsv, mapped).unwrap();
    let (a, b) = (at(dir.path(), "a.json"), at(dir.path(), "b.json"));
    trainer(&[
        "loo", "--points", &points, "--method", "two-step", "--json", &a,
    ])
    .unwrap();
    let maps = [
        "--map",
        "temp_c=T",
        "--map",
        "voltage_v=out_mv*0.001",
        "--map",
        "rate_dps=w",
    ];
    let mut args = vec![
        "loo", "--points", &tsv, "--method", "two-step", "--json", &b,
    ];
    args.extend(maps);
    trainer(&args).unwrap();
    let (ra, rb) = (
        json(&a)["rmse_dps"].as_f64().unwrap(),
        json(&b)["rmse_dps"].as_f64().unwrap(),
    );
    assert!((ra - rb).abs() < 1e-9 * ra, "{ra} vs {rb}");
}

#[test]
fn leave_one_group_out_uses_the_named_column() {
    let (dir, points) = paper_points("7");
    let out = at(dir.path(), "loo.json");
    let args = [
        "loo",
        "--points",
        &points,
        "--method",
        "two-step",
        "--group",
        "setpoint_c",
    ];
    trainer(&[&args[..], &["--json", &out]].concat()).unwrap();
    let groups: Vec<String> = json(&out)["per_temperature"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["group"].as_str().unwrap().to_owned())
        .collect();
    assert_eq!(
        groups,
        ["-30", "-20", "-10", "-5", "0", "5", "10", "20", "40", "60"]
    );
}

/// More points than a firmware model holds (140 rate points and 140 position tests: 280): the
/// default fit chooses a sparse GP on the data, says what it costs against the exact GP, and
/// writes a blob; asking for the exact GP is refused before any fitting, with the sizes.
#[test]
fn the_default_fit_of_too_many_points_yields_a_firmware_model_and_exact_is_refused_with_the_limit()
{
    let dir = tempfile::tempdir().unwrap();
    let points = at(dir.path(), "points.csv");
    sim(&[
        "generate",
        "paper",
        "--seed",
        "8",
        "--position-tests",
        "--out",
        &points,
    ])
    .unwrap();
    let out = at(dir.path(), "model.bin");
    let report = at(dir.path(), "fit.json");
    trainer(&["fit", "--points", &points, "--out", &out, "--json", &report]).unwrap();
    let fit = one(&report);
    let choice = &fit["centres_choice"];
    let chosen = choice["chosen"].as_u64().unwrap();
    assert!([24, 48, 96, 160, 256].contains(&chosen), "{choice:#}");
    assert!(fit["centres"].as_u64().unwrap() <= 256);
    assert_eq!(choice["exact"]["exportable"], false);
    assert!(
        choice["verdict"]
            .as_str()
            .unwrap()
            .contains("instructions per prediction")
    );
    // The rule: the fewest within 5% of the best candidate's held-out error.
    let candidates = choice["candidates"].as_array().unwrap();
    let best = candidates
        .iter()
        .map(|c| c["held_out_rmse_dps"].as_f64().unwrap())
        .fold(f64::INFINITY, f64::min);
    let first = candidates
        .iter()
        .find(|c| c["held_out_rmse_dps"].as_f64().unwrap() <= 1.05 * best)
        .unwrap();
    assert_eq!(first["asked"].as_u64().unwrap(), chosen);
    assert!(std::path::Path::new(&out).exists());

    let exact = at(dir.path(), "exact.bin");
    let e = trainer(&[
        "fit",
        "--points",
        &points,
        "--inducing",
        "exact",
        "--out",
        &exact,
    ])
    .unwrap_err();
    assert!(format!("{e:#}").contains("280 centres"), "{e:#}");
    assert!(format!("{e:#}").contains("at most 256 centres"), "{e:#}");
    assert!(format!("{e:#}").contains("checked before fitting"), "{e:#}");
    assert!(!std::path::Path::new(&exact).exists());
}

/// `value` without the wall-clock fields (`*_seconds`): the only bytes a rerun may change.
pub(crate) fn without_timings(mut value: serde_json::Value) -> serde_json::Value {
    match &mut value {
        serde_json::Value::Object(map) => {
            map.retain(|k, _| !k.ends_with("_seconds"));
            for v in map.values_mut() {
                *v = without_timings(v.take());
            }
        }
        serde_json::Value::Array(items) => {
            for v in items.iter_mut() {
                *v = without_timings(v.take());
            }
        }
        _ => {}
    }
    value
}

#[test]
fn the_same_inputs_and_seed_give_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| at(dir.path(), name);
    // Streams of the shorter lab design (60 min): determinism does not need the longest log,
    // and on these every command below takes its longer path (the pooled model ships, the
    // investigation names two causes and ships their extension).
    for (kind, seed, name) in [
        ("paper", "1", "points.csv"),
        ("stream", "2", "a.csv"),
        ("stream", "3", "b.csv"),
    ] {
        let design: &[&str] = if kind == "stream" {
            &["--design", "short"]
        } else {
            &[]
        };
        let out = p(name);
        let args = [
            &["generate", kind, "--seed", seed, "--effect", "thermal-rate"][..],
            design,
            &["--out", &out],
        ]
        .concat();
        sim(&args).unwrap();
    }
    let points = p("points.csv");
    for run in ["1", "2"] {
        let fit = |extra: &[&str], out: &str| {
            let mut args = vec!["fit", "--points", &points];
            args.extend(extra);
            let (blob, js) = (
                p(&format!("{out}{run}.bin")),
                p(&format!("{out}{run}.json")),
            );
            args.extend(["--out", &blob, "--json", &js, "-q"]);
            trainer(&args).unwrap();
        };
        fit(&[], "exact");
        let stream = p("a.csv");
        fit(&["--stream", &stream, "--pool-stream"], "sparse");
        fit(&["--stream", &stream, "--features", "auto"], "extended");
        let (model, js) = (p(&format!("ext{run}.bin")), p(&format!("inv{run}.json")));
        trainer(&[
            "investigate",
            "--points",
            &p("points.csv"),
            "--stream",
            &p("a.csv"),
            "--valid-stream",
            &p("b.csv"),
            "--out",
            &model,
            "--json",
            &js,
            "-q",
        ])
        .unwrap();
    }
    for name in ["exact", "sparse", "extended", "ext"] {
        let read = |run: &str| std::fs::read(p(&format!("{name}{run}.bin"))).unwrap();
        assert_eq!(read("1"), read("2"), "{name} blob");
    }
    for name in ["exact", "sparse", "extended", "inv"] {
        let read = |run: &str| without_timings(json(p(&format!("{name}{run}.json"))));
        assert_eq!(read("1"), read("2"), "{name} JSON");
    }
}

/// A static log at 1 Hz: white noise of `sd` °/s on a 0.38 V output at 25 °C, with a handling
/// event (a ±0.5 °/s swing for 60 s) at each of `handled` (s); returns its CSV text.
fn static_log(n: usize, sd: f64, handled: &[usize]) -> String {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut csv = String::from("time_s,temp_c,voltage_v,rate_dps\n");
    for i in 0..n {
        // Box–Muller: a standard normal from two uniforms.
        let (u, v): (f64, f64) = (rng.random(), rng.random());
        let z = (-2.0 * (1.0 - u).ln()).sqrt() * (std::f64::consts::TAU * v).cos();
        let moved = handled.iter().any(|&h| (h..h + 60).contains(&i));
        let swing = if moved {
            0.5 * (i as f64 / 3.0).sin()
        } else {
            0.0
        };
        csv.push_str(&format!("{i},25,{},0\n", 0.38 + sd * z + swing));
    }
    csv
}

/// Issue 45: handling stays out of the Allan deviation (its angle random walk within 20% of the
/// quiet log's), `--exclude` leaves a named window out of a replay's scores, and the windows left
/// out are said in one line.
#[test]
fn handling_and_excluded_windows_stay_out_of_the_allan_deviation_and_the_scores() {
    let dir = tempfile::tempdir().unwrap();
    let (quiet, moved) = (at(dir.path(), "quiet.csv"), at(dir.path(), "moved.csv"));
    std::fs::write(&quiet, static_log(7200, 0.01, &[])).unwrap();
    std::fs::write(
        &moved,
        static_log(7200, 0.01, &[600, 1800, 3000, 4200, 5400]),
    )
    .unwrap();
    let arw = |path: &str, name: &str| {
        let out = at(dir.path(), name);
        trainer(&[
            "allan",
            "--stream",
            path,
            "--scale-factor",
            "1",
            "--json",
            &out,
        ])
        .unwrap();
        one(&out)["arw_deg_per_sqrt_h"].as_f64().unwrap()
    };
    let (a, b) = (arw(&quiet, "q.json"), arw(&moved, "m.json"));
    assert!(
        (b / a - 1.0).abs() < 0.2,
        "ARW {b} with handling, {a} quiet"
    );
    // A window named by --exclude is left out of the replay's scores like a handled one.
    let blob = concat!(env!("CARGO_MANIFEST_DIR"), "/../firmware-core/doc/gyro.bin");
    let replay = |extra: &[&str], name: &str| {
        let out = at(dir.path(), name);
        let args = [
            &[
                "replay", "--model", blob, "--stream", &quiet, "--json", &out,
            ][..],
            extra,
        ]
        .concat();
        sim(&args).unwrap();
        one(&out)
    };
    let all = replay(&[], "all.json");
    let cut = replay(&["--exclude", "100:700", "--window", ":7000"], "cut.json");
    assert_eq!(all["n_handled"], 0);
    assert_eq!(cut["n_handled"], 600);
    assert_eq!(cut["handled"][0]["asked"], true);
    assert_eq!(
        cut["n"].as_u64().unwrap() + 600 + 200,
        all["n"].as_u64().unwrap()
    );
}
