//! Where a static model's points come from: a rate table (other power-ons' tables pooled with it),
//! a stream's 60 s block means, or, pooled, every sample of the streams. The command line reads
//! its flags into a [`PointFiles`]; a unit's channel gets its own ([`PointFiles::for_channel`]), so that
//! every channel is fitted as one channel is.

use std::path::{Path, PathBuf};

use anyhow::Context;
use firmware_core::Quantity;
use fog_data::channels::{Channels, Read};
use fog_data::columns::ColumnMap;
use fog_data::stream::Stream;

use crate::data::points::{Points, Screen};
use crate::progress::Messages;

/// The files and settings a static model's points are read with.
#[derive(Clone, Debug)]
pub struct PointFiles {
    /// The rate table; without it the points come from the streams.
    pub points: Option<PathBuf>,
    /// Other power-ons' rate tables of the same sensor, pooled with `points`, each a run.
    pub runs: Vec<PathBuf>,
    /// Column maps onto the canonical columns.
    pub maps: Vec<ColumnMap>,
    /// Nominal scale factor, output units per °/s: the bias is learned from temperature alone.
    pub scale_factor: Option<f64>,
    /// Implausible rate-table rows left out with a warning, rather than the file refused.
    pub exclude_implausible: bool,
    /// The rate table's groups, a column (default: temperature plateaus).
    pub group: Option<String>,
    /// What the output measures.
    pub quantity: Quantity,
}

impl PointFiles {
    /// The source of channel `k` of `channels` (of a unit of one CSV channel, this one), as if it
    /// were a single channel's: its columns
    /// mapped onto the canonical ones (a rate table read as a table), and its scale factor (the
    /// one it gives; without a rate table, 1 for an output in a physical unit: a bias model).
    pub fn for_channel(&self, channels: &Channels, k: usize) -> anyhow::Result<Self> {
        if channels.single {
            // A CSV of one channel is read by the command's own flags.
            return Ok(self.clone());
        }
        anyhow::ensure!(
            self.scale_factor.is_none(),
            "--scale-factor is for one channel: a unit's channels give theirs in {} \
             (scale_factor, or an output in a physical unit)",
            channels.path.display()
        );
        let ch = &channels.list[k];
        let scale_factor = match &self.points {
            Some(_) => ch.scale_factor,
            None => ch.bias_scale_factor(),
        };
        Ok(Self {
            maps: channels.maps(k, &self.maps, Read::Table)?,
            scale_factor,
            quantity: ch.quantity,
            ..self.clone()
        })
    }

    /// The points of the static model: the rate table when given, else the streams' block means;
    /// with `pool`, every sample of the streams as well.
    pub fn static_points(
        &self,
        streams: &[(&Path, Stream)],
        pool: bool,
        messages: &dyn Messages,
    ) -> anyhow::Result<Points> {
        let mut out = match &self.points {
            Some(path) => Some(load_runs(
                path,
                &self.runs,
                &self.maps,
                (self.group.as_deref(), self.scale_factor),
                self.exclude_implausible,
                messages,
            )?),
            None => None,
        };
        if !pool && let Some(points) = out {
            return Ok(points.measuring(self.quantity));
        }
        for (path, s) in streams {
            let more = if pool {
                Points::from_stream_samples(path, s, self.scale_factor)?
            } else {
                Points::from_stream(path, s, self.scale_factor)?
            };
            out = Some(match out {
                Some(p) => p.pooled(more)?,
                None => more,
            });
        }
        out.map(|p| p.measuring(self.quantity))
            .context("give --points (a rate table) or --stream to fit on")
    }
}

/// Loads rate-table points; with `exclude`, implausible rows are left out with a warning each
/// rather than refused.
pub fn load_points(
    path: &Path,
    maps: &[ColumnMap],
    (group, scale_factor): (Option<&str>, Option<f64>),
    exclude: bool,
    messages: &dyn Messages,
) -> anyhow::Result<Points> {
    let screen = if exclude {
        Screen::Exclude
    } else {
        Screen::Refuse
    };
    let (points, left_out) = Points::load_screened(path, maps, group, scale_factor, screen)?;
    for row in &left_out {
        messages.warn(&format!(
            "{} {row}: left out (--exclude-implausible)",
            path.display()
        ));
    }
    Ok(points)
}

/// Loads the rate table at `first` and those of other power-ons, `runs`, pooled: each file a run
/// ([`Points::run`]). With runs, each keeps its groups apart: its file's name, or the `group`
/// column's labels within it.
pub fn load_runs(
    first: &Path,
    runs: &[PathBuf],
    maps: &[ColumnMap],
    (group, scale_factor): (Option<&str>, Option<f64>),
    exclude: bool,
    messages: &dyn Messages,
) -> anyhow::Result<Points> {
    let load = |path: &Path| load_points(path, maps, (group, scale_factor), exclude, messages);
    let mut out = load(first)?;
    if runs.is_empty() {
        return Ok(out);
    }
    let named = |mut points: Points, path: &Path| {
        let name = path.display().to_string();
        for g in &mut points.group {
            *g = match group {
                Some(_) => format!("{name}: {g}"),
                None => name.clone(),
            };
        }
        points
    };
    out = named(out, first);
    for path in runs {
        out = out.pooled(named(load(path)?, path))?;
    }
    Ok(out)
}
