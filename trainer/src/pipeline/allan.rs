//! `trainer allan` as a library pipeline: the Allan deviation of a log's output, raw (over its
//! scale factor) or compensated by a blob, less the reference where the log has one, with its
//! noise terms, every channel of a unit ([`unit()`]; one channel is a unit of one). Reading the log
//! and the blob, and writing or drawing what comes back, are the caller's.

use anyhow::Context;
use fog_data::allan::{self, Analysis};
use fog_data::channels::{Channel, Channels};
use fog_data::replay;
use fog_data::stream::Stream;

use crate::progress::Messages;

/// What the Allan deviation is taken of.
#[derive(Clone, Copy)]
pub enum Output<'a> {
    /// The raw output over each channel's own scale factor (its channels file's `scale_factor`,
    /// `--scale-factor` for one channel, or 1 for an output in a physical unit).
    Raw,
    /// The output as this blob compensates it, named in the figures by `label` (its file).
    Compensated {
        /// The blob: one channel's, or the unit's.
        blob: &'a [u8],
        /// How the figures name it.
        label: &'a str,
    },
}

/// Every channel of a unit's log (`streams`, in the order of `channels`), raw or compensated by
/// the unit's blob, each said on a line under its name; a channel that cannot be (a raw output
/// without a scale factor, a channel the blob lacks) is skipped with the reason said.
pub fn unit<'c>(
    path: &str,
    (channels, streams): (&'c Channels, &[Stream]),
    output: Output<'_>,
    messages: &dyn Messages,
) -> anyhow::Result<Vec<(&'c Channel, Analysis)>> {
    let compensated = match output {
        Output::Compensated { blob, label } => {
            let unit = replay::decode_unit(blob)?;
            let names: Vec<&str> = channels.list.iter().map(|c| c.name.as_str()).collect();
            let ordered = replay::in_unit_order(&unit, &names, streams)
                .map_err(|e| anyhow::anyhow!("{label}: {e}"))?;
            let comps = replay::replay_unit(&unit, &ordered, false);
            // Back in the channels file's order: each replay is of one of `streams`.
            let mut by_name: Vec<Option<Vec<f64>>> = vec![None; channels.len()];
            for (stream, comp) in ordered.iter().zip(comps) {
                if let Some(k) = streams.iter().position(|s| std::ptr::eq(s, *stream)) {
                    by_name[k] = Some(comp.rate_dps.iter().map(|&w| f64::from(w)).collect());
                }
            }
            Some((label, by_name))
        }
        Output::Raw => None,
    };
    let mut out = Vec::new();
    for (k, (ch, data)) in channels.list.iter().zip(streams).enumerate() {
        let rate = match &compensated {
            Some((label, by_name)) => by_name[k]
                .clone()
                .map(|r| (r, format!("{} compensated by {label}", named(channels, k)))),
            None => ch.bias_scale_factor().map(|s| {
                let what = match channels.label(k) {
                    "" => format!("output / {s}"),
                    name => format!("{name} raw"),
                };
                (data.voltage_v.iter().map(|v| v / s).collect(), what)
            }),
        };
        let Some(rate) = rate else {
            messages.result(&format!(
                "{}: skipped: {}",
                ch.name,
                if compensated.is_some() {
                    "the blob has no such channel"
                } else {
                    "a raw output without a scale factor (a channels file's scale_factor, or \
                     --scale-factor for one channel)"
                }
            ));
            continue;
        };
        let analysis = channels.in_channel(k, analyse(path, data, rate, messages))?;
        let text = analysis.text_in(ch.quantity);
        messages.result(&match channels.label(k) {
            "" => text,
            label => format!("{label}: {text}"),
        });
        let raw_scale = compensated
            .is_none()
            .then(|| ch.bias_scale_factor())
            .flatten();
        quantization(data, (raw_scale, &analysis), messages);
        out.push((ch, analysis));
    }
    Ok(out)
}

/// How channel `k` is named in what its analysis is of: by its name, or (one channel's data)
/// as the output.
fn named(channels: &Channels, k: usize) -> &str {
    match channels.label(k) {
        "" => "the output",
        name => name,
    }
}

/// The Allan analysis of `rate` (and what it is, in words) of a log, less the reference where the
/// log has one: the samples without (handled windows, the windows `--exclude` names) are left out
/// of the clusters, not fed in raw.
fn analyse(
    path: &str,
    data: &Stream,
    (rate, what): (Vec<f64>, String),
    messages: &dyn Messages,
) -> anyhow::Result<Analysis> {
    // The window's samples: the history before it is no part of the analysis.
    let w = data.inside();
    let reference = &data.rate_dps[w.clone()];
    let referenced = reference.iter().any(|r| r.is_finite());
    let left_out = reference.iter().filter(|r| !r.is_finite()).count();
    if referenced && left_out > 0 {
        messages.result(&format!(
            "left out of the Allan deviation: the {left_out} samples without a reference (the \
             windows above); it is computed over the stretches between them"
        ));
    }
    let analysis = Analysis::less_reference(&what, &data.time_s[w.clone()], &rate[w], reference);
    analysis.enough().with_context(|| path.to_owned())?;
    Ok(analysis)
}

/// What the quantizer of a log's output adds to its white noise, where the output moves in whole
/// steps: how much of the measured term is the quantizer's, with the scale factor `k` that makes
/// it a rate (where the output is raw).
fn quantization(data: &Stream, (k, analysis): (Option<f64>, &Analysis), messages: &dyn Messages) {
    let Some(step) = fog_data::stats::quantization_step(&data.voltage_v) else {
        return;
    };
    match (k, analysis.terms.arw_deg_per_sqrt_h) {
        (Some(k), Some(arw)) => {
            let q = allan::quantization_arw(step / k.abs(), analysis.tau0_s);
            if q >= 0.3 * arw {
                messages.warn(&format!(
                    "the output is quantized in steps of {step:e} (a logger that keeps every \
                     n-th raw sample rather than averaging): the steps alone make a random walk \
                     of {q:.4}, {:.0}% of the {arw:.4} measured, which is the quantizer's as \
                     much as the sensor's",
                    100.0 * q / arw
                ));
            }
        }
        _ => messages.warn(&format!(
            "the output is quantized in steps of {step:e}: the quantizer adds white noise of \
             step/√12 per sample to the random walk"
        )),
    }
}
