//! The `firmware-sim` command line: flags parsed, then dispatched to the library. `main.rs` only
//! calls [`run`]; tests call it too, with arguments of their own.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Parser, Subcommand, ValueEnum};
use firmware_core::units::DPH_PER_DPS;
use serde::Serialize;

use crate::gyro::axes::Axes;
use crate::gyro::effects::{Effect, Hidden};
use crate::gyro::unit::UnitFile;
use crate::gyro::{output, paper, plant::GyroParams, stream};
use crate::qemu;
use fog_data::cause::Cause;
use fog_data::replay;
use fog_data::sigma;
use fog_terminal::console::{AFTER_HELP, Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_atomically, write_json};
use fog_terminal::log::LogArgs;
use fog_terminal::schema;

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
    Generate(Generate),
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
        /// The stream is the power-on the model was calibrated on (its held-out part): the σ
        /// leaves out another power-on's bias (the blob's turn-on term), up to the stream's first
        /// power cycle. Without it, every sample is scored as in service, on another power-on.
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
    /// Model blob (from `trainer fit --out`): one model, or a unit's channels.
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
    /// Whether the log was read as a unit's (`--channels`): its results are reported per channel.
    per_channel: bool,
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
        let Some(channels) = self.log.unit.load()? else {
            let names: Vec<&str> = unit.channels().iter().map(|c| c.name()).collect();
            anyhow::ensure!(
                names.len() == 1,
                "{} holds a unit of {} channels ({}): give --channels FILE naming them in the log",
                self.model.display(),
                names.len(),
                names.join(", ")
            );
            return Ok(Loaded {
                blob,
                unit,
                streams: vec![self.log.load(console)?],
                per_channel: false,
            });
        };
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
            per_channel: true,
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
                 fault); σ: {}",
                c.name,
                c.score.rmse_60s_dps * k,
                c.score.n,
                c.score.n_extrapolating,
                c.score.n_degraded,
                c.score.n_fault,
                sigma::describe(&c.score.sigma_samples, &c.score.sigma_60s)
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// What `replay --channels --json` writes: the sensor and each channel's scores.
#[derive(Serialize)]
struct UnitReplay<'a> {
    sensor_id: &'a str,
    channels: &'a [replay::ChannelScore],
}

#[derive(Subcommand)]
enum Generate {
    /// The paper's protocol: 10 soaked temperatures × 14 rates, each point the mean of 120 samples.
    ///
    /// Example: firmware-sim generate paper --seed 1 --out points.csv
    Paper {
        #[command(flatten)]
        common: GenerateCommon,
        /// Also write the zero-rate position test before each rate test (table_rate_dps = 0).
        #[arg(long)]
        position_tests: bool,
    },
    /// A rate table of any size: each point at a setpoint (−30…60 °C) and a table rate (±80 °/s)
    /// drawn at random, soaked and averaged over 2 min as in the paper's protocol.
    ///
    /// Example: firmware-sim generate scattered --points 1000 --seed 7 --out table.csv
    Scattered {
        #[command(flatten)]
        common: GenerateCommon,
        /// Number of points.
        #[arg(long)]
        points: usize,
    },
    /// A stream at 1 Hz, the rate table stepping through the paper's rates and zero: by default
    /// from power-on, chamber soaks and ramps over −30…60 °C at 0.5–1 °C/min, three power cycles
    /// (8.75 hours); or (--design ramps) eight 0.5 °C/min legs between 60 and −30 °C from a warm
    /// start (30.7 hours); or the shapes labs record, each from one power-on: power-on (340 min
    /// of soaks and ramps), short (60 min), warm-up (180 min at 25 °C), cool-down (200 min).
    ///
    /// Example: firmware-sim generate stream --seed 2 --effect thermal-rate --strength 10 --out s.csv
    Stream {
        #[command(flatten)]
        common: GenerateCommon,
        /// The chamber program.
        #[arg(long, value_enum, default_value_t = Design::Chamber)]
        design: Design,
    },
}

/// A stream's chamber program ([`stream::StreamConfig`]).
#[derive(Clone, Copy, ValueEnum)]
enum Design {
    /// Soaks and ramps at 0.5–1 °C/min from power-on, three power cycles.
    Chamber,
    /// Eight slow legs between 60 and −30 °C from a warm start, never switched off.
    Ramps,
    /// One cold power-on, then 340 minutes of soaks and ramps over −20…60 °C, never switched off:
    /// the commonest calibration log.
    PowerOn,
    /// 60 minutes from power-on: a soak and one ramp, over before a transient is.
    Short,
    /// 180 minutes at 25 °C from power-on: a warm-up alone.
    WarmUp,
    /// From power-on at 60 °C, one ramp down to −20 °C (200 minutes).
    CoolDown,
}

/// What every generator takes.
#[derive(Args)]
struct GenerateCommon {
    /// Seed of the noise. Same seed, same bytes.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output CSV.
    #[arg(long)]
    out: PathBuf,
    /// Which gyro: `nominal` (PHYSICS.md's unit), `random` (drawn from its published ranges), or a
    /// unit file `identify --out` wrote (its effects act with any --effect given).
    #[arg(long, default_value = "nominal", value_name = "nominal|random|FILE")]
    unit: Unit,
    /// Seed of the unit drawn with --unit random (default: --seed). Give points and streams of one
    /// gyro the same unit seed.
    #[arg(long)]
    unit_seed: Option<u64>,
    /// A unit of this many gyro axes (1 to 6; a unit file of several axes gives its own): each its
    /// own gyro (with --unit random, each drawn by its own seed) and noise, in one housing with
    /// one temperature sensor, on a table that turns every axis. The CSV gets each axis's columns
    /// (NAME.voltage_v, NAME.rate_dps) and a channels file beside it (OUT with .channels.toml)
    /// names them for the trainer's --channels.
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=6))]
    axes: Option<u8>,
    /// Hidden physical effect (docs/design.md §5): none, thermal-rate, sensor-lag, warm-up,
    /// hysteresis, time-drift; several act together joined by + (warm-up+thermal-rate); one per
    /// axis of a unit joined by , (thermal-rate,none,hysteresis), or one for every axis. It acts
    /// on the paper protocol and on streams alike.
    #[arg(long, default_value = "none", value_name = "ID[+ID…][,…]")]
    effect: PerAxis<Joined<Cause>>,
    /// Strength of the effect, in its unit: thermal-rate (°/h)/(°C/min), sensor-lag min, warm-up
    /// °/h, hysteresis °/h, time-drift (°/h)/h; one per effect, joined by + and , as they are.
    /// Default: the middle of each documented range.
    #[arg(long, value_name = "S[+S…][,…]")]
    strength: Option<PerAxis<Joined<f64>>>,
    /// Write a JSON summary (the unit's parameters, the effect and the row count) here.
    #[arg(long)]
    json: Option<PathBuf>,
}

/// What a generator simulates: one gyro, or a unit of several axes.
enum Simulated {
    /// One gyro and its effects.
    One(GyroParams, Hidden),
    /// Several axes.
    Unit(Axes),
}

impl GenerateCommon {
    /// The effects of axis `k` of `n`: its own entry of --effect (and --strength), or the one
    /// entry every axis shares.
    fn hidden(&self, k: usize, n: usize) -> anyhow::Result<Hidden> {
        let pick = |len: usize, what: &str| -> anyhow::Result<usize> {
            match len {
                1 => Ok(0),
                l if l == n => Ok(k),
                l => {
                    anyhow::bail!("{l} {what} for {n} axes: give one, or one per axis joined by ,")
                }
            }
        };
        let causes = &self.effect.0[pick(self.effect.0.len(), "--effect entries")?].0;
        let strengths = match &self.strength {
            Some(s) => s.0[pick(s.0.len(), "--strength entries")?].0.as_slice(),
            None => &[],
        };
        Ok(Hidden::new(causes, strengths)?)
    }

    /// The gyro (or the unit's axes) and their effects.
    fn gyro(&self) -> anyhow::Result<Simulated> {
        let seed = self.unit_seed.unwrap_or(self.seed);
        let n = usize::from(self.axes.unwrap_or(1));
        let file = match &self.unit {
            Unit::File(path) => Some((path, UnitFile::load(path)?)),
            _ => None,
        };
        if let Some((path, UnitFile::Axes(axes))) = file {
            anyhow::ensure!(
                self.axes.is_none() || n == axes.axes.len(),
                "{} holds {} axes; --axes {n} asks for another number",
                path.display(),
                axes.axes.len()
            );
            let parts = axes
                .axes
                .iter()
                .enumerate()
                .map(|(k, a)| {
                    Ok((
                        a.params.clone(),
                        with_effects(path, &a.effects, self.hidden(k, axes.axes.len())?)?,
                    ))
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            return Ok(Simulated::Unit(Axes::new(parts)));
        }
        let params = |k: usize| match (&self.unit, &file) {
            (_, Some((_, UnitFile::One(u)))) => u.params.clone(),
            (Unit::Random, _) => GyroParams::random_unit(seed.wrapping_add(k as u64)),
            _ => GyroParams::nominal(),
        };
        let effects = |k: usize| -> anyhow::Result<Hidden> {
            let flagged = self.hidden(k, n)?;
            match &file {
                Some((path, UnitFile::One(u))) => with_effects(path, &u.effects, flagged),
                _ => Ok(flagged),
            }
        };
        if n == 1 {
            return Ok(Simulated::One(params(0), effects(0)?));
        }
        let parts = (0..n)
            .map(|k| Ok((params(k), effects(k)?)))
            .collect::<anyhow::Result<Vec<_>>>()?;
        Ok(Simulated::Unit(Axes::new(parts)))
    }

    /// Writes the CSV and, when asked, the JSON summary of `n` rows.
    fn write(
        &self,
        params: &GyroParams,
        effects: &Hidden,
        csv: &str,
        n: usize,
        flags: ConsoleFlags,
    ) -> anyhow::Result<()> {
        write_atomically(&self.out, csv.as_bytes())?;
        Console::new(flags, self.json.as_deref())
            .result(&format!("wrote {} ({n} rows)", self.out.display()));
        if let Some(path) = &self.json {
            write_json(
                path,
                &[],
                schema::GENERATE,
                &Generated {
                    n,
                    seed: self.seed,
                    unit: params,
                    effect: effects.0.first().copied().unwrap_or(Effect::None),
                    effects,
                },
            )?;
        }
        Ok(())
    }

    /// Writes a unit's CSV, its channels file beside it and, when asked, the JSON summary (the
    /// axes, each with its gyro and effects).
    fn write_unit(
        &self,
        axes: &Axes,
        csv: &str,
        n: usize,
        flags: ConsoleFlags,
    ) -> anyhow::Result<()> {
        let channels = self.out.with_extension("channels.toml");
        write_atomically(&self.out, csv.as_bytes())?;
        write_atomically(
            &channels,
            axes.channels_toml(&format!("simulated-{}", self.seed))
                .as_bytes(),
        )?;
        Console::new(flags, self.json.as_deref()).result(&format!(
            "wrote {} ({n} rows of {} axes) and {} (its channels)",
            self.out.display(),
            axes.axes.len(),
            channels.display()
        ));
        if let Some(path) = &self.json {
            write_json(
                path,
                &[],
                schema::GENERATE_UNIT,
                &GeneratedUnit {
                    n,
                    seed: self.seed,
                    unit: axes,
                },
            )?;
        }
        Ok(())
    }
}

/// A unit file's effects with those the flags add: each cause at most once.
fn with_effects(path: &std::path::Path, own: &[Effect], flagged: Hidden) -> anyhow::Result<Hidden> {
    let mut effects = own.to_vec();
    for e in flagged.0.into_iter().filter(|e| *e != Effect::None) {
        if effects.iter().any(|u| u.cause() == e.cause()) {
            anyhow::bail!(
                "{} already has a {} effect; edit the unit file to change it",
                path.display(),
                e.cause().id()
            );
        }
        effects.push(e);
    }
    Ok(Hidden(effects))
}

/// What `generate … --json` writes: the row count, the seed, the unit and its hidden effects.
#[derive(Serialize)]
struct Generated<'a> {
    n: usize,
    seed: u64,
    unit: &'a GyroParams,
    /// The first hidden effect (`none` without one), for scripts that expect one.
    effect: Effect,
    effects: &'a Hidden,
}

/// What `qemu --json` writes: the M4 run's scores, its agreement with the host replay, its cost.
#[derive(Serialize)]
struct QemuReport<'a> {
    #[serde(flatten)]
    score: &'a replay::Score,
    agreement_with_host: qemu::Agreement,
    cost: qemu::Cost,
}

/// What `qemu --channels --json` writes: each channel's scores, the agreement of them all with
/// the host replay, the cost per sample of them all.
#[derive(Serialize)]
struct UnitQemuReport<'a> {
    sensor_id: &'a str,
    channels: &'a [replay::ChannelScore],
    agreement_with_host: qemu::Agreement,
    cost: qemu::Cost,
}

/// What `generate --axes … --json` writes: the row count, the seed and the unit's axes.
#[derive(Serialize)]
struct GeneratedUnit<'a> {
    n: usize,
    seed: u64,
    unit: &'a Axes,
}

/// One flag's values per axis, joined by `,` (`thermal-rate,none`).
#[derive(Debug, Clone)]
struct PerAxis<T>(Vec<T>);

impl<T: std::str::FromStr<Err = String>> std::str::FromStr for PerAxis<T> {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        s.split(',')
            .map(str::parse)
            .collect::<Result<Vec<T>, String>>()
            .map(PerAxis)
    }
}

/// Values of one flag joined by `+` (`warm-up+thermal-rate`, `40+15`).
#[derive(Debug, Clone)]
struct Joined<T>(Vec<T>);

impl<T: std::str::FromStr> std::str::FromStr for Joined<T>
where
    T::Err: std::fmt::Display,
{
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        s.split('+')
            .map(|part| {
                part.trim()
                    .parse::<T>()
                    .map_err(|e| format!("'{part}': {e}"))
            })
            .collect::<Result<Vec<T>, String>>()
            .map(Joined)
    }
}

/// `--unit`: which gyro to simulate.
#[derive(Clone)]
enum Unit {
    Nominal,
    Random,
    File(PathBuf),
}

impl std::str::FromStr for Unit {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "nominal" => Unit::Nominal,
            "random" => Unit::Random,
            path => Unit::File(PathBuf::from(path)),
        })
    }
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let flags = cli.console;
    match cli.command {
        Command::Generate(Generate::Paper {
            common,
            position_tests,
        }) => match common.gyro()? {
            Simulated::One(params, effects) => {
                let points = paper::run(&params, effects.clone(), common.seed, position_tests);
                let csv = output::points_csv(&points);
                common.write(&params, &effects, &csv, points.len(), flags)
            }
            Simulated::Unit(axes) => {
                let points = axes.paper(common.seed, position_tests);
                let n = points.first().map_or(0, Vec::len);
                common.write_unit(&axes, &axes.points_csv(&points), n, flags)
            }
        },
        Command::Generate(Generate::Scattered { common, points }) => match common.gyro()? {
            Simulated::One(params, effects) => {
                let points = paper::scattered(&params, effects.clone(), common.seed, points);
                let csv = output::points_csv(&points);
                common.write(&params, &effects, &csv, points.len(), flags)
            }
            Simulated::Unit(_) => {
                anyhow::bail!("generate scattered simulates one gyro: leave --axes out")
            }
        },
        Command::Generate(Generate::Stream { common, design }) => {
            let cfg = match design {
                Design::Chamber => stream::StreamConfig::default(),
                Design::Ramps => stream::StreamConfig::ramps(),
                Design::PowerOn => stream::StreamConfig::power_on(),
                Design::Short => stream::StreamConfig::short(),
                Design::WarmUp => stream::StreamConfig::warm_up(),
                Design::CoolDown => stream::StreamConfig::cool_down(),
            };
            match common.gyro()? {
                Simulated::One(params, effects) => {
                    let rows = stream::run(&params, &cfg, effects.clone(), common.seed);
                    common.write(
                        &params,
                        &effects,
                        &output::stream_csv(&rows),
                        rows.len(),
                        flags,
                    )
                }
                Simulated::Unit(axes) => {
                    let rows = axes.stream(&cfg, common.seed);
                    let n = rows.first().map_or(0, Vec::len);
                    common.write_unit(&axes, &axes.stream_csv(&rows), n, flags)
                }
            }
        }
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
    if loaded.per_channel {
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
            write_json(&path, &[], schema::REPLAY_UNIT, &report)?;
        }
        console.result(&format!(
            "replayed {} samples of {} channels through one unit blob:\n{}",
            streams.first().map_or(0, |s| s.len()),
            scores.len(),
            channel_lines(&scores)
        ));
        return Ok(());
    }
    let (data, comp) = (&loaded.streams[0], &comps[0]);
    let score = replay::score(data, comp);
    if let Some(path) = out {
        write_atomically(&path, replay::to_csv(data, comp).as_bytes())?;
    }
    if let Some(path) = json {
        write_json(&path, &[], schema::REPLAY, &score)?;
    }
    console.result(&format!(
        "replayed {} samples ({} scored, {} extrapolating, {} degraded, {} fault, {} time issues, {} handled): \
         rmse {:.3e} °/s, rmse_60s {:.3e} °/s ({:.2} °/h), max |err| {:.3e} °/s\n\
         the firmware's σ: {}",
        data.len(),
        score.n,
        score.n_extrapolating,
        score.n_degraded,
        score.n_fault,
        score.time_issues.len(),
        score.n_handled,
        score.rmse_dps,
        score.rmse_60s_dps,
        score.rmse_60s_dps * DPH_PER_DPS,
        score.max_abs_err_dps,
        sigma::describe(&score.sigma_samples, &score.sigma_60s)
    ));
    if let Some(why) = replay::degraded_reason(data, &score) {
        console.warn(&why);
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
            "qemu-system-arm {} {}",
            qemu::QEMU_ARGS.join(" "),
            image.display()
        ))
    });
    let n = streams.first().map_or(0, |s| s.len());
    spinner.set_message(format!("running {n} samples on the Cortex-M4 under QEMU"));
    let m4 = qemu::run(&image, &loaded.blob, &streams)?;
    spinner.set_message("host replay, for the comparison");
    let host = replay::replay_unit(&loaded.unit, &streams, false);
    spinner.finish_and_clear();
    let agreements: Vec<qemu::Agreement> = host
        .iter()
        .zip(&m4.compensated)
        .map(|(h, m)| qemu::compare(h, m))
        .collect();
    let agreement = qemu::Agreement::all(&agreements);
    let scores = replay::unit_scores(&loaded.unit, &streams, &m4.compensated);
    if let Some(path) = out {
        let csv = if loaded.per_channel {
            replay::unit_csv(&loaded.unit, &streams, &m4.compensated)
        } else {
            replay::to_csv(streams[0], &m4.compensated[0])
        };
        write_atomically(&path, csv.as_bytes())?;
    }
    if let Some(path) = json {
        if loaded.per_channel {
            write_json(
                &path,
                &[],
                schema::QEMU_UNIT,
                &UnitQemuReport {
                    sensor_id: loaded.unit.sensor_id(),
                    channels: &scores,
                    agreement_with_host: agreement,
                    cost: m4.cost,
                },
            )?;
        } else {
            let report = QemuReport {
                score: &scores[0].score,
                agreement_with_host: agreement,
                cost: m4.cost,
            };
            write_json(&path, &[], schema::QEMU, &report)?;
        }
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
    if loaded.per_channel {
        console.result(&channel_lines(&scores));
    } else {
        console.result(&format!(
            "M4 rmse_60s {:.3e} °/s",
            scores[0].score.rmse_60s_dps
        ));
    }
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
