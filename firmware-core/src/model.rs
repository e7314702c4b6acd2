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
//! bias variance  = var + model error(e(x)², t, s)       ([`ErrorModel`])
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
//! Never panics, never returns NaN. A `Fault` is a reading that cannot be true, and only that:
//! a non-finite or missing input, a temperature outside the sensor's rated range or an output
//! beyond its full scale (the blob's [`Limits`]), or a mean that is not finite, which a blob with
//! absurd but finite numbers could otherwise produce (the mutated-blob test,
//! `tests/mutated_blobs.rs`); it gives mean 0 and the prior variance σ_f². A reading the
//! calibration did not reach is not a fault: beyond the trained range the status is
//! `Extrapolating` and the mean is bounded by one rule, the same on the host, the M4 and in C:
//!
//! ```text
//! the kernel reads every input held at its trained range's edge (its value there, as PX4 and
//! ArduPilot clip the temperature); an input the kernel ignores (an extension's additive input,
//! a fitted slope) follows its value; the prior mean, its raw linear terms included, is, as the
//! blob states ([`Beyond`]):
//!   Hold     at the held inputs (the gyro output's and the time since power-on's linear terms
//!            still follow them: the scale factor, a drift rate)
//!   Tangent  at the held inputs plus its tangent there times the distance: the trend its
//!            coefficients, fitted on all the data, support, to first order
//! or (Follow) nothing is held: the GP's own prediction, its kernel's part fading with the
//! distance and its prior mean followed whole (blobs before format 6)
//! ```
//!
//! so a temperature 10 °C below the coldest trained gives, held, the model's value at the
//! coldest trained temperature, and a rate beyond the table's keeps its scale factor. The σ grows
//! with the distance: the model error's extrapolation term e(x)², which the trainer fits where its
//! training data show it and otherwise sets from a stated prior ([`ErrorModel`]).

use core::ops::Range;

use heapless::Vec;

use crate::blob::{self, Beyond, Dims, ErrorModel, Feature, Limits, Read};
use crate::error::{BlobError, PredictError, Storage};
use crate::features::{self, FeatureState, MAX_INPUTS, Sample};
use crate::status::Status;
use crate::units::SECONDS_PER_HOUR;

/// Most centres (inducing points, or training points of an exact GP) in a model this project
/// exports: 256 already need about 132 KB of f32 on the microcontroller, the top of a
/// Cortex-M4's RAM. The trainer refuses larger models, the host decodes into this capacity, and
/// the C interface's `FOG_MAX_CENTRES` must not exceed it.
pub const MAX_CENTRES: usize = 256;

/// The farthest beyond its trained range an input counts, in the range's widths: a σ grown that
/// far says nothing more than "not this model's", and e(x)² stays finite for any finite input.
const MAX_EXCESS: f32 = 1e3;

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
    limits: Limits,
    beyond: Beyond,
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
    maxs: [f32; D],
    linear: [bool; D],
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
            maxs: [0.0; D],
            linear: [false; D],
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
        if let Some(l) = s
            .length
            .contains(&i)
            .then(|| self.linear.get_mut(i - s.length.start))
            .flatten()
        {
            *l = v >= blob::IGNORED_LENGTH_SCALE;
        }
        let ok = if s.scale.contains(&i) || s.length.contains(&i) {
            v > 0.0
        } else if s.min.contains(&i) {
            if let Some(lo) = self.mins.get_mut(i - s.min.start) {
                *lo = v;
            }
            true
        } else if s.max.contains(&i) {
            if let Some(hi) = self.maxs.get_mut(i - s.max.start) {
                *hi = v;
            }
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
/// by its section, the sizes against `dims`, the capacities `D` and `E`, the error model, the
/// limits and the features, and the numbers against `room`, the storage left for them. Returns
/// the features, the exponents, the error model (none in a blob of format 3 or 4) and the limits.
pub(crate) fn read_numbers<const D: usize, const E: usize>(
    (dims, room): (Dims, usize),
    version: u16,
    payload: &[u8],
    mut keep: impl FnMut(f32) -> Result<(), ()>,
) -> Result<Read<Vec<Feature, D>, Vec<u8, E>>, BlobError> {
    capacity(Storage::Inputs, dims.d, D.min(MAX_INPUTS))?;
    capacity(Storage::Exponents, dims.exponents(), E)?;
    capacity(Storage::Floats, dims.floats(), room)?;
    if dims.d == 0 {
        return Err(BlobError::InconsistentDimensions);
    }
    let mut domains = Domains::<D>::new(dims);
    let read: Read<Vec<Feature, D>, Vec<u8, E>> = blob::read_payload(payload, version, |v| {
        domains.see(v);
        keep(v)
    })?;
    if read.features.len() != dims.d
        || read.exponents.len() != dims.exponents()
        || domains.seen != dims.floats()
    {
        return Err(BlobError::InconsistentDimensions);
    }
    domains.verdict()?;
    // Numbered after the flat array's.
    let after = |at: usize| {
        move |e| match e {
            BlobError::NonFinite(i) => BlobError::NonFinite(at + i),
            other => other,
        }
    };
    if let Some(e) = &read.error {
        e.check().map_err(after(dims.floats()))?;
    }
    read.limits
        .check()
        .map_err(after(dims.floats() + ErrorModel::NUMBERS))?;
    // The trained range lies within the limits: the data were readings. The evaluator relies on
    // it, checking the limits only beyond the trained range (and at every reading of an input
    // only linear terms read, whose range, a bias model's output's, may be unbounded). A blob
    // before format 6 states no limits: its trained range is what it held, and is kept.
    let within = version < blob::FORMAT_VERSION
        || read
            .features
            .iter()
            .zip(domains.mins.iter().zip(&domains.maxs))
            .zip(&domains.linear)
            .filter(|(_, linear)| !**linear)
            .all(|((f, (&lo, &hi)), _)| match f {
                Feature::Temperature | Feature::CoilTemperature { .. } => {
                    read.limits.temperature_ok(lo) && read.limits.temperature_ok(hi)
                }
                Feature::Voltage => read.limits.output_ok(lo) && read.limits.output_ok(hi),
                _ => true,
            });
    if !within {
        return Err(BlobError::InvalidParameter);
    }
    if !read.features.iter().all(Feature::is_valid) {
        return Err(BlobError::InvalidParameter);
    }
    Ok(read)
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
            limits: Limits::DEFAULT,
            beyond: Beyond::Hold,
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
            Ok((dims, read)) => {
                self.dims = dims;
                self.features = read.features;
                self.exponents = read.exponents;
                self.limits = read.limits;
                self.beyond = read.beyond;
                self.error = read
                    .error
                    .unwrap_or_else(|| ErrorModel::noise_only(self.variances()[1]));
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
        self.limits = Limits::DEFAULT;
        self.beyond = Beyond::Hold;
    }

    /// Checks a blob as [`Model::decode`] does, without storing it: what a calibration update
    /// runs before it writes a blob to flash. Returns the blob's sizes.
    pub fn check(bytes: &[u8]) -> Result<Dims, BlobError> {
        let mut held = 0usize;
        Self::read(bytes, |_| {
            held += 1;
            if held <= N { Ok(()) } else { Err(()) }
        })
        .map(|(dims, _)| dims)
    }

    /// Reads and checks a blob, handing its numbers to `keep` in order; returns its sizes and
    /// what [`read_numbers`] read.
    #[allow(clippy::type_complexity)]
    fn read(
        bytes: &[u8],
        keep: impl FnMut(f32) -> Result<(), ()>,
    ) -> Result<(Dims, Read<Vec<Feature, D>, Vec<u8, E>>), BlobError> {
        let header = blob::read_header(bytes)?;
        let dims = header.dims;
        let read = read_numbers::<D, E>((dims, N), header.version, header.payload, keep)?;
        Ok((dims, read))
    }

    /// The evaluator over this storage.
    fn evaluator(&self) -> Evaluator<'_, D> {
        Evaluator {
            dims: self.dims,
            exponents: &self.exponents,
            floats: &self.floats,
            features: &self.features,
            error: &self.error,
            limits: &self.limits,
            beyond: self.beyond,
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

    /// What a reading that cannot be true is ([`Limits::DEFAULT`] for blobs before format 6).
    pub fn limits(&self) -> Limits {
        self.limits
    }

    /// What the mean does beyond the trained range ([`Beyond::Follow`] for blobs before format
    /// 6).
    pub fn beyond(&self) -> Beyond {
        self.beyond
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
        let at = Conditions::of(state);
        let mut p = model.predict_in(x.get(..self.dims.d).unwrap_or(&[]), at, scratch)?;
        p.status = p.status.max(health);
        Ok(p)
    }

    /// [`Self::compensate`]'s mean and status alone, the cheap path (no variance), with e(x)²:
    /// how far the inputs lie beyond the trained range, squared, in length scales (what the
    /// model error's extrapolation term scales; 0 inside the range). The mean and status are
    /// those `compensate` returns for the same sample and state (but for a blob of absurd numbers
    /// whose variance overflows, which `compensate` calls a `Fault`).
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

    /// Predictive mean and variances at inputs `x`, `hours` after power-on, on a heating/cooling
    /// state the calibration held (no leg term: [`Conditions`]). `scratch` must hold at least `m`
    /// numbers.
    pub fn predict_at(
        &self,
        x: &[f32],
        hours: f32,
        scratch: &mut [f32],
    ) -> Result<Prediction, PredictError> {
        self.evaluator()
            .predict_in(x, Conditions::at_hours(hours), scratch)
    }

    /// Predictive mean and variances at inputs `x` in the service conditions `at` (time since
    /// power-on, heating/cooling state). `scratch` must hold at least `m` numbers.
    pub fn predict_in(
        &self,
        x: &[f32],
        at: Conditions,
        scratch: &mut [f32],
    ) -> Result<Prediction, PredictError> {
        self.evaluator().predict_in(x, at, scratch)
    }
}

/// What the model error reads of a sample besides its inputs: the hours since power-on and the
/// heating/cooling state ([`ErrorModel`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Conditions {
    /// Hours since power-on.
    pub hours: f32,
    /// Heating/cooling state in [−1, 1] ([`FeatureState::leg`]); `None`: one the calibration
    /// held (no leg term).
    pub leg: Option<f32>,
    /// Whether another power-on's bias applies (the turn-on term): always in service; not on
    /// the calibration's own power-on ([`FeatureState::calibration_run`]).
    pub another_power_on: bool,
}

impl Conditions {
    /// `hours` after power-on, on a heating/cooling state the calibration held.
    pub const fn at_hours(hours: f32) -> Self {
        Self {
            hours,
            leg: None,
            another_power_on: true,
        }
    }

    /// Those of the sample a feature state has just computed.
    pub fn of(state: &FeatureState) -> Self {
        Self {
            hours: (state.time_on_s() / SECONDS_PER_HOUR) as f32,
            leg: Some(state.leg()),
            another_power_on: !state.in_calibration_run(),
        }
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

    /// Normalizes the inputs into `z` and `s = z/ℓ`, each held at its trained range's edge as the
    /// blob's rule says (module doc); returns the status of the inputs and e(x)², how far they lie
    /// beyond the trained range in its widths, squared ([`ErrorModel`]). A reading that cannot be
    /// true ([`Limits`]) is a `Fault`.
    fn normalize(&self, x: &[f32], z: &mut [f32; D], s: &mut [f32; D]) -> (Status, f32) {
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
            Some(Feature::Temperature | Feature::CoilTemperature { .. }) => {
                self.limits.temperature_ok(xk)
            }
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
        // data: it follows its value, as every input does under `Follow`.
        let linear = length >= blob::IGNORED_LENGTH_SCALE;
        let held = if !linear && self.beyond != Beyond::Follow {
            clamped
        } else {
            xk
        };
        // A positive excess marks the input extrapolating, however small.
        Some((held, excess.max(f32::MIN_POSITIVE)))
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
        if status == Status::Extrapolating {
            self.add_beyond(x, zd, &mut acc);
        } else {
            self.add_raw_linear(x, &mut acc);
        }
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
        let bias_variance = signal * rest.total().max(0.0) + self.error.model_error(excess2, at);
        if !bias_variance.is_finite() {
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
        // The first sample: power-on, the heating/cooling play centred (state 0).
        let at = Conditions {
            hours: 0.0,
            leg: Some(0.0),
            another_power_on: true,
        };
        assert_eq!(p, m.predict_in(&[12.5, 0.4], at, &mut scratch).unwrap());
    }

    #[test]
    fn the_calibrations_own_power_on_leaves_out_another_ones_bias() {
        let r = Reference::small();
        let m = Small::decode(&r.blob()).unwrap();
        let mut scratch = [0.0f32; 5];
        let sample = Sample {
            time_s: 10.0,
            temp_c: 12.5,
            output: 0.4,
        };
        let (mut service, mut own) = (FeatureState::default(), FeatureState::default());
        own.calibration_run();
        let a = m.compensate(&sample, &mut service, &mut scratch).unwrap();
        let b = m.compensate(&sample, &mut own, &mut scratch).unwrap();
        assert_eq!(a.mean, b.mean);
        let gap = a.bias_variance - b.bias_variance;
        let expected = r.error.turn_on_var;
        assert!((gap - expected).abs() < 1e-3 * expected, "{gap} {expected}");
        // After a power cycle every power-on is another.
        own.power_on();
        assert!(!own.in_calibration_run());
        let later = Sample {
            time_s: 500.0,
            ..sample
        };
        let c = m.compensate(&later, &mut own, &mut scratch).unwrap();
        assert!(
            (c.bias_variance - a.bias_variance).abs() < 1e-3 * expected,
            "{c:?} {a:?}"
        );
    }

    #[test]
    fn variance_vanishes_at_a_centre_and_grows_with_the_distance_beyond_the_range() {
        let r = Reference::small();
        let m = Small::decode(&r.blob()).unwrap();
        let mut scratch = [0.0f32; 5];
        let c = r.centres[2];
        let x = [
            (c[0] * r.scale[0] + r.offset[0]) as f32,
            (c[1] * r.scale[1] + r.offset[1]) as f32,
        ];
        let floor = r.error.floor_var + r.error.turn_on_var;
        let at_centre = m.predict(&x, &mut scratch).unwrap().bias_variance - floor;
        assert!(at_centre < 1e-3 * r.signal_var as f32, "{at_centre}");
        // 40 °C beyond a 90 °C range: the mean and latent variance of the edge, e² = (40/90)².
        let edge = m.predict(&[60.0, 0.0], &mut scratch).unwrap();
        let beyond = m.predict(&[100.0, 0.0], &mut scratch).unwrap();
        assert_eq!(beyond.status, Status::Extrapolating);
        assert_eq!(beyond.mean, edge.mean);
        let grown = beyond.bias_variance - edge.bias_variance;
        let expected = r.error.extrapolation_var * (40.0f32 / 90.0).powi(2);
        assert!(
            (grown - expected).abs() < 1e-3 * expected,
            "{grown} {expected}"
        );
        // Further out, σ keeps growing and the mean stays the edge's.
        let far = m.predict(&[120.0, 0.0], &mut scratch).unwrap();
        assert_eq!(far.status, Status::Extrapolating);
        assert_eq!(far.mean, edge.mean);
        assert!(far.bias_variance > beyond.bias_variance);
    }

    #[test]
    fn beyond_the_range_the_output_keeps_its_scale_factor_and_the_temperature_is_held() {
        let r = Reference::small();
        let m = Small::decode(&r.blob()).unwrap();
        // The output's raw linear term follows it past the trained ±3: its slope stays the
        // scale factor's, while the kernel and prior read the edge.
        let at = |t: f32, v: f32| m.predict_mean(&[t, v]);
        let edge = at(20.0, 3.0);
        let beyond = at(20.0, 4.0);
        assert_eq!(beyond.status, Status::Extrapolating);
        let slope = beyond.mean - edge.mean;
        let scale = r.raw[1] as f32;
        assert!((slope - scale).abs() < 1e-4 * scale, "{slope} {scale}");
        // A temperature below the coldest trained is held there, linear term included.
        assert_eq!(at(-45.0, 0.5).mean, at(-30.0, 0.5).mean);
        assert_eq!(at(-45.0, 0.5).status, Status::Extrapolating);
    }

    #[test]
    fn an_input_only_linear_terms_read_follows_its_value_beyond_the_range() {
        // The second input as an extension's additive one: ignored by the kernel, its slope the
        // raw linear coefficient.
        let mut r = Reference::small();
        r.length[1] = f64::from(blob::IGNORED_LENGTH_SCALE);
        let features = [
            Feature::Temperature,
            Feature::TemperatureRate { tau_s: 60.0 },
        ];
        let m = Small::decode(&r.blob_of(features)).unwrap();
        let at = |rate: f32| m.predict_mean(&[20.0, rate]);
        let (edge, beyond) = (at(3.0), at(5.0));
        assert_eq!(beyond.status, Status::Extrapolating);
        let slope = (beyond.mean - edge.mean) / 2.0;
        // Its raw linear term and its prior monomial 0.5·z, both followed.
        let expected = (r.raw[1] + r.prior[2] / r.scale[1]) as f32;
        assert!(
            (slope - expected).abs() < 1e-3 * expected,
            "{slope} {expected}"
        );
    }

    #[test]
    fn the_tangent_continues_the_prior_mean_from_the_edge_to_first_order() {
        let r = Reference::small();
        let mut b = r.blob();
        blob::set_beyond(&mut b, Beyond::Tangent).unwrap();
        let m = Small::decode(&b).unwrap();
        let held = Small::decode(&r.blob()).unwrap();
        // 10 °C above the trained 60 °C at V = 0.5: the held value plus the prior's slope in T
        // (its z_T monomial's coefficient over T's scale, and the raw term) times 10 °C.
        let (edge, beyond) = (m.predict_mean(&[60.0, 0.5]), m.predict_mean(&[70.0, 0.5]));
        assert_eq!(beyond.status, Status::Extrapolating);
        let slope = (r.prior[1] / r.scale[0] + r.raw[0]) as f32;
        let expected = edge.mean + 10.0 * slope;
        assert!(
            (beyond.mean - expected).abs() < 1e-5,
            "{} {expected}",
            beyond.mean
        );
        // Held, the same sample is the edge's value.
        assert_eq!(held.predict_mean(&[70.0, 0.5]).mean, edge.mean);
    }

    #[test]
    fn only_a_reading_that_cannot_be_true_is_a_fault() {
        let r = Reference::small();
        let mut b = r.blob();
        let limits = Limits {
            temp_min_c: -40.0,
            temp_max_c: 85.0,
            full_scale: 5.0,
        };
        blob::set_limits(&mut b, &limits).unwrap();
        let m = Small::decode(&b).unwrap();
        let mut scratch = [0.0f32; 5];
        // Far from the calibration (−30…60 °C, ±3), inside the sensor's limits: a reading.
        for x in [[-40.0f32, 0.0], [85.0, 0.0], [20.0, 5.0], [20.0, -5.0]] {
            let p = m.predict(&x, &mut scratch).unwrap();
            assert_eq!(p.status, Status::Extrapolating, "{x:?}");
            assert!(p.mean.is_finite() && p.mean != 0.0 && p.bias_variance.is_finite());
        }
        for x in [[-40.5f32, 0.0], [85.5, 0.0], [20.0, 5.5], [20.0, -5.5]] {
            assert_eq!(
                m.predict(&x, &mut scratch).unwrap().status,
                Status::Fault,
                "{x:?}"
            );
        }
        // The default limits: −55…125 °C, no full scale.
        let m = Small::decode(&r.blob()).unwrap();
        assert_eq!(m.predict_mean(&[-55.0, 1e6]).status, Status::Extrapolating);
        assert_eq!(m.predict_mean(&[-55.5, 0.0]).status, Status::Fault);
        assert_eq!(m.predict_mean(&[125.5, 0.0]).status, Status::Fault);
    }

    #[test]
    fn a_bias_models_unbounded_output_is_still_held_to_its_full_scale() {
        // The output as a bias model carries it: read by its linear term alone, at any value.
        let mut r = Reference::small();
        r.length[1] = f64::from(blob::IGNORED_LENGTH_SCALE);
        r.min[1] = -1e30;
        r.max[1] = 1e30;
        let mut b = r.blob();
        let limits = Limits {
            full_scale: 5.0,
            ..Limits::DEFAULT
        };
        blob::set_limits(&mut b, &limits).unwrap();
        let m = Small::decode(&b).unwrap();
        assert_eq!(m.predict_mean(&[20.0, 4.0]).status, Status::Valid);
        assert_eq!(m.predict_mean(&[20.0, -5.5]).status, Status::Fault);
    }

    #[test]
    fn a_heating_cooling_state_the_calibration_did_not_hold_grows_the_variance() {
        let r = Reference::small();
        let m = Small::decode(&r.blob()).unwrap();
        let mut scratch = [0.0f32; 5];
        let mut at = |leg| {
            m.predict_in(
                &[20.0, 0.5],
                Conditions {
                    hours: 1.0,
                    leg,
                    another_power_on: true,
                },
                &mut scratch,
            )
            .unwrap()
        };
        // Trained on states 0.5…1 (heating): a full cooling state is 1.5 of the swing of 2 away.
        let trained = at(None);
        assert_eq!(at(Some(0.75)), trained);
        let cooling = at(Some(-1.0));
        let grown = cooling.bias_variance - trained.bias_variance;
        let expected = r.error.leg_var * 0.75 * 0.75;
        assert!(
            (grown - expected).abs() < 1e-3 * expected,
            "{grown} {expected}"
        );
        assert_eq!(cooling.mean, trained.mean);
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
        // Past the trained span's width, still a reading (it was a fault up to format 5).
        let out = m.predict(&[-125.0 + 70.0, 0.0], &mut scratch).unwrap();
        assert_eq!(out.status, Status::Extrapolating);
        assert_eq!(
            m.predict(&[20.0, 0.0], &mut [0.0; 4]),
            Err(PredictError::ScratchTooSmall { needed: 5 })
        );
    }
}
