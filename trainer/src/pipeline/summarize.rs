//! `trainer summarize` as a library: what a file holds as the loader sees it, before anything is
//! fitted; a unit's file (a channels file's, a flight controller's sensor) each channel's, with
//! the text that says what they share once and a line per channel.

use std::path::Path;

use firmware_core::Quantity;
use fog_data::channels::{Channels, Read};
use fog_data::columns::{ColumnMap, ColumnSource};
use serde::Serialize;

use crate::data::points::{Points, Screen};
use crate::data::summary::{self, Summary};

/// One channel of a unit's file, summarized (`summarize --json` lists one per channel of each
/// file under `files`; one channel's file is a unit of one).
#[derive(Serialize, schemars::JsonSchema)]
pub struct ChannelSummary {
    channel: String,
    quantity: Quantity,
    units: &'static str,
    /// The channel's summary, as one channel's file has it.
    #[serde(flatten)]
    pub summary: Summary,
}

/// Each channel's summary of the file at `path`, read as `read` (a log once for all channels,
/// with its time and handling checked once; a table with each channel's columns).
pub fn unit_summaries(
    path: &Path,
    channels: &Channels,
    maps: &[ColumnMap],
    read: Read,
) -> anyhow::Result<Vec<ChannelSummary>> {
    let file = path.display().to_string();
    let streams = match read {
        Read::Log => Some(channels.load_log(path, maps)?),
        Read::Table => None,
    };
    channels
        .list
        .iter()
        .enumerate()
        .map(|(k, ch)| {
            let own = channels.maps(k, maps, read)?;
            let summary = match &streams {
                Some(s) => {
                    let summary = summary::of_stream(&file, &s[k], &own);
                    match (&channels.recorded, &ch.output) {
                        (Some(sensor), ColumnSource::Column { name, .. }) => {
                            summary.recorded_from(sensor, name)
                        }
                        _ => summary,
                    }
                }
                None => {
                    let (points, left_out) =
                        Points::load_screened(path, &own, None, ch.scale_factor, Screen::Exclude)?;
                    summary::of_points(&file, &points, &own, &left_out)
                }
            };
            Ok(ChannelSummary {
                channel: ch.name.clone(),
                quantity: ch.quantity,
                units: ch.quantity.unit(),
                summary,
            })
        })
        .collect()
}

/// A unit's file as text: what the channels share once (the file's rows, time, temperature,
/// sampling and what was left out), then a line per channel; one channel's file, its summary.
pub fn unit_text(channels: &Channels, each: &[ChannelSummary]) -> String {
    let Some(first) = each.first() else {
        return String::new();
    };
    if channels.single {
        return first.summary.text();
    }
    let shared = first.summary.shared_text(&format!(
        "a unit of {} channels{}",
        channels.len(),
        if channels.sensor_id.is_empty() {
            String::new()
        } else {
            format!(", sensor '{}'", channels.sensor_id)
        }
    ));
    let mut s = shared;
    for (ch, c) in channels.list.iter().zip(each) {
        s.push_str(
            &c.summary
                .channel_text(&ch.name, &ch.unit.to_string(), ch.quantity),
        );
    }
    s
}
