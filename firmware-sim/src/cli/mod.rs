//! The `firmware-sim` command line: flags parsed, then dispatched to the library. `main.rs` only
//! calls [`run`]; tests call it too, with arguments of their own.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Parser, Subcommand};
use serde::Serialize;

use crate::qemu;
use fog_data::replay;
use fog_data::sigma;
use fog_terminal::console::{AFTER_HELP, Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_atomically, write_json};
use fog_terminal::log::LogArgs;
use fog_terminal::schema;

mod generate;
mod identify;

/// Simulated open-loop FOG, thermal chamber and rate table.
#[derive(Parser)]
#[command(version, about, after_help = AFTER_HELP)]
pub struct Cli {
    #[command(subcommand)]
    /// The subcommand.
    command: Command,
    #[command(flatten)]
    console: ConsoleFlags,
}

#[derive(Subcommand)]
enum Command {
    /// Generate simulated data.
    #[command(subcommand)]
    Generate(generate::Generate),
    /// Identify a twin of a measured gyro: the simulator's parameters fitted to its data (a rate
    /// table and/or a stream or static log), the effects the twin lacks named and fitted on the
    /// training data, and its fidelity on the held-out last third before and after. Writes a unit
    /// file that `generate paper|stream --unit FILE` simulates.
    ///
    /// Example: firmware-sim identify --points points.csv --stream s.csv --out unit.json --json
    /// id.json
    Identify(identify::IdentifyArgs),
    /// Replay a stream through the firmware evaluator (host build): compensated rate, predicted
    /// standard deviation and status per sample, and the scores against the reference.
    ///
    /// Example: firmware-sim replay --model model.bin --stream s.csv --out comp.csv --json r.json
    Replay {
        #[command(flatten)]
        input: ReplayInput,
        /// Compensated CSV to write: the stream's columns, comp_rate_dps, comp_std_dps, status.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Scores as JSON: n, rmse_dps, rmse_60s_dps, max_abs_err_dps, coverage_2sigma, ….
        #[arg(long)]
        json: Option<PathBuf>,
        /// The stream is the power-on the model was calibrated on (its held-out part): the σ leaves
        /// out another power-on's bias and scale (the blob's turn-on and scale terms), up to the
        /// stream's first power cycle. With --window, the rest of the log is taken for the
        /// calibration's data: the window's first power-on is the calibration's where the log has
        /// samples before it, its time terms counted forward from the window's start, and its last
        /// where the log goes on after it, counted back from where its data resume (from the nearer
        /// of the two where that is one power-on); a power-on between is another. Without it, every
        /// sample is scored as in service, on another power-on.
        #[arg(long)]
        calibration_run: bool,
    },
    /// Replay a stream on the Cortex-M4F build of the firmware under qemu-system-arm, compare with
    /// the host replay, and measure instructions per prediction.
    ///
    /// Example: firmware-sim qemu --model model.bin --stream s.csv --out m4.csv --json q.json
    Qemu {
        #[command(flatten)]
        input: ReplayInput,
        /// Compensated CSV of the M4 run.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Scores, agreement with the host replay and cost as JSON.
        #[arg(long)]
        json: Option<PathBuf>,
        /// The project's source tree, where the image is built (default: $FOG_SOURCE_DIR, else the
        /// checkout holding the current folder, else the one this program was built from).
        #[arg(long, value_name = "DIR")]
        source: Option<PathBuf>,
    },
}

/// What a replay reads: a model (or a unit's blob) and a stream (or a unit's log, with
/// `--channels`).
#[derive(Args)]
struct ReplayInput {
    /// Model blob (from `trainer fit --out`): one model, or a unit's channels. With a flight
    /// controller's log, the blob compensates the sensor it names.
    #[arg(long)]
    model: PathBuf,
    #[command(flatten)]
    log: LogArgs,
}

/// A replay's inputs, loaded: the blob, decoded as a unit (a model blob is a unit of one channel),
/// and one stream per channel in the unit's order.
struct Loaded {
    blob: Vec<u8>,
    unit: Box<replay::HostUnit>,
    streams: Vec<fog_data::stream::Stream>,
}

impl Loaded {
    /// The streams in the unit's channel order.
    fn streams(&self) -> Vec<&fog_data::stream::Stream> {
        self.streams.iter().collect()
    }
}

impl ReplayInput {
    /// Refuses outputs over the inputs, then loads both, matching the log's channels to the
    /// blob's.
    fn load(&self, outputs: &[&PathBuf], console: &Console) -> anyhow::Result<Loaded> {
        let mut inputs = vec![self.model.as_path(), self.log.stream.as_path()];
        inputs.extend(self.log.unit.channels.as_deref());
        for o in outputs {
            ensure_not_input(o, &inputs)?;
        }
        let blob = std::fs::read(&self.model)
            .with_context(|| format!("reading {}", self.model.display()))?;
        let unit = replay::decode_unit(&blob)
            .with_context(|| format!("decoding {}", self.model.display()))?;
        let sensor = (self.model.as_path(), unit.sensor_id());
        let channels = self.log.unit.load_for(&self.log.stream, sensor, console)?;
        let names: Vec<&str> = unit.channels().iter().map(|c| c.name()).collect();
        anyhow::ensure!(
            !channels.single || names.len() == 1,
            "{} holds a unit of {} channels ({}): give --channels FILE naming them in the log",
            self.model.display(),
            names.len(),
            names.join(", ")
        );
        let all = self.log.load_unit(&channels, console)?;
        let names: Vec<&str> = channels.list.iter().map(|c| c.name.as_str()).collect();
        let streams = replay::in_unit_order(&unit, &names, &all)
            .map_err(|e| anyhow::anyhow!("{}: {e}", self.model.display()))?
            .into_iter()
            .cloned()
            .collect();
        Ok(Loaded {
            blob,
            unit,
            streams,
        })
    }
}

/// A unit's channels' scores, one line each, in each channel's bias unit (°/h, mg).
fn channel_lines(scores: &[replay::ChannelScore]) -> String {
    scores
        .iter()
        .map(|c| {
            let k = c.quantity.bias_per_unit();
            let u = c.quantity.bias_unit();
            format!(
                "  {:<16} rmse_60s {:>10.3} {u:<4} ({} scored, {} extrapolating, {} degraded, {} \
                 fault); σ: {}; {}",
                c.name,
                c.score.rmse_60s_dps * k,
                c.score.n,
                c.score.n_extrapolating,
                c.score.n_degraded,
                c.score.n_fault,
                sigma::describe(&c.score.sigma_samples, &c.score.sigma_60s),
                sigma::describe_by_range(
                    c.score.sigma_60s_in_range.as_ref(),
                    c.score.sigma_60s_beyond.as_ref()
                )
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// What `replay --json` writes: the sensor and each channel's scores.
#[derive(Serialize, schemars::JsonSchema)]
struct UnitReplay<'a> {
    sensor_id: &'a str,
    channels: &'a [replay::ChannelScore],
}

/// What `qemu --json` writes: each channel's scores, the agreement of them all with
/// the host replay, the cost per sample of them all.
#[derive(Serialize, schemars::JsonSchema)]
struct UnitQemuReport<'a> {
    sensor_id: &'a str,
    channels: &'a [replay::ChannelScore],
    agreement_with_host: qemu::M4Agreement,
    cost: qemu::M4Cost,
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let flags = cli.console;
    match cli.command {
        Command::Generate(g) => generate::generate_command(g, flags),
        Command::Identify(args) => identify::identify_command(args, flags),
        Command::Replay {
            input,
            out,
            json,
            calibration_run,
        } => replay_command(&input, (out, json), calibration_run, flags),
        Command::Qemu {
            input,
            out,
            json,
            source,
        } => qemu_command(&input, (out, json), source, flags),
    }
}

/// `firmware-sim replay`: every sample through the firmware evaluator on the host, and the scores
/// (each channel's, for a unit).
fn replay_command(
    input: &ReplayInput,
    (out, json): (Option<PathBuf>, Option<PathBuf>),
    calibration_run: bool,
    flags: ConsoleFlags,
) -> anyhow::Result<()> {
    let console = Console::new(flags, json.as_deref());
    let loaded = input.load(&out.iter().chain(&json).collect::<Vec<_>>(), &console)?;
    let streams = loaded.streams();
    let comps = replay::replay_unit(&loaded.unit, &streams, calibration_run);
    let scores = replay::unit_scores(&loaded.unit, &streams, &comps);
    if let Some(path) = out {
        write_atomically(
            &path,
            replay::unit_csv(&loaded.unit, &streams, &comps).as_bytes(),
        )?;
    }
    if let Some(path) = json {
        let report = UnitReplay {
            sensor_id: loaded.unit.sensor_id(),
            channels: &scores,
        };
        write_json(&path, &[], schema::REPLAY, &report)?;
    }
    console.result(&format!(
        "replayed {} samples{} through {}:\n{}",
        streams.first().map_or(0, |s| s.inside().len()),
        match scores.len() {
            1 => String::new(),
            n => format!(" of {n} channels"),
        },
        input.model.display(),
        channel_lines(&scores)
    ));
    for (data, c) in streams.iter().zip(&scores) {
        if let Some(why) = replay::degraded_reason(data, &c.score) {
            console.warn(&format!("{}: {why}", c.name));
        }
    }
    Ok(())
}

/// `firmware-sim qemu`: the same on the Cortex-M4F image under QEMU, built from the source tree,
/// compared with the host replay, with its cost per sample.
fn qemu_command(
    input: &ReplayInput,
    (out, json): (Option<PathBuf>, Option<PathBuf>),
    source: Option<PathBuf>,
    flags: ConsoleFlags,
) -> anyhow::Result<()> {
    let console = Console::new(flags, json.as_deref());
    let loaded = input.load(&out.iter().chain(&json).collect::<Vec<_>>(), &console)?;
    let streams = loaded.streams();
    let root = crate::source_tree::locate(source.as_deref())?;
    console.detail(&format!(
        "cargo build --release (in {})",
        qemu::image_crate(&root).display()
    ));
    let spinner = console.spinner("building the Cortex-M4 image");
    let image = qemu::build_image(&root)?;
    spinner.suspend(|| {
        console.detail(&format!(
            "qemu-system-arm {} -kernel {} (every sample), then with {} on the first {} (the cost)",
            qemu::QEMU_ARGS.join(" "),
            image.display(),
            qemu::COUNTED.join(" "),
            qemu::COST_SAMPLES
        ))
    });
    let n = streams.first().map_or(0, |s| s.len());
    spinner.set_message(format!("running {n} samples on the Cortex-M4 under QEMU"));
    let m4 = qemu::run(&image, &loaded.blob, &streams)?;
    spinner.set_message("host replay, for the comparison");
    let host = replay::replay_unit(&loaded.unit, &streams, false);
    spinner.finish_and_clear();
    let agreements: Vec<qemu::M4Agreement> = host
        .iter()
        .zip(&m4.compensated)
        .map(|(h, m)| qemu::compare(h, m))
        .collect();
    let agreement = qemu::M4Agreement::all(&agreements);
    let scores = replay::unit_scores(&loaded.unit, &streams, &m4.compensated);
    if let Some(path) = out {
        let csv = replay::unit_csv(&loaded.unit, &streams, &m4.compensated);
        write_atomically(&path, csv.as_bytes())?;
    }
    if let Some(path) = json {
        let report = UnitQemuReport {
            sensor_id: loaded.unit.sensor_id(),
            channels: &scores,
            agreement_with_host: agreement,
            cost: m4.cost,
        };
        write_json(&path, &[], schema::QEMU, &report)?;
    }
    let c = loaded.unit.channels().len();
    console.result(&format!(
        "Cortex-M4 (QEMU) vs host replay over {n} samples{}: max |Δmean| {:.3e}, {} of {} \
         bit-identical, statuses equal: {}",
        if c > 1 {
            format!(" of {c} channels")
        } else {
            String::new()
        },
        agreement.max_abs_mean_diff,
        agreement.identical,
        n * c,
        agreement.statuses_equal
    ));
    console.result(&channel_lines(&scores));
    console.result(&format!(
        "instructions per prediction{}: mean {:.0}, mean + variance {:.0}; per sample, the \
         feature pipeline included: {:.0}, {:.0}",
        if c > 1 {
            format!(" of the {c} channels together")
        } else {
            String::new()
        },
        m4.cost.mean_instructions,
        m4.cost.full_instructions,
        m4.cost.sample_mean_instructions,
        m4.cost.sample_full_instructions
    ));
    let centres: usize = loaded.unit.channels().iter().map(|c| c.dims().m).sum();
    let minimum: f64 = loaded
        .unit
        .channels()
        .iter()
        .map(|ch| ch.dims().m as f64 * m4.cost.minimum_per_centre(ch.dims().d))
        .sum();
    console.result(&format!(
        "arithmetic minimum of the mean path: {centres} centres × (expf {:.0} + 3·d \
         multiply-adds) = {minimum:.0} instructions; measured {:.2}× that ({:.2} instructions \
         per SysTick tick)",
        m4.cost.exp_instructions,
        m4.cost.mean_instructions / minimum,
        m4.cost.instructions_per_tick
    ));
    Ok(())
}

/// What each JSON the bench writes is made of: every contract of [`schema`] it writes, paired
/// with the type its body is written from, in [`schema::ALL`]'s order. docs/json.md lists their
/// fields from here (generated; a test fails where the page differs).
pub fn contracts() -> Vec<schema::Contract> {
    vec![
        schema::Contract::of::<schema::PerChannel<'static, identify::IdentifiedChannel>>(
            schema::IDENTIFY,
        ),
        schema::Contract::of::<crate::gyro::unit::Unit>(schema::SIM_UNIT),
        schema::Contract::of::<crate::gyro::axes::Axes>(schema::SIM_AXES),
        schema::Contract::of::<generate::Generated<'static>>(schema::GENERATE),
        schema::Contract::of::<generate::GeneratedUnit<'static>>(schema::GENERATE_UNIT),
        schema::Contract::of::<UnitReplay<'static>>(schema::REPLAY),
        schema::Contract::of::<UnitQemuReport<'static>>(schema::QEMU),
        schema::Contract::of::<generate::BoardTruth<'static>>(schema::BOARD),
    ]
}
