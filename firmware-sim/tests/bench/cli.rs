//! The real binary as a script sees it: exit status, where results and errors go, and the help.

use std::path::Path;
use std::process::{Command, Output};

fn sim(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_firmware-sim"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

#[test]
fn replay_puts_json_alone_on_stdout_and_names_bad_samples() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let generated = sim(&["generate", "paper", "--seed", "1", "--out", "p.csv"], d);
    assert_eq!(generated.status.code(), Some(0));
    assert_eq!(generated.stdout, b"wrote p.csv (140 rows)\n");
    assert!(generated.stderr.is_empty());
    // The firmware-integration example's blob (docs/firmware.md): a model of the main job's gyro.
    std::fs::copy(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../firmware-core/doc/gyro.bin"),
        d.join("m.bin"),
    )
    .unwrap();
    std::fs::write(
        d.join("s.csv"),
        "time_s,temp_c,voltage_v,rate_dps\n0,25,0.1,1\n1,25,0.1,1\n2,25,abc,1\n",
    )
    .unwrap();
    let bad = sim(&["replay", "--model", "m.bin", "--stream", "s.csv"], d);
    assert_eq!(bad.status.code(), Some(1));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("s.csv line 4, column voltage_v: 'abc' is not a number"),
        "{err}"
    );

    let mut good = String::from("time_s,temp_c,voltage_v,rate_dps\n");
    for i in 0..120 {
        good.push_str(&format!("{i},25,0.385,10\n"));
    }
    std::fs::write(d.join("s.csv"), good).unwrap();
    let replay = ["replay", "--model", "m.bin", "--stream", "s.csv"];
    let out = sim(&[&replay[..], &["--json", "-"]].concat(), d);
    assert_eq!(out.status.code(), Some(0));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stdout is JSON alone");
    assert_eq!(v["channels"][0]["n"], 120);
    assert!(out.stderr.is_empty());
    let quiet = sim(&[&replay[..], &["-q"]].concat(), d);
    assert_eq!(quiet.status.code(), Some(0));
    assert!(quiet.stdout.is_empty() && quiet.stderr.is_empty());
    let plain = sim(&replay, d);
    assert!(String::from_utf8_lossy(&plain.stdout).starts_with("replayed 120 samples"));
}

#[test]
fn a_malformed_command_line_exits_two_and_every_command_has_an_example() {
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(
        sim(&["replay", "--model"], dir.path()).status.code(),
        Some(2)
    );
    assert_eq!(
        sim(&["generate", "paper"], dir.path()).status.code(),
        Some(2)
    );
    for cmd in [
        &["generate", "paper"][..],
        &["generate", "stream"],
        &["generate", "scattered"],
        &["replay"],
        &["qemu"],
    ] {
        let out = sim(&[cmd, &["--help"]].concat(), dir.path());
        assert_eq!(out.status.code(), Some(0));
        let help = String::from_utf8_lossy(&out.stdout);
        let example = format!("Example: firmware-sim {} ", cmd.join(" "));
        assert!(help.contains(&example), "{help}");
        assert!(
            help.contains("--quiet") && help.contains("--verbose"),
            "{help}"
        );
    }
}

#[test]
fn two_effects_join_with_a_plus_and_their_strengths_pair_with_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let generate = |extra: &[&str]| {
        let args = [
            &[
                "generate", "paper", "--seed", "1", "--out", "p.csv", "--json", "-",
            ][..],
            extra,
        ]
        .concat();
        sim(&args, d)
    };
    let out = generate(&["--effect", "warm-up+time-drift", "--strength", "40+7"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["effect"]["id"], "warm-up", "{json}");
    assert_eq!(json["effects"][0]["amplitude_dph"], 40.0, "{json}");
    assert_eq!(json["effects"][1]["id"], "time-drift", "{json}");
    assert_eq!(json["effects"][1]["dph_per_h"], 7.0, "{json}");
    // A strength for each effect, and only known effects.
    let out = generate(&["--effect", "warm-up+time-drift", "--strength", "40"]);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let out = generate(&["--effect", "warm-up+magic"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("magic"));
}
