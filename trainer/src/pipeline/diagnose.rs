//! `trainer diagnose` as a library pipeline: a blob replayed on a log, and the cause of each
//! channel's residual named ([`unit()`]: a unit's blob on its channels' streams; one channel's
//! blob is a unit of one). Reading the blob and the log, and writing what comes back, are the
//! caller's.

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

/// Each channel of the unit blob `blob` (or one channel's blob, a unit of one) diagnosed on its stream of `streams` (in the order of
/// `channels`, whose log they were read from), in the blob's order, each said under its name. A
/// channel of the blob that `channels` does not hold is refused.
pub fn unit<'c>(
    blob: &[u8],
    (channels, streams): (&'c Channels, &[Stream]),
    messages: &dyn Messages,
) -> anyhow::Result<Vec<(&'c Channel, Diagnosed)>> {
    let names: Vec<&str> = channels.list.iter().map(|c| c.name.as_str()).collect();
    let decoded = fog_data::replay::decode_unit(blob)?;
    // Matched as every replay matches a blob's channels to a log's (one to one channel's data).
    let ordered = fog_data::replay::in_unit_order(&decoded, &names, streams)
        .map_err(|e| anyhow::anyhow!("{}: {e}", channels.path.display()))?;
    let mut out = Vec::new();
    for ((name, quantity, blob), stream) in unit::channel_blobs(blob)?.into_iter().zip(ordered) {
        let k = streams
            .iter()
            .position(|s| std::ptr::eq(s, stream))
            .with_context(|| format!("the blob's channel {name}: its stream"))?;
        let model = fog_data::replay::decode(&blob)?;
        let diagnosis = diagnose::diagnose(&model, stream).in_quantity(quantity);
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
