//! A decoded model in fixed-size storage, and its predictive mean and variance in f32.
//!
//! Capacities are const generics chosen by the integrator: `D` inputs, `E` prior-mean exponents
//! (`p·d`), `N` numbers in the flat array ([`Dims::floats`]). For the paper's 140-point model on
//! (T, V) with the physics prior mean (m = 140, d = 2, p = 7 after the linear terms move to the
//! raw inputs): `Model<2, 14, 10_313>`, 41,292 bytes (`trainer inspect model.bin` prints it for
//! any blob).
//!
//! Evaluation (module doc of [`crate::blob`] for the layout):
//!
//! ```text
//! z_k  = (x_k − offset_k) / scale_k,   s_k = z_k / ℓ_k
//! k̃_i  = exp(−½ Σ_k (s_k − c_ik)²)
//! mean = Σ_i w_i k̃_i + Σ_j prior_j Π_k z_k^e_jk + Σ_k (hi_k + lo_k) x_k
//! var  = σ_f² · max(0, 1 − |v|²),  L v = k̃             (forward substitution, packed rows)
//! bias variance  = var + model error(e(x)², t)          ([`ErrorModel`])
//! noise variance = σ_w², one sample's white noise
//! ```
//!
//! The two variances are the σ contract (docs/design.md §4): the bias variance is the uncertainty
//! of the compensated rate's slowly varying error, which a mean over any window keeps (a Kalman
//! filter's bias state); the noise variance is one sample's white noise, which a mean of N samples
//! divides by N (its measurement noise). A sample's own error has their sum
//! ([`Prediction::variance`]); a mean over τ seconds has the bias variance plus
//! [`ErrorModel::noise_of_mean`].
//!
//! Summation order, for f32: the kernel terms, then the prior monomials from the highest degree
//! down, then the rounding parts of the raw linear terms, and their large products last, all
//! through one compensated (Neumaier) accumulator. The sum then rounds about once. The forward
//! substitution's dot products and 1 − |v|² are compensated sums too: the variance that matters
//! is a small difference of O(1) numbers.
//!
//! Never panics, never returns NaN: non-finite or missing inputs give a `Fault` status with mean 0
//! and the prior variance σ_f²; inputs outside the trained range give `Extrapolating`. An input
//! more than one trained span beyond its range is a sensor fault, not a reading (a temperature of
//! 1e30 °C overflowed the prior mean to NaN), and is a `Fault` too; so is any mean that is not
//! finite, which a blob with absurd but finite numbers could otherwise produce (the mutated-blob
//! test, `tests/mutated_blobs.rs`).

use core::ops::Range;

use heapless::Vec;

use crate::blob::{self, Dims, ErrorModel, Feature};
use crate::error::{BlobError, PredictError, Storage};
use crate::features::{self, FeatureState, MAX_INPUTS, Sample};
use crate::status::Status;
use crate::units::SECONDS_PER_HOUR;

/// Most centres (inducing points, or training points of an exact GP) in a model this project
/// exports: 256 already need about 132 KB of f32 on the microcontroller, the top of a
/// Cortex-M4's RAM. The trainer refuses larger models, the host decodes into this capacity, and
/// the C interface's `FOG_MAX_CENTRES` must not exceed it.
pub const MAX_CENTRES: usize = 256;

/// Predictive mean (output units, e.g. °/s) and its status.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mean {
    /// Compensated rate.
    pub mean: f32,
    /// Validity.
    pub status: Status,
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

/// A model decoded from a blob into fixed-size storage.
#[derive(Debug, Clone, PartialEq)]
pub struct Model<const D: usize, const E: usize, const N: usize> {
    dims: Dims,
    features: Vec<Feature, D>,
    exponents: Vec<u8, E>,
    floats: Vec<f32, N>,
    error: ErrorModel,
}

/// Neumaier-compensated sum: the running rounding error is carried and added once at the end.
#[derive(Default)]
struct Accumulator {
    sum: f32,
    carry: f32,
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

/// `needed` elements against a capacity: [`BlobError::CapacityExceeded`] beyond it.
pub(crate) fn capacity(what: Storage, needed: usize, capacity: usize) -> Result<(), BlobError> {
    if needed > capacity {
        Err(BlobError::CapacityExceeded {
            what,
            needed,
            capacity,
        })
    } else {
        Ok(())
    }
}

/// The checks a blob's numbers pass, made as they are read: each number's domain by its section
/// (scales, length scales and the factor's diagonal positive, variances not negative, each input's
/// minimum not above its maximum), and finiteness, which is reported first.
struct Domains<const D: usize> {
    sections: blob::Sections,
    mins: [f32; D],
    seen: usize,
    diagonal: usize,
    row: usize,
    non_finite: Option<usize>,
    valid: bool,
}

impl<const D: usize> Domains<D> {
    fn new(dims: Dims) -> Self {
        let sections = dims.sections();
        Self {
            diagonal: sections.factor.start,
            sections,
            mins: [0.0; D],
            seen: 0,
            row: 0,
            non_finite: None,
            valid: true,
        }
    }

    fn see(&mut self, v: f32) {
        let i = self.seen;
        self.seen += 1;
        if !v.is_finite() {
            self.non_finite.get_or_insert(i);
            return;
        }
        let s = &self.sections;
        let ok = if s.scale.contains(&i) || s.length.contains(&i) {
            v > 0.0
        } else if s.min.contains(&i) {
            if let Some(lo) = self.mins.get_mut(i - s.min.start) {
                *lo = v;
            }
            true
        } else if s.max.contains(&i) {
            self.mins.get(i - s.max.start).is_some_and(|lo| *lo <= v)
        } else if s.variances.contains(&i) {
            v >= 0.0
        } else if i == self.diagonal && s.factor.contains(&i) {
            // Row r's diagonal is r + 1 numbers after row r − 1's, in the packed rows.
            self.row += 1;
            self.diagonal += self.row + 1;
            v > 0.0
        } else {
            true
        };
        self.valid &= ok;
    }

    fn verdict(&self) -> Result<(), BlobError> {
        match self.non_finite {
            Some(i) => Err(BlobError::NonFinite(i)),
            None if self.valid => Ok(()),
            None => Err(BlobError::InvalidParameter),
        }
    }
}

/// Reads a model payload of format `version` and `dims` (a blob's, or one channel's of a unit
/// blob), checking it as it goes, and hands its numbers to `keep` in order: each number's domain
/// by its section, the sizes against `dims`, the capacities `D` and `E`, the error model and the
/// features, and the numbers against `room`, the storage left for them. Returns the features, the
/// exponents and the error model (none in a blob of format 3 or 4).
#[allow(clippy::type_complexity)]
pub(crate) fn read_numbers<const D: usize, const E: usize>(
    (dims, room): (Dims, usize),
    version: u16,
    payload: &[u8],
    mut keep: impl FnMut(f32) -> Result<(), ()>,
) -> Result<(Vec<Feature, D>, Vec<u8, E>, Option<ErrorModel>), BlobError> {
    capacity(Storage::Inputs, dims.d, D.min(MAX_INPUTS))?;
    capacity(Storage::Exponents, dims.exponents(), E)?;
    capacity(Storage::Floats, dims.floats(), room)?;
    if dims.d == 0 {
        return Err(BlobError::InconsistentDimensions);
    }
    let mut domains = Domains::<D>::new(dims);
    let (features, exponents, error): (Vec<Feature, D>, Vec<u8, E>, _) =
        blob::read_payload(payload, version, |v| {
            domains.see(v);
            keep(v)
        })?;
    if features.len() != dims.d
        || exponents.len() != dims.exponents()
        || domains.seen != dims.floats()
    {
        return Err(BlobError::InconsistentDimensions);
    }
    domains.verdict()?;
    if let Some(e) = &error {
        e.check().map_err(|e| match e {
            // Numbered after the flat array's.
            BlobError::NonFinite(i) => BlobError::NonFinite(dims.floats() + i),
            other => other,
        })?;
    }
    if !features.iter().all(Feature::is_valid) {
        return Err(BlobError::InvalidParameter);
    }
    Ok((features, exponents, error))
}

impl<const D: usize, const E: usize, const N: usize> Default for Model<D, E, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const D: usize, const E: usize, const N: usize> Model<D, E, N> {
    /// Storage that holds no model yet: every prediction is a `Fault` until a blob is decoded
    /// into it ([`Model::decode_into`]).
    pub const fn new() -> Self {
        Self {
            dims: Dims { m: 0, d: 0, p: 0 },
            features: Vec::new(),
            exponents: Vec::new(),
            floats: Vec::new(),
            error: ErrorModel::noise_only(0.0),
        }
    }

    /// Decodes and validates a blob. Every way a blob can be wrong is a [`BlobError`].
    pub fn decode(bytes: &[u8]) -> Result<Self, BlobError> {
        let mut model = Self::new();
        model.decode_into(bytes)?;
        Ok(model)
    }

    /// Decodes and validates a blob into this storage, replacing what it held: the way to
    /// decode into a `static`, since the numbers go straight into place (no copy of the model on
    /// the stack). On an error the storage holds no model.
    pub fn decode_into(&mut self, bytes: &[u8]) -> Result<(), BlobError> {
        self.floats.clear();
        let floats = &mut self.floats;
        match Self::read(bytes, |v| floats.push(v).map_err(|_| ())) {
            Ok((dims, features, exponents, error)) => {
                self.dims = dims;
                self.features = features;
                self.exponents = exponents;
                self.error = error.unwrap_or_else(|| ErrorModel::noise_only(self.variances()[1]));
                Ok(())
            }
            Err(e) => {
                self.clear();
                Err(e)
            }
        }
    }

    /// Empties the storage: it holds no model, as [`Model::new`].
    pub fn clear(&mut self) {
        self.dims = Dims { m: 0, d: 0, p: 0 };
        self.features.clear();
        self.exponents.clear();
        self.floats.clear();
        self.error = ErrorModel::noise_only(0.0);
    }

    /// Checks a blob as [`Model::decode`] does, without storing it: what a calibration update
    /// runs before it writes a blob to flash. Returns the blob's sizes.
    pub fn check(bytes: &[u8]) -> Result<Dims, BlobError> {
        let mut held = 0usize;
        Self::read(bytes, |_| {
            held += 1;
            if held <= N { Ok(()) } else { Err(()) }
        })
        .map(|(dims, ..)| dims)
    }

    /// Reads and checks a blob, handing its numbers to `keep` in order; returns its sizes,
    /// features, exponents and error model (none in a blob of format 3 or 4).
    #[allow(clippy::type_complexity)]
    fn read(
        bytes: &[u8],
        keep: impl FnMut(f32) -> Result<(), ()>,
    ) -> Result<(Dims, Vec<Feature, D>, Vec<u8, E>, Option<ErrorModel>), BlobError> {
        let header = blob::read_header(bytes)?;
        let dims = header.dims;
        let (features, exponents, error) =
            read_numbers::<D, E>((dims, N), header.version, header.payload, keep)?;
        Ok((dims, features, exponents, error))
    }

    /// The evaluator over this storage.
    fn evaluator(&self) -> Evaluator<'_, D> {
        Evaluator {
            dims: self.dims,
            exponents: &self.exponents,
            floats: &self.floats,
            error: self.error,
        }
    }

    /// Model sizes.
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// Input features, in order.
    pub fn features(&self) -> &[Feature] {
        &self.features
    }

    /// The variance besides the latent one (format 3 and 4 blobs: their noise alone).
    pub fn error_model(&self) -> ErrorModel {
        self.error
    }

    /// (σ_f², σ_n²) in output units²: the GP's signal variance, and the noise level of the points
    /// it was fitted on (a sample's own noise is the [`ErrorModel`]'s).
    pub fn variances(&self) -> [f32; 2] {
        self.evaluator().variances()
    }

    /// The trained range of input `k`, raw units: where its data were (beyond it the status is
    /// `Extrapolating`); `None` beyond the inputs.
    pub fn trained_range(&self, k: usize) -> Option<[f32; 2]> {
        self.evaluator().trained_range(k)
    }

    /// Predictive mean only: the cheap path (one exp and about 3·d operations per centre).
    pub fn predict_mean(&self, x: &[f32]) -> Mean {
        self.evaluator().mean_into(x, None).0
    }

    /// The feature pipeline on one raw sample, then [`Self::predict`] on its inputs.
    pub fn compensate(
        &self,
        sample: &Sample,
        state: &mut FeatureState,
        scratch: &mut [f32],
    ) -> Result<Prediction, PredictError> {
        let mut x = [0.0f32; D];
        // `decode` checked d ≤ D, so the inputs always fit.
        let health = features::compute(&self.features, sample, state, &mut x);
        let model = self.evaluator();
        if health == Status::Fault {
            return Ok(model.fault());
        }
        let hours = (state.time_on_s() / SECONDS_PER_HOUR) as f32;
        let mut p = model.predict_at(x.get(..self.dims.d).unwrap_or(&[]), hours, scratch)?;
        p.status = p.status.max(health);
        Ok(p)
    }

    /// [`Self::compensate`]'s mean and status alone, the cheap path (no variance), with e(x)²:
    /// how far the inputs lie beyond the trained range, squared, in length scales (what the
    /// model error's extrapolation term scales; 0 inside the range). The mean and status are
    /// those `compensate` returns for the same sample and state.
    pub fn compensate_mean(&self, sample: &Sample, state: &mut FeatureState) -> (Mean, f32) {
        let mut x = [0.0f32; D];
        let health = features::compute(&self.features, sample, state, &mut x);
        self.evaluator()
            .mean_with(x.get(..self.dims.d).unwrap_or(&[]), health)
    }

    /// Predictive mean and variances at inputs `x`, at power-on (no time term of the model
    /// error: [`Self::predict_at`]). `scratch` must hold at least `m` numbers.
    pub fn predict(&self, x: &[f32], scratch: &mut [f32]) -> Result<Prediction, PredictError> {
        self.predict_at(x, 0.0, scratch)
    }

    /// Predictive mean and variances at inputs `x`, `hours` after power-on. `scratch` must hold
    /// at least `m` numbers.
    pub fn predict_at(
        &self,
        x: &[f32],
        hours: f32,
        scratch: &mut [f32],
    ) -> Result<Prediction, PredictError> {
        self.evaluator().predict_at(x, hours, scratch)
    }
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
    /// The variance besides the latent one.
    pub(crate) error: ErrorModel,
}

impl<const D: usize> Evaluator<'_, D> {
    fn section(&self, range: Range<usize>) -> &[f32] {
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

    /// Normalizes the inputs into `z` and `s = z/ℓ`; returns the status of the inputs and e(x)²,
    /// how far they lie beyond the trained range in its widths, squared ([`ErrorModel`]).
    fn normalize(&self, x: &[f32], z: &mut [f32; D], s: &mut [f32; D]) -> (Status, f32) {
        let sec = self.dims.sections();
        let d = self.dims.d;
        // d = 0: storage that holds no model.
        if d == 0 || d > D || x.len() < d || x.iter().take(d).any(|v| !v.is_finite()) {
            return (Status::Fault, 0.0);
        }
        let mut status = Status::Valid;
        let mut excess2 = 0.0f32;
        let at = |base: usize, k: usize| self.floats.get(base + k).copied().unwrap_or(1.0);
        for (k, (zk, sk)) in z.iter_mut().zip(s.iter_mut()).take(d).enumerate() {
            let xk = x.get(k).copied().unwrap_or(0.0);
            let (lo, hi) = (at(sec.min.start, k), at(sec.max.start, k));
            if xk < lo || xk > hi {
                let span = hi - lo;
                let margin = if span > 0.0 { span } else { lo.abs().max(1.0) };
                if xk < lo - margin || xk > hi + margin {
                    return (Status::Fault, 0.0);
                }
                status = Status::Extrapolating;
                let excess = (lo - xk).max(xk - hi) / margin;
                excess2 += excess * excess;
            }
            *zk = (xk - at(sec.offset.start, k)) / at(sec.scale.start, k);
            *sk = *zk / at(sec.length.start, k);
        }
        (status, excess2)
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

    /// Adds the raw linear terms: `hi·x = p + e` exactly (FMA), so only the final additions round.
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
    /// and its order are the same for every `K`.
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
        for (i, (c, w)) in centres.chunks_exact(K).zip(weights).enumerate() {
            let r2 = s
                .iter()
                .zip(c)
                .fold(0.0f32, |r2, (a, b)| r2 + (a - b) * (a - b));
            let kv = libm::expf(-0.5 * r2);
            if let Some(slot) = k.as_deref_mut().and_then(|k| k.get_mut(i)) {
                *slot = kv;
            }
            acc.add(w * kv);
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
        self.add_prior_mean(zd, &mut acc);
        self.add_raw_linear(x, &mut acc);
        let mean = acc.total();
        let mean = if mean.is_finite() {
            Mean { mean, status }
        } else {
            Mean {
                mean: 0.0,
                status: Status::Fault,
            }
        };
        (mean, excess2)
    }

    /// The mean path at inputs `x` whose health the feature pipeline judged `health`: the mean,
    /// the worse of the two statuses, and e(x)² (a `Fault` anywhere: mean 0).
    pub(crate) fn mean_with(&self, x: &[f32], health: Status) -> (Mean, f32) {
        let fault = Mean {
            mean: 0.0,
            status: Status::Fault,
        };
        if health == Status::Fault {
            return (fault, 0.0);
        }
        let (m, excess2) = self.mean_into(x, None);
        if m.status == Status::Fault {
            return (fault, excess2);
        }
        (
            Mean {
                mean: m.mean,
                status: m.status.max(health),
            },
            excess2,
        )
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

    /// Predictive mean and variances at inputs `x`, `hours` after power-on. `scratch` must hold
    /// at least `m` numbers.
    pub(crate) fn predict_at(
        &self,
        x: &[f32],
        hours: f32,
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
        Ok(Prediction {
            mean,
            bias_variance: signal * rest.total().max(0.0) + self.error.model_error(excess2, hours),
            noise_variance: self.error.sample_noise_var,
            status,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::Reference;

    type Small = Model<2, 6, 64>;

    #[test]
    fn f32_mean_and_variance_follow_the_f64_reference() {
        let r = Reference::small();
        let m = Small::decode(&r.blob()).unwrap();
        let mut scratch = [0.0f32; 8];
        for t in [-30.0f32, -5.0, 12.5, 40.0, 60.0] {
            for v in [-3.0f32, -0.7, 0.0, 0.4, 2.9] {
                let x = [f64::from(t), f64::from(v)];
                let (mean, var) = r.predict(x);
                let hours = 2.5f32;
                let p = m.predict_at(&[t, v], hours, &mut scratch).unwrap();
                let expected = if (-30.0..=60.0).contains(&t) {
                    Status::Valid
                } else {
                    Status::Extrapolating
                };
                assert_eq!(p.status, expected);
                assert!(
                    (f64::from(p.mean) - mean).abs() < 1e-5,
                    "{t} {v}: {} vs {mean}",
                    p.mean
                );
                assert!(p.bias_variance >= 0.0);
                let bias = var + r.model_error(x, f64::from(hours));
                assert!(
                    (f64::from(p.bias_variance) - bias).abs() < 1e-3 * r.signal_var,
                    "{t} {v}: {} vs {bias}",
                    p.bias_variance
                );
                assert_eq!(p.noise_variance, r.error.sample_noise_var);
                assert_eq!(p.variance(), p.bias_variance + p.noise_variance);
                assert_eq!(m.predict_mean(&[t, v]).mean, p.mean);
            }
        }
    }

    #[test]
    fn compensate_runs_the_feature_pipeline() {
        let m = Small::decode(&Reference::small().blob()).unwrap();
        let mut scratch = [0.0f32; 5];
        let sample = Sample {
            time_s: 10.0,
            temp_c: 12.5,
            output: 0.4,
        };
        let p = m
            .compensate(&sample, &mut FeatureState::default(), &mut scratch)
            .unwrap();
        assert_eq!(p, m.predict(&[12.5, 0.4], &mut scratch).unwrap());
    }

    #[test]
    fn variance_vanishes_at_a_centre_and_returns_to_the_prior_far_away() {
        let r = Reference::small();
        let m = Small::decode(&r.blob()).unwrap();
        let mut scratch = [0.0f32; 5];
        let c = r.centres[2];
        let x = [
            (c[0] * r.scale[0] + r.offset[0]) as f32,
            (c[1] * r.scale[1] + r.offset[1]) as f32,
        ];
        let floor = r.error.floor_var;
        let at_centre = m.predict(&x, &mut scratch).unwrap().bias_variance - floor;
        assert!(at_centre < 1e-3 * r.signal_var as f32, "{at_centre}");
        let far = m.predict(&[500.0, 40.0], &mut scratch).unwrap();
        assert_eq!(far.status, Status::Fault);
        let beyond = m.predict(&[100.0, 0.0], &mut scratch).unwrap();
        assert_eq!(beyond.status, Status::Extrapolating);
        // 40 °C beyond a 90 °C range: e² = (40/90)².
        let expected = r.model_error([100.0, 0.0], 0.0) as f32;
        let latent = beyond.bias_variance - expected;
        assert!(latent > 0.5 * r.signal_var as f32, "{latent}");
        assert!((latent - r.signal_var as f32).abs() < 0.05 * r.signal_var as f32);
    }

    #[test]
    fn bad_inputs_are_flagged_never_nan() {
        let m = Small::decode(&Reference::small().blob()).unwrap();
        let mut scratch = [0.0f32; 5];
        for x in [
            [f32::NAN, 0.0],
            [20.0, f32::INFINITY],
            [f32::NEG_INFINITY, 0.0],
        ] {
            let p = m.predict(&x, &mut scratch).unwrap();
            assert_eq!(p.status, Status::Fault);
            assert!(p.mean.is_finite() && p.variance().is_finite());
        }
        assert_eq!(m.predict_mean(&[20.0]).status, Status::Fault);
        let out = m.predict(&[70.0, 0.0], &mut scratch).unwrap();
        assert_eq!(out.status, Status::Extrapolating);
        assert!(out.mean.is_finite());
        assert_eq!(
            m.predict(&[20.0, 0.0], &mut [0.0; 4]),
            Err(PredictError::ScratchTooSmall { needed: 5 })
        );
    }
}
