//! Replay: every sample of a stream through firmware-core (host build) — feature pipeline, mean and
//! variance in f32, exactly as on the gyro — and the scores of the result (docs/design.md §6).
//!
//! It lives in the test bench, below the trainer: `firmware-sim replay`, the QEMU comparison and
//! the trainer's diagnosis all score a blob the same way, and none of them may depend on the models
//! under test.
//!
//! Scores, over rows with a reference rate: `rmse_dps` and `max_abs_err_dps` per sample;
//! `rmse_60s_dps` over 60 s block means of the error (blocks at least half filled), the figure that
//! does not drown in angle random walk; and the firmware's σ scored against the errors
//! ([`crate::sigma`]), per sample (σ² = bias + noise variance) and per 60 s mean (σ² = the block's
//! mean bias variance + the noise variance of a mean that long: docs/design.md §4, "The σ
//! contract"). `coverage_2sigma` is the per-sample fraction within 2σ.

use firmware_core::blob::Dims;
use firmware_core::model::{Conditions, Evaluation, Mean, Model, Prediction, Prepared};
use firmware_core::record;
use firmware_core::unit::SINGLE_CHANNEL;
use firmware_core::unit::{Numbers, Unit, UnitSample};
use firmware_core::{BlobError, ErrorModel, FeatureState, Sample, Status};
use serde::Serialize;

use crate::sigma::Coverage;

use crate::stats::rms;
use crate::stream::{Handled, Stream, TimeIssue};
use held_out::HeldOut;

/// The host decodes blobs into the firmware's largest capacities ([`MAX_CENTRES`] centres,
/// [`MAX_INPUTS`] inputs; heapless storage is inline, so they also bound the host's stack use).
use firmware_core::{MAX_CENTRES, MAX_INPUTS};
/// Host-side exponent capacity.
pub const MAX_EXPONENTS: usize = 8 * 165;
/// Host-side float capacity, for MAX_CENTRES centres.
pub const MAX_FLOATS: usize = Dims {
    m: MAX_CENTRES,
    d: MAX_INPUTS,
    p: 165,
}
.floats();

/// The model type the host decodes blobs into (boxed: it is large).
pub type HostModel = Model<MAX_INPUTS, MAX_EXPONENTS, MAX_FLOATS>;

/// Decodes a blob into host capacities (boxed: the capacities make the value large).
pub fn decode(bytes: &[u8]) -> Result<Box<HostModel>, BlobError> {
    HostModel::decode(bytes).map(Box::new)
}

/// Most channels the host decodes a unit into (a unit blob holds up to 255; an IMU has six).
pub const MAX_CHANNELS: usize = 32;

/// The host's storage of a unit's numbers: a growable vector, where a microcontroller declares a
/// fixed one (`heapless::Vec`), so that a unit of any size decodes on the host without a
/// megabyte-sized value on the stack.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct HostNumbers(Vec<f32>);

impl Numbers for HostNumbers {
    const CAPACITY: usize = usize::MAX;

    fn clear(&mut self) {
        self.0.clear();
    }

    fn push(&mut self, v: f32) -> bool {
        self.0.push(v);
        true
    }

    fn as_slice(&self) -> &[f32] {
        &self.0
    }
}

/// The unit type the host decodes unit blobs (and model blobs, as one channel) into.
pub type HostUnit = Unit<MAX_CHANNELS, MAX_INPUTS, MAX_EXPONENTS, HostNumbers>;

/// Decodes a unit blob, or a model blob as a unit of one channel, into host capacities.
pub fn decode_unit(bytes: &[u8]) -> Result<Box<HostUnit>, BlobError> {
    let mut unit = Box::new(HostUnit::with_numbers(HostNumbers::default()));
    unit.decode_into(bytes)?;
    Ok(unit)
}

/// Samples a replay prepares before it evaluates them, [`firmware_core::model::LANES`] side by
/// side: a few batches of lanes, so that the prepared inputs stay in the processor's cache.
const BATCH: usize = 64;

/// The firmware's output for every sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Compensated {
    /// Compensated rate, °/s.
    pub rate_dps: Vec<f32>,
    /// Bias variance (°/s)²: latent plus model error.
    pub bias_var: Vec<f32>,
    /// Noise variance of the sample (°/s)².
    pub noise_var: Vec<f32>,
    /// Status of each sample.
    pub status: Vec<Status>,
    /// The blob's error model: how the noise of a mean shrinks.
    pub error: ErrorModel,
}

impl Default for Compensated {
    fn default() -> Self {
        Self {
            rate_dps: Vec::new(),
            bias_var: Vec::new(),
            noise_var: Vec::new(),
            status: Vec::new(),
            error: ErrorModel::noise_only(0.0),
        }
    }
}

impl Compensated {
    /// Standard deviation of sample `i`'s error, °/s: bias and noise.
    pub fn std_dps(&self, i: usize) -> f64 {
        (f64::from(self.bias_var[i]) + f64::from(self.noise_var[i])).sqrt()
    }

    /// Standard deviation of the mean of samples `idx` spanning `window_s`, °/s: their mean bias
    /// variance and the noise variance of a mean that long.
    pub fn mean_std_dps(&self, idx: &[usize], window_s: f64) -> f64 {
        let bias = idx
            .iter()
            .map(|&i| f64::from(self.bias_var[i]))
            .sum::<f64>()
            / idx.len().max(1) as f64;
        (bias + f64::from(self.error.noise_of_mean(window_s as f32))).sqrt()
    }

    fn push(&mut self, p: &Prediction) {
        self.rate_dps.push(p.mean);
        self.bias_var.push(p.bias_variance);
        self.noise_var.push(p.noise_variance);
        self.status.push(p.status);
    }

    /// Sample `i`'s prediction.
    fn set(&mut self, i: usize, p: &Prediction) {
        self.rate_dps[i] = p.mean;
        self.bias_var[i] = p.bias_variance;
        self.noise_var[i] = p.noise_variance;
        self.status[i] = p.status;
    }
}

/// Word for a status in the compensated CSV (docs/design.md §3).
pub fn status_word(s: Status) -> &'static str {
    match s {
        Status::Valid => "ok",
        Status::Extrapolating => "extrapolating",
        Status::Degraded => "degraded",
        Status::Fault => "fault",
    }
}

/// Per sample: whether the gyro was powered on there (time jumps back or leaves a gap: a power
/// cycle, or a reset the firmware would make). The feature state goes through
/// [`FeatureState::power_on`] there: kept through the time off where the clock ran on, started
/// afresh where it jumped back.
pub fn restarts(stream: &Stream) -> Vec<bool> {
    let at = stream.restart_lines();
    stream.lines.iter().map(|l| at.contains(l)).collect()
}

/// Sample `i` as the firmware sees it.
pub fn sample(stream: &Stream, i: usize) -> Sample {
    Sample {
        time_s: stream.time_s[i],
        temp_c: stream.temp_c[i] as f32,
        output: stream.voltage_v[i] as f32,
    }
}

/// Walks `stream` sample by sample with one feature state, powered on again at each of its
/// [`restarts`] as a gyro that stores the state at power-down would (`firmware_core::features`):
/// the loop every replay of one model shares. With `calibration_run`, the samples of the power-on
/// the model was calibrated on are marked so ([`FeatureState::calibration_run`], [`HeldOut`]).
fn walk(
    stream: &Stream,
    calibration_run: bool,
    mut each: impl FnMut(usize, &Sample, &mut FeatureState, &HeldOut),
) {
    let mut state = FeatureState::default();
    let restarts = restarts(stream);
    let held_out = HeldOut::new(stream, &restarts, calibration_run);
    for (i, restart) in restarts.into_iter().enumerate() {
        if restart {
            state.power_on();
        }
        if held_out.begins_at(i) {
            state.calibration_run();
        }
        each(i, &sample(stream, i), &mut state, &held_out);
    }
}

/// Runs every sample through the firmware, its feature state kept through the power cycles at
/// [`restarts`] as a gyro that stores it at power-down would (`firmware_core::features`): as in
/// service, every sample of another power-on than the calibration's.
pub fn replay(model: &HostModel, stream: &Stream) -> Compensated {
    replay_run(model, stream, false)
}

/// [`replay`], where with `calibration_run` the stream is the power-on the model was calibrated on
/// (the held-out part of its own log): in that power-on (a whole log's first; a window's first and
/// last, beside the rest of the log taken for the calibration's data) the σ leaves out another
/// power-on's bias and scale, as [`replay_unit`]'s `calibration_run` does.
pub fn replay_run(model: &HostModel, stream: &Stream, calibration_run: bool) -> Compensated {
    evaluate_where(model, stream, &vec![true; stream.len()], calibration_run).1
}

/// Every sample of a unit's `streams` (one per channel, in the unit's channel order, sharing
/// their time and temperature: [`crate::channels::Channels::load_log`]) through the unit in
/// one call each, its one feature state kept through the power cycles as [`replay`] keeps a
/// model's; one replay per channel. With `calibration_run`, the stream is of the power-on the
/// model was calibrated on where [`replay_run`] says ([`FeatureState::calibration_run`]).
pub fn replay_unit(
    unit: &HostUnit,
    streams: &[&Stream],
    calibration_run: bool,
) -> Vec<Compensated> {
    let c = unit.channels().len();
    let mut out: Vec<Compensated> = unit
        .channels()
        .iter()
        .map(|ch| Compensated {
            error: ch.error_model(),
            ..Compensated::default()
        })
        .collect();
    let Some(first) = streams.first() else {
        return out;
    };
    let mut scratch = vec![0.0f32; unit.evaluate_scratch_len()];
    // Each channel's samples wait to be evaluated side by side ([`HostUnit::evaluate`]); a
    // sample the unit refused (fewer outputs than channels) is a `Fault` with mean 0 and an
    // infinite variance in every channel, as is one the evaluation refused (a scratch too short:
    // never the one sized here).
    let mut one = vec![Prepared::inputs(&[], Conditions::at_hours(0.0)); c];
    let mut pending: Vec<Vec<Prepared<MAX_INPUTS>>> = vec![Vec::with_capacity(BATCH); c];
    let mut refused = Vec::with_capacity(BATCH);
    let mut outputs = vec![0.0f32; streams.len()];
    let mut evaluations = vec![Evaluation::NONE; BATCH];
    let mut flush = |pending: &mut Vec<Vec<Prepared<MAX_INPUTS>>>,
                     refused: &mut Vec<bool>,
                     out: &mut Vec<Compensated>| {
        for (k, (o, prepared)) in out.iter_mut().zip(pending.iter_mut()).enumerate() {
            let evaluations = &mut evaluations[..prepared.len()];
            let evaluated = unit.evaluate(k, prepared, &mut scratch, evaluations);
            let mut done = evaluations.iter();
            for &refused in refused.iter() {
                let e = match (refused, evaluated) {
                    (false, Some(Ok(()))) => done.next(),
                    _ => None,
                };
                o.push(&e.unwrap_or(&Evaluation::NONE).prediction);
            }
            prepared.clear();
        }
        refused.clear();
    };
    walk(first, calibration_run, |i, sample, state, held_out| {
        for (o, s) in outputs.iter_mut().zip(streams) {
            *o = s.voltage_v[i] as f32;
        }
        let sample = UnitSample {
            time_s: sample.time_s,
            temp_c: sample.temp_c,
            outputs: &outputs,
        };
        let prepared = unit.prepare(&sample, state, &mut one).is_ok();
        if prepared {
            let hours = held_out.hours(first, i, state);
            for (p, one) in pending.iter_mut().zip(&one) {
                let mut one = *one;
                if let Some(h) = hours {
                    one.hours_since_data(h);
                }
                p.push(one);
            }
        }
        refused.push(!prepared);
        if refused.len() == BATCH {
            flush(&mut pending, &mut refused, &mut out);
        }
    });
    flush(&mut pending, &mut refused, &mut out);
    out
}

/// The streams of a unit's log (`names`: the channels file's, in its order) in the order of the
/// unit's channels, matched by name; a blob of one channel takes a log of one channel where
/// either is one channel's data (named [`SINGLE_CHANNEL`]).
pub fn in_unit_order<'a>(
    unit: &HostUnit,
    names: &[&str],
    streams: &'a [Stream],
) -> Result<Vec<&'a Stream>, String> {
    let ours = unit.channels();
    if let ([only], [stream], [name]) = (ours, streams, names)
        && (only.name() == SINGLE_CHANNEL || *name == SINGLE_CHANNEL)
    {
        return Ok(vec![stream]);
    }
    ours.iter()
        .map(|ch| {
            names
                .iter()
                .position(|n| *n == ch.name())
                .and_then(|k| streams.get(k))
                .ok_or_else(|| {
                    format!(
                        "the blob's channel {} is not among the log's ({})",
                        ch.name(),
                        names.join(", ")
                    )
                })
        })
        .collect()
}

/// One channel's scores, as the commands that replay a unit write them in their JSON: its values
/// (`_dps` fields included) are in its quantity's unit, `units`.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct ChannelScore {
    /// The channel's name.
    pub name: String,
    /// What it measures.
    pub quantity: firmware_core::Quantity,
    /// The unit of its values: °/s or m/s².
    pub units: &'static str,
    /// Its scores.
    #[serde(flatten)]
    pub score: Score,
}

/// The scores of every channel of a unit's replay (`comps`, in the unit's order, of `streams`).
pub fn unit_scores(
    unit: &HostUnit,
    streams: &[&Stream],
    comps: &[Compensated],
) -> Vec<ChannelScore> {
    unit.channels()
        .iter()
        .zip(streams)
        .zip(comps)
        .map(|((ch, s), c)| ChannelScore {
            name: ch.name().to_owned(),
            quantity: ch.quantity(),
            units: ch.quantity().unit(),
            score: score(s, c),
        })
        .collect()
}

/// A unit's compensated CSV (docs/design.md §3), the window's samples (not the history before
/// it, [`Stream::history`]): time and temperature, then each channel's
/// output and reference (empty where unknown), `comp_rate_dps`, `comp_std_dps` (the sample's σ:
/// bias and noise), `status` and `comp_bias_std_dps` (the bias part alone, which a mean keeps),
/// its values in its quantity's unit. Where the unit has several channels, each column is
/// prefixed by its channel's name (`gyro.x.comp_rate_dps`); one channel's are the canonical
/// names (`voltage_v`, `rate_dps`, `comp_rate_dps`, …).
pub fn unit_csv(unit: &HostUnit, streams: &[&Stream], comps: &[Compensated]) -> String {
    let names: Vec<&str> = unit.channels().iter().map(|c| c.name()).collect();
    let mut s = String::from("time_s,temp_c");
    for n in &names {
        for col in [
            "voltage_v",
            "rate_dps",
            "comp_rate_dps",
            "comp_std_dps",
            "status",
            "comp_bias_std_dps",
        ] {
            if names.len() == 1 {
                s.push_str(&format!(",{col}"));
            } else {
                s.push_str(&format!(",{n}.{col}"));
            }
        }
    }
    s.push('\n');
    let Some(first) = streams.first() else {
        return s;
    };
    for i in first.inside() {
        s.push_str(&format!("{},{}", first.time_s[i], first.temp_c[i]));
        for (st, comp) in streams.iter().zip(comps) {
            s.push(',');
            s.push_str(&csv_cells(st, comp, i));
        }
        s.push('\n');
    }
    s
}

/// Row `i`'s cells after time and temperature: output, reference (empty where unknown), and the
/// compensated value, σ, status and bias σ.
fn csv_cells(stream: &Stream, comp: &Compensated, i: usize) -> String {
    let reference = if stream.rate_dps[i].is_finite() {
        stream.rate_dps[i].to_string()
    } else {
        String::new()
    };
    format!(
        "{},{},{:e},{:e},{},{:e}",
        stream.voltage_v[i],
        reference,
        comp.rate_dps[i],
        comp.std_dps(i) as f32,
        status_word(comp.status[i]),
        comp.bias_var[i].sqrt()
    )
}

/// A replay's means alone ([`means`]): the cheap path where no variance is read.
#[derive(Debug, Clone, Default)]
pub struct Means {
    /// Compensated rate, °/s: as [`replay`] gives it.
    pub rate_dps: Vec<f32>,
    /// Status of each sample: as [`replay`] gives it.
    pub status: Vec<Status>,
    /// e(x)² of each sample ([`firmware_core::Model::compensate_mean`]).
    pub excess2: Vec<f32>,
}

impl Means {
    fn set(&mut self, i: usize, m: Mean, excess2: f32) {
        self.rate_dps[i] = m.mean;
        self.status[i] = m.status;
        self.excess2[i] = excess2;
    }
}

/// Every sample of `stream` through `model`'s mean alone: the rates and statuses of [`replay`]
/// at a fraction of its cost (the variance is O(m²) per sample, the mean O(m·d)).
pub fn means(model: &HostModel, stream: &Stream) -> Means {
    replay_where(model, stream, &[]).0
}

/// [`means`] at every sample and [`replay`] where `wanted` marks one, in one pass: the
/// variance is O(m²) per sample, so a caller that reads it on part of a stream pays for that part
/// alone. The feature state runs through every sample as in [`replay`], so each marked sample's
/// prediction is the one [`replay`] gives; elsewhere the returned replay holds the mean path's
/// rate and status with NaN variances.
pub fn replay_where(model: &HostModel, stream: &Stream, wanted: &[bool]) -> (Means, Compensated) {
    evaluate_where(model, stream, wanted, false)
}

/// [`replay_where`], the stream of the calibration's own power-on with `calibration_run`
/// ([`replay_run`]).
fn evaluate_where(
    model: &HostModel,
    stream: &Stream,
    wanted: &[bool],
    calibration_run: bool,
) -> (Means, Compensated) {
    let n = stream.len();
    let mut means = Means {
        rate_dps: vec![0.0; n],
        status: vec![Status::Fault; n],
        excess2: vec![0.0; n],
    };
    let mut full = Compensated {
        rate_dps: vec![0.0; n],
        bias_var: vec![f32::NAN; n],
        noise_var: vec![f32::NAN; n],
        status: vec![Status::Fault; n],
        error: model.error_model(),
    };
    // The samples wait to be evaluated side by side, the marked ones in full
    // ([`HostModel::evaluate`]), the others on the mean path ([`HostModel::means`]).
    let mut scratch = vec![0.0f32; model.evaluate_scratch_len()];
    let mut pending: [(Vec<usize>, Vec<Prepared<MAX_INPUTS>>); 2] = Default::default();
    let mut evaluations = Vec::with_capacity(BATCH);
    let mut mean_paths = Vec::with_capacity(BATCH);
    let mut flush = |pending: &mut [(Vec<usize>, Vec<Prepared<MAX_INPUTS>>); 2],
                     means: &mut Means,
                     full: &mut Compensated| {
        let [(mean_at, mean_batch), (full_at, full_batch)] = pending;
        mean_paths.resize(mean_batch.len(), (Mean::FAULT, 0.0));
        model.means(mean_batch, &mut mean_paths);
        for (&i, &(m, excess2)) in mean_at.iter().zip(&mean_paths) {
            full.rate_dps[i] = m.mean;
            full.status[i] = m.status;
            means.set(i, m, excess2);
        }
        evaluations.resize(full_batch.len(), Evaluation::NONE);
        let evaluated = model.evaluate(full_batch, &mut scratch, &mut evaluations);
        for ((&i, p), e) in full_at.iter().zip(full_batch.iter()).zip(&evaluations) {
            if evaluated.is_ok() {
                full.set(i, &e.prediction);
                means.set(i, e.mean, e.excess2);
            } else {
                // A scratch too short (never the one sized here): no prediction.
                full.set(i, &Evaluation::NONE.prediction);
                let (m, excess2) = model.mean_of(p);
                means.set(i, m, excess2);
            }
        }
        for (at, batch) in pending.iter_mut() {
            at.clear();
            batch.clear();
        }
    };
    walk(stream, calibration_run, |i, sample, state, held_out| {
        let (at, batch) = &mut pending[usize::from(wanted.get(i).copied().unwrap_or(false))];
        at.push(i);
        let mut prepared = model.prepare(sample, state);
        if let Some(h) = held_out.hours(stream, i, state) {
            prepared.hours_since_data(h);
        }
        batch.push(prepared);
        if batch.len() == BATCH {
            flush(&mut pending, &mut means, &mut full);
        }
    });
    flush(&mut pending, &mut means, &mut full);
    (means, full)
}

/// A unit's `streams` as unit sample records (`firmware_core::record`: each sample's outputs in
/// channel order), [`restarts`] of the first as power-on flags: what a device replays.
pub fn unit_sample_records(streams: &[&Stream]) -> Vec<u8> {
    let Some(first) = streams.first() else {
        return Vec::new();
    };
    let len = record::unit_sample_bytes(streams.len());
    let mut out = vec![0u8; len * first.len()];
    let mut outputs = vec![0.0f32; streams.len()];
    for ((i, power_on), rec) in restarts(first)
        .into_iter()
        .enumerate()
        .zip(out.chunks_exact_mut(len))
    {
        for (o, s) in outputs.iter_mut().zip(streams) {
            *o = s.voltage_v[i] as f32;
        }
        let sample = UnitSample {
            time_s: first.time_s[i],
            temp_c: first.temp_c[i] as f32,
            outputs: &outputs,
        };
        record::encode_unit_sample(&sample, power_on, rec);
    }
    out
}

/// A device's unit result records (one per channel per sample) as one replay per channel of
/// `blob` (a unit or model blob), the noise variances the blob's.
pub fn from_unit_result_records(bytes: &[u8], blob: &[u8]) -> Vec<Compensated> {
    let errors: Vec<ErrorModel> = decode_unit(blob).map_or(Vec::new(), |u| {
        u.channels().iter().map(|c| c.error_model()).collect()
    });
    let mut out: Vec<Compensated> = errors
        .iter()
        .map(|&error| Compensated {
            error,
            ..Compensated::default()
        })
        .collect();
    let c = out.len().max(1);
    for (k, rec) in bytes.chunks_exact(record::RESULT_BYTES).enumerate() {
        let Ok(rec) = rec.try_into() else { continue };
        let (mean, variance, status) = record::decode_result(rec);
        if let Some(o) = out.get_mut(k % c) {
            o.push(&Prediction {
                mean,
                bias_variance: variance,
                noise_variance: o.error.sample_noise_var,
                status,
            });
        }
    }
    out
}

/// Scores of a replay against the stream's reference (docs/design.md §6 names).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct Score {
    /// Scored samples (those with a reference).
    pub n: usize,
    /// RMSE per sample, °/s.
    pub rmse_dps: f64,
    /// RMSE of 60 s block means, °/s.
    pub rmse_60s_dps: f64,
    /// Largest |error| per sample, °/s.
    pub max_abs_err_dps: f64,
    /// Fraction of scored samples with |error| ≤ 2σ.
    pub coverage_2sigma: f64,
    /// The firmware's σ against the errors of the scored samples.
    pub sigma_samples: Coverage,
    /// The σ of each 60 s mean against its error.
    pub sigma_60s: Coverage,
    /// 60 s blocks scored.
    pub n_blocks: usize,
    /// RMSE of 60 s block means over the samples inside the trained range (status valid), °/s.
    pub rmse_60s_in_range_dps: f64,
    /// 60 s blocks inside the trained range.
    pub n_blocks_in_range: usize,
    /// The σ of each 60 s mean of the samples inside the trained range (status valid) against
    /// its error, over the 60 s blocks at least half of whose samples are such (null where none
    /// is): a σ right on the whole can be too narrow here and too wide beyond, where the model
    /// error it assumes grows. A block counts where most of its samples lie, in both parts if
    /// they split evenly, in neither if most are degraded; the parts need not add up to
    /// `sigma_60s`.
    pub sigma_60s_in_range: Option<Coverage>,
    /// The σ of each 60 s mean of the samples beyond the trained range (status extrapolating)
    /// against its error, over the 60 s blocks at least half of whose samples are such (null
    /// where none is), as `sigma_60s_in_range` is counted.
    pub sigma_60s_beyond: Option<Coverage>,
    /// Samples without a reference (compensated, not scored), but for faults and handled
    /// windows: `n`, `n_fault`, `n_handled` and `n_unscored` add up to the window's samples.
    pub n_unscored: usize,
    /// Samples of the window flagged extrapolating, scored or not (as `n_degraded` and
    /// `n_fault` count the window's).
    pub n_extrapolating: usize,
    /// Samples flagged degraded (a stateful input's history not trusted: time jumps, a stuck
    /// temperature sensor).
    pub n_degraded: usize,
    /// Samples flagged fault.
    pub n_fault: usize,
    /// Time problems in the stream.
    pub time_issues: Vec<TimeIssue>,
    /// Samples in windows where the unit was handled (compensated, not scored), but for faults;
    /// each once, where windows overlap.
    pub n_handled: usize,
    /// Those windows.
    pub handled: Vec<Handled>,
}

impl Score {
    /// What the RMS counted and left out, in one parenthesis: every figure that scores a replay
    /// says it beside its RMS.
    pub fn counted(&self) -> String {
        // `n` counts the scored samples alone: a fault is already out of it.
        format!(
            "({} samples scored, {} extrapolating; left out: {} fault, {} handled, {} \
             without a reference)",
            self.n, self.n_extrapolating, self.n_fault, self.n_handled, self.n_unscored
        )
    }
}

/// The samples a score counts: a known reference, and no fault.
pub fn scored_samples(stream: &Stream, status: &[Status]) -> Vec<usize> {
    (0..stream.len())
        .filter(|&i| stream.rate_dps[i].is_finite() && status[i] != Status::Fault)
        .collect()
}

/// The mean error of the compensated `rate_dps` in each of `blocks` (samples of `stream`).
pub fn block_errors(stream: &Stream, rate_dps: &[f32], blocks: &[Vec<usize>]) -> Vec<f64> {
    blocks
        .iter()
        .map(|b| {
            b.iter()
                .map(|&i| f64::from(rate_dps[i]) - stream.rate_dps[i])
                .sum::<f64>()
                / b.len() as f64
        })
        .collect()
}

impl Means {
    /// The mean error of each 60 s block [`score`] counts ([`Score::n_blocks`] of them), from
    /// the means alone: what the full replay gives, without the variance it does not read.
    pub fn block_errors(&self, stream: &Stream) -> Vec<f64> {
        let blocks = stream.half_filled_blocks(&scored_samples(stream, &self.status));
        block_errors(stream, &self.rate_dps, &blocks)
    }

    /// [`Score::rmse_60s_dps`] of these means against `stream`'s reference.
    pub fn rmse_60s_dps(&self, stream: &Stream) -> f64 {
        rms(&self.block_errors(stream))
    }
}

/// Scores `comp` against `stream`'s reference.
pub fn score(stream: &Stream, comp: &Compensated) -> Score {
    let scored = scored_samples(stream, &comp.status);
    let err = |i: usize| f64::from(comp.rate_dps[i]) - stream.rate_dps[i];
    let n = scored.len();
    let errors: Vec<f64> = scored.iter().map(|&i| err(i)).collect();
    let sigmas: Vec<f64> = scored.iter().map(|&i| comp.std_dps(i)).collect();
    let sigma_samples = Coverage::of(&errors, &sigmas);
    // The 60 s blocks at least half filled with scored samples, and each block's mean error and
    // the σ the firmware states for that mean.
    let blocks = stream.half_filled_blocks(&scored);
    let block_means = |blocks: &[Vec<usize>]| {
        let sigmas: Vec<f64> = blocks
            .iter()
            .map(|b| comp.mean_std_dps(b, b.len() as f64 * stream.step_s))
            .collect();
        (block_errors(stream, &comp.rate_dps, blocks), sigmas)
    };
    let (means, mean_sigmas) = block_means(&blocks);
    // A part: the blocks at least half of whose samples are of `status`, each the mean of those
    // samples alone.
    let part = |status: Status| {
        let of_status: Vec<Vec<usize>> = blocks
            .iter()
            .filter_map(|b| {
                let of: Vec<usize> = b
                    .iter()
                    .copied()
                    .filter(|&i| comp.status[i] == status)
                    .collect();
                (!of.is_empty() && 2 * of.len() >= b.len()).then_some(of)
            })
            .collect();
        let (means, sigmas) = block_means(&of_status);
        let coverage = (!means.is_empty()).then(|| Coverage::of(&means, &sigmas));
        (means, coverage)
    };
    let (means_in_range, sigma_60s_in_range) = part(Status::Valid);
    let (_, sigma_60s_beyond) = part(Status::Extrapolating);
    // The counts are the window's: the history before it is replayed, not scored. Each sample
    // left out is counted once: a fault, else one in a handled window, else one without a
    // reference.
    let inside = stream.inside();
    let flagged = |status: Status| inside.clone().filter(|&i| comp.status[i] == status).count();
    let in_window = stream.handled_rows();
    let fault = |i: usize| comp.status[i] == Status::Fault;
    // A handled row has no reference left, whatever window it was found in.
    let handled = |i: usize| in_window[i] && !stream.rate_dps[i].is_finite() && !fault(i);
    Score {
        n,
        rmse_dps: rms(&errors),
        rmse_60s_dps: rms(&means),
        max_abs_err_dps: errors.iter().fold(0.0, |m, e| m.max(e.abs())),
        coverage_2sigma: sigma_samples.within_2sigma,
        sigma_samples,
        sigma_60s: Coverage::of(&means, &mean_sigmas),
        n_blocks: means.len(),
        rmse_60s_in_range_dps: rms(&means_in_range),
        n_blocks_in_range: means_in_range.len(),
        sigma_60s_in_range,
        sigma_60s_beyond,
        n_unscored: inside
            .clone()
            .filter(|&i| !stream.rate_dps[i].is_finite() && !fault(i) && !handled(i))
            .count(),
        n_extrapolating: flagged(Status::Extrapolating),
        n_degraded: flagged(Status::Degraded),
        n_fault: flagged(Status::Fault),
        time_issues: stream
            .time_issues
            .iter()
            .filter(|t| stream.lines[inside.clone()].contains(&t.line()))
            .cloned()
            .collect(),
        n_handled: inside.clone().filter(|&i| handled(i)).count(),
        handled: stream.handled.clone(),
    }
}

/// Why most of a replay came out `Degraded`, where the stream says: samples further apart than the
/// firmware's time jump (a clock in milliseconds read as seconds shows every step as a jump).
/// `None` where fewer than half are degraded or the steps are not the reason.
pub fn degraded_reason(stream: &Stream, score: &Score) -> Option<String> {
    use firmware_core::features::{JUMP_MIN_S, JUMP_STEPS};
    (2 * score.n_degraded > stream.inside().len() && stream.step_s > JUMP_MIN_S).then(|| {
        format!(
            "{} of {} samples degraded: they are {} s apart, and the firmware takes any step over \
             {JUMP_MIN_S} s (and {JUMP_STEPS} regular steps) for a time jump, after which its \
             filters settle; is the time in other units than seconds (milliseconds: --map \
             time_s=COLUMN*0.001)?",
            score.n_degraded,
            stream.inside().len(),
            stream.step_s
        )
    })
}

mod held_out;
#[cfg(test)]
mod tests;
