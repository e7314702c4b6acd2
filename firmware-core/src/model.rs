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
//! bias variance  = var + model error(e(x)², mean, t, s) ([`ErrorModel`])
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
//! with the distance: the model error's extrapolation term e(x)² (and, assumed, its part in
//! proportion to the output, e(x)²·y²), which the trainer fits where its training data show it and
//! otherwise sets from a stated prior ([`ErrorModel`]), over the inputs the kernel or the prior
//! mean reads. An input only its raw linear term reads (an extension's time drift, warm-up,
//! heating/cooling state or temperature rate) adds instead the square of what that term added
//! past the edge: its slope was fitted where its data were, and following it further may be wrong
//! by all it adds there. Counted in e(x)², a time drift's hours grew the σ at the temperature's
//! growth per width: on the simulated room log, a drift fitted on the earlier half and followed
//! over the later half made it 6.6× the error of its 60 s means (1.43 with this term), and where
//! it covered a drift followed back to the power-on, the temperature's growth stood in for the
//! drift's own (docs/uncertainty.md).

use heapless::Vec;

use crate::blob::{self, Beyond, Dims, ErrorModel, Feature, Limits, Read};
use crate::error::{BlobError, PredictError, Storage};
use crate::features::{self, FeatureState, MAX_INPUTS, Sample};
use crate::status::Status;
use evaluate::Evaluator;
pub use evaluate::{Conditions, Mean, Prediction};
pub(crate) use lanes::scratch_len as lanes_scratch_len;
pub use lanes::{Evaluation, LANES, Prepared};

pub(crate) mod evaluate;
#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
mod exp;
mod lanes;

/// Most centres (inducing points, or training points of an exact GP) in a model this project
/// exports: 256 already need about 132 KB of f32 on the microcontroller, the top of a
/// Cortex-M4's RAM. The trainer refuses larger models, the host decodes into this capacity, and
/// the C interface's `FOG_MAX_CENTRES` must not exceed it.
pub const MAX_CENTRES: usize = 256;

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
    let error_numbers = match version {
        blob::V6 => ErrorModel::V6_NUMBERS,
        blob::V7 => ErrorModel::V7_NUMBERS,
        blob::V8 => ErrorModel::V8_NUMBERS,
        _ => ErrorModel::NUMBERS,
    };
    read.limits
        .check()
        .map_err(after(dims.floats() + error_numbers))?;
    // The trained range lies within the limits: the data were readings. The evaluator relies on
    // it, checking the limits only beyond the trained range (and at every reading of an input
    // only linear terms read, whose range, a bias model's output's, may be unbounded). A blob
    // before format 6 states no limits: its trained range is what it held, and is kept.
    let within = version < blob::V6
        || read
            .features
            .iter()
            .zip(domains.mins.iter().zip(&domains.maxs))
            .zip(&domains.linear)
            .filter(|(_, linear)| !**linear)
            .all(|((f, (&lo, &hi)), _)| match f {
                f if f.is_temperature() => {
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

    /// Decodes and validates a model blob, or a unit blob of one channel (its model). Every way a
    /// blob can be wrong is a [`BlobError`]; a unit of several channels is
    /// [`BlobError::CapacityExceeded`] (decode it as a [`crate::unit::Unit`]).
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
        if bytes.get(..4) == Some(&blob::unit::MAGIC[..]) {
            // A unit blob of one channel (what `trainer fit` writes for one channel's data) is
            // that channel's model, as a unit reads a model blob as a unit of one.
            let header = blob::unit::read_header(bytes)?;
            capacity(Storage::Channels, header.channels, 1)?;
            let payload = blob::unit::read_payload::<1>(&header)?;
            let [entry] = payload.channels.as_slice() else {
                return Err(BlobError::Malformed);
            };
            let dims = entry.dims();
            let read = read_numbers::<D, E>((dims, N), header.model_version, entry.model, keep)?;
            if read.error.is_none() {
                return Err(BlobError::Malformed);
            }
            return Ok((dims, read));
        }
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

    /// The feature pipeline on one raw sample: the model's inputs, their health and the
    /// conditions the model error reads, for [`Self::evaluate`] or [`Self::mean_of`].
    pub fn prepare(&self, sample: &Sample, state: &mut FeatureState) -> Prepared<D> {
        let mut x = [0.0f32; D];
        // `decode` checked d ≤ D, so the inputs always fit.
        let health = features::compute(&self.features, sample, state, &mut x);
        Prepared {
            x,
            len: D,
            health,
            at: Conditions::of(state),
        }
    }

    /// The feature pipeline on one raw sample, then [`Self::predict`] on its inputs.
    pub fn compensate(
        &self,
        sample: &Sample,
        state: &mut FeatureState,
        scratch: &mut [f32],
    ) -> Result<Prediction, PredictError> {
        // [`Self::prepare`]'s steps, written out: the Cortex-M4's code of this call stays as it
        // was measured (docs/firmware.md, "Cost on the M4").
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
        self.mean_of(&self.prepare(sample, state))
    }

    /// [`Self::compensate_mean`] of a sample already through the feature pipeline.
    pub fn mean_of(&self, prepared: &Prepared<D>) -> (Mean, f32) {
        self.evaluator()
            .mean_with(prepared.read(self.dims.d), prepared.health)
    }

    /// [`Self::mean_of`] of every `prepared` sample into `out` (as many as both hold), [`LANES`]
    /// side by side as in [`Self::evaluate`]: bit for bit the same.
    pub fn means(&self, prepared: &[Prepared<D>], out: &mut [(Mean, f32)]) {
        self.evaluator().means(prepared, out);
    }

    /// Scratch numbers [`Self::evaluate`] needs: 2 · [`LANES`] · m.
    pub fn evaluate_scratch_len(&self) -> usize {
        self.evaluator().lanes_scratch_len()
    }

    /// Every `prepared` sample's [`Evaluation`] into `out` (as many as both hold), [`LANES`]
    /// side by side: bit for bit what [`Self::compensate`] and [`Self::compensate_mean`] give
    /// each, for a host that replays a stream (the sums of one sample wait on their own
    /// additions, of several they fill the vector registers). `scratch` must hold
    /// [`Self::evaluate_scratch_len`] numbers; a shorter one refuses the batch
    /// ([`PredictError::ScratchTooSmall`]).
    pub fn evaluate(
        &self,
        prepared: &[Prepared<D>],
        scratch: &mut [f32],
        out: &mut [Evaluation],
    ) -> Result<(), PredictError> {
        self.evaluator().evaluate(prepared, scratch, out)
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

#[cfg(test)]
mod tests;
