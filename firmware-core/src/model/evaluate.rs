//! The arithmetic of every prediction, once for a model decoded alone and a channel of a unit:
//! the inputs normalized and held at the trained range, the compensated sums of the kernel terms,
//! prior mean and raw linear terms, and the variance by forward substitution (the parent
//! module's doc gives the formulas and the summation order), and what a prediction returns.

use core::ops::Range;

use crate::blob::{self, Beyond, Dims, ErrorModel, Feature, Limits};
use crate::error::PredictError;
use crate::features::{FeatureState, MAX_INPUTS};
use crate::status::Status;
use crate::units::SECONDS_PER_HOUR;

/// The farthest beyond its trained range an input counts, in the range's widths: a σ grown that
/// far says nothing more than "not this model's", and e(x)² stays finite for any finite input.
const MAX_EXCESS: f32 = 1e3;
/// The most [`Evaluator::followed2`] adds: a variance far past any use that leaves room for the
/// terms added beside it.
const FOLLOWED2_MAX: f32 = f32::MAX / 16.0;

/// Predictive mean (output units, e.g. °/s) and its status.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mean {
    /// Compensated rate.
    pub mean: f32,
    /// Validity.
    pub status: Status,
}

impl Mean {
    /// A `Fault`'s mean.
    pub const FAULT: Self = Self {
        mean: 0.0,
        status: Status::Fault,
    };

    /// This mean with the feature pipeline's `health` folded in: the worse of the two statuses,
    /// and a `Fault`'s mean 0.
    pub(crate) fn with_health(self, health: Status) -> Self {
        if self.status == Status::Fault {
            Self::FAULT
        } else {
            Self {
                mean: self.mean,
                status: self.status.max(health),
            }
        }
    }
}

/// Predictive mean, its two variances (output units², never negative) and status: the σ
/// contract of the module doc.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Prediction {
    /// Compensated rate.
    pub mean: f32,
    /// Variance of the compensated rate's slowly varying error: the GP's latent variance plus the
    /// model error the trainer measured ([`ErrorModel`]). A mean over any window keeps it.
    pub bias_variance: f32,
    /// White noise of one sample (at the blob's sample interval): a mean of N samples has 1/N of
    /// it.
    pub noise_variance: f32,
    /// Validity.
    pub status: Status,
}

impl Prediction {
    /// Variance of this one sample's error: bias plus noise.
    pub fn variance(&self) -> f32 {
        self.bias_variance + self.noise_variance
    }
}

/// What the model error reads of a sample besides its inputs: the hours since power-on, the
/// heating/cooling state and the heating rate ([`ErrorModel`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Conditions {
    /// Hours since power-on.
    pub hours: f32,
    /// Heating/cooling state in [−1, 1] ([`FeatureState::leg`]); `None`: one the calibration
    /// held (no leg term).
    pub leg: Option<f32>,
    /// Temperature reading (°C) and heating rate (°C/min, [`FeatureState::heating_rate`]);
    /// `None`: a rate the calibration held (no heating term).
    pub heating: Option<(f32, f32)>,
    /// Whether another power-on's bias and scale apply (the turn-on and scale terms): always in
    /// service; not on the calibration's own power-on ([`FeatureState::calibration_run`]).
    pub another_power_on: bool,
}

impl Conditions {
    /// `hours` after power-on, on a heating/cooling state and a heating rate the calibration
    /// held.
    pub const fn at_hours(hours: f32) -> Self {
        Self {
            hours,
            leg: None,
            heating: None,
            another_power_on: true,
        }
    }

    /// Those of the sample a feature state has just computed.
    pub fn of(state: &FeatureState) -> Self {
        Self {
            hours: (state.time_on_s() / SECONDS_PER_HOUR) as f32,
            leg: Some(state.leg()),
            heating: state.heating(),
            another_power_on: !state.in_calibration_run(),
        }
    }
}

/// Neumaier-compensated sum: the running rounding error is carried and added once at the end.
#[derive(Default)]
pub(crate) struct Accumulator {
    pub(crate) sum: f32,
    pub(crate) carry: f32,
}

impl Accumulator {
    // Inlined always: the variance's double loop calls it m(m+1)/2 times per sample, and a call
    // there costs more than the addition (the Cortex-M4's release build inlines it anyway).
    #[inline(always)]
    fn add(&mut self, term: f32) {
        let t = self.sum + term;
        self.carry += if self.sum.abs() >= term.abs() {
            (self.sum - t) + term
        } else {
            (term - t) + self.sum
        };
        self.sum = t;
    }

    #[inline(always)]
    fn total(&self) -> f32 {
        self.sum + self.carry
    }
}

/// |s − c|², summed in input order (the kernel's distance, the same on every target).
#[inline(always)]
fn squared_distance<const K: usize>(s: &[f32; K], c: &[f32]) -> f32 {
    s.iter()
        .zip(c)
        .fold(0.0f32, |r2, (a, b)| r2 + (a - b) * (a - b))
}

/// A decoded model's numbers as the evaluator reads them: its sizes, prior exponents, flat array
/// and error model, borrowed from where they are stored (a [`Model`]'s own storage, or a
/// channel's part of a [`crate::unit::Unit`]'s). Every prediction's arithmetic is here, once, so a
/// channel of a unit computes bit for bit what the same model decoded alone does. `D` is the
/// capacity of inputs of the storage it reads from, the size of its working arrays.
#[derive(Clone, Copy)]
pub(crate) struct Evaluator<'a, const D: usize> {
    /// Model sizes (`d` = 0: no model).
    pub(crate) dims: Dims,
    /// Prior-mean exponents, `p` rows of `d`.
    pub(crate) exponents: &'a [u8],
    /// The flat array ([`crate::blob`]'s layout).
    pub(crate) floats: &'a [f32],
    /// What each input is: the rule beyond the trained range and the limits read it.
    pub(crate) features: &'a [Feature],
    /// The variance besides the latent one (borrowed: the evaluator is made for every
    /// prediction, and copying these cost the mean path tens of instructions on the M4).
    pub(crate) error: &'a ErrorModel,
    /// What a reading that cannot be true is.
    pub(crate) limits: &'a Limits,
    /// What the mean does beyond the trained range.
    pub(crate) beyond: Beyond,
}

impl<const D: usize> Evaluator<'_, D> {
    pub(crate) fn section(&self, range: Range<usize>) -> &[f32] {
        self.floats.get(range).unwrap_or(&[])
    }

    /// The trained range of input `k`.
    pub(crate) fn trained_range(&self, k: usize) -> Option<[f32; 2]> {
        if k >= self.dims.d {
            return None;
        }
        let s = self.dims.sections();
        Some([
            *self.floats.get(s.min.start + k)?,
            *self.floats.get(s.max.start + k)?,
        ])
    }

    /// (σ_f², σ_n²) in output units².
    pub(crate) fn variances(&self) -> [f32; 2] {
        let s = self.dims.sections();
        let v = self.section(s.variances);
        [
            v.first().copied().unwrap_or(0.0),
            v.get(1).copied().unwrap_or(0.0),
        ]
    }

    /// Normalizes the inputs into `z` and `s = z/ℓ`, each held at its trained range's edge as the
    /// blob's rule says (module doc); returns the status of the inputs and e(x)², how far they lie
    /// beyond the trained range in its widths, squared ([`ErrorModel`]). A reading that cannot be
    /// true ([`Limits`]) is a `Fault`.
    pub(crate) fn normalize(&self, x: &[f32], z: &mut [f32; D], s: &mut [f32; D]) -> (Status, f32) {
        let sec = self.dims.sections();
        let d = self.dims.d;
        // d = 0: storage that holds no model.
        if d == 0 || d > D || x.len() < d || x.iter().take(d).any(|v| !v.is_finite()) {
            return (Status::Fault, 0.0);
        }
        let mut status = Status::Valid;
        let mut excess2 = 0.0f32;
        // Each section sliced once and walked together: indexing them per input cost a bounds
        // check a number on the Cortex-M4, a per-prediction cost the sparse model feels most.
        let bounds = self
            .section(sec.min)
            .iter()
            .zip(self.section(sec.max))
            .zip(self.section(sec.length));
        let norm = self.section(sec.offset).iter().zip(self.section(sec.scale));
        for (k, (((zk, sk), &xk), (((&lo, &hi), &length), (&offset, &scale)))) in z
            .iter_mut()
            .zip(s.iter_mut())
            .zip(x)
            .zip(bounds.zip(norm))
            .take(d)
            .enumerate()
        {
            // Inside the trained range a reading is possible (the decoder checked the range
            // against the limits, but for inputs only linear terms read); beyond it, it may not
            // be, and what it is held at is the blob's rule: both off the common path.
            let held = if (lo..=hi).contains(&xk) && length < blob::IGNORED_LENGTH_SCALE {
                xk
            } else {
                match self.beyond_range(k, xk, (lo, hi), length) {
                    Some((held, excess)) => {
                        if excess > 0.0 {
                            status = Status::Extrapolating;
                            excess2 += excess * excess;
                        }
                        held
                    }
                    None => return (Status::Fault, 0.0),
                }
            };
            *zk = (held - offset) / scale;
            *sk = *zk / length;
        }
        (status, excess2)
    }

    /// Input `k` at `xk`, outside its trained range `lo..=hi` or read by linear terms alone
    /// (`length`): `None` for a reading that cannot be true ([`Limits`]), else what the kernel and
    /// prior read (held at the edge as the blob's rule says, module doc) and how far beyond the
    /// range it lies in the range's widths (0 inside). Out of line: the common path is a reading
    /// inside the range.
    #[cold]
    #[inline(never)]
    fn beyond_range(
        &self,
        k: usize,
        xk: f32,
        (lo, hi): (f32, f32),
        length: f32,
    ) -> Option<(f32, f32)> {
        let possible = match self.features.get(k) {
            Some(f) if f.is_temperature() => self.limits.temperature_ok(xk),
            Some(Feature::Voltage) => self.limits.output_ok(xk),
            _ => true,
        };
        if !possible {
            return None;
        }
        if (lo..=hi).contains(&xk) {
            return Some((xk, 0.0));
        }
        let span = hi - lo;
        let width = if span > 0.0 { span } else { lo.abs().max(1.0) };
        // max/min rather than clamp, which asserts lo ≤ hi (the decoder checked it) with a panic
        // path of its own.
        let clamped = xk.max(lo).min(hi);
        let excess = ((clamped - xk) / width).abs().min(MAX_EXCESS);
        // An input the kernel ignores enters through linear terms alone, a slope fitted on the
        // data: it follows its value, as every input does under `Follow`. Where the prior mean
        // does not read it either, its distance grows the variance through what its raw linear
        // term followed ([`Self::followed2`]), not through e(x)².
        let linear = length >= blob::IGNORED_LENGTH_SCALE;
        let held = if !linear && self.beyond != Beyond::Follow {
            clamped
        } else {
            xk
        };
        let excess = if linear && !self.in_prior(k) {
            0.0
        } else {
            excess
        };
        // A positive excess marks the input extrapolating, however small.
        Some((held, excess.max(f32::MIN_POSITIVE)))
    }

    /// Whether a prior-mean monomial reads input `k`.
    fn in_prior(&self, k: usize) -> bool {
        self.exponents
            .chunks(self.dims.d.max(1))
            .any(|e| e.get(k).is_some_and(|&ek| ek > 0))
    }

    /// f(x)²: over the inputs only a raw linear term reads (an extension's time drift, warm-up,
    /// heating/cooling state, temperature rate), the square of what that term added past the
    /// trained range's edge ([`ErrorModel`]): the slope was fitted where the data were, and
    /// followed further it may be wrong by all it adds there. The distance is capped as the
    /// widths are (a time since power-on of years stays finite), and so is the sum. Out of line,
    /// called only for a sample that is extrapolating: the common path costs nothing more.
    #[cold]
    #[inline(never)]
    pub(crate) fn followed2(&self, x: &[f32]) -> f32 {
        let sec = self.dims.sections();
        let at = |base: usize, k: usize| self.floats.get(base + k).copied().unwrap_or(0.0);
        let mut sum = 0.0f32;
        for (k, &xk) in x.iter().enumerate().take(self.dims.d) {
            let (lo, hi) = (at(sec.min.start, k), at(sec.max.start, k));
            if at(sec.length.start, k) < blob::IGNORED_LENGTH_SCALE
                || (lo..=hi).contains(&xk)
                || self.in_prior(k)
            {
                continue;
            }
            let span = hi - lo;
            let width = if span > 0.0 { span } else { lo.abs().max(1.0) };
            let reach = MAX_EXCESS * width;
            let distance = (xk - xk.max(lo).min(hi)).max(-reach).min(reach);
            let followed = (at(sec.raw_hi.start, k) + at(sec.raw_lo.start, k)) * distance;
            sum += followed * followed;
        }
        // However large a coefficient, finite: a reading is never made a fault by its variance.
        sum.min(FOLLOWED2_MAX)
    }

    /// Adds the prior monomials, highest degree (smallest term) first.
    fn add_prior_mean(&self, z: &[f32], acc: &mut Accumulator) {
        let sec = self.dims.sections();
        let d = self.dims.d;
        for (c, e) in self
            .section(sec.prior)
            .iter()
            .zip(self.exponents.chunks(d))
            .rev()
        {
            acc.add(
                e.iter()
                    .zip(z)
                    .fold(*c, |a, (&k, &zk)| (0..k).fold(a, |a, _| a * zk)),
            );
        }
    }

    /// Adds the prior mean's first-order change from the held inputs `z` to the inputs `x` (raw):
    /// Σ_k ∂prior/∂z_k(z) · (z_k(x) − z_k), [`Beyond::Tangent`]'s continuation past the edge.
    fn add_prior_tangent(&self, x: &[f32], z: &[f32], acc: &mut Accumulator) {
        let sec = self.dims.sections();
        let d = self.dims.d;
        let at = |base: usize, k: usize| self.floats.get(base + k).copied().unwrap_or(1.0);
        for (k, (&xk, &zk)) in x.iter().zip(z).enumerate().take(d) {
            let dz = (xk - at(sec.offset.start, k)) / at(sec.scale.start, k) - zk;
            if dz == 0.0 {
                continue;
            }
            for (c, e) in self
                .section(sec.prior.clone())
                .iter()
                .zip(self.exponents.chunks(d))
            {
                let Some(&ek) = e.get(k).filter(|&&ek| ek > 0) else {
                    continue;
                };
                // c · e_k · z_k^(e_k − 1) · Π_{i≠k} z_i^e_i
                let slope =
                    e.iter()
                        .zip(z)
                        .enumerate()
                        .fold(*c * f32::from(ek), |a, (i, (&ei, &zi))| {
                            let n = if i == k { ei - 1 } else { ei };
                            (0..n).fold(a, |a, _| a * zi)
                        });
                acc.add(slope * dz);
            }
        }
    }

    /// Beyond the trained range, what the prior mean adds past the held inputs `z` (the tangent's
    /// part, under [`Beyond::Tangent`]) and the raw linear terms at what they read there. Out of
    /// line: the common path is a reading inside the range.
    #[cold]
    #[inline(never)]
    fn add_beyond(&self, x: &[f32], z: &[f32], acc: &mut Accumulator) {
        if self.beyond == Beyond::Tangent {
            self.add_prior_tangent(x, z, acc);
        }
        let mut r = [0.0f32; D];
        for (k, (rk, &xk)) in r.iter_mut().zip(x).take(self.dims.d).enumerate() {
            *rk = self.raw_input(k, xk);
        }
        self.add_raw_linear(r.get(..self.dims.d).unwrap_or(&[]), acc);
    }

    /// What the raw linear term of input `k` reads at `xk`, beyond the trained range: held at the
    /// edge under [`Beyond::Hold`] but for the gyro output, the time since power-on and an input
    /// only linear terms read; `xk` otherwise (module doc).
    fn raw_input(&self, k: usize, xk: f32) -> f32 {
        let sec = self.dims.sections();
        let at = |base: usize| self.floats.get(base + k).copied().unwrap_or(1.0);
        let follows = self.beyond != Beyond::Hold
            || at(sec.length.start) >= blob::IGNORED_LENGTH_SCALE
            || matches!(
                self.features.get(k),
                Some(Feature::Voltage | Feature::TimeOn)
            );
        if follows {
            xk
        } else {
            xk.max(at(sec.min.start)).min(at(sec.max.start))
        }
    }

    /// Adds the raw linear terms: `hi·x = p + e` exactly (FMA), so only the final additions round.
    // Inlined always: called out of line, the accumulator goes through memory (+120 instructions
    // a mean on the Cortex-M4, the sparse-vs-exact test's figures).
    #[inline(always)]
    fn add_raw_linear(&self, x: &[f32], acc: &mut Accumulator) {
        let sec = self.dims.sections();
        let terms = || {
            self.section(sec.raw_hi.clone())
                .iter()
                .zip(self.section(sec.raw_lo.clone()))
                .zip(x)
        };
        for ((hi, lo), xk) in terms() {
            let p = hi * xk;
            acc.add(libm::fmaf(*xk, *hi, -p) + lo * xk);
        }
        for ((hi, _), xk) in terms() {
            acc.add(hi * xk);
        }
    }

    /// Adds the kernel terms `w_i·k(s, c_i)` with the input count fixed at compile time, so the
    /// distance loop unrolls completely: a generic-length loop cost about 40 instructions per
    /// centre in bookkeeping on the Cortex-M4 (docs/firmware.md, "Cost on the M4"). The arithmetic
    /// and its order are the same for every `K`, and on every target: on a host the exponentials
    /// of [`super::exp::LANES`] centres are taken at a time, vectorized ([`super::exp`]), then
    /// added in the same order.
    fn add_kernel_terms<const K: usize>(
        s: &[f32],
        centres: &[f32],
        weights: &[f32],
        mut k: Option<&mut [f32]>,
        acc: &mut Accumulator,
    ) {
        let Some(s) = s.first_chunk::<K>() else {
            return;
        };
        #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
        for (i, (c, w)) in centres.chunks_exact(K).zip(weights).enumerate() {
            let kv = libm::expf(-0.5 * squared_distance(s, c));
            if let Some(slot) = k.as_deref_mut().and_then(|k| k.get_mut(i)) {
                *slot = kv;
            }
            acc.add(w * kv);
        }
        #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
        {
            use super::exp::{LANES, expf_lanes};
            let m = weights.len().min(centres.len() / K);
            let mut kv = [0.0f32; LANES];
            for start in (0..m).step_by(LANES) {
                let n = LANES.min(m - start);
                let batch = centres.get(start * K..(start + n) * K).unwrap_or(&[]);
                for (x, c) in kv.iter_mut().zip(batch.chunks_exact(K)) {
                    *x = -0.5 * squared_distance(s, c);
                }
                expf_lanes(&mut kv);
                let w = weights.get(start..start + n).unwrap_or(&[]);
                if let Some(slots) = k.as_deref_mut().and_then(|k| k.get_mut(start..)) {
                    for (slot, v) in slots.iter_mut().zip(&kv).take(n) {
                        *slot = *v;
                    }
                }
                for (w, kv) in w.iter().zip(kv) {
                    acc.add(w * kv);
                }
            }
        }
    }

    /// Mean, status and e(x)²; the kernel values go to `k` when it is long enough.
    pub(crate) fn mean_into(&self, x: &[f32], k: Option<&mut [f32]>) -> (Mean, f32) {
        let mut z = [0.0f32; D];
        let mut s = [0.0f32; D];
        let (status, excess2) = self.normalize(x, &mut z, &mut s);
        if status == Status::Fault {
            return (Mean { mean: 0.0, status }, excess2);
        }
        let sec = self.dims.sections();
        let d = self.dims.d;
        let zd = z.get(..d).unwrap_or(&[]);
        let sd = s.get(..d).unwrap_or(&[]);
        let mut acc = Accumulator::default();
        let centres = self.section(sec.centres);
        let weights = self.section(sec.weights);
        match d {
            1 => Self::add_kernel_terms::<1>(sd, centres, weights, k, &mut acc),
            2 => Self::add_kernel_terms::<2>(sd, centres, weights, k, &mut acc),
            3 => Self::add_kernel_terms::<3>(sd, centres, weights, k, &mut acc),
            4 => Self::add_kernel_terms::<4>(sd, centres, weights, k, &mut acc),
            5 => Self::add_kernel_terms::<5>(sd, centres, weights, k, &mut acc),
            6 => Self::add_kernel_terms::<6>(sd, centres, weights, k, &mut acc),
            7 => Self::add_kernel_terms::<7>(sd, centres, weights, k, &mut acc),
            // `decode` refuses more than MAX_INPUTS.
            _ => Self::add_kernel_terms::<MAX_INPUTS>(sd, centres, weights, k, &mut acc),
        }
        (self.finish_mean(x, zd, status, &mut acc), excess2)
    }

    /// The mean of inputs `x` (normalized and held: `z`) of status `status`, whose kernel terms
    /// are in `acc`: the prior mean and the raw linear terms (or the rule beyond the trained
    /// range) added after them, in that order.
    #[inline(always)]
    pub(crate) fn finish_mean(
        &self,
        x: &[f32],
        z: &[f32],
        status: Status,
        acc: &mut Accumulator,
    ) -> Mean {
        self.add_prior_mean(z, acc);
        if status == Status::Extrapolating {
            self.add_beyond(x, z, acc);
        } else {
            self.add_raw_linear(x, acc);
        }
        let mean = acc.total();
        if mean.is_finite() {
            Mean { mean, status }
        } else {
            Mean::FAULT
        }
    }

    /// The mean path at inputs `x` whose health the feature pipeline judged `health`: the mean,
    /// the worse of the two statuses, and e(x)² (a `Fault` anywhere: mean 0).
    pub(crate) fn mean_with(&self, x: &[f32], health: Status) -> (Mean, f32) {
        if health == Status::Fault {
            return (Mean::FAULT, 0.0);
        }
        let (m, excess2) = self.mean_into(x, None);
        (m.with_health(health), excess2)
    }

    /// A `Fault`'s prediction: mean 0, the prior's variance.
    pub(crate) fn fault(&self) -> Prediction {
        let [signal, _] = self.variances();
        Prediction {
            mean: 0.0,
            bias_variance: signal,
            noise_variance: self.error.sample_noise_var,
            status: Status::Fault,
        }
    }

    /// Predictive mean and variances at inputs `x` in the conditions `at`. `scratch` must hold
    /// at least `m` numbers.
    pub(crate) fn predict_in(
        &self,
        x: &[f32],
        at: Conditions,
        scratch: &mut [f32],
    ) -> Result<Prediction, PredictError> {
        let m = self.dims.m;
        let v = scratch
            .get_mut(..m)
            .ok_or(PredictError::ScratchTooSmall { needed: m })?;
        let (Mean { mean, status }, excess2) = self.mean_into(x, Some(v));
        let [signal, _] = self.variances();
        if status == Status::Fault {
            return Ok(self.fault());
        }
        // Forward substitution L v = k̃ on packed rows (row i holds L_i0 … L_ii), and 1 − |v|²,
        // both compensated: where the variance matters it is a small difference of O(1) numbers,
        // and plain f32 sums lost 1e-3 of it (docs/paper.md, "Measured for the firmware").
        let factor = self.section(self.dims.sections().factor);
        let mut rest = Accumulator::default();
        rest.add(1.0);
        for i in 0..m {
            let row = factor
                .get(i * (i + 1) / 2..(i + 1) * (i + 2) / 2)
                .unwrap_or(&[]);
            let (before, diag) = row.split_at(row.len().saturating_sub(1));
            let mut acc = Accumulator::default();
            acc.add(v.get(i).copied().unwrap_or(0.0));
            // Four terms a pass, in order (the same sum): the compiler then unrolls the loop as
            // it did before the evaluator read its numbers through a borrowed slice (0.4
            // instructions less per term on the Cortex-M4, docs/firmware.md "Cost on the M4").
            let (pairs, rest_l) = before.as_chunks::<4>();
            let (v_pairs, rest_v) = v.get(..before.len()).unwrap_or(&[]).as_chunks::<4>();
            for (l, vj) in pairs.iter().zip(v_pairs) {
                acc.add(-(l[0] * vj[0]));
                acc.add(-(l[1] * vj[1]));
                acc.add(-(l[2] * vj[2]));
                acc.add(-(l[3] * vj[3]));
            }
            for (l, vj) in rest_l.iter().zip(rest_v) {
                acc.add(-(l * vj));
            }
            let vi = diag.first().map_or(0.0, |lii| acc.total() / lii);
            if let Some(slot) = v.get_mut(i) {
                *slot = vi;
            }
            rest.add(-(vi * vi));
        }
        let mut bias_variance =
            signal * rest.total().max(0.0) + self.error.model_error(excess2, mean, at);
        if status == Status::Extrapolating {
            bias_variance += self.followed2(x);
        }
        // With the noise, so that the sum a caller forms (`Prediction::variance`) is finite too.
        if !(bias_variance + self.error.sample_noise_var).is_finite() {
            // Absurd but finite numbers in a blob (the mutated-blob test), as a mean that is not
            // finite.
            return Ok(self.fault());
        }
        Ok(Prediction {
            mean,
            bias_variance,
            noise_variance: self.error.sample_noise_var,
            status,
        })
    }
}
