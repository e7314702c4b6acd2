//! A sensor unit's channels, named once in a channels file (`--channels FILE`, TOML) and read by
//! every command that takes a unit's data: each channel's output column and the unit it is in, its
//! reference, and what the channels share (the time, the temperature, the sensor's ID).
//!
//! ```toml
//! sensor_id = "IMU-0042"            # optional, at most 32 bytes: the blob carries it
//! time = "timestamp*1e-6"           # optional: else --map time_s=…, else a column time_s
//! temperature = "imu.temperature"   # optional: else --map temp_c=…, else a column temp_c
//!
//! [[channel]]
//! name = "gyro.x"                   # at most 16 bytes, unique
//! output = "imu.gyro.x"             # a column, or COLUMN*FACTOR
//! unit = "rad/s"                    # rad/s, deg/s, deg/h, m/s2, g, mg, or the raw unit (V, counts)
//! reference = "0"                   # a column, COLUMN*FACTOR or a constant, in °/s (m/s²)
//! # kind = "gyro"                   # gyro or accelerometer: what a raw output measures
//! # scale_factor = 26592.6          # raw output per °/s (m/s²), for a log without a rate table
//! # The channel's datasheet, each optional, in place of the `fit` flag of its name for this
//! # channel: in °/s (m/s²), the output converted as below (a raw output's full_scale in its
//! # raw unit):
//! # full_scale = 2000               # a reading beyond ± it is a fault
//! # repeatability = 0.05            # the bias's run-to-run σ
//! # scale_repeatability = 300       # the scale factor's, ppm
//! # tempco = 0.005                  # the bias's change per °C, beyond the trained range
//! # hysteresis = 0.02               # the gap between heating and cooling at one temperature
//! # sensor_lag = 90                 # s the temperature sensor lags the sensing element by
//! ```
//!
//! A channel's datasheet ([`Datasheet`]) is what the σ of its blob takes where one power-on's
//! data cannot show it (docs/uncertainty.md), and its full scale where a reading is a fault.
//!
//! An output in a physical unit is converted to the channel's quantity's unit (°/s for a gyro,
//! m/s² for an accelerometer) as it is read; on a log without a rate table it then needs no scale
//! factor (1: the model learns the bias). A raw output (a FOG's volts or counts) is mapped to
//! rate by the rate table, as one channel's `voltage_v` is, or given a `scale_factor`. Each
//! channel is read as a stream of its own whose `voltage_v` is its output and whose `rate_dps` is
//! its reference, so everything a command does with one channel it does with each; what the
//! channels share, the time checks and the handled minutes, is computed once for the unit
//! ([`Channels::load_log`]).

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use firmware_core::Quantity;
use firmware_core::blob::unit::{NAME_BYTES, SENSOR_ID_BYTES};
use firmware_core::unit::SINGLE_CHANNEL;
use serde::Deserialize;

use crate::autopilot::{Recorded, RecordedError, Sensor, gravity_reference};
use crate::columns::{self, ColumnMap, ColumnSource, DataError};
use crate::stream::{self, Stream};

mod datasheet;
pub use datasheet::{Datasheet, InvalidFigure};

/// What kind of file the channels are read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Read {
    /// A log in time order: the file's time column applies.
    Log,
    /// A rate table: its time, where it has one, is its own `--map time_s=…`.
    Table,
}

/// The unit a channel's output column is in.
#[derive(Debug, Clone, PartialEq)]
pub enum OutputUnit {
    /// rad/s (a gyro).
    RadPerSecond,
    /// °/s (a gyro).
    DegreePerSecond,
    /// °/h (a gyro).
    DegreePerHour,
    /// m/s² (an accelerometer).
    MetrePerSecond2,
    /// Standard gravities (an accelerometer).
    Gravity,
    /// Thousandths of standard gravity (an accelerometer).
    MilliGravity,
    /// The sensor's own unit (volts, counts): mapped to a rate by a rate table or a scale factor.
    Raw(String),
}

impl OutputUnit {
    /// The unit named `text`.
    fn parse(text: &str) -> Self {
        match text.trim() {
            "rad/s" => Self::RadPerSecond,
            "deg/s" | "°/s" | "dps" => Self::DegreePerSecond,
            "deg/h" | "°/h" | "dph" => Self::DegreePerHour,
            "m/s2" | "m/s²" | "m/s^2" => Self::MetrePerSecond2,
            "g" => Self::Gravity,
            "mg" => Self::MilliGravity,
            other => Self::Raw(other.to_owned()),
        }
    }

    /// What it measures, where the unit says so.
    fn quantity(&self) -> Option<Quantity> {
        match self {
            Self::RadPerSecond | Self::DegreePerSecond | Self::DegreePerHour => {
                Some(Quantity::AngularRate)
            }
            Self::MetrePerSecond2 | Self::Gravity | Self::MilliGravity => {
                Some(Quantity::SpecificForce)
            }
            Self::Raw(_) => None,
        }
    }

    /// Its values times this are in the quantity's unit (°/s, m/s²); `None` for a raw unit.
    pub fn factor(&self) -> Option<f64> {
        let g = firmware_core::units::STANDARD_GRAVITY;
        match self {
            Self::RadPerSecond => Some(180.0 / std::f64::consts::PI),
            Self::DegreePerSecond | Self::MetrePerSecond2 => Some(1.0),
            Self::DegreePerHour => Some(1.0 / firmware_core::units::DPH_PER_DPS),
            Self::Gravity => Some(g),
            Self::MilliGravity => Some(g / 1000.0),
            Self::Raw(_) => None,
        }
    }
}

impl std::fmt::Display for OutputUnit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::RadPerSecond => "rad/s",
            Self::DegreePerSecond => "°/s",
            Self::DegreePerHour => "°/h",
            Self::MetrePerSecond2 => "m/s²",
            Self::Gravity => "g",
            Self::MilliGravity => "mg",
            Self::Raw(u) => u,
        })
    }
}

/// One channel, as its commands read it.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    /// Its name (`gyro.x`).
    pub name: String,
    /// What it measures.
    pub quantity: Quantity,
    /// The unit its output column is in.
    pub unit: OutputUnit,
    /// Where its output comes from, converted to the quantity's unit where the unit is physical.
    pub output: ColumnSource,
    /// Where its reference comes from (°/s or m/s²).
    pub reference: ColumnSource,
    /// A raw output's scale factor, for a log without a rate table.
    pub scale_factor: Option<f64>,
    /// The output's full scale, in the unit its output is read in (°/s or m/s² where its unit
    /// is physical, else the raw unit): a reading beyond ± it is a fault.
    pub full_scale: Option<f64>,
    /// What its datasheet states for its σ.
    pub datasheet: Datasheet,
}

impl Channel {
    /// The scale factor its bias model takes on a log without a rate table: the one given, else 1
    /// for an output in a physical unit (already converted); `None` for a raw output without one.
    pub fn bias_scale_factor(&self) -> Option<f64> {
        self.scale_factor
            .or_else(|| self.unit.factor().map(|_| 1.0))
    }
}

/// A unit's channels (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct Channels {
    /// The file they came from.
    pub path: PathBuf,
    /// The sensor's ID (empty where the file gives none).
    pub sensor_id: String,
    /// The time column, where the file names it.
    pub time: Option<ColumnSource>,
    /// The temperature column, where the file names it.
    pub temperature: Option<ColumnSource>,
    /// The channels, in order.
    pub list: Vec<Channel>,
    /// The sensor of an autopilot's log they are the axes of, read already: its samples are
    /// taken from there rather than from a CSV's columns.
    pub recorded: Option<Arc<Sensor>>,
    /// The name the user gave that sensor (`--sensor gyro0=front`), where one was given.
    pub renamed: Option<String>,
    /// A CSV of one channel ([`Channels::single`]): read by its canonical columns, `--map`
    /// renaming any of them.
    pub single: bool,
}

/// A channels file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ChannelsError {
    /// Unreadable.
    #[error("{path}: cannot read ({source})")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not a channels file: the TOML parser's message, with its line and column.
    #[error("{path}: not a channels file: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// Why, where.
        message: String,
    },
    /// Readable, but not usable.
    #[error("{path}: {why}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Why.
        why: String,
    },
}

/// The file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    sensor_id: Option<String>,
    time: Option<String>,
    temperature: Option<String>,
    channel: Vec<Entry>,
}

/// One `[[channel]]` as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    name: String,
    output: String,
    unit: String,
    reference: String,
    kind: Option<SensorKind>,
    scale_factor: Option<f64>,
    full_scale: Option<f64>,
    repeatability: Option<f64>,
    scale_repeatability: Option<f64>,
    tempco: Option<f64>,
    hysteresis: Option<f64>,
    sensor_lag: Option<f64>,
}

/// What a raw output measures.
#[derive(Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
enum SensorKind {
    Gyro,
    Accelerometer,
}

impl Channels {
    /// Reads and checks a channels file.
    pub fn load(path: &Path) -> Result<Self, ChannelsError> {
        let text = std::fs::read_to_string(path).map_err(|source| ChannelsError::Io {
            path: path.to_owned(),
            source,
        })?;
        Self::parse(path, &text)
    }

    /// Parses the text of a channels file read from `path`.
    pub fn parse(path: &Path, text: &str) -> Result<Self, ChannelsError> {
        let file: File = toml::from_str(text).map_err(|e| ChannelsError::Format {
            path: path.to_owned(),
            message: e.to_string().trim_end().to_owned(),
        })?;
        let invalid = |why: String| ChannelsError::Invalid {
            path: path.to_owned(),
            why,
        };
        let source = |what: &str, text: &str| {
            text.parse::<ColumnSource>().map_err(|_| {
                invalid(format!(
                    "{what} '{text}': expected a column, COLUMN*FACTOR or a number"
                ))
            })
        };
        let sensor_id = file.sensor_id.unwrap_or_default();
        if sensor_id.len() > SENSOR_ID_BYTES {
            return Err(invalid(format!(
                "sensor_id '{sensor_id}' is {} bytes; the blob holds {SENSOR_ID_BYTES}",
                sensor_id.len()
            )));
        }
        if file.channel.is_empty() {
            return Err(invalid("no [[channel]]".to_owned()));
        }
        if file.channel.len() > usize::from(u8::MAX) {
            return Err(invalid(format!(
                "{} channels; a unit blob holds 255",
                file.channel.len()
            )));
        }
        let mut seen = HashSet::new();
        let mut list = Vec::new();
        for e in file.channel {
            let name = e.name.trim().to_owned();
            if name.is_empty() || name.len() > NAME_BYTES {
                return Err(invalid(format!(
                    "channel name '{name}': 1 to {NAME_BYTES} bytes"
                )));
            }
            if !seen.insert(name.clone()) {
                return Err(invalid(format!("channel '{name}' is named twice")));
            }
            let unit = OutputUnit::parse(&e.unit);
            let kind = e.kind.map(|k| match k {
                SensorKind::Gyro => Quantity::AngularRate,
                SensorKind::Accelerometer => Quantity::SpecificForce,
            });
            let quantity = match (unit.quantity(), kind) {
                (Some(q), Some(k)) if q != k => {
                    return Err(invalid(format!(
                        "channel '{name}': unit {unit} is not a {} unit",
                        if k == Quantity::AngularRate {
                            "gyro"
                        } else {
                            "accelerometer"
                        }
                    )));
                }
                (Some(q), _) => q,
                (None, k) => k.unwrap_or(Quantity::AngularRate),
            };
            if let Some(k) = e.scale_factor
                && !(k.is_finite() && k != 0.0)
            {
                return Err(invalid(format!(
                    "channel '{name}': scale_factor {k} is not a finite non-zero number"
                )));
            }
            let output = source(&format!("channel '{name}': output"), &e.output)?;
            if matches!(output, ColumnSource::Constant(_)) {
                return Err(invalid(format!(
                    "channel '{name}': output '{}' is a number, not a column",
                    e.output
                )));
            }
            let output = output.scaled(unit.factor().unwrap_or(1.0));
            let reference = source(&format!("channel '{name}': reference"), &e.reference)?;
            if let Some(f) = e.full_scale
                && !(f > 0.0 && (f as f32).is_finite())
            {
                return Err(invalid(format!(
                    "channel '{name}': full_scale {f} is not a positive number"
                )));
            }
            let datasheet = Datasheet {
                repeatability: e.repeatability,
                scale_repeatability: e.scale_repeatability,
                tempco: e.tempco,
                hysteresis: e.hysteresis,
                sensor_lag_s: e.sensor_lag,
            };
            if let Err(e) = datasheet.check() {
                return Err(invalid(format!("channel '{name}': {e}")));
            }
            list.push(Channel {
                name,
                quantity,
                unit,
                output,
                reference,
                scale_factor: e.scale_factor,
                full_scale: e.full_scale,
                datasheet,
            });
        }
        let time = file.time.map(|t| source("time", &t)).transpose()?;
        let temperature = file
            .temperature
            .map(|t| source("temperature", &t))
            .transpose()?;
        Ok(Self {
            path: path.to_owned(),
            sensor_id,
            time,
            temperature,
            list,
            recorded: None,
            renamed: None,
            single: false,
        })
    }

    /// A CSV of one channel (`time_s,temp_c,voltage_v,rate_dps`, or what `--map` names) as a unit
    /// of one: its channel is the firmware's [`SINGLE_CHANNEL`], a gyro whose raw output is
    /// `voltage_v` and whose reference is `rate_dps`, read as every log of one channel is
    /// ([`Stream::load`]), so that every command has one path for one channel and for many.
    pub fn single(path: &Path) -> Self {
        let column = |name: &str| ColumnSource::Column {
            name: name.to_owned(),
            factor: 1.0,
        };
        Self {
            path: path.to_owned(),
            sensor_id: String::new(),
            time: None,
            temperature: None,
            list: vec![Channel {
                name: SINGLE_CHANNEL.to_owned(),
                quantity: Quantity::AngularRate,
                unit: OutputUnit::Raw("V".to_owned()),
                output: column("voltage_v"),
                reference: column("rate_dps"),
                scale_factor: None,
                full_scale: None,
                datasheet: Datasheet::default(),
            }],
            recorded: None,
            renamed: None,
            single: true,
        }
    }

    /// A flight controller log's sensor as a unit's channels, as a channels file would name them:
    /// each axis's output in its quantity's unit, its reference that of a board at rest (no
    /// rotation; on an accelerometer axis the component of gravity nearest its first minute's
    /// median: [`gravity_reference`]).
    pub fn of_sensor(sensor: &Arc<Sensor>, path: &Path) -> Self {
        let list = sensor
            .axes
            .iter()
            .map(|a| Channel {
                name: a.name.clone(),
                quantity: a.quantity,
                unit: match a.quantity {
                    Quantity::AngularRate => OutputUnit::DegreePerSecond,
                    Quantity::SpecificForce => OutputUnit::MetrePerSecond2,
                },
                output: ColumnSource::Column {
                    name: a.name.clone(),
                    factor: 1.0,
                },
                reference: ColumnSource::Constant(match a.quantity {
                    Quantity::AngularRate => 0.0,
                    Quantity::SpecificForce => gravity_reference(&sensor.time_s, &a.values),
                }),
                scale_factor: None,
                full_scale: None,
                datasheet: Datasheet::default(),
            })
            .collect();
        Self {
            path: path.to_owned(),
            sensor_id: sensor.sensor_id(),
            time: None,
            temperature: None,
            list,
            recorded: Some(Arc::clone(sensor)),
            renamed: None,
            single: false,
        }
    }

    /// The sensors of `log` named `names`, each as a unit's channels ([`Self::of_sensor`]);
    /// where none is named, all but the autopilot's learning means ([`Sensor::learned`]), which
    /// record the same sensors again (all of them, where the log holds nothing else).
    pub fn of_log(log: &Recorded, names: &[String]) -> Result<Vec<Self>, RecordedError> {
        if names.is_empty() {
            return Ok(log.taken().map(|s| Self::of_sensor(s, &log.path)).collect());
        }
        names
            .iter()
            .map(|n| {
                log.sensors
                    .iter()
                    .find(|s| &s.name == n)
                    .map(|s| Self::of_sensor(s, &log.path))
                    .ok_or_else(|| RecordedError::NoSuchSensor {
                        path: log.path.clone(),
                        asked: n.clone(),
                        found: log.listing(),
                    })
            })
            .collect()
    }

    /// The unit's name among a log's sensors: the one the user gave, else the sensor's
    /// (`gyro0`); `None` for a channels file's unit.
    pub fn unit_name(&self) -> Option<&str> {
        self.renamed
            .as_deref()
            .or(self.recorded.as_ref().map(|s| s.name.as_str()))
    }

    /// Gives a log's sensor a name of the user's (`--sensor gyro0=front`): its unit's name and
    /// sensor ID. Refused unless 1 to 32 bytes (what a blob holds) without a slash (it names
    /// files).
    pub fn rename(&mut self, new: &str) -> Result<(), ChannelsError> {
        if new.is_empty() || new.len() > SENSOR_ID_BYTES || new.contains(['/', '\\']) {
            return Err(ChannelsError::Invalid {
                path: self.path.clone(),
                why: format!(
                    "--sensor …={new}: a name of 1 to {SENSOR_ID_BYTES} bytes, without a slash"
                ),
            });
        }
        self.sensor_id = new.to_owned();
        self.renamed = Some(new.to_owned());
        Ok(())
    }

    /// `--scale-factor K` (raw output per °/s): one channel's data take it as their channel's; a
    /// unit's channels give theirs in its file (or are in a physical unit), and it is refused
    /// there, as a scale factor that is not a finite non-zero number is.
    pub fn take_scale_factor(&mut self, k: Option<f64>) -> Result<(), ChannelsError> {
        let invalid = |why: String| ChannelsError::Invalid {
            path: self.path.clone(),
            why,
        };
        match k {
            Some(k) if !(k.is_finite() && k != 0.0) => Err(invalid(format!(
                "--scale-factor {k}: a scale factor is a finite non-zero number"
            ))),
            Some(_) if !self.single => Err(invalid(
                "--scale-factor is for one channel: a unit's channels give theirs in its \
                 channels file, or are in a physical unit"
                    .to_owned(),
            )),
            _ => {
                if self.single {
                    self.list[0].scale_factor = k;
                }
                Ok(())
            }
        }
    }

    /// How the lines about channel `k` name it: by its name, or (one channel's CSV, a unit of one)
    /// not at all.
    pub fn label(&self, k: usize) -> &str {
        match self.list.get(k) {
            Some(ch) if !self.single => &ch.name,
            _ => "",
        }
    }

    /// The heading of channel `k`'s lines, `what` it is beside its name and place (`gyro.x (°/s,
    /// [1/6]):`); none for one channel's CSV ([`Self::label`]).
    pub fn heading(&self, k: usize, what: &str) -> String {
        match self.label(k) {
            "" => String::new(),
            name => format!("{name} ({what}, [{}/{}]):", k + 1, self.len()),
        }
    }

    /// `result`, its error naming channel `k` ([`Self::label`]: not for one channel's CSV).
    pub fn in_channel<T>(&self, k: usize, result: anyhow::Result<T>) -> anyhow::Result<T> {
        match self.label(k) {
            "" => result,
            label => anyhow::Context::with_context(result, || format!("channel {label}")),
        }
    }

    /// Number of channels.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// True when there are none (never, once loaded).
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// The maps that read channel `k` of a file as a single channel's file: the shared ones (the
    /// file's temperature, and for a log its time; then the command's `--map`s), its output as
    /// `voltage_v` and its reference as `rate_dps`. A `--map` of what the file gives is refused.
    /// A rate table keeps its own time (`--map time_s=…`, for a table recorded in time order).
    pub fn maps(
        &self,
        k: usize,
        maps: &[ColumnMap],
        read: Read,
    ) -> Result<Vec<ColumnMap>, ChannelsError> {
        if self.single {
            return Ok(maps.to_vec());
        }
        let mut out = self.shared_maps(maps, read)?;
        if let Some(ch) = self.list.get(k) {
            out.push(ColumnMap {
                name: "voltage_v".to_owned(),
                source: ch.output.clone(),
            });
            out.push(ColumnMap {
                name: "rate_dps".to_owned(),
                source: ch.reference.clone(),
            });
        }
        Ok(out)
    }

    /// The maps the channels share: the file's time (for a log) and temperature, and the
    /// command's `--map`s (of neither a channel's output nor its reference, which the file gives).
    fn shared_maps(&self, maps: &[ColumnMap], read: Read) -> Result<Vec<ColumnMap>, ChannelsError> {
        let mut out = Vec::new();
        let time = match read {
            Read::Log => &self.time,
            Read::Table => &None,
        };
        for (name, given) in [("time_s", time), ("temp_c", &self.temperature)] {
            if let Some(source) = given {
                out.push(ColumnMap {
                    name: name.to_owned(),
                    source: source.clone(),
                });
            }
        }
        for m in maps {
            let by_file = out.iter().any(|o| o.name == m.name)
                || m.name == "voltage_v"
                || m.name == "rate_dps";
            if by_file {
                return Err(ChannelsError::Invalid {
                    path: self.path.clone(),
                    why: format!(
                        "--map {}=… is given by the channels file: each channel's output and \
                         reference{} are there",
                        m.name,
                        if m.name == "time_s" || m.name == "temp_c" {
                            ", and the unit's time and temperature"
                        } else {
                            ""
                        }
                    ),
                });
            }
            out.push(m.clone());
        }
        Ok(out)
    }

    /// Reads a unit's log in one pass: one stream per channel (its output as `voltage_v`, its
    /// reference as `rate_dps`), the time checked once and the minutes where the unit was handled
    /// found on any channel and left out of every channel.
    pub fn load_log(&self, path: &Path, maps: &[ColumnMap]) -> anyhow::Result<Vec<Stream>> {
        if self.single {
            return Ok(vec![Stream::load(path, maps)?]);
        }
        if let Some(sensor) = &self.recorded {
            anyhow::ensure!(
                maps.is_empty(),
                "{}: --map renames a CSV's columns; a flight controller's log names its own",
                path.display()
            );
            if path == self.path {
                return Ok(sensor.streams(&self.references()));
            }
            // Another log of the same board (a held-out power-on): its own instance of the same
            // name, the same device where both say which.
            let other = Recorded::read(path, &mut |_, _| {})?.ok_or_else(|| {
                anyhow::anyhow!(
                    "{}: a CSV, where {}'s sensor {} is held out from a flight controller's log",
                    path.display(),
                    self.path.display(),
                    sensor.name
                )
            })?;
            let [unit] = <[Channels; 1]>::try_from(Self::of_log(
                &other,
                std::slice::from_ref(&sensor.name),
            )?)
            .map_err(|_| anyhow::anyhow!("one sensor asked, one returned"))?;
            let theirs = unit.recorded.as_ref().map(|s| s.device_id);
            anyhow::ensure!(
                theirs.flatten().is_none()
                    || sensor.device_id.is_none()
                    || theirs == Some(sensor.device_id),
                "{}: its {} is device {}, {}'s is device {}: another sensor",
                path.display(),
                sensor.name,
                theirs.flatten().unwrap_or_default(),
                self.path.display(),
                sensor.device_id.unwrap_or_default()
            );
            return unit.load_log(path, maps);
        }
        let mut all = self.shared_maps(maps, Read::Log)?;
        let names: Vec<(String, String)> = (0..self.len())
            .map(|k| (format!("output:{k}"), format!("reference:{k}")))
            .collect();
        for (ch, (out, reference)) in self.list.iter().zip(&names) {
            all.push(ColumnMap {
                name: out.clone(),
                source: ch.output.clone(),
            });
            all.push(ColumnMap {
                name: reference.clone(),
                source: ch.reference.clone(),
            });
        }
        let mut numeric: Vec<&str> = vec!["time_s", "temp_c"];
        for (o, r) in &names {
            numeric.push(o);
            numeric.push(r);
        }
        let nullable: Vec<&str> = names.iter().map(|(_, r)| r.as_str()).collect();
        let c = columns::read_columns(path, &numeric, &nullable, &[], &all)
            .map_err(|e| self.named(e))?;
        let time_s = c.get("time_s").to_vec();
        let (step_s, time_issues) = stream::time_checks(&time_s, &c.lines);
        let mut data: Vec<(Vec<f64>, Vec<f64>)> = names
            .iter()
            .map(|(o, r)| (c.get(o).to_vec(), c.get(r).to_vec()))
            .collect();
        let handled = stream::screen_unit_handling(&time_s, &mut data, &c.lines);
        let temp_c = c.get("temp_c").to_vec();
        Ok(data
            .into_iter()
            .map(|(voltage_v, rate_dps)| Stream {
                time_s: time_s.clone(),
                temp_c: temp_c.clone(),
                voltage_v,
                rate_dps,
                lines: c.lines.clone(),
                step_s,
                time_issues: time_issues.clone(),
                handled: handled.clone(),
                history: 0,
                after_s: None,
            })
            .collect())
    }

    /// Each channel's reference where it is a constant (NaN where it is a column).
    fn references(&self) -> Vec<f64> {
        self.list
            .iter()
            .map(|ch| match ch.reference {
                ColumnSource::Constant(r) => r,
                ColumnSource::Column { .. } => f64::NAN,
            })
            .collect()
    }

    /// A loader's error, a missing column named by the channel whose file names it.
    fn named(&self, e: DataError) -> anyhow::Error {
        let DataError::MissingColumn {
            path,
            column,
            available,
        } = &e
        else {
            return e.into();
        };
        let uses =
            |s: &ColumnSource| matches!(s, ColumnSource::Column { name, .. } if name == column);
        let by = self.list.iter().find_map(|ch| {
            if uses(&ch.output) {
                Some(format!("channel {}'s output", ch.name))
            } else if uses(&ch.reference) {
                Some(format!("channel {}'s reference", ch.name))
            } else {
                None
            }
        });
        let by = by.or_else(|| {
            [("time", &self.time), ("temperature", &self.temperature)]
                .into_iter()
                .find(|(_, s)| s.as_ref().is_some_and(uses))
                .map(|(what, _)| format!("the unit's {what}"))
        });
        match by {
            Some(by) => anyhow::anyhow!(
                "{}: missing column '{column}' (header has: {available}), {by} in {}",
                path.display(),
                self.path.display()
            ),
            None => e.into(),
        }
    }
}

#[cfg(test)]
mod tests;
