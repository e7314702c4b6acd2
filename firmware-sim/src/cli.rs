//! The `firmware-sim` command line: flags parsed, then dispatched to the library. `main.rs` only
//! calls [`run`]; tests call it too, with arguments of their own.

use std::path::PathBuf;

use crate::{output, paper, plant::GyroParams};
use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};

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
            let params = match unit {
                Unit::Nominal => GyroParams::nominal(),
                Unit::Random => GyroParams::random_unit(seed),
            };
            let points = paper::run(&params, seed, position_tests);
            trainer::io::write_atomically(&out, output::points_csv(&points).as_bytes())?;
            if let Some(path) = json {
                let summary =
                    serde_json::json!({ "n": points.len(), "seed": seed, "unit": params });
                let text = serde_json::to_string_pretty(&summary).context("encoding JSON")?;
                trainer::io::write_atomically(&path, text.as_bytes())?;
            }
            Ok(())
        }
    }
}
