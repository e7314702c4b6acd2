//! `trainer allan` as a library pipeline: the Allan deviation of a log's output, raw (over its
//! scale factor) or compensated by a blob, less the reference where the log has one, with its
//! noise terms. One channel ([`one`]) or a unit's ([`unit()`]). Reading the log and the blob, and
//! writing or drawing what comes back, are the caller's.

use anyhow::Context;
use fog_data::allan::{self, Analysis};
use fog_data::channels::{Channel, Channels};
use fog_data::replay;
use fog_data::stream::Stream;

use crate::progress::Messages;

/// What the Allan deviation is taken of.
#[derive(Clone, Copy)]
pub enum Output<'a> {
    /// The raw output over this scale factor (output units per °/s); for a unit, each channel's
    /// own (its channels file's `scale_factor`, or 1 for an output in a physical unit).
    Raw(Option<f64>),
    /// The output as this blob compensates it, named in the figures by `label` (its file).
    Compensated {
        /// The blob: one channel's, or the unit's.
        blob: &'a [u8],
        /// How the figures name it.
        label: &'a str,
    },
}

/// One channel's Allan analysis of `stream` (read from `path`, which errors name), said in full
/// with what a quantized output adds to it.
pub fn one(
    path: &str,
    stream: &Stream,
    output: Output<'_>,
    messages: &dyn Messages,
) -> anyhow::Result<Analysis> {
    let (rate, what, k) = match output {
        Output::Compensated { blob, label } => {
            let model = replay::decode(blob)?;
            let comp = replay::means(&model, stream);
            let rate = comp.rate_dps.iter().map(|&w| f64::from(w)).collect();
            (rate, format!("the output compensated by {label}"), None)
        }
        Output::Raw(Some(k)) => {
            anyhow::ensure!(
                k.is_finite() && k != 0.0,
                "--scale-factor {k}: a scale factor is a finite non-zero number"
            );
            let rate = stream.voltage_v.iter().map(|v| v / k).collect();
            (rate, format!("output / {k}"), Some(k))
        }
        Output::Raw(None) => anyhow::bail!("give --scale-factor K or --model M"),
    };
    let analysis = analyse(path, stream, (rate, what), messages)?;
    messages.result(&analysis.text());
    quantization(stream, (k, &analysis), messages);
    Ok(analysis)
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
            // Back in the channels file's order.
            let mut by_name: Vec<Option<Vec<f64>>> = vec![None; channels.len()];
            for (ch, comp) in unit.channels().iter().zip(comps) {
                if let Some(k) = names.iter().position(|n| *n == ch.name()) {
                    by_name[k] = Some(comp.rate_dps.iter().map(|&w| f64::from(w)).collect());
                }
            }
            Some((label, by_name))
        }
        Output::Raw(_) => None,
    };
    let mut out = Vec::new();
    for (k, (ch, data)) in channels.list.iter().zip(streams).enumerate() {
        let rate = match &compensated {
            Some((label, by_name)) => by_name[k]
                .clone()
                .map(|r| (r, format!("{} compensated by {label}", ch.name))),
            None => ch.bias_scale_factor().map(|s| {
                (
                    data.voltage_v.iter().map(|v| v / s).collect(),
                    format!("{} raw", ch.name),
                )
            }),
        };
        let Some(rate) = rate else {
            messages.result(&format!(
                "{}: skipped: {}",
                ch.name,
                if compensated.is_some() {
                    "the blob has no such channel"
                } else {
                    "a raw output without a scale_factor in the channels file"
                }
            ));
            continue;
        };
        let analysis =
            analyse(path, data, rate, messages).with_context(|| format!("channel {}", ch.name))?;
        messages.result(&format!("{}: {}", ch.name, analysis.text_in(ch.quantity)));
        out.push((ch, analysis));
    }
    Ok(out)
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
    let referenced = data.rate_dps.iter().any(|r| r.is_finite());
    let left_out = data.rate_dps.iter().filter(|r| !r.is_finite()).count();
    if referenced && left_out > 0 {
        messages.result(&format!(
            "left out of the Allan deviation: the {left_out} samples without a reference (the \
             windows above); it is computed over the stretches between them"
        ));
    }
    let analysis = Analysis::less_reference(&what, &data.time_s, &rate, &data.rate_dps);
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
