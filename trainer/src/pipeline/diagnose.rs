//! `trainer diagnose` as a library pipeline: a blob replayed on a log, and the cause of each
//! channel's residual named. One channel's blob on its stream ([`one`]) or a unit's blob on its
//! channels' streams ([`unit()`]). Reading the blob and the log, and writing what comes back, are
//! the caller's.

use anyhow::Context;
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

/// The cause of the residual `blob` (one channel's) leaves on `stream`, said in full.
pub fn one(blob: &[u8], stream: &Stream, messages: &dyn Messages) -> anyhow::Result<Diagnosis> {
    let model = fog_data::replay::decode(blob)?;
    let d = diagnose::diagnose(&model, stream);
    messages.result(render_diagnosis(&d).trim_end());
    Ok(d)
}

/// Each channel of the unit blob `blob` diagnosed on its stream of `streams` (in the order of
/// `channels`, whose log they were read from), in the blob's order, each said under its name. A
/// channel of the blob that `channels` does not hold is refused.
pub fn unit<'c>(
    blob: &[u8],
    (channels, streams): (&'c Channels, &[Stream]),
    messages: &dyn Messages,
) -> anyhow::Result<Vec<(&'c Channel, Diagnosed)>> {
    let mut out = Vec::new();
    for (name, quantity, blob) in unit::channel_blobs(blob)? {
        let k = channels
            .list
            .iter()
            .position(|c| c.name == name)
            .with_context(|| {
                format!(
                    "the blob's channel {name} is not among {}'s ({})",
                    channels.path.display(),
                    names(channels)
                )
            })?;
        let model = fog_data::replay::decode(&blob)?;
        let diagnosis = diagnose::diagnose(&model, &streams[k]).in_quantity(quantity);
        messages
            .channel(&name, &format!("{name}:"))
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
