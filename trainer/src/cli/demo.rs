//! `trainer demo`: the main job in one command (README.md). A simulated gyro with a hidden
//! thermal-rate drift → its rate table and two ramp streams → static fit → blob → replay →
//! diagnosis → extended model → gain on the held-out stream → replay of the extended blob → the
//! paper's tables → the report.
//!
//! Each step is the command a user would type, printed before it runs and run in this process
//! (the simulator is a library below the trainer, not a sibling program), so any step can be
//! rerun alone or changed; the files are those the steps write, in one directory.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::{Args, Parser};
use firmware_sim::gyro::effects::Hidden;
use firmware_sim::gyro::plant::GyroParams;
use firmware_sim::gyro::stream::{self, StreamConfig};
use firmware_sim::gyro::{output, paper};
use fog_terminal::console::Console;
use fog_terminal::io::write_atomically;
use fog_terminal::log::{Excludes, Maps, UnitArgs};

use super::Cli;
use super::inputs::ModelInput;
use fog_data::cause::Cause;
use fog_terminal::console::ConsoleFlags;

/// The arguments of `trainer demo`.
#[derive(Args)]
pub(super) struct DemoArgs {
    /// Directory for every file of the main job (created if missing).
    #[arg(long)]
    pub(super) out: PathBuf,
}

/// Which program a step is a command of.
#[derive(Clone, Copy)]
pub(super) enum Program {
    Sim,
    Trainer,
}

/// One step: the program and its arguments, as typed.
pub(super) struct Step(pub(super) Program, Vec<String>);

impl Step {
    fn new(program: Program, args: &[&str]) -> Self {
        Self(program, args.iter().map(|a| (*a).to_owned()).collect())
    }

    fn name(&self) -> &'static str {
        match self.0 {
            Program::Sim => "firmware-sim",
            Program::Trainer => "trainer",
        }
    }

    /// The command line as a user would type it.
    pub(super) fn text(&self) -> String {
        format!("{} {}", self.name(), self.1.join(" "))
    }

    /// The arguments to parse, with the console flags of the whole demo.
    pub(super) fn argv(&self, flags: ConsoleFlags) -> Vec<String> {
        let mut argv = vec![self.name().to_owned()];
        argv.extend(self.1.iter().cloned());
        if flags.quiet {
            argv.push("--quiet".into());
        }
        if flags.verbose {
            argv.push("--verbose".into());
        }
        argv
    }
}

/// What the simulator writes for the main job.
#[derive(Clone, Copy)]
pub(super) enum Data {
    /// The paper's rate-table protocol (`generate paper`).
    Points,
    /// A chamber-ramp stream (`generate stream`).
    Stream,
}

/// The hidden effect of the main job's gyro (the nominal unit).
pub(super) const EFFECT: Cause = Cause::ThermalRate;

/// The main job's data: its rate table (seed 1) and two ramp streams (seeds 2 and 3), by the file
/// each is written to.
pub(super) const DATA: [(Data, u64, &str); 3] = [
    (Data::Points, 1, "points.csv"),
    (Data::Stream, 2, "train.csv"),
    (Data::Stream, 3, "valid.csv"),
];

/// Every step of the main job, writing into `dir`.
pub(super) fn steps(dir: &Path) -> Vec<Step> {
    let at = |name: &str| dir.join(name).display().to_string();
    let (points, train, valid) = (at("points.csv"), at("train.csv"), at("valid.csv"));
    let mut steps: Vec<Step> = DATA
        .iter()
        .map(|&(data, seed, name)| {
            let kind = match data {
                Data::Points => "paper",
                Data::Stream => "stream",
            };
            let (seed, out) = (seed.to_string(), at(name));
            let args = [
                "generate",
                kind,
                "--seed",
                &seed,
                "--effect",
                EFFECT.id(),
                "--out",
                &out,
            ];
            Step::new(Program::Sim, &args)
        })
        .collect();
    // The rate table and both streams, as `investigate` and `report` take them.
    let data = [
        "--points",
        &points,
        "--stream",
        &train,
        "--valid-stream",
        &valid,
    ];
    let (model, ext) = (at("model.bin"), at("ext.bin"));
    let investigate = [
        "--out-static",
        &model,
        "--out",
        &ext,
        "--json",
        &at("investigate.json"),
    ];
    steps.extend([
        Step::new(
            Program::Trainer,
            &[&["investigate"][..], &data, &investigate].concat(),
        ),
        Step::new(
            Program::Sim,
            &[
                "replay",
                "--model",
                &ext,
                "--stream",
                &valid,
                "--out",
                &at("comp.csv"),
                "--json",
                &at("replay.json"),
            ],
        ),
        Step::new(
            Program::Trainer,
            &[
                "reproduce",
                "--points",
                &points,
                "--json",
                &at("reproduce.json"),
            ],
        ),
        Step::new(
            Program::Trainer,
            &[&["report"][..], &data, &["--out", &at("report")]].concat(),
        ),
    ]);
    steps
}

/// `trainer demo`: every step of the main job, each printed as the command that does it alone
/// and run in this process (`trainer` runs a trainer command).
pub(super) fn run(
    args: DemoArgs,
    flags: ConsoleFlags,
    trainer: fn(Cli) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let console = Console::new(flags, None);
    let dir = &args.out;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let steps = steps(dir);
    let n = steps.len();
    for (i, step) in steps.iter().enumerate() {
        console.result(&format!("[{}/{n}] {}", i + 1, step.text()));
        let argv = step.argv(flags);
        match step.0 {
            Program::Sim => firmware_sim::cli::run(firmware_sim::cli::Cli::try_parse_from(argv)?),
            Program::Trainer => trainer(Cli::try_parse_from(argv)?),
        }
        .with_context(|| format!("step `{}`", step.text()))?;
    }
    console.result(&format!(
        "done: open {}",
        dir.join("report").join("report.html").display()
    ));
    Ok(())
}

/// The main job's data (README.md), simulated into `dir`: a nominal gyro with a hidden
/// thermal-rate drift, its rate table and two ramp streams (the files `trainer demo` writes).
pub(super) fn simulated(
    dir: &Path,
    console: &Console,
) -> anyhow::Result<(ModelInput, PathBuf, PathBuf)> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let gyro = GyroParams::nominal();
    let hidden = Hidden::new(&[EFFECT], &[])?;
    for (data, seed, name) in DATA {
        let csv = match data {
            Data::Points => output::points_csv(&paper::run(&gyro, hidden.clone(), seed, false)),
            Data::Stream => output::stream_csv(&stream::run(
                &gyro,
                &StreamConfig::default(),
                hidden.clone(),
                seed,
            )),
        };
        write_atomically(&dir.join(name), csv.as_bytes())?;
    }
    console.result(&format!(
        "no data given: simulated a gyro with a hidden thermal-rate drift into {}",
        dir.display()
    ));
    let input = ModelInput {
        points: Some(dir.join("points.csv")),
        runs: Vec::new(),
        maps: Maps::default(),
        exclude: Excludes::default(),
        scale_factor: None,
        exclude_implausible: false,
        group: None,
        unit: UnitArgs::default(),
        quantity: firmware_core::Quantity::AngularRate,
    };
    Ok((input, dir.join("train.csv"), dir.join("valid.csv")))
}
