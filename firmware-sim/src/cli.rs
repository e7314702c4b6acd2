//! The `firmware-sim` command line: flags parsed, then dispatched to the library. `main.rs` only
//! calls [`run`]; tests call it too, with arguments of their own.

use std::path::PathBuf;

use crate::{output, paper, plant::GyroParams, stream};
use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};
use trainer::data::ColumnMap;
use trainer::io::{ensure_not_input, write_atomically};
use trainer::replay;

/// Simulated open-loop FOG, thermal chamber and rate table.
#[derive(Parser)]
#[command(version, about)]
pub struct Cli {
    #[command(subcommand)]
    /// The subcommand.
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate simulated data.
    #[command(subcommand)]
    Generate(Generate),
    /// Replay a stream through the firmware evaluator (host build): compensated rate, predicted
    /// standard deviation and status per sample, and the scores against the reference.
    ///
    /// Example: firmware-sim replay --model model.bin --stream s.csv --out comp.csv --json r.json
    Replay {
        /// Model blob (from `trainer fit --out`).
        #[arg(long)]
        model: PathBuf,
        /// Stream CSV: time_s,temp_c,voltage_v,rate_dps (rate_dps may be empty where unknown).
        #[arg(long)]
        stream: PathBuf,
        /// Map a canonical column onto a source column, COLUMN*FACTOR, or a constant (repeatable).
        #[arg(long = "map", value_name = "NAME=SOURCE")]
        maps: Vec<ColumnMap>,
        /// Compensated CSV to write: the stream's columns, comp_rate_dps, comp_std_dps, status.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Scores as JSON: n, rmse_dps, rmse_60s_dps, max_abs_err_dps, coverage_2sigma, ….
        #[arg(long)]
        json: Option<PathBuf>,
    },
}

#[derive(Subcommand)]
enum Generate {
    /// The paper's protocol: 10 soaked temperatures × 14 rates, each point the mean of 120 samples.
    ///
    /// Example: firmware-sim generate paper --seed 1 --out points.csv
    Paper {
        /// Seed of the noise (and of the unit, with --unit random). Same seed, same bytes.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output points CSV.
        #[arg(long)]
        out: PathBuf,
        /// Which gyro: the nominal unit of PHYSICS.md, or one drawn from its published ranges.
        #[arg(long, value_enum, default_value_t = Unit::Nominal)]
        unit: Unit,
        /// Also write the zero-rate position test before each rate test (table_rate_dps = 0).
        #[arg(long)]
        position_tests: bool,
        /// Write a JSON summary (the unit's parameters and the point count) here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// A stream from power-on at 1 Hz: chamber soaks and ramps over −30…60 °C at 0.5–1 °C/min,
    /// the rate table stepping through the paper's rates and zero (about 9.5 hours).
    ///
    /// Example: firmware-sim generate stream --seed 2 --out s.csv
    Stream {
        /// Seed of the noise and the rate order (and of the unit, with --unit random).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output stream CSV.
        #[arg(long)]
        out: PathBuf,
        /// Which gyro: the nominal unit of PHYSICS.md, or one drawn from its published ranges.
        #[arg(long, value_enum, default_value_t = Unit::Nominal)]
        unit: Unit,
        /// Write a JSON summary (the unit's parameters and the sample count) here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
}

#[derive(Clone, Copy, ValueEnum)]
enum Unit {
    Nominal,
    Random,
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Generate(Generate::Paper {
            seed,
            out,
            unit,
            position_tests,
            json,
        }) => {
            let params = unit.params(seed);
            let points = paper::run(&params, seed, position_tests);
            write_atomically(&out, output::points_csv(&points).as_bytes())?;
            if let Some(path) = json {
                write_json(
                    &path,
                    &serde_json::json!({ "n": points.len(), "seed": seed, "unit": params }),
                )?;
            }
            Ok(())
        }
        Command::Generate(Generate::Stream {
            seed,
            out,
            unit,
            json,
        }) => {
            let params = unit.params(seed);
            let rows = stream::run(&params, &stream::StreamConfig::default(), seed);
            write_atomically(&out, output::stream_csv(&rows).as_bytes())?;
            if let Some(path) = json {
                write_json(
                    &path,
                    &serde_json::json!({ "n": rows.len(), "seed": seed, "unit": params }),
                )?;
            }
            Ok(())
        }
        Command::Replay {
            model,
            stream,
            maps,
            out,
            json,
        } => {
            let inputs = [model.as_path(), stream.as_path()];
            for o in out.iter().chain(&json) {
                ensure_not_input(o, &inputs)?;
            }
            let firmware = load_model(&model)?;
            let data = trainer::stream::Stream::load(&stream, &maps)?;
            for issue in &data.time_issues {
                eprintln!("{}: time issue {issue:?}", stream.display());
            }
            let comp = replay::replay(&firmware, &data);
            let score = replay::score(&data, &comp);
            if let Some(path) = out {
                write_atomically(&path, replay::to_csv(&data, &comp).as_bytes())?;
            }
            if let Some(path) = json {
                write_json(&path, &score)?;
            }
            println!(
                "replayed {} samples ({} scored, {} extrapolating, {} fault, {} time issues): \
                 rmse {:.3e} °/s, rmse_60s {:.3e} °/s ({:.2} °/h), max |err| {:.3e} °/s, 2σ coverage {:.3}",
                data.len(),
                score.n,
                score.n_extrapolating,
                score.n_fault,
                score.time_issues.len(),
                score.rmse_dps,
                score.rmse_60s_dps,
                score.rmse_60s_dps * 3600.0,
                score.max_abs_err_dps,
                score.coverage_2sigma
            );
            Ok(())
        }
    }
}

impl Unit {
    fn params(self, seed: u64) -> GyroParams {
        match self {
            Unit::Nominal => GyroParams::nominal(),
            Unit::Random => GyroParams::random_unit(seed),
        }
    }
}

fn write_json(path: &std::path::Path, value: &impl serde::Serialize) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(value).context("encoding JSON")?;
    write_atomically(path, text.as_bytes())?;
    Ok(())
}

fn load_model(path: &std::path::Path) -> anyhow::Result<Box<trainer::export::HostModel>> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    trainer::export::decode(&bytes).with_context(|| format!("decoding {}", path.display()))
}
