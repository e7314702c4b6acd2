//! Several samples' means and variances side by side, for a host that replays a stream.
//!
//! A sample's mean and variance are chains of dependent compensated additions, m for the kernel
//! terms of the mean and m(m+1)/2 for the variance's forward substitution: one sample at a time, a
//! processor mostly waits for each addition's result (the variance alone was 42 % of an
//! investigation's time on the host, measured with `perf` on `trainer challenge --kind single`).
//! [`LANES`] samples side by side take the same operations in the same order, each on its own
//! numbers, so every one is bit for bit what `mean_into`, `mean_with` and
//! [`Evaluator::predict_in`] give it, while the compiler packs the lanes into vector registers.
//! Only a scratch too short differs: it refuses the whole batch, where a sample alone that the
//! feature pipeline called a `Fault` needs none. A gyro evaluates the one sample that has just
//! arrived, so its firmware never calls this (and its image does not contain it).

use super::evaluate::{Accumulator, Conditions, Evaluator, Mean, Prediction};
use crate::blob::Dims;
use crate::error::PredictError;
use crate::status::Status;

/// Samples side by side: two SSE registers of f32, one AVX or two NEON ones.
pub const LANES: usize = 8;

/// One sample to evaluate: the model's inputs, their health and the conditions the model error
/// reads; from the feature pipeline ([`crate::Model::prepare`]) or given ([`Prepared::inputs`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prepared<const D: usize> {
    /// The inputs, in the order of the model's features.
    pub(crate) x: [f32; D],
    /// Inputs given, of `x`.
    pub(crate) len: usize,
    /// The feature pipeline's status (`Valid` for inputs given).
    pub(crate) health: Status,
    /// What the model error reads besides the inputs.
    pub(crate) at: Conditions,
}

impl<const D: usize> Prepared<D> {
    /// Inputs `x` as they are, in the conditions `at`: what [`crate::Model::predict_in`]
    /// evaluates (a model reads at most `D` inputs, so any past `D` are left out).
    pub fn inputs(x: &[f32], at: Conditions) -> Self {
        Self::judged(x, Status::Valid, at)
    }

    /// The time the model error's time terms read, h: a host that replays a held-out part of the
    /// calibration's own power-on counts them from the calibration's data, as the trainer fitted
    /// them (the hours since the data a model saw), where the firmware counts them from the
    /// power-on. The firmware in service never calls this.
    pub fn hours_since_data(&mut self, hours: f32) {
        self.at.hours = hours;
    }

    /// Inputs `x` whose health the feature pipeline judged `health`, in the conditions `at`.
    pub(crate) fn judged(x: &[f32], health: Status, at: Conditions) -> Self {
        let mut kept = [0.0; D];
        for (k, v) in kept.iter_mut().zip(x) {
            *k = *v;
        }
        Self {
            x: kept,
            len: x.len().min(D),
            health,
            at,
        }
    }

    /// The inputs a model of `d` reads (fewer where fewer were given: a `Fault`).
    pub(crate) fn read(&self, d: usize) -> &[f32] {
        self.x.get(..self.len.min(d)).unwrap_or(&[])
    }
}

/// What the firmware computes for one sample: the prediction the feature pipeline and the
/// variance give ([`crate::Model::compensate`]), and the mean path's mean, status
/// and e(x)² ([`crate::Model::compensate_mean`]; the same mean and status but for a blob of
/// absurd numbers whose variance overflows, where the prediction is a `Fault`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evaluation {
    /// The prediction.
    pub prediction: Prediction,
    /// The mean path's mean and status.
    pub mean: Mean,
    /// e(x)²: how far the inputs lie beyond the trained range, squared, in length scales.
    pub excess2: f32,
}

impl Evaluation {
    /// No evaluation: a `Fault` with mean 0 and an infinite variance (what a replay records where
    /// the firmware gave none, and a placeholder for one not yet made).
    pub const NONE: Self = Self {
        prediction: Prediction {
            mean: 0.0,
            bias_variance: f32::INFINITY,
            noise_variance: 0.0,
            status: Status::Fault,
        },
        mean: Mean::FAULT,
        excess2: 0.0,
    };
}

/// `Accumulator`s of [`LANES`] samples: lane `l` takes exactly the operations an
/// `Accumulator` takes on lane `l`'s terms (both of Neumaier's corrections are computed and one
/// is kept, which is what the branch keeps).
#[derive(Default)]
struct Sums {
    sum: [f32; LANES],
    carry: [f32; LANES],
}

impl Sums {
    #[inline(always)]
    fn add(&mut self, terms: [f32; LANES]) {
        for ((sum, carry), term) in self.sum.iter_mut().zip(&mut self.carry).zip(terms) {
            let t = *sum + term;
            let sum_larger = (*sum - t) + term;
            let term_larger = (term - t) + *sum;
            // The branch's choice as a bit mask: a lane that branched would keep the compiler
            // from packing the lanes into vector registers.
            let mask = 0u32.wrapping_sub(u32::from(sum.abs() >= term.abs()));
            let kept = (sum_larger.to_bits() & mask) | (term_larger.to_bits() & !mask);
            *carry += f32::from_bits(kept);
            *sum = t;
        }
    }

    #[inline(always)]
    fn total(&self) -> [f32; LANES] {
        let mut t = self.sum;
        for (t, c) in t.iter_mut().zip(self.carry) {
            *t += c;
        }
        t
    }
}

/// Scratch numbers the side-by-side evaluation of a model of `m` centres needs: each lane's
/// kernel values, then the lanes' forward substitution side by side.
pub(crate) const fn scratch_len(m: usize) -> usize {
    2 * LANES * m
}

/// `libm::expf` of each lane, vectorized where the processor has vector registers
/// ([`super::exp`]).
#[inline(always)]
fn exp(x: &mut [f32; LANES]) {
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    super::exp::expf_lanes(x);
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    for v in x {
        *v = libm::expf(*v);
    }
}

/// `f` of each lane of `a`.
#[inline(always)]
fn each(a: [f32; LANES], f: impl Fn(f32) -> f32) -> [f32; LANES] {
    let mut out = a;
    for x in &mut out {
        *x = f(*x);
    }
    out
}

impl<const D: usize> Evaluator<'_, D> {
    /// Every `prepared` sample's mean path into `out` (as many as both hold), [`LANES`] at a
    /// time: its mean and status, and e(x)², as `mean_with` gives them.
    pub(crate) fn means(&self, prepared: &[Prepared<D>], out: &mut [(Mean, f32)]) {
        for (lanes, out) in prepared.chunks(LANES).zip(out.chunks_mut(LANES)) {
            let means = self.means_lanes(lanes, &mut []);
            for ((q, mean), slot) in lanes.iter().zip(means).zip(out) {
                *slot = match mean {
                    Some((mean, excess2)) => (mean.with_health(q.health), excess2),
                    None => (Mean::FAULT, 0.0),
                };
            }
        }
    }

    /// `mean_into` of up to [`LANES`] samples, their kernel terms side by side: each lane's
    /// inputs normalized alone, then for each centre in turn every lane's distance, exponential
    /// and compensated addition, then each lane's prior mean and raw linear terms alone, each
    /// in `mean_into`'s order. Each lane's k̃ goes to its `m` numbers of `kernels` where that
    /// holds them. `None` for a lane with no query or whose feature pipeline gave a `Fault`.
    fn means_lanes(
        &self,
        queries: &[Prepared<D>],
        kernels: &mut [f32],
    ) -> [Option<(Mean, f32)>; LANES] {
        let Dims { m, d, .. } = self.dims;
        let mut out = [None; LANES];
        let (mut z, mut s) = ([[0.0f32; D]; LANES], [[0.0f32; D]; LANES]);
        let mut status = [Status::Fault; LANES];
        for (q, (((z, s), status), out)) in queries
            .iter()
            .zip(z.iter_mut().zip(&mut s).zip(&mut status).zip(&mut out))
        {
            if q.health != Status::Fault {
                let (normalized, excess2) = self.normalize(q.read(d), z, s);
                *status = normalized;
                *out = Some((Mean::FAULT, excess2));
            }
        }
        // Input k of every lane side by side (zeros in a lane not evaluated).
        let mut across = [[0.0f32; LANES]; D];
        for (l, (s, status)) in s.iter().zip(&status).enumerate() {
            if *status != Status::Fault {
                for (row, v) in across.iter_mut().zip(s).take(d) {
                    if let Some(slot) = row.get_mut(l) {
                        *slot = *v;
                    }
                }
            }
        }
        let sec = self.dims.sections();
        let weights = self.section(sec.weights);
        let mut sums = Sums::default();
        for (i, (c, w)) in self
            .section(sec.centres)
            .chunks_exact(d.max(1))
            .zip(weights)
            .enumerate()
        {
            let mut r2 = [0.0f32; LANES];
            for (inputs, ck) in across.iter().zip(c).take(d) {
                for (r, a) in r2.iter_mut().zip(inputs) {
                    *r += (a - ck) * (a - ck);
                }
            }
            let mut kv = each(r2, |r| -0.5 * r);
            exp(&mut kv);
            for (l, v) in kv.iter().enumerate() {
                if let Some(slot) = kernels.get_mut(l * m + i) {
                    *slot = *v;
                }
            }
            sums.add(each(kv, |v| w * v));
        }
        for (l, (q, out)) in queries.iter().zip(&mut out).enumerate() {
            let (Some((_, excess2)), Some(status), Some(z), Some(sum), Some(carry)) = (
                *out,
                status.get(l),
                z.get(l),
                sums.sum.get(l),
                sums.carry.get(l),
            ) else {
                continue;
            };
            if *status == Status::Fault {
                continue;
            }
            let mut acc = Accumulator {
                sum: *sum,
                carry: *carry,
            };
            let z = z.get(..d).unwrap_or(&[]);
            *out = Some((self.finish_mean(q.read(d), z, *status, &mut acc), excess2));
        }
        out
    }

    /// Scratch numbers [`Self::evaluate_lanes`] needs: each lane's kernel values, then the lanes'
    /// forward substitution side by side.
    pub(crate) fn lanes_scratch_len(&self) -> usize {
        scratch_len(self.dims.m)
    }

    /// Every `prepared` sample's [`Evaluation`] into `out` (as many as both hold), [`LANES`] at a
    /// time. `scratch` must hold [`Self::lanes_scratch_len`] numbers.
    pub(crate) fn evaluate(
        &self,
        prepared: &[Prepared<D>],
        scratch: &mut [f32],
        out: &mut [Evaluation],
    ) -> Result<(), PredictError> {
        for (lanes, out) in prepared.chunks(LANES).zip(out.chunks_mut(LANES)) {
            self.evaluate_lanes(lanes, scratch, out)?;
        }
        Ok(())
    }

    /// Up to [`LANES`] samples' [`Evaluation`]s into `out` (one per query, in order; queries past
    /// [`LANES`] are left alone). `scratch` must hold [`Self::lanes_scratch_len`] numbers.
    fn evaluate_lanes(
        &self,
        queries: &[Prepared<D>],
        scratch: &mut [f32],
        out: &mut [Evaluation],
    ) -> Result<(), PredictError> {
        let m = self.dims.m;
        let needed = self.lanes_scratch_len();
        let scratch = scratch
            .get_mut(..needed)
            .ok_or(PredictError::ScratchTooSmall { needed })?;
        let (kernels, v) = scratch.split_at_mut(LANES * m);
        // Each lane's mean path, its kernel values k̃ into its own part of `kernels`, then laid
        // side by side in `v` (row j holds every lane's k̃_j); a lane with no query, or a fault,
        // substitutes zeros and is not read.
        let means = self.means_lanes(queries, kernels);
        for (j, row) in v.chunks_exact_mut(LANES).enumerate() {
            for (l, (x, mean)) in row.iter_mut().zip(&means).enumerate() {
                *x = match mean {
                    Some((mean, _)) if mean.status != Status::Fault => {
                        kernels.get(l * m + j).copied().unwrap_or(0.0)
                    }
                    _ => 0.0,
                };
            }
        }
        // `predict_in`'s forward substitution L v = k̃ and 1 − |v|², lane by lane.
        let factor = self.section(self.dims.sections().factor);
        let mut rest = Sums::default();
        rest.add([1.0; LANES]);
        for i in 0..m {
            let row = factor
                .get(i * (i + 1) / 2..(i + 1) * (i + 2) / 2)
                .unwrap_or(&[]);
            let (before, diag) = row.split_at(row.len().saturating_sub(1));
            let (done, now) = v.split_at_mut(i * LANES);
            let Some(vi) = now.first_chunk_mut::<LANES>() else {
                break;
            };
            let mut acc = Sums::default();
            acc.add(*vi);
            for (l, vj) in before.iter().zip(done.as_chunks::<LANES>().0) {
                let mut terms = *vj;
                for t in &mut terms {
                    *t = -(l * *t);
                }
                acc.add(terms);
            }
            *vi = match diag.first() {
                Some(lii) => each(acc.total(), |t| t / lii),
                None => [0.0; LANES],
            };
            rest.add(each(*vi, |x| -(x * x)));
        }
        let rest = rest.total();
        let [signal, _] = self.variances();
        for (((q, mean), rest), slot) in queries.iter().zip(means).zip(rest).zip(out) {
            *slot = match mean {
                None => Evaluation {
                    prediction: self.fault(),
                    mean: Mean::FAULT,
                    excess2: 0.0,
                },
                Some((mean, excess2)) => {
                    let mut prediction = if mean.status == Status::Fault {
                        self.fault()
                    } else {
                        let mut bias_variance = signal * rest.max(0.0)
                            + self.error.model_error(excess2, mean.mean, q.at);
                        if mean.status == Status::Extrapolating {
                            bias_variance += self.followed2(q.read(self.dims.d));
                        }
                        if (bias_variance + self.error.sample_noise_var).is_finite() {
                            Prediction {
                                mean: mean.mean,
                                bias_variance,
                                noise_variance: self.error.sample_noise_var,
                                status: mean.status,
                            }
                        } else {
                            self.fault()
                        }
                    };
                    prediction.status = prediction.status.max(q.health);
                    Evaluation {
                        prediction,
                        mean: mean.with_health(q.health),
                        excess2,
                    }
                }
            };
        }
        Ok(())
    }
}
