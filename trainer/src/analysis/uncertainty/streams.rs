//! The residuals of a stream: a model fitted on part of a log and replayed through the firmware's
//! own evaluation on the rest, with the covariates the error model grows by (the hours since the
//! data it saw, the heating/cooling state); and what a model's errors over a log show: one
//! sample's noise, and the bias's random walk (over the whole log, or the part a split's model
//! did not see).

use firmware_core::ErrorModel;
use firmware_core::units::SECONDS_PER_HOUR;
use fog_data::replay::{self, HostModel};
use fog_data::stream::Stream;

use super::terms::MOVES;
use super::{Residual, ResidualSource, SampleNoise, Series};
use crate::firmware::export::{self, ExportError};

/// The residuals of a model fitted on part of `stream` and scored on another: the 60 s means of
/// the samples with a reference in `stream` (the whole stream is replayed, so the stateful inputs
/// keep their history), each with the blob's latent variance, e(x)² and `hours[i]` (time since
/// the data it was fitted on) of its samples. `blob` is the model as exported, before any error
/// model; the latent variance and e(x)² come from the firmware's own evaluation of it.
pub fn stream_series(
    source: ResidualSource,
    blob: &[u8],
    stream: &Stream,
    hours: &[f64],
    noise: SampleNoise,
) -> Result<Series, ExportError> {
    // The latent variance from the firmware's own evaluation, and e(x)² from its mean path, as
    // the firmware computes it before the extrapolation term multiplies it.
    let model = replay::decode(&export::with_error_model(
        blob,
        &ErrorModel::noise_only(0.0),
    )?)?;
    let wanted: Vec<bool> = (0..stream.len())
        .map(|i| stream.rate_dps[i].is_finite() && hours[i].is_finite())
        .collect();
    let (means, latent) = replay::replay_where(&model, stream, &wanted);
    let excess2 = means.excess2;
    let scored: Vec<usize> = (0..stream.len())
        .filter(|&i| wanted[i] && latent.status[i] != firmware_core::Status::Fault)
        .collect();
    let mean = |b: &[usize], f: &dyn Fn(usize) -> f64| {
        b.iter().map(|&i| f(i)).sum::<f64>() / b.len() as f64
    };
    let residuals = stream
        .half_filled_blocks(&scored)
        .iter()
        .map(|b| {
            let latent_var = mean(b, &|i| f64::from(latent.bias_var[i]));
            Residual {
                error: mean(b, &|i| f64::from(latent.rate_dps[i]) - stream.rate_dps[i]),
                base_var: latent_var + noise.of_mean(b.len() as f64 * stream.step_s),
                excess2: mean(b, &|i| f64::from(excess2[i])).max(0.0),
                output2: mean(b, &|i| stream.rate_dps[i].powi(2)),
                output: mean(b, &|i| stream.rate_dps[i]),
                hours: mean(b, &|i| hours[i]),
            }
        })
        .collect();
    Ok(Series { source, residuals })
}

/// One sample's white noise in `model`'s errors over `streams`, each replayed whole through the
/// firmware's evaluation ([`SampleNoise::from_streams`]); `None` where they hold too few
/// consecutive samples.
pub fn sample_noise(model: &HostModel, streams: &[&Stream]) -> Option<SampleNoise> {
    let errors: Vec<Vec<f64>> = streams.iter().map(|s| errors(model, s)).collect();
    let parts: Vec<(&Stream, &[f64])> = streams
        .iter()
        .zip(&errors)
        .map(|(s, e)| (*s, e.as_slice()))
        .collect();
    SampleNoise::from_streams(&parts)
}

/// The bias's random walk a model leaves on `stream`, output units² per hour, from its `errors`
/// there ([`errors`]; NaN where not scored): the rate random walk K of their Allan deviation
/// (IEEE 952's +½ slope after the bottom, over the stretches without a gap, a NaN or a power
/// cycle), K² per hour; 0 where the stretches are too short to show a slope +½, or where the
/// reference does not hold still as a log at rest does. It reads the walk at every lag up to a
/// third of a stretch at once, where a forward split's fit scores one path of it: on 24 fits of
/// the simulated room logs (one half of a three-day static log each) the split's walk was 0 on 7
/// and up to 4.7× the simulator's on others. `investigate::calibrate` reads it on the shipped
/// model's errors over the whole log, and ([`part_walk`]) on the forward split's model's over
/// the part that model was not fitted on, out of sample: in sample, a model fitted on the log
/// takes part of the walk up (docs/uncertainty.md, "The walk from the Allan deviation").
pub fn allan_walk(stream: &Stream, mut e: Vec<f64>, noise_std: f64) -> f64 {
    if !holds_still(&stream.rate_dps, noise_std) {
        return 0.0;
    }
    // A power-on starts a stretch of its own, where the clock jumps back as where it leaves a
    // gap: another power-on's bias is a step, whose Allan deviation rises as a walk's does.
    for (e, restart) in e.iter_mut().zip(replay::restarts(stream)) {
        if restart {
            *e = f64::NAN;
        }
    }
    rate_random_walk(&stream.time_s, &e)
}

/// [`allan_walk`] of `errors` over `part`, a part of `train` (its reference NaN elsewhere, as a
/// forward split's scored stream): read only where the whole of `train`'s reference holds
/// still, as [`allan_walk`] asks of the log it reads; a log that rests only in its later part
/// moved where its models were fitted.
pub fn part_walk(train: &Stream, part: &Stream, errors: Vec<f64>, noise_std: f64) -> f64 {
    if !holds_still(&train.rate_dps, noise_std) {
        return 0.0;
    }
    allan_walk(part, errors, noise_std)
}

/// Whose errors a walk was read on, by their Allan deviation ([`allan_walk`], [`part_walk`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum WalkReading {
    /// The calibrated model's, over the whole training log: in sample, where the model was fitted
    /// on that log and its fit may have taken part of the walk up; out of sample for a rate
    /// table's static model beside a stream, which never saw the stream.
    WholeLog,
    /// The forward split's model's, over the part of the log it was not fitted on.
    ForwardSplit,
}

/// Whether a log's `reference` holds still, as a log at rest does: its spread under ten times
/// `noise_std` (one sample's noise), as the outputs that do not move ([`MOVES`]). Where the
/// reference moves, the errors follow the rate program (a scale factor's miss at each rate, a
/// table's cycles), which the Allan deviation cannot tell from a walk: read there, it left the
/// simulated chamber, ramp and warm-up runs' σ up to 1.8, 2.2 and 2.4× wider held out. False
/// for a log without a reference, or a noise that is not a number.
pub(crate) fn holds_still(reference: &[f64], noise_std: f64) -> bool {
    let finite: Vec<f64> = reference
        .iter()
        .copied()
        .filter(|r| r.is_finite())
        .collect();
    let n = finite.len() as f64;
    let mean = finite.iter().sum::<f64>() / n;
    let spread = (finite.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
    spread <= MOVES * noise_std
}

/// [`allan_walk`] of `errors` (output units) sampled at `time_s` (s), a NaN error a gap.
pub(super) fn rate_random_walk(time_s: &[f64], errors: &[f64]) -> f64 {
    fog_data::allan::Analysis::of("errors", time_s, errors)
        .terms
        .rrw_deg_per_h_per_sqrt_h
        .map_or(0.0, |k| (k / SECONDS_PER_HOUR).powi(2))
}

/// `model`'s error at every sample of `stream`, replayed whole through the firmware's
/// evaluation (NaN where the stream has no reference).
pub fn errors(model: &HostModel, stream: &Stream) -> Vec<f64> {
    let c = replay::means(model, stream);
    (0..stream.len())
        .map(|i| f64::from(c.rate_dps[i]) - stream.rate_dps[i])
        .collect()
}

/// The heating/cooling state of every sample of `stream` with a reference, as the firmware tracks
/// it (`firmware_core::FeatureState::leg`), the state carried through the whole stream and its
/// power-ons ([`tracked`]), with the sample's temperature.
pub fn legs(stream: &Stream) -> Vec<(f32, f64)> {
    leg_states(stream)
        .into_iter()
        .enumerate()
        .filter_map(|(i, state)| {
            state
                .filter(|_| stream.rate_dps[i].is_finite())
                .map(|s| (s, stream.temp_c[i]))
        })
        .collect()
}

/// The heating/cooling state of every sample of `stream` as the firmware tracks it
/// (`firmware_core::FeatureState::leg`), the state carried through the whole stream and its
/// power-ons ([`tracked`]); `None` where the firmware refuses the sample.
pub fn leg_states(stream: &Stream) -> Vec<Option<f32>> {
    tracked(stream, firmware_core::FeatureState::leg)
}

/// What `read` reads of the firmware's feature state after each sample of `stream` (the
/// conditions the model error reads whatever the model's inputs), the state carried through the
/// whole stream and powered on again at each of its restarts, as every replay does
/// (`fog_data::replay::restarts`); `None` where the firmware refuses the sample.
pub fn tracked<T>(
    stream: &Stream,
    read: impl Fn(&firmware_core::FeatureState) -> T,
) -> Vec<Option<T>> {
    let mut state = firmware_core::FeatureState::default();
    replay::restarts(stream)
        .into_iter()
        .enumerate()
        .map(|(i, restart)| {
            if restart {
                state.power_on();
            }
            let sample = firmware_core::Sample {
                time_s: stream.time_s[i],
                temp_c: stream.temp_c[i] as f32,
                output: 0.0,
            };
            let health = firmware_core::features::compute(&[], &sample, &mut state, &mut []);
            (health != firmware_core::Status::Fault).then(|| read(&state))
        })
        .collect()
}

/// Hours since power-on of every sample of `stream` (a power cycle where the replay has one),
/// for a run the model never saw.
pub fn hours_on(stream: &Stream) -> Vec<f64> {
    let mut on = stream.time_s.first().copied().unwrap_or(0.0);
    replay::restarts(stream)
        .into_iter()
        .zip(&stream.time_s)
        .map(|(restart, &t)| {
            if restart {
                on = t;
            }
            (t - on).max(0.0) / SECONDS_PER_HOUR
        })
        .collect()
}

/// Hours from every sample of `stream` to the nearest of the `fitted` ones (sorted indices), NaN
/// for the fitted ones themselves: the time since (or until) the data a model saw.
pub fn hours_from(stream: &Stream, fitted: &[usize]) -> Vec<f64> {
    let mut is_fitted = vec![false; stream.len()];
    for &i in fitted {
        is_fitted[i] = true;
    }
    let times: Vec<f64> = fitted.iter().map(|&i| stream.time_s[i]).collect();
    (0..stream.len())
        .map(|i| {
            if is_fitted[i] || times.is_empty() {
                return f64::NAN;
            }
            let t = stream.time_s[i];
            let k = times.partition_point(|&x| x < t);
            let before = k.checked_sub(1).map(|j| t - times[j]);
            let after = times.get(k).map(|x| x - t);
            before
                .into_iter()
                .chain(after)
                .fold(f64::INFINITY, f64::min)
                / SECONDS_PER_HOUR
        })
        .collect()
}
