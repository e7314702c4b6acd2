//! Several samples' variances side by side, for a host that replays a stream.
//!
//! The variance's forward substitution is a chain of dependent compensated additions, m(m+1)/2
//! per sample: one sample at a time, a processor mostly waits for each addition's result (42 % of
//! an investigation's time on the host, measured with `perf` on `trainer challenge --kind
//! single`). [`LANES`] samples side by side take the same operations in the same order, each on
//! its own numbers, so every one is bit for bit what [`Evaluator::predict_in`] gives, while the
//! compiler packs the lanes into vector registers. A gyro evaluates the one sample that has just
//! arrived, so its firmware never calls this.

use super::evaluate::{Conditions, Evaluator, Mean, Prediction};
use crate::error::PredictError;
use crate::status::Status;

/// Samples side by side: two SSE registers of f32, one AVX or two NEON ones.
pub const LANES: usize = 8;

/// One sample to evaluate: the model's inputs, their health and the conditions the model error
/// reads; from the feature pipeline ([`crate::Model::prepare`]) or given ([`Prepared::inputs`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prepared<const D: usize> {
    pub(crate) x: [f32; D],
    /// Inputs given, of `x`.
    pub(crate) len: usize,
    pub(crate) health: Status,
    pub(crate) at: Conditions,
}

impl<const D: usize> Prepared<D> {
    /// Inputs `x` as they are, in the conditions `at`: what [`crate::Model::predict_in`]
    /// evaluates (a model reads at most `D` inputs, so any past `D` are left out).
    pub fn inputs(x: &[f32], at: Conditions) -> Self {
        Self::judged(x, Status::Valid, at)
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
    /// Scratch numbers [`Self::evaluate_lanes`] needs: each lane's kernel values, then the lanes'
    /// forward substitution side by side.
    pub(crate) fn lanes_scratch_len(&self) -> usize {
        2 * LANES * self.dims.m
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
        let mut means = [None; LANES];
        for (l, (q, slot)) in queries.iter().zip(&mut means).enumerate() {
            if q.health != Status::Fault {
                let k = kernels.get_mut(l * m..(l + 1) * m);
                *slot = Some(self.mean_into(q.read(self.dims.d), k));
            }
        }
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
                        let bias_variance =
                            signal * rest.max(0.0) + self.error.model_error(excess2, q.at);
                        if bias_variance.is_finite() {
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
