//! A flight controller's log in, the autopilots' parameters out: a simulated board's thermal
//! calibration (two IMUs) recorded as PX4 and as ArduPilot record it, fitted in one command each,
//! and the parameter files evaluated by the formulas the autopilots' firmware applies, written
//! here from their documentation (not from this project's code).

use std::collections::HashMap;
use std::path::Path;

use trainer::analysis::autopilot::CubicFigures;

use crate::cli::without_timings;
use crate::{at, json, sim, trainer};

/// PX4's `.params` file: parameter name → value.
fn px4_params(path: &Path) -> HashMap<String, f64> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            assert_eq!(f.len(), 5, "vehicle, component, name, value, type: {l}");
            assert_eq!((f[0], f[1]), ("1", "1"));
            let int = f[2].ends_with("_ID") || f[2].ends_with("_ENABLE");
            assert_eq!(f[4], if int { "6" } else { "9" }, "{l}");
            (f[2].to_owned(), f[3].parse().unwrap())
        })
        .collect()
}

/// ArduPilot's `.parm` file: parameter name → value.
fn ardupilot_params(path: &Path) -> HashMap<String, f64> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| {
            let (name, value) = l.split_once(' ').unwrap();
            (name.to_owned(), value.parse().unwrap())
        })
        .collect()
}

/// PX4's `TemperatureCompensation::calc_thermal_offsets_3D` for one axis: the offset the firmware
/// subtracts at temperature `t`, in rad/s or m/s².
fn px4_offset(p: &HashMap<String, f64>, prefix: &str, axis: usize, t: f64) -> f64 {
    let get = |k: &str| p[&format!("{prefix}_{k}")];
    let d = t.clamp(get("TMIN"), get("TMAX")) - get("TREF");
    let x = |i: usize| get(&format!("X{i}_{axis}"));
    x(0) + x(1) * d + x(2) * d * d + x(3) * d * d * d
}

/// ArduPilot's `AP_InertialSensor_TCal::correct_sensor` for one axis of IMU `n` (1-based): what
/// the firmware subtracts at temperature `t` for a sensor whose constant offset was calibrated at
/// `cal_t`; `kind` is `ACC` or `GYR`, `axis` `X`, `Y` or `Z`.
fn ardupilot_offset(
    p: &HashMap<String, f64>,
    (n, kind, axis): (u32, &str, &str),
    t: f64,
    cal_t: f64,
) -> f64 {
    let (lo, hi) = (
        p[&format!("INS_TCAL{n}_TMIN")],
        p[&format!("INS_TCAL{n}_TMAX")],
    );
    let c = |power: u32| p[&format!("INS_TCAL{n}_{kind}{power}_{axis}")];
    let poly = |t: f64| {
        let d = t.clamp(lo, hi) - 35.0;
        (c(1) * d + c(2) * d * d + c(3) * d * d * d) * 1e-6
    };
    poly(t) - poly(cal_t)
}

/// The project's cubic of one channel from `fit --json`'s `autopilot`, at `t` (clipped), in the
/// channel's units.
fn cubic(fit: &serde_json::Value, axis: usize, t: f64) -> f64 {
    let c = &fit["autopilot"]["axes"][axis];
    let f = |k: &str| c[k].as_f64().unwrap();
    let d = t.clamp(f("tmin_c"), f("tmax_c")) - f("tref_c");
    let k: Vec<f64> = (0..4).map(|i| c["coef"][i].as_f64().unwrap()).collect();
    k[0] + d * (k[1] + d * (k[2] + d * k[3]))
}

/// A simulated board's log of `minutes` (`firmware-sim generate board --seed SEED`), written as
/// `name` in `d` (its format by the extension); its path.
fn board(d: &Path, name: &str, seed: &str, minutes: &str) -> String {
    board_with(d, name, &["--seed", seed, "--minutes", minutes])
}

/// A simulated board's log (`firmware-sim generate board` with `args`), written as `name` in
/// `d`; its path.
fn board_with(d: &Path, name: &str, args: &[&str]) -> String {
    let log = at(d, name);
    sim(&[&["generate", "board"], args, &["--out", log.as_str()]].concat()).unwrap();
    log
}

#[test]
fn a_px4_and_an_ardupilot_log_give_the_parameters_their_firmware_evaluates_as_the_cubic() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (log, flag, file) in [
        ("cal.ulg", "--px4-params", "cal.params"),
        ("cal.bin", "--ardupilot-params", "tcal.parm"),
    ] {
        let log = &board(d, log, "3", "60");
        trainer(&[
            "-q",
            "fit",
            "--stream",
            log,
            flag,
            &at(d, file),
            "--out",
            &at(d, "imu.bin"),
            "--json",
            &at(d, "fit.json"),
        ])
        .unwrap();
        let names: &[&str] = if log.ends_with(".ulg") {
            &["gyro0", "gyro1", "accel0", "accel1"]
        } else {
            &["imu0", "imu1"]
        };
        for name in names {
            // One blob and one JSON per sensor, beside the names given.
            let blob = d.join(format!("imu.{name}.bin"));
            assert!(std::fs::metadata(&blob).unwrap().len() > 1000);
            let fit = json(d.join(format!("fit.{name}.json")));
            let axes = fit["autopilot"]["axes"].as_array().unwrap();
            assert_eq!(axes.len(), if name.starts_with("imu") { 6 } else { 3 });
            for (k, a) in axes.iter().enumerate() {
                let gyro = a["quantity"] == "angular-rate";
                // The firmwares take rad/s; the project's cubic is in °/s.
                let to_fw = if gyro {
                    std::f64::consts::PI / 180.0
                } else {
                    1.0
                };
                let ours = |t: f64| cubic(&fit, k, t) * to_fw;
                let (theirs, temps): (Box<dyn Fn(f64) -> f64>, Vec<f64>) = if log.ends_with("ulg") {
                    let p = px4_params(&d.join(file));
                    let letter = if gyro { "G" } else { "A" };
                    let prefix = format!("TC_{letter}{}", &name[name.len() - 1..]);
                    assert_eq!(
                        p[&format!("{prefix}_ID")],
                        fit["autopilot"]["device_id"].as_f64().unwrap()
                    );
                    assert_eq!(p[&format!("TC_{letter}_ENABLE")], 1.0);
                    // Clipped beyond the range as the firmware clips.
                    let temps = vec![-30.0, -5.0, 12.5, 25.0, 40.0, 55.0, 80.0];
                    (Box::new(move |t| px4_offset(&p, &prefix, k, t)), temps)
                } else {
                    let p = ardupilot_params(&d.join(file));
                    let n = name[3..].parse::<u32>().unwrap() + 1;
                    assert_eq!(p[&format!("INS_TCAL{n}_ENABLE")], 1.0);
                    let kind = if gyro { "GYR" } else { "ACC" };
                    let axis = ["X", "Y", "Z"][k % 3];
                    // ArduPilot's constant is the boot calibration's, at its own temperature:
                    // the cubic counts from there. TMIN and TMAX are written to 0.1 °C, so the
                    // comparison stays inside them.
                    let (lo, hi) = (
                        p[&format!("INS_TCAL{n}_TMIN")],
                        p[&format!("INS_TCAL{n}_TMAX")],
                    );
                    let cal_t = 20.0;
                    let shift = ours(cal_t);
                    let temps = vec![lo, -5.0, 12.5, 25.0, 40.0, hi];
                    (
                        Box::new(move |t| ardupilot_offset(&p, (n, kind, axis), t, cal_t) + shift),
                        temps,
                    )
                };
                for t in temps {
                    let (a, b) = (theirs(t), ours(t));
                    assert!(
                        (a - b).abs() < 1e-6,
                        "{name} axis {k} at {t} °C: {a} against {b}"
                    );
                }
            }
        }
    }
}

/// ArduPilot's own temperature learning logs its means (`TCLR`, one per 0.5 °C of warming) beside
/// the `IMU` messages, as the simulated board does. Named, they are calibrated as any sensor is,
/// and their parameters agree with the `IMU` messages' on the IMU whose bias is a cubic: within
/// 1% of the correction's swing over the range both cover, at every degree.
#[test]
fn the_learnings_means_calibrate_as_the_imu_messages_do() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let log = board(d, "cal.bin", "3", "60");
    let fit = |sensors: &[&str], parm: &str| {
        let mut args = vec!["-q", "fit", "--stream", &log];
        for s in sensors {
            args.extend(["--sensor", s]);
        }
        let (parm, out) = (at(d, parm), at(d, &format!("{}.bin", sensors.join("-"))));
        args.extend(["--ardupilot-params", &parm, "--out", &out]);
        trainer(&args).unwrap();
        ardupilot_params(Path::new(&parm))
    };
    let imu = fit(&["imu0"], "imu.parm");
    let learned = fit(&["tclr-gyro0", "tclr-accel0"], "tclr.parm");
    let range = |p: &HashMap<String, f64>| (p["INS_TCAL1_TMIN"], p["INS_TCAL1_TMAX"]);
    let (a, b) = (range(&imu), range(&learned));
    let (lo, hi) = (a.0.max(b.0), a.1.min(b.1));
    assert!(hi - lo > 50.0, "{lo} … {hi}");
    same_correction(&imu, &learned, 1, (lo, hi), 0.01);
}

/// Asserts that two `tcal.parm` give IMU `n` the same correction (calibrated at `lo`) on every
/// axis at every whole degree from `lo` to `hi`, within `tolerance` of the first's swing there.
fn same_correction(
    a: &HashMap<String, f64>,
    b: &HashMap<String, f64>,
    n: u32,
    (lo, hi): (f64, f64),
    tolerance: f64,
) {
    let temps: Vec<f64> = (0..=(hi - lo) as usize).map(|k| lo + k as f64).collect();
    for kind in ["GYR", "ACC"] {
        for axis in ["X", "Y", "Z"] {
            let at_t = |p: &HashMap<String, f64>, t| ardupilot_offset(p, (n, kind, axis), t, lo);
            let swing = temps.iter().map(|&t| at_t(a, t).abs()).fold(0.0, f64::max);
            let worst = temps
                .iter()
                .map(|&t| (at_t(a, t) - at_t(b, t)).abs())
                .fold(0.0, f64::max);
            assert!(
                worst < tolerance * swing,
                "IMU {n} {kind} {axis}: {worst:e} against a swing of {swing:e}"
            );
        }
    }
}

/// A board mounted turned in the vehicle (`AHRS_ORIENTATION`): ArduPilot logs the vehicle's axes,
/// and applies its temperature correction in the board's. The same board logged level and mounted
/// rolled 90° and pitched 90° (every axis moved, two negated) gives the same `tcal.parm` to the
/// digit; mounted at an angle that is not a right one (38: roll 90°, pitch 68.8°, yaw 293.3°), the
/// same within what the log's f32 samples keep, and so mounted at a custom rotation whose angles
/// the log's parameters give. A rotation that cannot be turned back writes neither autopilot's
/// file. A ULog, whose sensor topics are the board's axes, takes no mounting; a custom rotation
/// takes its angles.
#[test]
fn a_board_mounted_turned_gets_the_parameters_of_its_own_axes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let parm_of = |orientation: &str, angles: &[&str]| {
        let (log, parm) = (
            at(d, &format!("cal{orientation}.bin")),
            at(d, &format!("tcal{orientation}.parm")),
        );
        let board = [
            "-q",
            "generate",
            "board",
            "--minutes",
            "30",
            "--orientation",
            orientation,
            "--out",
            &log,
        ];
        sim(&[&board[..], angles].concat()).unwrap();
        let out = at(d, "imu.bin");
        trainer(&[
            "-q",
            "fit",
            "--stream",
            &log,
            "--ardupilot-params",
            &parm,
            "--out",
            &out,
        ])
        .unwrap();
        parm
    };
    let parm = |orientation: &str| parm_of(orientation, &[]);
    let level = parm("0");
    let read = |p: &str| std::fs::read_to_string(p).unwrap();
    assert_eq!(read(&level), read(&parm("28")));
    // A custom rotation (101, `CUST_ROT1_*`): its angles are read from the log's parameters.
    let custom = parm_of("101", &["--custom-rotation", "30,-20,250"]);
    let level = ardupilot_params(Path::new(&level));
    for odd in [parm("38"), custom] {
        let odd = ardupilot_params(Path::new(&odd));
        assert_eq!(level.len(), odd.len());
        for n in [1, 2] {
            let range = |k: &str| level[&format!("INS_TCAL{n}_{k}")];
            same_correction(&level, &odd, n, (range("TMIN"), range("TMAX")), 1e-6);
        }
    }
    // A rotation this reader does not know (44: past ArduPilot's table, as a newer firmware's
    // might be): the axes stay the vehicle's, so neither autopilot's file is written; the blob is.
    let log = at(d, "cal0.bin");
    let mut bytes = std::fs::read(&log).unwrap();
    let name = b"AHRS_ORIENTATION";
    let at_value = bytes.windows(16).position(|w| w == name).unwrap() + 16;
    bytes[at_value..at_value + 4].copy_from_slice(&44f32.to_le_bytes());
    let unknown = at(d, "unknown.bin");
    std::fs::write(&unknown, bytes).unwrap();
    let (parm, params, out) = (at(d, "u.parm"), at(d, "u.params"), at(d, "u-imu.bin"));
    trainer(&[
        "-q",
        "fit",
        "--stream",
        &unknown,
        "--ardupilot-params",
        &parm,
        "--px4-params",
        &params,
        "--out",
        &out,
    ])
    .unwrap();
    assert!(!Path::new(&parm).exists() && !Path::new(&params).exists());
    assert!(Path::new(&at(d, "u-imu.imu0.bin")).exists());
    for (orientation, log, refusal) in [
        ("2", "cal.ulg", "name the log .bin"),
        ("102", "custom.bin", "--custom-rotation"),
    ] {
        let e = sim(&[
            "-q",
            "generate",
            "board",
            "--orientation",
            orientation,
            "--out",
            &at(d, log),
        ])
        .unwrap_err();
        assert!(format!("{e:#}").contains(refusal), "{e:#}");
    }
}

/// The cubic and the GP of each axis of `sensor`, held out on another power-on of the board
/// (a warmer soak, a faster warm-up, a cooler bench: inside the calibrated range): 60 s RMS, in
/// the channel's units.
fn cubic_and_gp(d: &Path, sensor: &str) -> Vec<(CubicFigures, f64)> {
    trainer(&[
        "-q",
        "investigate",
        "--stream",
        &at(d, "cal.ulg"),
        "--valid-stream",
        &at(d, "held.ulg"),
        "--sensor",
        sensor,
        "--json",
        &at(d, "inv.json"),
    ])
    .unwrap();
    let inv = json(d.join("inv.json"));
    let read = |name: &str| {
        let log = fog_data::autopilot::Recorded::read(&d.join(name), &mut |_, _| {})
            .unwrap()
            .unwrap();
        let [unit] = <[_; 1]>::try_from(
            fog_data::channels::Channels::of_log(&log, &[sensor.to_owned()]).unwrap(),
        )
        .unwrap();
        unit.load_log(&d.join(name), &[]).unwrap()
    };
    let (train, valid) = (read("cal.ulg"), read("held.ulg"));
    (0..3)
        .map(|k| {
            let cubic = trainer::analysis::autopilot::held_out(&train[k], &valid[k]).unwrap();
            let gp = inv["channels"][k]["extended_score"]["rmse_60s_in_range_dps"]
                .as_f64()
                .unwrap();
            let all = inv["channels"][k]["extended_score"]["rmse_60s_dps"]
                .as_f64()
                .unwrap();
            assert_eq!(gp, all, "every held-out block inside the calibrated range");
            assert_eq!(cubic.project.rmse_60s_in_range, cubic.project.rmse_60s);
            (cubic, gp)
        })
        .collect()
}

/// The project's cubic, held out with every degree counted once, within `slack` of (or better
/// than) the cubic each autopilot's script fits on the same samples.
fn at_least_as_good_every_degree(f: &CubicFigures, slack: f64, what: &str) {
    let ours = f.project.rmse_per_degree;
    for (script, theirs) in [("PX4", f.px4_script), ("ArduPilot", f.ardupilot_script)] {
        let theirs = theirs.unwrap().rmse_per_degree;
        assert!(
            ours <= theirs * slack,
            "{what}: ours {ours:.3e}, {script}'s script {theirs:.3e}"
        );
    }
}

#[test]
fn held_out_the_gp_beats_the_cubic_where_the_board_hides_an_effect_and_matches_it_elsewhere() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    sim(&[
        "generate",
        "board",
        "--seed",
        "4",
        "--minutes",
        "60",
        "--out",
        &at(d, "cal.ulg"),
    ])
    .unwrap();
    let held = [
        "generate",
        "board",
        "--seed",
        "5",
        "--soak",
        "5",
        "--settle",
        "40",
        "--warm-up-min",
        "12",
        "--minutes",
        "90",
        "--out",
    ];
    sim(&[&held[..], &[at(d, "held.ulg").as_str()]].concat()).unwrap();
    // IMU 0's bias is a cubic: the GP can only match it, and every cubic fits it alike.
    for (k, (figures, gp)) in cubic_and_gp(d, "gyro0").into_iter().enumerate() {
        let cubic = figures.project.rmse_60s;
        at_least_as_good_every_degree(&figures, 1.05, &format!("gyro0 axis {k}"));
        assert!(
            (gp / cubic - 1.0).abs() < 0.05,
            "gyro0 axis {k}: GP {gp:.2e}, cubic {cubic:.2e}"
        );
    }
    // IMU 1 hides a knee and a lagging sensor: the GP follows what the cubic cannot.
    // Where the cubic cannot follow, how it is weighted decides where it errs: fitted with every
    // degree counted once, it errs least held out counted so (PX4's script bins by temperature
    // too: the two tie, within 1%).
    for (k, (figures, gp)) in cubic_and_gp(d, "gyro1").into_iter().enumerate() {
        let cubic = figures.project.rmse_60s;
        at_least_as_good_every_degree(&figures, 1.01, &format!("gyro1 axis {k}"));
        assert!(
            gp < 0.9 * cubic,
            "gyro1 axis {k}: GP {gp:.2e}, cubic {cubic:.2e}"
        );
    }
}

/// Two warm-ups of a board pooled (`fit --stream A --stream B`, each a power-on left out in turn):
/// the static model's points are the logs' 60 s means, and the GP's noise level on them is no
/// sample's (at 5 Hz, a sixteenth of one). The blob states one sample's noise as the logs show
/// it, so its σ covers another warm-up's samples, not only their 60 s means.
#[test]
fn a_fit_on_two_warm_ups_states_the_noise_of_one_sample() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let first = board(d, "a.ulg", "4", "60");
    let warm_up = |name: &str, seed: &str, soak: &str, minutes_to_warm: &str| {
        board_with(
            d,
            name,
            &[
                "--seed",
                seed,
                "--soak",
                soak,
                "--warm-up-min",
                minutes_to_warm,
                "--minutes",
                "60",
            ],
        )
    };
    let second = warm_up("b.ulg", "6", "20", "6");
    let held = warm_up("held.ulg", "5", "5", "12");
    let blob = at(d, "two.bin");
    trainer(&[
        "-q", "fit", "--stream", &first, "--stream", &second, "--sensor", "gyro0", "--out", &blob,
    ])
    .unwrap();
    let replay = at(d, "r.json");
    sim(&[
        "-q", "replay", "--model", &blob, "--stream", &held, "--json", &replay,
    ])
    .unwrap();
    // Its 60 s means are covered too (on x widely: two power-ons, each left out, are few to
    // measure another's bias by).
    for c in json(&replay)["channels"].as_array().unwrap() {
        let (samples, means) = (&c["sigma_samples"], &c["sigma_60s"]);
        let within = |s: &serde_json::Value| s["within_2sigma"].as_f64().unwrap();
        assert!((0.85..=0.99).contains(&within(samples)), "{samples}");
        assert!(samples["sharpness"].as_f64().unwrap() <= 1.5, "{samples}");
        assert!(within(means) >= 0.85, "{means}");
    }
}

#[test]
fn the_real_px4_logs_are_summarized_sensor_by_sensor_and_a_log_without_sensors_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let px4 = |name: &str| {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("data/px4-yule-log")
            .join(name)
            .display()
            .to_string()
    };
    let out = at(dir.path(), "s.json");
    trainer(&[
        "-q",
        "summarize",
        "--stream",
        &px4("sample_log_small.ulg"),
        "--json",
        &out,
    ])
    .unwrap();
    let s = json(&out);
    assert_eq!(s["schema"]["name"], "trainer.summarize");
    let files = s["files"].as_array().unwrap();
    assert_eq!(files.len(), 6, "three gyros and three accelerometers");
    for unit in files {
        let axes: Vec<&str> = unit
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["channel"].as_str().unwrap())
            .collect();
        assert_eq!(axes, ["x", "y", "z"]);
    }
    // Choosing one; naming one it lacks; a log of no sensor.
    trainer(&[
        "-q",
        "summarize",
        "--stream",
        &px4("sample_log_small.ulg"),
        "--sensor",
        "accel2",
        "--json",
        &out,
    ])
    .unwrap();
    let accel2 = json(&out)["files"].as_array().unwrap().clone();
    assert_eq!(accel2.len(), 1);
    // Each column named by the log's field it was read from, not by the project's own columns.
    let columns: Vec<(String, String)> =
        serde_json::from_value(accel2[0][2]["columns"].clone()).unwrap();
    let from = |name: &str| {
        columns
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, f)| f.clone())
            .unwrap_or_default()
    };
    assert!(
        from("time_s").starts_with("sensor_accel[2].timestamp"),
        "{columns:?}"
    );
    assert_eq!(from("temp_c"), "sensor_accel[2].temperature (°C)");
    assert_eq!(from("voltage_v"), "sensor_accel[2].z");
    let e = trainer(&[
        "-q",
        "summarize",
        "--stream",
        &px4("sample_log_small.ulg"),
        "--sensor",
        "gyro5",
    ])
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("no sensor 'gyro5' (it holds: gyro0 (ID 2424842)"),
        "{e}"
    );
    let e = trainer(&["-q", "summarize", "--stream", &px4("trig_stats.ulg")])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("a PX4 ULog with no gyro or accelerometer samples"),
        "{e}"
    );
    // Each command names the sensor and channel it could not do, and why.
    let out = at(dir.path(), "never.bin");
    for (command, why) in [
        (
            "investigate",
            "a static model from a stream needs at least 10",
        ),
        ("fit", "a static model from a stream needs at least 10"),
        (
            "allan",
            "6 samples without a gap: too few for an Allan deviation",
        ),
        (
            "identify",
            "6 measurements: identification needs at least 12",
        ),
    ] {
        let log = px4("sample_log_small.ulg");
        let mut args = vec!["-q", command, "--stream", &log];
        if matches!(command, "fit" | "identify") {
            args.extend(["--out", &out]);
        }
        let e = match command {
            "identify" => format!("{:#}", sim(&args).unwrap_err()),
            _ => format!("{:#}", trainer(&args).unwrap_err()),
        };
        assert!(e.starts_with("sensor gyro0: channel x: "), "{command}: {e}");
        assert!(e.contains(why), "{command}: {e}");
    }
}

#[test]
fn the_report_on_a_boards_log_sets_the_cubic_beside_the_gp_and_writes_the_parameters_too() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let log = board(d, "cal.bin", "6", "60");
    let out = at(d, "report");
    let parm = at(d, "tcal.parm");
    trainer(&[
        "-q",
        "report",
        "--stream",
        &log,
        "--ardupilot-params",
        &parm,
        "--out",
        &out,
    ])
    .unwrap();
    // A page per IMU, each with the cubic's table and a verdict per axis.
    for imu in ["imu0", "imu1"] {
        let page = std::fs::read_to_string(d.join("report").join(imu).join("report.html")).unwrap();
        assert!(page.contains("The autopilots' cubic, held out"), "{imu}");
        assert_eq!(
            page.matches("the cubic is enough").count() + page.matches("the cubic misses").count(),
            6,
            "{imu}"
        );
        // The same figures as data, beside the page: every axis's cubics and verdict.
        let figures = json(d.join("report").join(imu).join("report.json"));
        assert_eq!(figures["schema"]["name"], "trainer.report", "{imu}");
        let channels = figures["channels"].as_array().unwrap();
        assert_eq!(channels.len(), 6, "{imu}");
        for ch in channels {
            let cubic = &ch["cubic"]["project"];
            assert!(cubic["rmse_60s"].as_f64().unwrap() > 0.0, "{imu}: {ch}");
            assert!(
                cubic["rmse_per_degree"].as_f64().unwrap() > 0.0,
                "{imu}: {ch}"
            );
            let verdict = ch["cubic_verdict"].as_str().unwrap();
            assert!(
                verdict.starts_with("the cubic is enough")
                    || verdict.starts_with("the cubic misses"),
                "{imu}: {verdict}"
            );
            assert!(ch["held_out"]["investigation"]["extended_score"].is_object());
        }
    }
    let p = ardupilot_params(Path::new(&parm));
    assert_eq!(p.len(), 2 * 21, "21 lines per IMU");
    // A parameter file needs a unit's log.
    let e = trainer(&[
        "report",
        "--points",
        "p.csv",
        "--px4-params",
        &at(d, "x.params"),
        "--out",
        &out,
    ])
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("take a sensor's three axes, fitted on a log"),
        "{e}"
    );
}

#[test]
fn a_ulog_whose_gyros_record_no_temperature_is_said_so_and_refused() {
    use fog_data::autopilot::write::{ULogWriter, Value};
    let dir = tempfile::tempdir().unwrap();
    // An older PX4's sensor_gyro: no temperature field.
    let mut w = ULogWriter::new(Vec::new(), 0).unwrap();
    let fields = [
        ("uint64_t", "timestamp"),
        ("uint32_t", "device_id"),
        ("float", "x"),
        ("float", "y"),
        ("float", "z"),
    ];
    w.format("sensor_gyro", &fields).unwrap();
    let id = w.subscribe("sensor_gyro", 0).unwrap();
    for i in 0..600u64 {
        let v = [
            Value::U64(i * 1_000_000),
            Value::U32(7),
            Value::F32(0.0),
            Value::F32(0.0),
            Value::F32(0.0),
        ];
        w.data(id, &v).unwrap();
    }
    let log = dir.path().join("old.ulg");
    std::fs::write(&log, w.into_inner()).unwrap();
    let e = trainer(&["-q", "summarize", "--stream", &log.display().to_string()])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no sensor with a temperature (gyro0): nothing to calibrate"),
        "{e}"
    );
}

/// A simulated board's 30-minute warm-up as PX4 logs it, `cal.ulg` in `d`: its path.
fn short_board(d: &Path) -> String {
    let log = at(d, "cal.ulg");
    sim(&[
        "generate",
        "board",
        "--seed",
        "7",
        "--minutes",
        "30",
        "--out",
        &log,
    ])
    .unwrap();
    log
}

#[test]
fn a_logs_sensors_are_chosen_and_renamed_and_their_files_named_after_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let log = short_board(d);
    // The log's gyro and accelerometer sensors read in °/s and m/s²: a figure in one channel's
    // units is refused for all of them at once.
    let out = at(d, "refused.bin");
    let refused = trainer(&[
        "fit", "--stream", &log, "--tempco", "0.001", "--out", &out, "-q",
    ]);
    let refused = refused.unwrap_err().to_string();
    assert!(refused.contains("one channel's, in its units"), "{refused}");
    assert!(refused.contains("°/s, m/s²"), "{refused}");
    let fit = |extra: &[&str]| {
        let base = ["-q", "fit", "--stream", &log, "--out", &at(d, "imu.bin")];
        let json = at(d, "fit.json");
        trainer(&[&base[..], extra, &["--json", json.as_str()]].concat())
    };
    // One sensor's axes read in one unit: its datasheet's figure is every axis's.
    fit(&["--sensor", "gyro0", "--repeatability", "0.001"]).unwrap();
    for ch in json(d.join("fit.json"))["channels"].as_array().unwrap() {
        assert_eq!(ch["calibration"]["turn_on_std"], 0.001, "{ch}");
    }
    fit(&["--sensor", "gyro0=front", "--sensor", "gyro1=back"]).unwrap();
    for name in ["front", "back"] {
        assert!(d.join(format!("imu.{name}.bin")).exists(), "{name}");
        assert_eq!(json(d.join(format!("fit.{name}.json")))["sensor_id"], name);
    }
    assert!(!d.join("imu.gyro0.bin").exists(), "only the sensors asked");
    let e = fit(&["--sensor", "gyro0=a/b"]).unwrap_err().to_string();
    assert!(
        e.contains("a name of 1 to 32 bytes, without a slash"),
        "{e}"
    );
}

/// `investigate` takes every sensor of a flight controller's log, as `fit` does: one blob and one
/// JSON per sensor beside the names given, each byte for byte what it writes for that sensor
/// alone; `--json -` is refused for several, before any work.
#[test]
fn investigate_takes_each_sensor_of_a_boards_log_as_it_takes_it_alone() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let log = short_board(d);
    let investigate = |sensors: &[&str], out: &str| {
        let (blob, js) = (at(d, &format!("{out}.bin")), at(d, &format!("{out}.json")));
        let static_blob = at(d, "static.bin");
        let mut args = vec!["-q", "investigate", "--stream", &log];
        for s in sensors {
            args.extend(["--sensor", s]);
        }
        args.extend(["--out", &blob, "--out-static", &static_blob, "--json", &js]);
        trainer(&args)
    };
    investigate(&["gyro0", "gyro1"], "both").unwrap();
    for name in ["gyro0", "gyro1"] {
        investigate(&[name], name).unwrap();
        let read = |path: String| std::fs::read(path).unwrap();
        assert_eq!(
            read(at(d, &format!("both.{name}.bin"))),
            read(at(d, &format!("{name}.bin"))),
            "{name}"
        );
        assert!(d.join(format!("static.{name}.bin")).exists(), "{name}");
        let (both, alone) = (
            json(d.join(format!("both.{name}.json"))),
            json(d.join(format!("{name}.json"))),
        );
        assert!(
            both["sensor_id"].as_str().unwrap().starts_with(name),
            "{both}"
        );
        assert_eq!(both["channels"].as_array().unwrap().len(), 3);
        assert_eq!(without_timings(both), without_timings(alone), "{name}");
    }
    let e = trainer(&["-q", "investigate", "--stream", &log, "--json", "-"])
        .unwrap_err()
        .to_string();
    assert!(e.contains("holds 4 sensors"), "{e}");
    each_blob_is_taken_on_the_sensor_it_names(d, &log);
}

/// `diagnose`, `allan` and `replay` on a board's log: each blob on the sensor it names, with no
/// `--sensor`, as on that sensor alone; a blob of a sensor the log does not give is refused. And
/// `identify` twins each gyro as it twins that gyro alone.
fn each_blob_is_taken_on_the_sensor_it_names(d: &Path, log: &str) {
    let (gyro0, gyro1) = (at(d, "both.gyro0.bin"), at(d, "both.gyro1.bin"));
    let diagnosed = at(d, "diagnosed.json");
    trainer(&[
        "-q", "diagnose", "--model", &gyro0, &gyro1, "--stream", log, "--json", &diagnosed,
    ])
    .unwrap();
    let alone = at(d, "alone.json");
    for (name, blob) in [("gyro0", &gyro0), ("gyro1", &gyro1)] {
        trainer(&[
            "-q", "diagnose", "--model", blob, "--stream", log, "--json", &alone,
        ])
        .unwrap();
        let both = json(d.join(format!("diagnosed.{name}.json")));
        assert_eq!(both["schema"]["name"], "trainer.diagnose");
        assert_eq!(both["channels"].as_array().unwrap().len(), 3, "{both}");
        assert_eq!(both, json(&alone), "diagnose {name}");
    }
    let e = trainer(&[
        "-q", "diagnose", "--model", &gyro0, "--stream", log, "--sensor", "gyro1",
    ])
    .unwrap_err()
    .to_string();
    assert!(e.contains("a blob of sensor \"gyro0 "), "{e}");
    assert!(
        e.contains("sensors left to pair (one blob per sensor): gyro1 "),
        "{e}"
    );

    let allan = at(d, "allan.json");
    trainer(&["-q", "allan", "--stream", log, "--json", &allan]).unwrap();
    for name in ["gyro0", "gyro1", "accel0", "accel1"] {
        let args = [
            "-q", "allan", "--stream", log, "--sensor", name, "--json", &alone,
        ];
        trainer(&args).unwrap();
        let each = json(d.join(format!("allan.{name}.json")));
        assert_eq!(each["channels"].as_array().unwrap().len(), 3, "{each}");
        assert_eq!(each, json(&alone), "allan {name}");
    }
    let compensated = at(d, "compensated.json");
    trainer(&[
        "-q",
        "allan",
        "--stream",
        log,
        "--model",
        &gyro1,
        "--json",
        &compensated,
    ])
    .unwrap();
    let c = json(&compensated);
    assert!(
        c["channels"][0]["of"]
            .as_str()
            .unwrap()
            .contains("compensated by"),
        "{c}"
    );

    let (named, chosen) = (at(d, "named.json"), at(d, "chosen.json"));
    sim(&[
        "-q", "replay", "--model", &gyro1, "--stream", log, "--json", &named,
    ])
    .unwrap();
    let args = [
        "-q", "replay", "--model", &gyro1, "--stream", log, "--sensor", "gyro1",
    ];
    sim(&[&args[..], &["--json", &chosen]].concat()).unwrap();
    let (named, chosen) = (json(&named), json(&chosen));
    assert!(
        named["sensor_id"].as_str().unwrap().starts_with("gyro1 "),
        "{named}"
    );
    assert_eq!(without_timings(named), without_timings(chosen));

    // The bench's twin of each gyro of the board, as of that gyro alone.
    let twin = at(d, "twin.json");
    sim(&["-q", "identify", "--stream", log, "--out", &twin]).unwrap();
    assert!(
        !d.join("twin.accel0.json").exists(),
        "an accelerometer has no twin"
    );
    let alone = at(d, "twin1.json");
    let args = ["-q", "identify", "--stream", log, "--sensor", "gyro1"];
    sim(&[&args[..], &["--out", &alone]].concat()).unwrap();
    let each = json(d.join("twin.gyro1.json"));
    assert_eq!(each["axes"].as_array().unwrap().len(), 3, "{each}");
    assert_eq!(each, json(&alone));
    assert!(d.join("twin.gyro0.json").exists());
}

#[test]
fn a_simulated_board_is_written_only_as_a_log_the_autopilots_record() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["cal.csv", "cal"] {
        let e = format!(
            "{:#}",
            sim(&["generate", "board", "--out", &at(dir.path(), name)]).unwrap_err()
        );
        assert!(
            e.contains("name the log .ulg (a PX4 ULog) or .bin (an ArduPilot DataFlash log)"),
            "{e}"
        );
        assert!(!dir.path().join(name).exists(), "{name} written");
    }
}
