//! A sensor unit's calibration, decoded: every channel's model in fixed-size storage (the blob
//! format is [`crate::blob::unit`]), and every channel's mean and variances for one sample in one
//! call.
//!
//! What the channels share is computed once per sample: the time since power-on, the health of
//! the time base and of the temperature reading, and every temperature input ([`Feature`]s other
//! than the gyro output) that any channel uses, each distinct one a single filter in one
//! [`FeatureState`] for the whole unit. A channel's own output is its `Voltage` input. Each
//! channel is then evaluated by the same code as a model decoded alone ([`crate::model`]), so its
//! mean and variances are those of its own blob, bit for bit, for the same samples. Two things
//! differ, by design: a status of `Degraded` after a time anomaly lasts until the slowest filter
//! of the whole unit has settled (one state, one settling time), and an output that is not a
//! number faults its own channel only, while the shared state goes on with the others.
//!
//! A model blob of the single-channel format still decodes, as a unit of one channel named
//! [`SINGLE_CHANNEL`] measuring angular rate, with no sensor ID and the temperature range of its
//! temperature input: firmware written against this type loads the blobs of earlier trainers.
//!
//! Capacities are the integrator's: `C` channels, `D` inputs and `E` prior-mean exponents per
//! channel, and the storage `S` of every channel's numbers together ([`Numbers`]: a
//! `heapless::Vec<f32, N>` on the microcontroller, where `N` is the sum of the channels'
//! [`Dims::floats`]). A blob beyond any of them is refused with
//! [`BlobError::CapacityExceeded`] before anything is stored.

use heapless::{String, Vec};

use crate::blob::unit::{self as format, NAME_BYTES, SENSOR_ID_BYTES};
use crate::blob::{self, Beyond, Dims, ErrorModel, Feature, Limits};
use crate::error::{BlobError, PredictError, Storage};
use crate::features::{self, FeatureState, MAX_FEATURES, MAX_INPUTS, Sample};
use crate::model::evaluate::Evaluator;
use crate::model::{
    Conditions, Evaluation, Mean, Prediction, Prepared, capacity, lanes_scratch_len, read_numbers,
};
use crate::status::Status;
use crate::units::Quantity;

/// The name a model blob of the single-channel format gets when decoded as a unit.
pub const SINGLE_CHANNEL: &str = "rate";

/// Where a unit keeps its channels' numbers: a fixed-capacity vector on the microcontroller; the
/// host's bench keeps them in a growable one.
pub trait Numbers {
    /// Most numbers it holds.
    const CAPACITY: usize;
    /// Forgets every number.
    fn clear(&mut self);
    /// Appends a number; `false` (and nothing stored) when full.
    fn push(&mut self, v: f32) -> bool;
    /// The numbers held.
    fn as_slice(&self) -> &[f32];
}

impl<const N: usize> Numbers for Vec<f32, N> {
    const CAPACITY: usize = N;

    fn clear(&mut self) {
        Vec::clear(self);
    }

    fn push(&mut self, v: f32) -> bool {
        Vec::push(self, v).is_ok()
    }

    fn as_slice(&self) -> &[f32] {
        self
    }
}

/// Where one model input of a channel comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Input {
    /// The unit's shared feature of this index.
    Shared(u8),
    /// The channel's own output.
    Output,
}

/// One channel of a decoded unit: its name, what it measures, and its model.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel<const D: usize, const E: usize> {
    name: String<NAME_BYTES>,
    quantity: Quantity,
    dims: Dims,
    features: Vec<Feature, D>,
    exponents: Vec<u8, E>,
    error: ErrorModel,
    limits: Limits,
    beyond: Beyond,
    /// Its first number in the unit's storage.
    start: usize,
    inputs: [Input; D],
}

impl<const D: usize, const E: usize> Channel<D, E> {
    /// Its name (`gyro.x`, `acc.z`, …).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// What it measures: the unit of its means and variances.
    pub fn quantity(&self) -> Quantity {
        self.quantity
    }

    /// Its model's sizes.
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// Its model's inputs, in order (`Voltage` is the channel's own output).
    pub fn features(&self) -> &[Feature] {
        &self.features
    }

    /// The variance its predictions hold besides the latent one.
    pub fn error_model(&self) -> ErrorModel {
        self.error
    }

    /// What a reading that cannot be true is, for it.
    pub fn limits(&self) -> Limits {
        self.limits
    }
}

/// A unit whose numbers are in a fixed-capacity vector of `N`: what a microcontroller declares,
/// typically as a `static` ([`Unit::new`] is `const`).
pub type StaticUnit<const C: usize, const D: usize, const E: usize, const N: usize> =
    Unit<C, D, E, Vec<f32, N>>;

/// One raw sample of a unit: the time and temperature its channels share, and every channel's
/// output, in the unit's channel order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnitSample<'a> {
    /// Time, s (as [`Sample::time_s`]: a clock that runs through power-offs where the state is
    /// kept).
    pub time_s: f64,
    /// Temperature-sensor reading, °C.
    pub temp_c: f32,
    /// Each channel's output, in channel order.
    pub outputs: &'a [f32],
}

/// A decoded unit in fixed-size storage (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct Unit<const C: usize, const D: usize, const E: usize, S> {
    sensor_id: String<SENSOR_ID_BYTES>,
    temperature_c: [f32; 2],
    shared: Vec<Feature, MAX_FEATURES>,
    channels: Vec<Channel<D, E>, C>,
    numbers: S,
}

/// A unit blob's parts as read: the sensor's ID and trained temperature range.
struct Identity {
    sensor_id: String<SENSOR_ID_BYTES>,
    temperature_c: [f32; 2],
}

/// A channel as read, its numbers from `start` in the unit's storage, before its inputs are
/// known.
fn channel<const D: usize, const E: usize>(
    name: &str,
    quantity: Quantity,
    dims: Dims,
    (features, exponents, error, limits, beyond): (
        Vec<Feature, D>,
        Vec<u8, E>,
        ErrorModel,
        Limits,
        Beyond,
    ),
    start: usize,
) -> Result<Channel<D, E>, BlobError> {
    Ok(Channel {
        name: String::try_from(name).map_err(|_| BlobError::InvalidParameter)?,
        quantity,
        dims,
        features,
        exponents,
        error,
        limits,
        beyond,
        start,
        inputs: [Input::Output; D],
    })
}

impl<const C: usize, const D: usize, const E: usize, const N: usize> Default
    for Unit<C, D, E, Vec<f32, N>>
{
    fn default() -> Self {
        Self::new()
    }
}

impl<const C: usize, const D: usize, const E: usize, const N: usize> Unit<C, D, E, Vec<f32, N>> {
    /// Storage for `N` numbers that holds no unit yet: every call sees no channel until a blob
    /// is decoded into it ([`Unit::decode_into`]).
    pub const fn new() -> Self {
        Self::with_numbers(Vec::new())
    }
}

impl<const C: usize, const D: usize, const E: usize, S: Numbers> Unit<C, D, E, S> {
    /// Storage that holds no unit yet, its numbers kept in `numbers` (empty).
    pub const fn with_numbers(numbers: S) -> Self {
        Self {
            sensor_id: String::new(),
            temperature_c: [0.0; 2],
            shared: Vec::new(),
            channels: Vec::new(),
            numbers,
        }
    }

    /// Empties the storage: it holds no unit.
    pub fn clear(&mut self) {
        self.sensor_id.clear();
        self.temperature_c = [0.0; 2];
        self.shared.clear();
        self.channels.clear();
        self.numbers.clear();
    }

    /// Decodes and validates a unit blob, or a model blob as a unit of one channel (module doc),
    /// into this storage, replacing what it held; the numbers go straight into place. On an error
    /// the storage holds no unit.
    pub fn decode_into(&mut self, bytes: &[u8]) -> Result<(), BlobError> {
        self.clear();
        let numbers = &mut self.numbers;
        let channels = &mut self.channels;
        let read = Self::read(
            bytes,
            |v| if numbers.push(v) { Ok(()) } else { Err(()) },
            |c| channels.push(c).map_err(|_| ()),
        );
        match read.and_then(|id| self.link(id)) {
            Ok(()) => Ok(()),
            Err(e) => {
                self.clear();
                Err(e)
            }
        }
    }

    /// Checks a blob as [`Unit::decode_into`] does, without storing it: what a calibration update
    /// runs before it writes a blob to flash. Returns the number of channels.
    pub fn check(bytes: &[u8]) -> Result<usize, BlobError> {
        let (mut held, mut channels) = (0usize, 0usize);
        Self::read(
            bytes,
            |_| {
                held += 1;
                if held <= S::CAPACITY { Ok(()) } else { Err(()) }
            },
            |_| {
                channels += 1;
                Ok(())
            },
        )?;
        Ok(channels)
    }

    /// Reads and checks a blob, handing each number and then each channel on in order; returns the
    /// sensor's ID and temperature range.
    fn read(
        bytes: &[u8],
        mut number: impl FnMut(f32) -> Result<(), ()>,
        mut keep: impl FnMut(Channel<D, E>) -> Result<(), ()>,
    ) -> Result<Identity, BlobError> {
        if bytes.get(..4) == Some(&blob::MAGIC[..]) {
            let header = blob::read_header(bytes)?;
            // A format 3 or 4 blob states no error model: its noise variance is its sample noise.
            let noise_at = header.dims.sections().variances.start + 1;
            let (mut at, mut noise) = (0usize, 0.0f32);
            let read = read_numbers::<D, E>(
                (header.dims, S::CAPACITY),
                header.version,
                header.payload,
                |v| {
                    if at == noise_at {
                        noise = v;
                    }
                    at += 1;
                    number(v)
                },
            )?;
            let error = read.error.unwrap_or(ErrorModel::noise_only(noise));
            let ch = channel(
                SINGLE_CHANNEL,
                Quantity::AngularRate,
                header.dims,
                (
                    read.features,
                    read.exponents,
                    error,
                    read.limits,
                    read.beyond,
                ),
                0,
            )?;
            keep(ch).map_err(|()| BlobError::CapacityExceeded {
                what: Storage::Channels,
                needed: 1,
                capacity: C,
            })?;
            // Its temperature input's trained range, once its numbers are in place (`link`).
            return Ok(Identity {
                sensor_id: String::new(),
                temperature_c: [f32::MIN, f32::MAX],
            });
        }
        let header = format::read_header(bytes)?;
        capacity(Storage::Channels, header.channels, C)?;
        let payload = format::read_payload::<C>(&header)?;
        capacity(Storage::Floats, payload.numbers as usize, S::CAPACITY)?;
        let mut used = 0usize;
        for entry in &payload.channels {
            let dims = entry.dims();
            let read = read_numbers::<D, E>(
                (dims, S::CAPACITY - used),
                header.model_version,
                entry.model,
                &mut number,
            )?;
            let error = read.error.ok_or(BlobError::Malformed)?;
            let ch = channel(
                entry.name,
                entry.quantity,
                dims,
                (
                    read.features,
                    read.exponents,
                    error,
                    read.limits,
                    read.beyond,
                ),
                used,
            )?;
            used += dims.floats();
            keep(ch).map_err(|()| BlobError::Malformed)?;
        }
        Ok(Identity {
            sensor_id: String::try_from(payload.sensor_id)
                .map_err(|_| BlobError::InvalidParameter)?,
            temperature_c: payload.temperature_c,
        })
    }

    /// With the channels and numbers in place: the identity (a single-channel blob's temperature
    /// range from its numbers), and the shared features with each input's source.
    fn link(&mut self, id: Identity) -> Result<(), BlobError> {
        self.sensor_id = id.sensor_id;
        self.temperature_c = id.temperature_c;
        for ch in &mut self.channels {
            for (input, feature) in ch.inputs.iter_mut().zip(&ch.features) {
                *input = if *feature == Feature::Voltage {
                    Input::Output
                } else {
                    let at = match self.shared.iter().position(|f| f == feature) {
                        Some(at) => at,
                        None => {
                            self.shared.push(*feature).map_err(|_| {
                                BlobError::CapacityExceeded {
                                    what: Storage::Features,
                                    needed: self.shared.len() + 1,
                                    capacity: MAX_FEATURES,
                                }
                            })?;
                            self.shared.len() - 1
                        }
                    };
                    Input::Shared(u8::try_from(at).map_err(|_| BlobError::InvalidParameter)?)
                };
            }
        }
        if self.temperature_c == [f32::MIN, f32::MAX]
            && let [ch] = self.channels.as_slice()
            && let Some(k) = ch.features.iter().position(|f| *f == Feature::Temperature)
            && let Some(range) = self.evaluator(ch).trained_range(k)
        {
            // A single-channel blob: its temperature input's trained range.
            self.temperature_c = range;
        }
        Ok(())
    }

    /// The channels, in order (none before a blob is decoded).
    pub fn channels(&self) -> &[Channel<D, E>] {
        &self.channels
    }

    /// The sensor's ID the blob was calibrated for (empty for a single-channel blob).
    pub fn sensor_id(&self) -> &str {
        &self.sensor_id
    }

    /// The trained temperature range, °C: where every channel was calibrated.
    pub fn temperature_range(&self) -> [f32; 2] {
        self.temperature_c
    }

    /// The features computed once per sample for every channel, in the order of the state's
    /// filters.
    pub fn shared_features(&self) -> &[Feature] {
        &self.shared
    }

    /// The variance scratch a sample needs: the most centres of any channel.
    pub fn scratch_len(&self) -> usize {
        self.channels.iter().map(|c| c.dims.m).max().unwrap_or(0)
    }

    fn evaluator<'a>(&'a self, ch: &'a Channel<D, E>) -> Evaluator<'a, D> {
        Evaluator {
            dims: ch.dims,
            exponents: &ch.exponents,
            floats: self
                .numbers
                .as_slice()
                .get(ch.start..ch.start + ch.dims.floats())
                .unwrap_or(&[]),
            features: &ch.features,
            error: &ch.error,
            limits: &ch.limits,
            beyond: ch.beyond,
        }
    }

    /// The shared features of one sample (advancing `state`), their health and the sample's
    /// conditions; refuses fewer outputs than channels, or fewer result slots.
    fn shared(
        &self,
        sample: &UnitSample<'_>,
        state: &mut FeatureState,
        results: usize,
    ) -> Result<(Status, [f32; MAX_FEATURES], Conditions), PredictError> {
        let c = self.channels.len();
        if sample.outputs.len() < c {
            return Err(PredictError::TooFewOutputs { needed: c });
        }
        if results < c {
            return Err(PredictError::ResultsTooShort { needed: c });
        }
        let mut values = [0.0f32; MAX_FEATURES];
        let raw = Sample {
            time_s: sample.time_s,
            temp_c: sample.temp_c,
            output: 0.0,
        };
        let health = features::compute(&self.shared, &raw, state, &mut values);
        Ok((health, values, Conditions::of(state)))
    }

    /// Channel `ch`'s inputs from the shared values and its output; `None` where either is not
    /// usable (a `Fault` of the shared pipeline, an output that is not a number).
    fn inputs(
        ch: &Channel<D, E>,
        shared: &[f32; MAX_FEATURES],
        output: f32,
        health: Status,
    ) -> Option<[f32; MAX_INPUTS]> {
        if health == Status::Fault || !output.is_finite() {
            return None;
        }
        let mut x = [0.0f32; MAX_INPUTS];
        for (slot, input) in x.iter_mut().zip(&ch.inputs).take(ch.dims.d) {
            *slot = match *input {
                Input::Output => output,
                Input::Shared(k) => shared.get(usize::from(k)).copied().unwrap_or(f32::NAN),
            };
        }
        Some(x)
    }

    /// Every channel's mean and variances for one sample, through the unit's one feature state
    /// (module doc), into `out` (one per channel, in channel order); returns the number of
    /// channels. `scratch` holds at least [`Self::scratch_len`] numbers, `sample.outputs` and
    /// `out` at least one per channel.
    pub fn compensate(
        &self,
        sample: &UnitSample<'_>,
        state: &mut FeatureState,
        scratch: &mut [f32],
        out: &mut [Prediction],
    ) -> Result<usize, PredictError> {
        let needed = self.scratch_len();
        if scratch.len() < needed {
            return Err(PredictError::ScratchTooSmall { needed });
        }
        let (health, shared, at) = self.shared(sample, state, out.len())?;
        for ((ch, slot), &output) in self.channels.iter().zip(out.iter_mut()).zip(sample.outputs) {
            let model = self.evaluator(ch);
            *slot = match Self::inputs(ch, &shared, output, health) {
                None => model.fault(),
                Some(x) => {
                    let mut p = model.predict_in(x.get(..ch.dims.d).unwrap_or(&[]), at, scratch)?;
                    p.status = p.status.max(health);
                    p
                }
            };
        }
        Ok(self.channels.len())
    }

    /// Every channel's inputs for one sample, through the unit's one feature state (advancing
    /// it), into `out` (one per channel, in channel order), for [`Self::evaluate`]; returns the
    /// number of channels. `sample.outputs` and `out` hold at least one per channel.
    pub fn prepare(
        &self,
        sample: &UnitSample<'_>,
        state: &mut FeatureState,
        out: &mut [Prepared<D>],
    ) -> Result<usize, PredictError> {
        let (health, shared, at) = self.shared(sample, state, out.len())?;
        for ((ch, slot), &output) in self.channels.iter().zip(out.iter_mut()).zip(sample.outputs) {
            *slot = match Self::inputs(ch, &shared, output, health) {
                None => Prepared::judged(&[], Status::Fault, at),
                Some(x) => Prepared::judged(&x, health, at),
            };
        }
        Ok(self.channels.len())
    }

    /// Scratch numbers [`Self::evaluate`] needs: 2 · [`crate::model::LANES`] · the most centres of any channel.
    pub fn evaluate_scratch_len(&self) -> usize {
        lanes_scratch_len(self.scratch_len())
    }

    /// Channel `k`'s [`Evaluation`] of each of its `prepared` samples ([`Self::prepare`]) into
    /// `out` (as many as both hold), [`crate::model::LANES`] side by side ([`crate::Model::evaluate`]): bit for
    /// bit what [`Self::compensate`] and [`Self::compensate_mean`] give it. `None` for no such
    /// channel.
    pub fn evaluate(
        &self,
        k: usize,
        prepared: &[Prepared<D>],
        scratch: &mut [f32],
        out: &mut [Evaluation],
    ) -> Option<Result<(), PredictError>> {
        let ch = self.channels.get(k)?;
        Some(self.evaluator(ch).evaluate(prepared, scratch, out))
    }

    /// [`Self::compensate`]'s means and statuses alone, the cheap path, each with e(x)² (as
    /// [`crate::Model::compensate_mean`]); returns the number of channels.
    pub fn compensate_mean(
        &self,
        sample: &UnitSample<'_>,
        state: &mut FeatureState,
        out: &mut [(Mean, f32)],
    ) -> Result<usize, PredictError> {
        let (health, shared, _) = self.shared(sample, state, out.len())?;
        for ((ch, slot), &output) in self.channels.iter().zip(out.iter_mut()).zip(sample.outputs) {
            let x = Self::inputs(ch, &shared, output, health);
            let health = if x.is_some() { health } else { Status::Fault };
            let x = x.unwrap_or([0.0; MAX_INPUTS]);
            *slot = self
                .evaluator(ch)
                .mean_with(x.get(..ch.dims.d).unwrap_or(&[]), health);
        }
        Ok(self.channels.len())
    }

    /// Channel `k`'s mean and variances at inputs `x` (in the order of its features), `hours`
    /// after power-on: its model alone, without the feature pipeline, as
    /// [`crate::Model::predict_at`] is for a model decoded alone; `None` for no such channel.
    pub fn predict_at(
        &self,
        k: usize,
        x: &[f32],
        hours: f32,
        scratch: &mut [f32],
    ) -> Option<Result<Prediction, PredictError>> {
        let ch = self.channels.get(k)?;
        Some(
            self.evaluator(ch)
                .predict_in(x, Conditions::at_hours(hours), scratch),
        )
    }

    /// Channel `k`'s mean alone at inputs `x`, as [`crate::Model::predict_mean`]; `None` for no
    /// such channel.
    pub fn predict_mean(&self, k: usize, x: &[f32]) -> Option<Mean> {
        let ch = self.channels.get(k)?;
        Some(self.evaluator(ch).mean_into(x, None).0)
    }

    /// The noise variance of a mean over `window_s` seconds of channel `k`'s compensated samples
    /// ([`ErrorModel::noise_of_mean`]); `None` for no such channel.
    pub fn noise_of_mean(&self, k: usize, window_s: f32) -> Option<f32> {
        self.channels
            .get(k)
            .map(|c| c.error.noise_of_mean(window_s))
    }
}

#[cfg(test)]
mod tests;
