//! A flight controller's log holds several sensors, and a command that takes each runs once per
//! sensor: its files one per sensor beside the names given, its lines under the sensor's heading,
//! its errors prefixed by the sensor. The commands that take a blob take one per sensor, each
//! matched to the sensor it names. One place for these rules, so every command follows them alike.

use std::path::{Path, PathBuf};

use anyhow::Context;
use fog_data::channels::Channels;
use fog_terminal::console::Console;
use fog_terminal::log::unit_of_blob;

use super::fit::params::beside;

/// How a command names what it does for each of the units it runs on: by the sensor, where there
/// are several.
pub(super) struct Each {
    several: bool,
}

impl Each {
    /// For `units` units read from `stream`; refused where `json` is stdout and there are several
    /// (one JSON each).
    pub(super) fn new(units: usize, stream: &Path, json: Option<&Path>) -> anyhow::Result<Self> {
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
    pub(super) fn file(&self, unit: &Channels, path: &Path) -> PathBuf {
        match unit.unit_name().filter(|_| self.several) {
            Some(n) => beside(path, n),
            None => path.to_owned(),
        }
    }

    /// Says `unit`'s heading, where there are several.
    pub(super) fn heading(&self, unit: &Channels, console: &Console) {
        if self.several {
            console.result(&format!(
                "{} ({}):",
                unit.unit_name().unwrap_or_default(),
                unit.sensor_id
            ));
        }
    }

    /// `e`, named by `unit`'s sensor where there are several.
    pub(super) fn naming(&self, unit: &Channels, e: anyhow::Error) -> anyhow::Error {
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

/// A blob read, with the file it came from.
pub(super) struct Blob {
    /// Its file.
    pub(super) path: PathBuf,
    /// Its bytes.
    pub(super) bytes: Vec<u8>,
}

impl Blob {
    /// The blobs of `paths`, read.
    pub(super) fn read(paths: &[PathBuf]) -> anyhow::Result<Vec<Self>> {
        paths
            .iter()
            .map(|p| {
                let bytes = std::fs::read(p).with_context(|| format!("reading {}", p.display()))?;
                Ok(Self {
                    path: p.clone(),
                    bytes,
                })
            })
            .collect()
    }
}

/// Each blob with the unit of `units` (read from `stream`) it is for: a channels file's unit, or
/// the flight controller's sensor the blob names ([`unit_of_blob`]), each at most once.
pub(super) fn units_of_blobs(
    mut units: Vec<Channels>,
    blobs: Vec<Blob>,
    stream: &Path,
) -> anyhow::Result<Vec<(Channels, Blob)>> {
    if units.len() == 1 && blobs.len() == 1 && units[0].recorded.is_none() {
        return Ok(units.into_iter().zip(blobs).collect());
    }
    blobs
        .into_iter()
        .map(|blob| {
            let unit = fog_data::replay::decode_unit(&blob.bytes).with_context(|| {
                format!(
                    "decoding {} (a sensor of {} is compensated by a unit's blob, which names \
                     its sensor)",
                    blob.path.display(),
                    stream.display()
                )
            })?;
            let channels = unit_of_blob(&mut units, (&blob.path, unit.sensor_id()), stream)?;
            Ok((channels, blob))
        })
        .collect()
}
