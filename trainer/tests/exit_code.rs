//! The real binary: exit status and error text on bad input (scripts rely on both).

use std::process::Command;

#[test]
fn bad_input_exits_non_zero_with_the_location_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("p.csv");
    std::fs::write(&points, "temp_c,voltage_v,rate_dps\n0,0.1,1\n20,x,2\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_trainer"))
        .args(["fit", "--points"])
        .arg(&points)
        .args(["--out"])
        .arg(dir.path().join("m.json"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("line 3, column voltage_v: 'x' is not a number"),
        "{err}"
    );
    assert!(!dir.path().join("m.json").exists());
}

#[test]
fn help_shows_an_example_and_exits_zero() {
    let out = Command::new(env!("CARGO_BIN_EXE_trainer"))
        .args(["fit", "--help"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("Example: trainer fit"));
}
