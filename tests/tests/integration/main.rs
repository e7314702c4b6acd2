//! Cross-crate integration tests: one binary, one module per capability.

mod autopilot;
mod c;
mod cli;
mod diagnosis;
mod docs;
mod firmware;
mod heating;
mod layers;
mod m4;
mod paper;
mod real;
mod report;
mod service;
mod sigma;
mod sparse;
mod twin;
mod unit;
mod window;

use std::path::{Path, PathBuf};

/// The trainer's own allocator (`trainer/src/main.rs`), so that the commands run here in process
/// allocate as its binary does.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Runs `firmware-sim` with these arguments, in process.
pub fn sim(args: &[&str]) -> anyhow::Result<()> {
    use clap::Parser;
    let argv = std::iter::once("firmware-sim").chain(args.iter().copied());
    firmware_sim::cli::run(firmware_sim::cli::Cli::try_parse_from(argv)?)
}

/// Runs `trainer` with these arguments, in process.
pub fn trainer(args: &[&str]) -> anyhow::Result<()> {
    use clap::Parser;
    let argv = std::iter::once("trainer").chain(args.iter().copied());
    trainer::cli::run(trainer::cli::Cli::try_parse_from(argv)?)
}

/// A path inside `dir`, as a string for argument lists.
pub fn at(dir: &Path, name: &str) -> String {
    dir.join(name).display().to_string()
}

/// The one channel's entry of a command's JSON on one channel's data (a unit of one), read and
/// checked as [`json`] reads it.
pub fn one(path: impl Into<PathBuf>) -> serde_json::Value {
    let value = json(path);
    let list = value["channels"].as_array().expect("a unit's channels");
    assert_eq!(list.len(), 1, "one channel: {value}");
    list[0].clone()
}

/// Whether a channel's `calibration` (its JSON) names `term` among those it assumed.
pub fn assumes(calibration: &serde_json::Value, term: &str) -> bool {
    let assumed = calibration["assumed"]
        .as_array()
        .expect("calibration.assumed");
    assumed.iter().any(|t| t == term)
}

/// The model blob of a blob of one channel (`fit` writes one channel's model in a unit blob of one
/// entry; a model blob of one channel is still read everywhere).
pub fn model_blob(blob: &[u8]) -> Vec<u8> {
    let [(_, _, model)] = <[_; 1]>::try_from(trainer::firmware::unit::channel_blobs(blob).unwrap())
        .expect("a blob of one channel");
    model
}

/// Reads a JSON file; one a command wrote (with a `schema`) is checked against its contract on
/// the way: every field it holds is one docs/json.md lists, and every field listed as required
/// is there. Every test that reads a command's JSON so checks the contract too.
pub fn json(path: impl Into<PathBuf>) -> serde_json::Value {
    let path = path.into();
    let text = std::fs::read_to_string(&path).expect("JSON output exists");
    let value: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
    if let Some(name) = value["schema"]["name"].as_str() {
        let fields = contract_fields(name);
        let object = value.as_object().expect("a contract's JSON is an object");
        let listed = fields["properties"].as_object().expect("listed fields");
        for key in object.keys() {
            assert!(
                listed.contains_key(key),
                "{}: `{key}` is not a field of {name} (docs/json.md)",
                path.display()
            );
        }
        for key in fields["required"].as_array().into_iter().flatten() {
            let key = key.as_str().unwrap_or_default();
            assert!(
                object.contains_key(key),
                "{}: {name}'s field `{key}` is missing",
                path.display()
            );
        }
    }
    value
}

/// The JSON Schema of the contract named `name`, as docs/json.md is generated from it.
fn contract_fields(name: &str) -> serde_json::Value {
    static ALL: std::sync::OnceLock<Vec<fog_terminal::schema::Contract>> =
        std::sync::OnceLock::new();
    let all = ALL.get_or_init(|| {
        let mut all = trainer::cli::contracts();
        all.extend(firmware_sim::cli::contracts());
        all
    });
    all.iter()
        .find(|c| c.schema.name == name)
        .unwrap_or_else(|| panic!("no contract named {name}"))
        .fields
        .as_value()
        .clone()
}

/// The MIT-licensed MEMS thermal-cycle log copied in `tests/data/`.
pub fn imu() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/tofupilot-imu-thermal/imu_raw_data.tsv")
        .display()
        .to_string()
}

/// The MEMS log's time, temperature and (static) reference columns; the gyro axis is mapped by
/// each test.
pub const IMU_MAPS: [&str; 6] = [
    "--map",
    "time_s=timestamp*1e-6",
    "--map",
    "temp_c=imu.temperature",
    "--map",
    "rate_dps=0",
];
