//! Replay: every sample of a stream through firmware-core (host build) — feature pipeline, mean and
//! variance in f32, exactly as on the gyro — and the scores of the result (docs/design.md §6).
//!
//! It lives in the test bench, below the trainer: `firmware-sim replay`, the QEMU comparison and
//! the trainer's diagnosis all score a blob the same way, and none of them may depend on the models
//! under test.
//!
//! Scores, over rows with a reference rate: `rmse_dps` and `max_abs_err_dps` per sample;
//! `rmse_60s_dps` over 60 s block means of the error (blocks at least half filled), the figure that
//! does not drown in angle random walk; `coverage_2sigma`, the fraction of samples whose error lies
//! within twice the predicted standard deviation (latent variance plus the trained noise level,
//! which describes 2-min means: per 1 Hz sample the gyro's white noise is larger, so this coverage
//! is low by construction; the 60 s figure is the one to read).

use firmware_core::blob::Dims;
use firmware_core::model::Model;
use firmware_core::record;
use firmware_core::{BlobError, FeatureState, Sample, Status};
use serde::Serialize;

pub use crate::data::stream::BLOCK_S;
use crate::data::stream::{Handled, Stream, TimeIssue, group_blocks};

/// The largest model the host handles (the trainer exports no larger): 256 centres already need
/// about 132 KB of f32 on the microcontroller, the top of a Cortex-M4's RAM. The host decodes blobs
/// back into these capacities (heapless storage is inline, so they also bound the host's stack
/// use).
pub const MAX_CENTRES: usize = 256;
/// Host-side input capacity: all the evaluator accepts.
pub use firmware_core::MAX_INPUTS;
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

/// The firmware's output for every sample.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Compensated {
    /// Compensated rate, °/s.
    pub rate_dps: Vec<f32>,
    /// Predicted standard deviation, °/s (latent plus trained noise).
    pub std_dps: Vec<f32>,
    /// Status of each sample.
    pub status: Vec<Status>,
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
    let at: std::collections::HashSet<u64> = stream
        .time_issues
        .iter()
        .filter(|i| !matches!(i, TimeIssue::Duplicate { .. }))
        .map(TimeIssue::line)
        .collect();
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

/// Runs every sample through the firmware, its feature state kept through the power cycles at
/// [`restarts`] as a gyro that stores it at power-down would (`firmware_core::features`).
pub fn replay(model: &HostModel, stream: &Stream) -> Compensated {
    let mut scratch = vec![0.0f32; model.dims().m];
    let [_, noise_var] = model.variances();
    let mut state = FeatureState::default();
    let mut out = Compensated::default();
    for (i, restart) in restarts(stream).into_iter().enumerate() {
        if restart {
            state.power_on();
        }
        let sample = sample(stream, i);
        let (rate, var, status) = match model.compensate(&sample, &mut state, &mut scratch) {
            Ok(p) => (p.mean, p.variance, p.status),
            Err(_) => (0.0, f32::INFINITY, Status::Fault),
        };
        out.rate_dps.push(rate);
        out.std_dps.push((var + noise_var).sqrt());
        out.status.push(status);
    }
    out
}

/// The stream as sample records (`firmware_core::record`), [`restarts`] as power-on flags: what a
/// device replay (the Cortex-M4 image, the C program) reads.
pub fn sample_records(stream: &Stream) -> Vec<u8> {
    let mut out = Vec::with_capacity(record::SAMPLE_BYTES * stream.len());
    for (i, power_on) in restarts(stream).into_iter().enumerate() {
        out.extend(record::encode_sample(&sample(stream, i), power_on));
    }
    out
}

/// A device's result records as a replay of `blob`: standard deviations with the blob's noise
/// variance added, as [`replay`] computes them.
pub fn from_result_records(bytes: &[u8], blob: &[u8]) -> Compensated {
    let [_, noise_var] = decode(blob).map(|m| m.variances()).unwrap_or([0.0, 0.0]);
    let mut out = Compensated::default();
    for rec in bytes.chunks_exact(record::RESULT_BYTES) {
        let Ok(rec) = rec.try_into() else { continue };
        let (mean, variance, status) = record::decode_result(rec);
        out.rate_dps.push(mean);
        out.std_dps.push((variance + noise_var).sqrt());
        out.status.push(status);
    }
    out
}

/// Scores of a replay against the stream's reference (docs/design.md §6 names).
#[derive(Debug, Clone, Serialize)]
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
    /// 60 s blocks scored.
    pub n_blocks: usize,
    /// RMSE of 60 s block means over the samples inside the trained range (status valid), °/s.
    pub rmse_60s_in_range_dps: f64,
    /// 60 s blocks inside the trained range.
    pub n_blocks_in_range: usize,
    /// Samples without a reference (compensated, not scored).
    pub n_unscored: usize,
    /// Samples flagged extrapolating.
    pub n_extrapolating: usize,
    /// Samples flagged degraded (a stateful input's history not trusted: time jumps, a stuck
    /// temperature sensor).
    pub n_degraded: usize,
    /// Samples flagged fault.
    pub n_fault: usize,
    /// Time problems in the stream.
    pub time_issues: Vec<TimeIssue>,
    /// Samples in windows where the unit was handled (compensated, not scored).
    pub n_handled: usize,
    /// Those windows.
    pub handled: Vec<Handled>,
}

/// Scores `comp` against `stream`'s reference.
pub fn score(stream: &Stream, comp: &Compensated) -> Score {
    let scored: Vec<usize> = (0..stream.len())
        .filter(|&i| stream.rate_dps[i].is_finite() && comp.status[i] != Status::Fault)
        .collect();
    let err = |i: usize| f64::from(comp.rate_dps[i]) - stream.rate_dps[i];
    let n = scored.len();
    let rms = |v: &[f64]| {
        if v.is_empty() {
            f64::NAN
        } else {
            (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt()
        }
    };
    let errors: Vec<f64> = scored.iter().map(|&i| err(i)).collect();
    let covered = scored
        .iter()
        .filter(|&&i| err(i).abs() <= 2.0 * f64::from(comp.std_dps[i]))
        .count();
    let block_means = |idx: &[usize]| -> Vec<f64> {
        blocks(stream, idx)
            .iter()
            .map(|b| b.iter().map(|&i| err(i)).sum::<f64>() / b.len() as f64)
            .collect()
    };
    let means = block_means(&scored);
    let valid: Vec<usize> = scored
        .iter()
        .copied()
        .filter(|&i| comp.status[i] == Status::Valid)
        .collect();
    let means_in_range = block_means(&valid);
    Score {
        n,
        rmse_dps: rms(&errors),
        rmse_60s_dps: rms(&means),
        max_abs_err_dps: errors.iter().fold(0.0, |m, e| m.max(e.abs())),
        coverage_2sigma: if n == 0 {
            f64::NAN
        } else {
            covered as f64 / n as f64
        },
        n_blocks: means.len(),
        rmse_60s_in_range_dps: rms(&means_in_range),
        n_blocks_in_range: means_in_range.len(),
        n_unscored: stream.len() - stream.rate_dps.iter().filter(|r| r.is_finite()).count(),
        n_extrapolating: comp
            .status
            .iter()
            .filter(|s| **s == Status::Extrapolating)
            .count(),
        n_degraded: comp
            .status
            .iter()
            .filter(|s| **s == Status::Degraded)
            .count(),
        n_fault: comp.status.iter().filter(|s| **s == Status::Fault).count(),
        time_issues: stream.time_issues.clone(),
        n_handled: stream.handled.iter().map(|h| h.n).sum(),
        handled: stream.handled.clone(),
    }
}

/// The samples `scored` grouped into 60 s blocks, counted from the first sample of the stream, in
/// time order; a block counts when at least half of it is there.
pub fn blocks(stream: &Stream, scored: &[usize]) -> Vec<Vec<usize>> {
    let need = (0.5 * BLOCK_S / stream.step_s).ceil().max(1.0) as usize;
    group_blocks(&stream.time_s, scored)
        .into_iter()
        .filter(|b| b.len() >= need)
        .collect()
}

/// The compensated CSV (docs/design.md §3): the stream's canonical columns, then `comp_rate_dps`,
/// `comp_std_dps`, `status`. An unknown reference stays an empty cell.
pub fn to_csv(stream: &Stream, comp: &Compensated) -> String {
    let mut s =
        String::from("time_s,temp_c,voltage_v,rate_dps,comp_rate_dps,comp_std_dps,status\n");
    for i in 0..stream.len() {
        let reference = if stream.rate_dps[i].is_finite() {
            stream.rate_dps[i].to_string()
        } else {
            String::new()
        };
        s.push_str(&format!(
            "{},{},{},{},{:e},{:e},{}\n",
            stream.time_s[i],
            stream.temp_c[i],
            stream.voltage_v[i],
            reference,
            comp.rate_dps[i],
            comp.std_dps[i],
            status_word(comp.status[i])
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stream(rate: &[f64], step: f64) -> Stream {
        let n = rate.len();
        Stream {
            time_s: (0..n).map(|i| i as f64 * step).collect(),
            temp_c: vec![20.0; n],
            voltage_v: vec![0.0; n],
            rate_dps: rate.to_vec(),
            lines: (2..n as u64 + 2).collect(),
            step_s: step,
            time_issues: vec![],
            handled: vec![],
        }
    }

    #[test]
    fn scores_follow_their_definitions() {
        // 120 samples at 1 Hz: error +1 in the first minute, −1 in the second, one unscored row.
        let mut rate = vec![0.0; 120];
        rate[5] = f64::NAN;
        let s = stream(&rate, 1.0);
        let comp = Compensated {
            rate_dps: (0..120).map(|i| if i < 60 { 1.0 } else { -1.0 }).collect(),
            std_dps: (0..120).map(|i| if i < 30 { 1.0 } else { 0.1 }).collect(),
            status: vec![Status::Valid; 120],
        };
        let sc = score(&s, &comp);
        assert_eq!(sc.n, 119);
        assert_eq!(sc.n_unscored, 1);
        assert!((sc.rmse_dps - 1.0).abs() < 1e-12);
        assert!((sc.rmse_60s_dps - 1.0).abs() < 1e-12);
        assert_eq!(sc.n_blocks, 2);
        assert!((sc.coverage_2sigma - 29.0 / 119.0).abs() < 1e-12);
        let csv = to_csv(&s, &comp);
        assert!(csv.lines().nth(6).unwrap().starts_with("5,20,0,,"), "{csv}");
    }

    #[test]
    fn block_means_cancel_white_errors() {
        let rate = vec![0.0; 600];
        let s = stream(&rate, 1.0);
        let comp = Compensated {
            rate_dps: (0..600)
                .map(|i| if i % 2 == 0 { 0.5 } else { -0.5 })
                .collect(),
            std_dps: vec![1.0; 600],
            status: vec![Status::Valid; 600],
        };
        let sc = score(&s, &comp);
        assert!((sc.rmse_dps - 0.5).abs() < 1e-12);
        assert!(sc.rmse_60s_dps < 1e-12);
    }
}
