//! The commands that take a blob take one per sensor of a flight controller's log, each matched
//! to the sensor it names; how each sensor's files, lines and errors are named is
//! [`fog_terminal::log::Each`]'s.

use std::path::{Path, PathBuf};

use anyhow::Context;
use fog_data::channels::Channels;
use fog_terminal::log::unit_of_blob;

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
    if let [unit] = units.as_slice()
        && unit.recorded.is_none()
    {
        let [blob] = <[Blob; 1]>::try_from(blobs).map_err(|_| {
            anyhow::anyhow!(
                "several --model take a flight controller's log, each blob for one of its \
                 sensors; {} is one unit's (a CSV, one channel or --channels)",
                stream.display()
            )
        })?;
        return Ok(vec![(unit.clone(), blob)]);
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
