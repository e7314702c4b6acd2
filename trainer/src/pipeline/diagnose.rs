//! `trainer diagnose` as a library pipeline: a blob replayed on a log, and the cause of each
//! channel's residual named ([`unit()`]: a unit's blob on its channels' streams; one channel's
//! blob is a unit of one). Reading the blob and the log, and writing what comes back, are the
//! caller's.

use anyhow::Context;
use firmware_core::unit::SINGLE_CHANNEL;
use fog_data::channels::{Channel, Channels};
use fog_data::stream::Stream;
use serde::Serialize;

use crate::analysis::diagnose::{self, Diagnosis};
use crate::firmware::unit;
use crate::pipeline::ChannelEntry;
use crate::pipeline::text::render_diagnosis;
use crate::progress::Messages;

/// One channel's diagnosis, as a unit's JSON holds it (under its [`ChannelEntry`]).
#[derive(Serialize, schemars::JsonSchema)]
pub struct Diagnosed {
    /// The diagnosis, its figures in the channel's unit.
    pub diagnosis: Diagnosis,
}

/// Each channel of the unit blob `blob` (or one channel's blob, a unit of one) diagnosed on its stream of `streams` (in the order of
/// `channels`, whose log they were read from), in the blob's order, each said under its name. A
/// channel of the blob that `channels` does not hold is refused.
pub fn unit<'c>(
    blob: &[u8],
    (channels, streams): (&'c Channels, &[Stream]),
    messages: &dyn Messages,
) -> anyhow::Result<Vec<(&'c Channel, Diagnosed)>> {
    let mut out = Vec::new();
    let blobs = unit::channel_blobs(blob)?;
    let one = match (blobs.as_slice(), channels.list.as_slice()) {
        ([(name, _, _)], [ch]) => name == SINGLE_CHANNEL || ch.name == SINGLE_CHANNEL,
        _ => false,
    };
    for (name, quantity, blob) in blobs {
        let k = channels
            .list
            .iter()
            .position(|c| one || c.name == name)
            .with_context(|| {
                format!(
                    "the blob's channel {name} is not among {}'s ({})",
                    channels.path.display(),
                    names(channels)
                )
            })?;
        let model = fog_data::replay::decode(&blob)?;
        let diagnosis = diagnose::diagnose(&model, &streams[k]).in_quantity(quantity);
        let label = channels.label(k);
        let heading = if label.is_empty() {
            String::new()
        } else {
            format!("{label}:")
        };
        messages
            .channel(label, &heading)
            .result(render_diagnosis(&diagnosis).trim_end());
        out.push((&channels.list[k], Diagnosed { diagnosis }));
    }
    Ok(out)
}

/// A unit's diagnoses as its JSON lists them.
pub fn entries<'a>(each: &'a [(&'a Channel, Diagnosed)]) -> Vec<ChannelEntry<'a, Diagnosed>> {
    each.iter().map(|(c, d)| ChannelEntry::new(c, d)).collect()
}

/// The channels' names, comma-separated.
fn names(channels: &Channels) -> String {
    channels
        .list
        .iter()
        .map(|c| c.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}
