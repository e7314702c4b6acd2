//! A log as every command reads it, in both programs: the `--map`, `--exclude` and `--channels`
//! flags, and the loader that applies them with a `--window` and says in one line what it left
//! out (once for a unit's channels).

use std::path::{Path, PathBuf};

use clap::Args;

use crate::console::Console;
use fog_data::autopilot::{Format, Recorded, sniff};
use fog_data::channels::Channels;
use fog_data::columns::ColumnMap;
use fog_data::stream::Window;

/// The `--map` flag of every data-reading command, in both programs.
#[derive(Args, Clone, Default)]
pub struct Maps {
    /// Map a canonical column onto a source column, COLUMN*FACTOR, or a constant (repeatable).
    #[arg(long = "map", value_name = "NAME=SOURCE")]
    pub list: Vec<ColumnMap>,
}

/// The `--exclude` flag of every command that reads a log, in both programs.
#[derive(Args, Clone, Default)]
pub struct Excludes {
    /// Leave START:END out of every fit, score and Allan deviation, as a handled window is (s
    /// from the log's first sample; repeatable): a handling event the screening missed, a door
    /// opened, a cable touched.
    #[arg(long = "exclude", id = "exclude", value_name = "START:END")]
    pub list: Vec<Window>,
}

/// One log and how to read it: the flags of every command that reads one log.
#[derive(Args, Clone)]
pub struct LogArgs {
    /// Stream or static log: a CSV (time_s,temp_c,voltage_v,rate_dps; rate_dps may be empty
    /// where unknown), or a flight controller's log (PX4 ULog, ArduPilot DataFlash), told by its
    /// content.
    #[arg(long)]
    pub stream: PathBuf,
    #[command(flatten)]
    maps: Maps,
    #[command(flatten)]
    exclude: Excludes,
    /// Use only this part of the stream: START:END, s from its first sample (either end open).
    /// The samples before it are its history: the firmware's state runs through them from the
    /// power-on, as it did on the gyro, but nothing is fitted or scored on them.
    #[arg(long)]
    pub window: Option<Window>,
    /// The unit's channels, where the log holds several.
    #[command(flatten)]
    pub unit: UnitArgs,
}

/// The `--channels` and `--sensor` flags of every command that can read a whole sensor unit.
#[derive(Args, Clone, Default)]
pub struct UnitArgs {
    /// A sensor unit's channels file (TOML: each channel's output column, unit and reference; the
    /// shared time and temperature): every channel at once, each with its own model.
    #[arg(long, value_name = "FILE")]
    pub channels: Option<PathBuf>,
    /// The sensor of a flight controller's log (a PX4 ULog, an ArduPilot DataFlash log) to use:
    /// gyro0, accel1 (ULog), imu0 (DataFlash), or NAME=NEW to give it a name of your own (its
    /// files', pages' and blob's); repeatable. Each is a unit whose channels are its axes.
    /// Default: every sensor the log holds (a command that takes a blob: the sensor it names).
    #[arg(
        long = "sensor",
        value_name = "NAME[=NEW]",
        conflicts_with = "channels"
    )]
    pub sensors: Vec<String>,
}

impl UnitArgs {
    /// The units `stream` is read as: the channels file's, or the sensors of a flight
    /// controller's log (those named with `--sensor`, else all, each with a temperature); a CSV
    /// of one channel is a unit of one ([`Channels::single`]); none without a log. A flight controller's log is read once here, with a progress bar,
    /// and what a calibration must be told about it said a line each.
    pub fn units(&self, stream: Option<&Path>, console: &Console) -> anyhow::Result<Vec<Channels>> {
        if let Some(c) = &self.channels {
            return Ok(vec![Channels::load(c)?]);
        }
        let Some(stream) = stream else {
            anyhow::ensure!(
                self.sensors.is_empty(),
                "--sensor names a sensor of a flight controller's log (--stream)"
            );
            return Ok(Vec::new());
        };
        if sniff(stream)? == Format::Csv {
            anyhow::ensure!(
                self.sensors.is_empty(),
                "{}: --sensor names a sensor of a flight controller's log (a PX4 ULog, an \
                 ArduPilot DataFlash log); this is a CSV (--channels names a CSV's unit)",
                stream.display()
            );
            return Ok(vec![Channels::single(stream)]);
        }
        let bar = console.bar(0);
        let log = Recorded::read(stream, &mut |at, total| {
            bar.set_length(total);
            bar.set_position(at);
        })?;
        bar.finish_and_clear();
        let Some(log) = log else {
            return Ok(Vec::new());
        };
        for note in log.notes() {
            console.warn(&note);
        }
        let (names, new): (Vec<String>, Vec<Option<&str>>) = self
            .sensors
            .iter()
            .map(|s| match s.split_once('=') {
                Some((name, new)) => (name.to_owned(), Some(new)),
                None => (s.clone(), None),
            })
            .unzip();
        let mut units = Channels::of_log(&log, &names)?;
        for (unit, new) in units.iter_mut().zip(new) {
            if let Some(new) = new {
                unit.rename(new)?;
            }
        }
        let (with, without): (Vec<Channels>, Vec<Channels>) = units
            .into_iter()
            .partition(|u| u.recorded.as_ref().is_some_and(|s| !s.temp_c.is_empty()));
        if !without.is_empty() {
            let names: Vec<&str> = without.iter().filter_map(Channels::unit_name).collect();
            anyhow::ensure!(
                !with.is_empty(),
                "{}: no sensor with a temperature ({}): nothing to calibrate",
                stream.display(),
                names.join(", ")
            );
            console.warn(&format!(
                "{}: skipped {} (no temperature)",
                stream.display(),
                names.join(", ")
            ));
        }
        Ok(with)
    }

    /// The one unit of `stream` that the blob `blob` (of sensor `sensor_id`) compensates: a
    /// channels file's, or the flight controller's sensor the blob names ([`unit_of_blob`]).
    /// A CSV of one channel is a unit of one ([`Channels::single`]).
    pub fn load_for(
        &self,
        stream: &Path,
        (blob, sensor_id): (&Path, &str),
        console: &Console,
    ) -> anyhow::Result<Channels> {
        let mut units = self.units(Some(stream), console)?;
        if let [unit] = units.as_slice()
            && unit.recorded.is_none()
        {
            return Ok(unit.clone());
        }
        unit_of_blob(&mut units, (blob, sensor_id), stream)
    }
}

/// Takes out of `units` (read from `stream`) the one a blob (`blob`, of sensor `sensor_id`)
/// compensates: the one whose sensor ID it names (`trainer fit` writes a sensor's ID into its
/// blob). Refused where none is, with the sensors there are.
pub fn unit_of_blob(
    units: &mut Vec<Channels>,
    (blob, sensor_id): (&Path, &str),
    stream: &Path,
) -> anyhow::Result<Channels> {
    match units.iter().position(|u| u.sensor_id == sensor_id) {
        Some(k) => Ok(units.remove(k)),
        None if units.is_empty() => anyhow::bail!(
            "{}: a blob of sensor \"{sensor_id}\", and every sensor of {} read already has its \
             blob (one blob per sensor)",
            blob.display(),
            stream.display()
        ),
        None => anyhow::bail!(
            "{}: a blob of sensor \"{sensor_id}\", which is not among {}'s sensors left to pair \
             (one blob per sensor): {}",
            blob.display(),
            stream.display(),
            units
                .iter()
                .map(|u| u.sensor_id.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

impl LogArgs {
    /// The log of the unit `channels` names, one stream per channel ([`load_unit_log`]).
    pub fn load_unit(
        &self,
        channels: &Channels,
        console: &Console,
    ) -> anyhow::Result<Vec<fog_data::stream::Stream>> {
        load_unit_log(
            &self.stream,
            channels,
            &self.maps.list,
            (self.window, &self.exclude.list),
            console,
        )
    }
}

/// Loads a unit's log as the commands read it ([`Channels::load_log`]: one stream per channel,
/// the time and handling checked once; one channel's CSV is a unit of one): `exclude` left out
/// (s from its first sample), then the part inside `window` kept. The windows left out (the
/// handled ones the loader found and those named) are said in one line, each under
/// `--verbose`; the time problems a line each.
pub fn load_unit_log(
    path: &std::path::Path,
    channels: &Channels,
    maps: &[ColumnMap],
    (window, exclude): (Option<Window>, &[Window]),
    console: &Console,
) -> anyhow::Result<Vec<fog_data::stream::Stream>> {
    let streams = cut(path, channels.load_log(path, maps)?, (window, exclude))?;
    if let Some(first) = streams.first() {
        say(path, first, console);
    }
    Ok(streams)
}

/// The streams (one log's channels, sharing its time) with `exclude` left out and the part inside
/// `window` kept.
fn cut(
    path: &std::path::Path,
    streams: Vec<fog_data::stream::Stream>,
    (window, exclude): (Option<Window>, &[Window]),
) -> anyhow::Result<Vec<fog_data::stream::Stream>> {
    streams
        .into_iter()
        .map(|mut s| {
            s.exclude(exclude)?;
            Ok(match window {
                Some(w) => {
                    let part = s.window(w);
                    anyhow::ensure!(
                        part.inside().len() >= 2,
                        "{}: the window {w} s holds {} samples",
                        path.display(),
                        part.inside().len()
                    );
                    part
                }
                None => s,
            })
        })
        .collect()
}

/// Says what the loader found in a log: its time problems and the windows left out.
fn say(path: &std::path::Path, s: &fog_data::stream::Stream, console: &Console) {
    if s.time_issues.len() <= 3 {
        for issue in &s.time_issues {
            console.warn(&format!("{} {issue}", path.display()));
        }
    } else {
        console.warn(&format!(
            "{}: {} time problems (jumps, steps back, repeated stamps), the first {} (each with -v)",
            path.display(),
            s.time_issues.len(),
            s.time_issues[0]
        ));
        for issue in &s.time_issues {
            console.detail(&format!("{} {issue}", path.display()));
        }
    }
    if let Some(line) = fog_data::stream::left_out_summary(&s.handled) {
        console.warn(&format!("{}: {line}", path.display()));
    }
    for h in &s.handled {
        console.detail(&format!("{} {h}", path.display()));
    }
}

/// A flight controller's log holds several sensors, and a command that takes each runs once per
/// sensor: its files one per sensor beside the names given, its lines under the sensor's heading,
/// its errors prefixed by the sensor. One definition, so every command of both programs names
/// them alike.
pub struct Each {
    several: bool,
}

impl Each {
    /// For `units` units read from `stream`; refused where `json` is stdout and there are several
    /// (one JSON each).
    pub fn new(units: usize, stream: &Path, json: Option<&Path>) -> anyhow::Result<Self> {
        let several = units > 1;
        anyhow::ensure!(
            !several || json != Some(Path::new("-")),
            "--json - writes one JSON and {} holds {} sensors: name a file (one per sensor is \
             written beside it), or choose one with --sensor",
            stream.display(),
            units
        );
        Ok(Self { several })
    }

    /// Where `unit`'s copy of the file `path` goes: beside it, named by the sensor, where there
    /// are several; `path` itself otherwise.
    pub fn file(&self, unit: &Channels, path: &Path) -> PathBuf {
        match unit.unit_name().filter(|_| self.several) {
            Some(n) => beside(path, n),
            None => path.to_owned(),
        }
    }

    /// Says `unit`'s heading, where there are several.
    pub fn heading(&self, unit: &Channels, console: &Console) {
        if self.several {
            console.result(&format!(
                "{} ({}):",
                unit.unit_name().unwrap_or_default(),
                unit.sensor_id
            ));
        }
    }

    /// `e`, named by `unit`'s sensor where there are several.
    pub fn naming(&self, unit: &Channels, e: anyhow::Error) -> anyhow::Error {
        if self.several {
            e.context(format!(
                "sensor {}",
                unit.unit_name().unwrap_or(&unit.sensor_id)
            ))
        } else {
            e
        }
    }
}

/// `path` with `name` before its extension: a unit's file among several (`imu.bin` → `imu.gyro0.bin`).
pub fn beside(path: &Path, name: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let file = match path.extension() {
        Some(ext) => format!("{stem}.{name}.{}", ext.to_string_lossy()),
        None => format!("{stem}.{name}"),
    };
    path.with_file_name(file)
}
