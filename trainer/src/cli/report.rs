//! `trainer report`: the HTML report, on the user's data or on a simulated gyro.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use firmware_sim::cli::Maps;
use firmware_sim::console::{Console, ConsoleFlags};
use firmware_sim::gyro::effects::Hidden;
use firmware_sim::gyro::plant::GyroParams;
use firmware_sim::gyro::stream::{self, StreamConfig};
use firmware_sim::gyro::{output, paper};
use firmware_sim::io::ensure_not_input;
use firmware_sim::io::write_atomically;

use super::demo::{self, Data};
use super::inputs::{FitOptions, ModelInput, load_stream};
use crate::report;

/// The arguments of `trainer report`.
#[derive(Args)]
pub(super) struct ReportArgs {
    #[command(flatten)]
    input: ModelInput,
    #[command(flatten)]
    fit: FitOptions,
    /// Stream the extension is fitted on.
    #[arg(long, requires = "valid_stream")]
    train_stream: Option<PathBuf>,
    /// Held-out stream: replayed, diagnosed and scored.
    #[arg(long, requires = "train_stream")]
    valid_stream: Option<PathBuf>,
    /// Directory for report.html and the figures (created if missing).
    #[arg(long, visible_alias = "out-dir")]
    out: PathBuf,
}

/// The main job's data (README.md), simulated into `dir`: a nominal gyro with a hidden
/// thermal-rate drift, its rate table and two ramp streams (the files `trainer demo` writes).
fn simulated(dir: &Path, console: &Console) -> anyhow::Result<(ModelInput, PathBuf, PathBuf)> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let gyro = GyroParams::nominal();
    let hidden = Hidden::new(&[demo::EFFECT], &[])?;
    for (data, seed, name) in demo::DATA {
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
        maps: Maps::default(),
        scale_factor: None,
        exclude_implausible: false,
        group: None,
        offsets: false,
    };
    Ok((input, dir.join("train.csv"), dir.join("valid.csv")))
}

/// `trainer report`: the HTML report and its figures.
pub(super) fn report_command(args: ReportArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let ReportArgs {
        input,
        fit,
        train_stream,
        valid_stream,
        out: out_dir,
    } = args;
    input.without_offsets("report")?;
    let console = Console::new(flags, None);
    let (input, train_stream, valid_stream) = match (train_stream, valid_stream) {
        (Some(a), Some(b)) => (input, a, b),
        _ if input.points.is_some() => anyhow::bail!(
            "--points needs --train-stream and --valid-stream: the report replays a \
             held-out stream (or give no data at all for the simulated gyro)"
        ),
        _ => simulated(&out_dir.join("data"), &console)?,
    };
    let mut inputs: Vec<&Path> = input.points.iter().map(PathBuf::as_path).collect();
    inputs.extend([train_stream.as_path(), valid_stream.as_path()]);
    let names = report::FIGURES.iter().map(|f| f.0).chain(["report.html"]);
    for name in names {
        ensure_not_input(&out_dir.join(name), &inputs)?;
    }
    let train = [(
        train_stream.as_path(),
        load_stream(&train_stream, &input.maps.list, None)?,
    )];
    let valid = load_stream(&valid_stream, &input.maps.list, None)?;
    let points = input.static_points(&train, false)?;
    let source = input.points.as_deref().unwrap_or(train_stream.as_path());
    let bar = console.bar(0);
    let r = report::build(source, points, &train[0].1, valid, &fit.gp(), &bar)?;
    bar.finish_and_clear();
    for path in report::write(&out_dir, &r)? {
        console.result(&format!("wrote {}", path.display()));
    }
    Ok(())
}
