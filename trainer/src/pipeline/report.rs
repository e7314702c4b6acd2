//! `trainer report` as a library pipeline: the analyses a report page shows, on each channel of a
//! unit ([`ReportPlan::unit`]; one channel's data is a unit of one): on a rate table alone, or on
//! a log's training and held-out parts, with the autopilots' cubic held out beside each channel
//! in a physical unit. Reading the files, splitting off the held-out part and writing the pages
//! are the caller's.

use std::path::Path;

use fog_data::channels::{Channels, Datasheet};
use fog_data::stream::Stream;

use crate::analysis::autopilot;
use crate::data::summary::Summary;
use crate::firmware::autopilot::SensorCubics;
use crate::models::gp::GpConfig;
use crate::pipeline::fit::unit_cubics;
use crate::pipeline::source::PointFiles;
use crate::progress::Messages;
use crate::report::unit::ChannelSection;
use crate::report::{self, Report, ReportKind};

/// `trainer report`'s settings, checked once by whoever built them.
#[derive(Clone, Debug)]
pub struct ReportPlan {
    /// Where the static model's points come from.
    pub source: PointFiles,
    /// The GP's settings.
    pub gp: GpConfig,
    /// A datasheet's figures for the blobs' σ, the command's (each channel's own in its
    /// `[[channel]]` before them).
    pub sheet: Datasheet,
}

/// A log's parts as the caller read them: the training log's file, whether the held-out part is
/// a log of its own (else the training log's later part), the parts (one stream, or one per
/// channel of a unit) and what is held out, in words.
pub struct Held<'a, T> {
    /// The training log's file.
    pub path: &'a Path,
    /// The held-out part is a log of its own.
    pub own_log: bool,
    /// The part fitted.
    pub train: T,
    /// The part held out.
    pub valid: T,
    /// What is held out, in words.
    pub said: String,
}

impl ReportPlan {
    /// Each channel of `channels` analysed as one channel's data are (its files as loaded from
    /// `summaries`, one list per channel), with the autopilots' cubic held out beside it (a
    /// channel in a physical unit, where a part is held out); and, where `params` asks, the
    /// autopilots' cubics fitted on the training part.
    pub fn unit<'c>(
        &self,
        (channels, summaries): (&'c Channels, Vec<Vec<Summary>>),
        held: Option<&Held<'_, Vec<Stream>>>,
        params: bool,
        messages: &dyn Messages,
    ) -> anyhow::Result<(Vec<ChannelSection<'c>>, Option<SensorCubics>)> {
        let mut pages = Vec::new();
        let mut summaries = summaries.into_iter();
        for (k, ch) in channels.list.iter().enumerate() {
            let messages = messages.channel(channels.label(k), "");
            let own = self.source.for_channel(channels, k)?;
            let files = summaries.next().unwrap_or_default();
            let report = match held {
                None => table(&own, files, &self.gp, &*messages)?,
                Some(h) => {
                    let (kind, named) = kind_and_source(own.points.as_deref(), h.path, h.own_log);
                    let parts = (h.path, &h.train[k], h.valid[k].clone(), h.said.clone());
                    let fitting = (&self.gp, &ch.datasheet.or(self.sheet));
                    logs(&own, (named, kind), files, parts, fitting, &*messages)?
                }
            };
            let cubic = match held {
                Some(h) if ch.unit.factor().is_some() => {
                    match autopilot::held_out(&h.train[k], &h.valid[k]) {
                        Ok(c) => Some(c),
                        Err(e) => {
                            messages.warn(&format!("no cubic to compare: {e}"));
                            None
                        }
                    }
                }
                _ => None,
            };
            pages.push(ChannelSection {
                name: &ch.name,
                quantity: ch.quantity,
                report,
                cubic,
            });
        }
        let cubics = match held {
            Some(h) if params => Some(unit_cubics(channels, h.train.iter().map(std::iter::once))?),
            _ => None,
        };
        Ok((pages, cubics))
    }
}

/// The report on `source`'s rate table alone.
fn table(
    source: &PointFiles,
    summaries: Vec<Summary>,
    gp: &GpConfig,
    messages: &dyn Messages,
) -> anyhow::Result<Report> {
    let points = source.static_points(&[], false, messages)?;
    let progress = messages.counted();
    let table = source.points.clone().unwrap_or_default();
    report::table(&table, summaries, points, gp, &*progress)
}

/// The report on a log's parts, the static points from `source` (its rate table, or the
/// training part's block means), its blobs' σ stating what the channel's `sheet` states.
fn logs(
    source: &PointFiles,
    (named, kind): (std::path::PathBuf, ReportKind),
    summaries: Vec<Summary>,
    (path, train, valid, said): (&Path, &Stream, Stream, String),
    (gp, sheet): (&GpConfig, &Datasheet),
    messages: &dyn Messages,
) -> anyhow::Result<Report> {
    let points = source.static_points(&[(path, train.clone())], false, messages)?;
    let rebuild = |part: &Stream| source.static_points(&[(path, part.clone())], false, messages);
    let progress = messages.counted();
    report::with_streams(
        &named,
        kind,
        summaries,
        points,
        train,
        valid,
        said,
        (gp, &rebuild, sheet),
        &*progress,
    )
}

/// What a report on the log `path` says it is, and the file it names as its source: a table
/// beside a log, a log alone, or a training log beside a held-out log of its own.
fn kind_and_source(
    points: Option<&Path>,
    path: &Path,
    own_log: bool,
) -> (ReportKind, std::path::PathBuf) {
    match (points, own_log) {
        (_, true) => (ReportKind::Full, points.unwrap_or(path).to_path_buf()),
        (Some(p), false) => (ReportKind::TableAndStream, p.to_path_buf()),
        (None, false) => (ReportKind::Log, path.to_path_buf()),
    }
}
