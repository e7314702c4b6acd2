//! `firmware-sim generate`: the simulated gyro's rate tables and streams (one gyro, or a unit of
//! several axes), and a simulated flight controller's thermal calibration log.

use std::path::PathBuf;

use clap::{Args, Subcommand, ValueEnum};
use serde::Serialize;

use crate::board::{self, Board};
use crate::gyro::axes::Axes;
use crate::gyro::effects::{Effect, Hidden};
use crate::gyro::unit::UnitFile;
use crate::gyro::{output, paper, plant::GyroParams, stream};
use fog_data::autopilot::BoardRotation;
use fog_data::cause::Cause;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{write_atomically, write_json};
use fog_terminal::schema;

#[derive(Subcommand)]
pub(crate) enum Generate {
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
    /// A stream at 1 Hz, the rate table stepping through the paper's rates and zero (at rest in a
    /// room's): by default
    /// from power-on, chamber soaks and ramps over −30…60 °C at 0.5–1 °C/min, three power cycles
    /// (8.75 hours); or (--design ramps) eight 0.5 °C/min legs between 60 and −30 °C from a warm
    /// start (30.7 hours); or the shapes labs record, each from one power-on: power-on (340 min
    /// of soaks and ramps), short (60 min), warm-up (180 min at 25 °C), cool-down (200 min), and
    /// room (three days at rest in a room's daily swing: a static log).
    ///
    /// Example: firmware-sim generate stream --seed 2 --effect thermal-rate --strength 10 --out s.csv
    Stream {
        #[command(flatten)]
        common: GenerateCommon,
        /// The program: a chamber's, on the rate table, or a room's, at rest (room).
        #[arg(long, value_enum, default_value_t = Design::Chamber)]
        design: Design,
    },
    /// A flight controller's thermal calibration, recorded as PX4 (`.ulg`) or ArduPilot (`.bin`)
    /// records it: two IMUs (a gyro and an accelerometer each, with their own device IDs) warming
    /// from a cold soak, 5 samples a second. IMU 0's bias is a cubic in temperature; IMU 1 hides a
    /// knee near 30 °C and a temperature sensor that lags its die by 90 s. The seed draws the noise
    /// only: every log of the board shares its curves.
    ///
    /// Example: firmware-sim generate board --seed 1 --out cal.ulg
    Board {
        /// Seed of the noise. Same seed, same bytes.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The board's temperature at power-on, °C.
        #[arg(long, default_value_t = -10.0, allow_hyphen_values = true)]
        soak: f64,
        /// Where the board settles, °C (its dies a few degrees above).
        #[arg(long, default_value_t = 60.0, allow_hyphen_values = true)]
        settle: f64,
        /// The warm-up's time constant, minutes.
        #[arg(long, default_value_t = 25.0)]
        warm_up_min: f64,
        /// The log's length, minutes.
        #[arg(long, default_value_t = 120.0)]
        minutes: f64,
        /// How the board is mounted in the vehicle: ArduPilot's `AHRS_ORIENTATION` (0 level, 2 yaw
        /// 90°, 8 roll 180°, … up to 43; 100–102 custom, with `--custom-rotation`). A `.bin` log
        /// then holds the vehicle's axes, as the firmware logs them; a ULog's sensor topics are the
        /// board's whatever the mounting.
        #[arg(long, default_value_t = 0)]
        orientation: u16,
        /// A custom `--orientation` (100, 101 or 102)'s roll, pitch and yaw, degrees, written as
        /// the parameters ArduPilot reads them from (`AHRS_CUSTOM_*`, `CUST_ROT1_*`,
        /// `CUST_ROT2_*`).
        #[arg(
            long,
            value_name = "ROLL,PITCH,YAW",
            value_delimiter = ',',
            allow_hyphen_values = true
        )]
        custom_rotation: Vec<f64>,
        /// The log to write: a PX4 ULog (`.ulg`) or an ArduPilot DataFlash log (`.bin`).
        #[arg(long)]
        out: PathBuf,
        /// Write the board's truth (every bias curve, the run) as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
}

/// A stream's chamber program ([`stream::StreamConfig`]).
#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum Design {
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
    /// A static log: three days at rest from power-on in a room swinging 21…25 °C once a day,
    /// as a bias stability run records one (fit it with `--scale-factor`).
    Room,
}

/// What every generator takes.
#[derive(Args)]
pub(crate) struct GenerateCommon {
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
            let mut parts = axes
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
            // A unit of one axis (the twin of one gyro's data) is that gyro.
            if parts.len() == 1 {
                let (params, hidden) = parts.remove(0);
                return Ok(Simulated::One(params, hidden));
            }
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
#[derive(Serialize, schemars::JsonSchema)]
pub(super) struct Generated<'a> {
    n: usize,
    seed: u64,
    unit: &'a GyroParams,
    /// The first hidden effect (`none` without one), for scripts that expect one.
    effect: Effect,
    effects: &'a Hidden,
}

/// What `generate --axes … --json` writes: the row count, the seed and the unit's axes.
#[derive(Serialize, schemars::JsonSchema)]
pub(super) struct GeneratedUnit<'a> {
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

/// `firmware-sim generate`: the data asked, written.
pub(super) fn generate_command(g: Generate, flags: ConsoleFlags) -> anyhow::Result<()> {
    match g {
        Generate::Paper {
            common,
            position_tests,
        } => match common.gyro()? {
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
        Generate::Scattered { common, points } => match common.gyro()? {
            Simulated::One(params, effects) => {
                let points = paper::scattered(&params, effects.clone(), common.seed, points);
                let csv = output::points_csv(&points);
                common.write(&params, &effects, &csv, points.len(), flags)
            }
            Simulated::Unit(_) => {
                anyhow::bail!("generate scattered simulates one gyro: leave --axes out")
            }
        },
        Generate::Stream { common, design } => {
            let cfg = match design {
                Design::Chamber => stream::StreamConfig::default(),
                Design::Ramps => stream::StreamConfig::ramps(),
                Design::PowerOn => stream::StreamConfig::power_on(),
                Design::Short => stream::StreamConfig::short(),
                Design::WarmUp => stream::StreamConfig::warm_up(),
                Design::CoolDown => stream::StreamConfig::cool_down(),
                Design::Room => stream::StreamConfig::room(),
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
        Generate::Board {
            seed,
            soak,
            settle,
            warm_up_min,
            minutes,
            orientation,
            custom_rotation,
            out,
            json,
        } => {
            let run = board::Run {
                soak_c: soak,
                settle_c: settle,
                warm_up_s: warm_up_min * 60.0,
                duration_s: minutes * 60.0,
                ..board::Run::default()
            };
            let mounting = mounting(orientation, &custom_rotation)?;
            anyhow::ensure!(
                orientation == 0 || out.extension().is_none_or(|e| e != "ulg"),
                "--orientation is ArduPilot's AHRS_ORIENTATION: a PX4 ULog's sensor topics hold \
                 the board's axes however it is mounted (PX4 turns them by SENS_BOARD_ROT later); \
                 name the log .bin"
            );
            board_command(seed, (run, &mounting), (&out, json.as_deref()), flags)
        }
    }
}

/// The board's mounting: ArduPilot's rotation `orientation`, a custom one (100 to 102) with its
/// `angles` (roll, pitch, yaw in degrees); refused where the two do not go together.
fn mounting(orientation: u16, angles: &[f64]) -> anyhow::Result<BoardRotation> {
    let custom = (100..=102).contains(&orientation);
    anyhow::ensure!(
        custom || angles.is_empty(),
        "--custom-rotation gives a custom rotation's angles: use it with --orientation 100, 101 \
         or 102"
    );
    anyhow::ensure!(
        angles.is_empty() || (angles.len() == 3 && angles.iter().all(|a| a.is_finite())),
        "--custom-rotation takes three finite angles in degrees: ROLL,PITCH,YAW"
    );
    match <[f64; 3]>::try_from(angles) {
        Ok(angles) => BoardRotation::custom(orientation, angles),
        Err(_) => BoardRotation::ardupilot(orientation, |_| None),
    }
    .ok_or_else(|| {
        if custom {
            anyhow::anyhow!(
                "--orientation {orientation} is a custom rotation: give its angles with \
                 --custom-rotation ROLL,PITCH,YAW (degrees)"
            )
        } else {
            anyhow::anyhow!(
                "--orientation {orientation}: the board's mounting is one of ArduPilot's \
                 rotations, 0 to 43, or a custom one, 100 to 102"
            )
        }
    })
}

/// `firmware-sim generate board`: the board's log, in the format its extension names.
fn board_command(
    seed: u64,
    (run, mounting): (board::Run, &BoardRotation),
    (out, json): (&std::path::Path, Option<&std::path::Path>),
    flags: ConsoleFlags,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        run.warm_up_s > 0.0 && run.duration_s >= 60.0,
        "--warm-up-min must be positive and --minutes at least 1"
    );
    let board = Board::nominal();
    let samples = board.record(&run, seed);
    let mut bytes = Vec::new();
    match out.extension().and_then(|e| e.to_str()) {
        Some("ulg") => board.ulog(&samples, &mut bytes)?,
        Some("bin") => board.dataflash(&samples, mounting, &mut bytes)?,
        _ => anyhow::bail!(
            "{}: name the log .ulg (a PX4 ULog) or .bin (an ArduPilot DataFlash log)",
            out.display()
        ),
    }
    write_atomically(out, &bytes)?;
    let n = samples.first().map_or(0, Vec::len);
    Console::new(flags, json).result(&format!(
        "wrote {} ({} IMUs, {n} samples each, {:.0} MB)",
        out.display(),
        board.imus.len(),
        bytes.len() as f64 / 1e6
    ));
    if let Some(path) = json {
        write_json(
            path,
            &[],
            schema::BOARD,
            &BoardTruth {
                n,
                seed,
                board: &board,
                run,
            },
        )?;
    }
    Ok(())
}

/// What `generate board --json` writes: the samples per IMU, the seed, the board and the run.
#[derive(Serialize, schemars::JsonSchema)]
pub(super) struct BoardTruth<'a> {
    n: usize,
    seed: u64,
    board: &'a Board,
    run: board::Run,
}
