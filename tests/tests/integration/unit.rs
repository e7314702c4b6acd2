//! A whole inertial unit in one calibration (issue 48): every channel of a log named once in a
//! channels file, fitted in one `trainer fit` into one blob, replayed in one `firmware-sim
//! replay`, on the host, on the Cortex-M4F under QEMU and from C, bit for bit; and the
//! simulator's units, whose every axis hides its own cause.

use std::path::Path;

use firmware_sim::{c_replay, qemu};
use fog_data::channels::Channels;
use fog_data::replay;

use crate::{IMU_MAPS, at, imu, json, sim, trainer};

/// The MEMS log's channels file (`tests/data/tofupilot-imu-thermal/imu.toml`).
fn channels() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/tofupilot-imu-thermal/imu.toml")
        .display()
        .to_string()
}

/// The six channels, each as one channel's `--map` reads it: (name, output map, reference).
const CHANNELS: [(&str, &str, &str); 6] = [
    (
        "gyro.x",
        "voltage_v=imu.gyro.x*57.29577951308232",
        "rate_dps=0",
    ),
    (
        "gyro.y",
        "voltage_v=imu.gyro.y*57.29577951308232",
        "rate_dps=0",
    ),
    (
        "gyro.z",
        "voltage_v=imu.gyro.z*57.29577951308232",
        "rate_dps=0",
    ),
    ("acc.x", "voltage_v=imu.acc.x", "rate_dps=0"),
    ("acc.y", "voltage_v=imu.acc.y", "rate_dps=0"),
    ("acc.z", "voltage_v=imu.acc.z", "rate_dps=-9.80665"),
];

/// The MEMS IMU in one `trainer fit` (its first 40 minutes, causes named and checked there) and
/// one `firmware-sim replay` of the rest: each channel's held-out figure is the one its own
/// single-channel fit and replay give (within 1%; they are the same models), the blob is
/// `firmware-core/doc/imu.bin` byte for byte (`FOG_BLESS=1` rewrites it), and the shared loading
/// said its time and handling once.
#[test]
fn the_mems_imu_is_calibrated_in_one_fit_and_replayed_in_one_replay() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| at(dir.path(), name);
    let (imu, channels) = (imu(), channels());
    let fit_unit = |extra: &[&str]| {
        let args = ["fit", "--stream", &imu, "--channels", &channels];
        trainer(&[&args[..], &["--window", ":2400"], extra].concat())
    };
    fit_unit(&[
        "--features",
        "auto",
        "--out",
        &p("imu.bin"),
        "--json",
        &p("fit.json"),
    ])
    .unwrap();
    sim(&[
        "replay",
        "--model",
        &p("imu.bin"),
        "--stream",
        &imu,
        "--channels",
        &channels,
        "--window",
        "2400:",
        "--json",
        &p("replay.json"),
    ])
    .unwrap();
    let fit = json(p("fit.json"));
    // One power-on: every channel's σ assumes another power-on's bias, unless stated. A unit
    // takes one figure for every channel only where it means the same in every unit: 0.
    for ch in fit["channels"].as_array().unwrap() {
        assert!(crate::assumes(&ch["calibration"], "turn-on"), "{ch}");
    }
    let stated = |sigma: &str| {
        let (out, json) = (p("stated.bin"), p("stated.json"));
        fit_unit(&[
            "--repeatability",
            sigma,
            "--out",
            &out,
            "--json",
            &json,
            "-q",
        ])
    };
    let refused = stated("0.01").unwrap_err().to_string();
    assert!(refused.contains("one channel's, in its units"), "{refused}");
    let args = ["investigate", "--stream", &imu, "--channels", &channels];
    let refused = trainer(&[&args[..], &["--repeatability", "0.01", "-q"]].concat());
    let refused = refused.unwrap_err().to_string();
    assert!(refused.contains("one channel's, in its units"), "{refused}");
    // A datasheet's temperature coefficient and heating/cooling gap are in one channel's units
    // too.
    for flag in ["--tempco", "--hysteresis"] {
        let refused = trainer(&[&args[..], &[flag, "0.01", "-q"]].concat());
        let refused = refused.unwrap_err().to_string();
        assert!(refused.contains("one channel's, in its units"), "{refused}");
        let refused = fit_unit(&[flag, "0.01", "--out", &p("t.bin"), "-q"]);
        let refused = refused.unwrap_err().to_string();
        assert!(refused.contains("one channel's, in its units"), "{refused}");
    }
    stated("0").unwrap();
    for ch in json(p("stated.json"))["channels"].as_array().unwrap() {
        let c = &ch["calibration"];
        assert_eq!(c["turn_on_std"], 0.0, "{ch}");
        assert!(!crate::assumes(c, "turn-on"), "{ch}");
    }
    assert_eq!(fit["sensor_id"], "tofupilot-example-imu");
    assert_eq!(fit["channels"].as_array().unwrap().len(), 6);
    assert_eq!(fit["channels"][3]["units"], "m/s²");
    // acc.y's three causes are refused together and hysteresis alone, tried next, ships; acc.z's
    // warm-up loses on both heating/cooling legs, each fitted on the other, and the static model
    // ships (shipped, it was 1.5× worse than static held out).
    let (acc_y, acc_z) = (&fit["channels"][4], &fit["channels"][5]);
    assert_eq!(acc_y["shipped"], "extended", "{acc_y}");
    assert!(
        acc_y["verdict"]
            .as_str()
            .unwrap()
            .contains("nested, hysteresis alone"),
        "{acc_y}"
    );
    assert_eq!(acc_z["shipped"], "static", "{acc_z}");
    let legs = acc_z["forward_check"]["legs"].as_array().unwrap();
    assert_eq!(legs.len(), 2, "{acc_z}");
    for leg in legs {
        let rmse = |key: &str| leg[key].as_f64().unwrap();
        assert!(
            rmse("extended_rmse_60s_dps") > rmse("static_rmse_60s_dps"),
            "{leg}"
        );
    }
    let unit = json(p("replay.json"));
    assert_eq!(unit["schema"]["name"], "sim.replay");
    for (k, (name, output, reference)) in CHANNELS.iter().enumerate() {
        let one = |file: &str| p(&format!("{name}.{file}"));
        let maps = [&IMU_MAPS[..4], &["--map", output, "--map", reference]].concat();
        trainer(
            &[
                &[
                    "fit",
                    "--stream",
                    &imu,
                    "--window",
                    ":2400",
                    "--features",
                    "auto",
                ][..],
                &["--scale-factor", "1", "--out", &one("bin")],
                &maps,
            ]
            .concat(),
        )
        .unwrap();
        sim(&[
            &[
                "replay",
                "--model",
                &one("bin"),
                "--stream",
                &imu,
                "--window",
                "2400:",
            ][..],
            &["--json", &one("json")],
            &maps,
        ]
        .concat())
        .unwrap();
        let alone = crate::one(one("json"))["rmse_60s_dps"].as_f64().unwrap();
        let ours = &unit["channels"][k];
        assert_eq!(ours["name"], *name);
        let together = ours["rmse_60s_dps"].as_f64().unwrap();
        assert!(
            (together / alone - 1.0).abs() < 0.01,
            "{name}: {together} in the unit, {alone} alone"
        );
    }
    let blob = std::fs::read(p("imu.bin")).unwrap();
    let doc = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware-core/doc/imu.bin");
    if std::env::var_os("FOG_BLESS").is_some() {
        std::fs::write(&doc, &blob).unwrap();
    }
    assert!(
        std::fs::read(&doc).unwrap() == blob,
        "firmware-core/doc/imu.bin is stale: FOG_BLESS=1 cargo test -p integration-tests \
         --test integration -- calibrated_in_one_fit"
    );
}

/// The unit blob runs on the Cortex-M4F and from C as on the host, bit for bit, every channel in
/// one call per sample; on the M4 the six channels together cost no more than the six alone
/// (the temperature features are computed once), measured under QEMU.
#[test]
fn the_unit_blob_runs_bit_for_bit_on_the_m4_and_from_c_at_most_the_cost_of_its_channels_alone() {
    let blob = include_bytes!("../../../firmware-core/doc/imu.bin");
    let channels = Channels::load(Path::new(&channels())).unwrap();
    let all = channels
        .load_log(Path::new(&imu()), &[])
        .unwrap()
        .into_iter()
        .map(|s| s.window("2400:2700".parse().unwrap()))
        .collect::<Vec<_>>();
    let unit = replay::decode_unit(blob).unwrap();
    let names: Vec<&str> = channels.list.iter().map(|c| c.name.as_str()).collect();
    let streams = replay::in_unit_order(&unit, &names, &all).unwrap();
    let host = replay::replay_unit(&unit, &streams, false);
    let image = qemu::build_image(&firmware_sim::source_tree::locate(None).unwrap()).unwrap();
    let m4 = qemu::run(&image, blob, &streams).unwrap();
    let c = c_replay::run(&c_replay::build().unwrap(), blob, &streams).unwrap();
    for (k, h) in host.iter().enumerate() {
        for (what, device) in [("M4", &m4.compensated[k]), ("C", &c[k])] {
            let a = qemu::compare(h, device);
            assert_eq!(a.identical, streams[0].len(), "{what} {}: {a:?}", names[k]);
            assert!(a.statuses_equal, "{what} {}", names[k]);
        }
    }
    // Each channel alone: its model as a blob of its own, through the same image.
    let mut alone = 0.0;
    let blobs = trainer::firmware::unit::channel_blobs(blob).unwrap();
    assert_eq!(blobs.len(), streams.len());
    for (k, (_, _, one)) in blobs.iter().enumerate() {
        alone += qemu::run(&image, one, &streams[k..=k])
            .unwrap()
            .cost
            .sample_full_instructions;
    }
    let together = m4.cost.sample_full_instructions;
    assert!(
        together <= alone && together > 0.8 * alone,
        "six channels in one call {together}, each alone {alone} in all"
    );
}

/// The simulator's unit of three axes, each hiding its own cause, is calibrated and investigated
/// through its files and channels file as a user's unit is: each axis's cause is named (the first
/// three causes of the unit challenge's order: none, thermal-rate, sensor-lag) and no axis ships a
/// model worse than its static one.
#[test]
fn a_simulated_unit_of_three_axes_names_each_axis_own_cause() {
    let cases = trainer::analysis::challenge::run_unit_case(0, 1200).unwrap();
    assert_eq!(cases.len(), 3);
    for c in &cases {
        assert_eq!(c.named_cause(), c.hidden_cause(), "{c:?}");
        assert!(c.gain >= 0.98, "{c:?}");
    }
}

/// The command line around a unit: a channels file that cannot be used says why, a blob of
/// several channels is not replayed without one, a flag the file gives is refused, and a budget
/// below the smallest models is refused before anything is fitted.
#[test]
fn a_unit_on_the_command_line_says_what_is_wrong_before_fitting() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| at(dir.path(), name);
    let imu = imu();
    std::fs::write(p("bad.toml"), "[[channel]]\nname = \"x\"\n").unwrap();
    let e = trainer(&["summarize", "--stream", &imu, "--channels", &p("bad.toml")])
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.toml") && e.contains("missing field"), "{e}");
    let blob = concat!(env!("CARGO_MANIFEST_DIR"), "/../firmware-core/doc/imu.bin");
    let e = sim(&[
        &["replay", "--model", blob, "--stream", &imu][..],
        &IMU_MAPS,
    ]
    .concat())
    .unwrap_err()
    .to_string();
    assert!(e.contains("6 channels") && e.contains("--channels"), "{e}");
    let e = trainer(&[
        "fit",
        "--stream",
        &imu,
        "--channels",
        &channels(),
        "--map",
        "temp_c=x",
        "--out",
        &p("u.bin"),
    ])
    .unwrap_err()
    .to_string();
    assert!(e.contains("given by the channels file"), "{e}");
    let e = trainer(&[
        "fit",
        "--stream",
        &imu,
        "--channels",
        &channels(),
        "--budget-ram",
        "4K",
        "--out",
        &p("u.bin"),
    ])
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("smallest models") && e.contains("checked before fitting"),
        "{e}"
    );
    assert!(!dir.path().join("u.bin").exists());
    // A unit's three axes from the simulator, with the channels file beside them.
    three_axes("thermal-rate,none,hysteresis", &p("s.csv")).unwrap();
    let c = Channels::load(&dir.path().join("s.channels.toml")).unwrap();
    assert_eq!(c.len(), 3);
    let e = three_axes("none,none", &p("t.csv"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("2 --effect entries for 3 axes"), "{e}");
}

/// A budget sizes each channel's model after its prior mean's basis is chosen, so the size
/// chosen is that of the model that ships: a simulated unit of three axes whose default models
/// take 25 KB of RAM, fitted within 7 KiB. One axis's bands show the physics prior mean running
/// away beyond its range (degree 2 ships), one keeps physics.
#[test]
fn a_budget_sizes_the_model_of_the_basis_each_channel_ships() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| at(dir.path(), name);
    three_axes("none,thermal-rate,none", &p("s.csv")).unwrap();
    trainer(&[
        "fit",
        "--stream",
        &p("s.csv"),
        "--channels",
        &p("s.channels.toml"),
        "--budget-ram",
        "7K",
        "--out",
        &p("u.bin"),
        "--json",
        &p("f.json"),
        "-q",
    ])
    .unwrap();
    let f = json(p("f.json"));
    let budget = &f["budget"];
    let ram = |cost: &serde_json::Value| cost["ram_bytes"].as_u64().unwrap();
    assert_eq!(budget["budget"]["ram_bytes"], 7168);
    assert!(ram(&budget["default_cost"]) > 7168, "{budget}");
    assert!(ram(&budget["chosen_cost"]) <= 7168, "{budget}");
    assert!(f["footprint"]["unit_bytes"].as_u64().unwrap() <= 7168);
    let mut bases = Vec::new();
    for (channel, sized) in f["channels"]
        .as_array()
        .unwrap()
        .iter()
        .zip(budget["channels"].as_array().unwrap())
    {
        assert_eq!(channel["name"], sized["name"]);
        // A size was chosen for every channel (the default did not fit), and the model kept
        // no more centres than it asked for (a sparse fit may drop some).
        let chosen = sized["chosen"].as_u64().expect("a size chosen") as usize;
        let asked = sized["sizes"][chosen]["asked"].as_u64().unwrap();
        let centres = channel["centres"].as_u64().unwrap();
        assert!(centres > 0 && centres <= asked, "{sized}");
        let choice = &channel["basis_choice"];
        assert_eq!(channel["mean_basis"], choice["basis"], "{choice}");
        assert_eq!(choice["scores"].as_array().unwrap().len(), 3, "{choice}");
        bases.push(channel["mean_basis"].as_str().unwrap().to_owned());
    }
    assert!(bases.iter().any(|b| b == "physics"), "{bases:?}");
    assert!(bases.iter().any(|b| b == "poly2"), "{bases:?}");
}

/// A simulated unit of three axes on the short design, each with its `effects` entry, written to
/// `out` with its channels file beside it.
fn three_axes(effects: &str, out: &str) -> anyhow::Result<()> {
    sim(&[
        "generate", "stream", "--design", "short", "--axes", "3", "--effect", effects, "--out",
        out, "-q",
    ])
}
