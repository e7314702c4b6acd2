//! The C interface to firmware-core: what a gyro's firmware written in C (a vendor HAL, an RTOS
//! application) calls to use a compensation model. The header is `include/fog.h`, generated from
//! this crate by cbindgen (the `header_is_current` test fails when it is stale): this file holds a
//! model, its state and its prediction; `flash.rs` the calibration slots on the C side's flash
//! driver, `unit.rs` a whole unit.
//!
//! The C side owns all memory: a [`FogModel`] (one channel's model), a [`FogUnit`] (a whole
//! sensor unit's channels, from a unit blob or a one-channel model blob) and a [`FogState`] are
//! opaque blocks of the sizes the header states, typically `static`; nothing is allocated. Every
//! function returns a [`FogResult`], one code per variant of the Rust errors
//! ([`firmware_core::BlobError`], [`firmware_core::PredictError`],
//! [`firmware_core::SlotError`]), and checks its pointers for null first.
//!
//! This is the one crate of the project with `unsafe` code: turning C pointers into references.
//! Each block says why it is sound; everything past that is the safe Rust of firmware-core.
#![cfg_attr(target_os = "none", no_std)]

use core::mem::{align_of, size_of};

use firmware_core::blob::Dims;

use firmware_core::blob::unit::{NAME_BYTES, SENSOR_ID_BYTES};
use firmware_core::slots::{Calibration, FlashError, SlotError};
use firmware_core::{
    BlobError, FeatureState, Model, PredictError, Quantity, Sample, StaticUnit, Status,
};

/// Most model inputs a [`FogModel`] holds.
pub const FOG_MAX_INPUTS: usize = 4;
/// Most prior-mean monomials a [`FogModel`] holds.
pub const FOG_MAX_MONOMIALS: usize = 16;
/// Most centres (inducing points of a sparse GP) a [`FogModel`] holds: the trainer exports at
/// most 256. A smaller number shrinks [`FogModel`] to about `4·m(m+1)/2` bytes: set it to the
/// largest model the product ships and regenerate the header (docs/firmware.md gives the figures
/// at 24, 140 and 256).
pub const FOG_MAX_CENTRES: usize = 256;
const _: () = assert!(FOG_MAX_CENTRES <= firmware_core::MAX_CENTRES);
/// Numbers in the model's flat array at those capacities (firmware-core's `Dims::floats`).
pub const FOG_MODEL_FLOATS: usize = 7 * FOG_MAX_INPUTS
    + FOG_MAX_MONOMIALS
    + 2
    + FOG_MAX_CENTRES * FOG_MAX_INPUTS
    + FOG_MAX_CENTRES
    + FOG_MAX_CENTRES * (FOG_MAX_CENTRES + 1) / 2;

/// Most channels a [`FogUnit`] holds: an IMU's three gyro and three accelerometer axes.
pub const FOG_UNIT_MAX_CHANNELS: usize = 6;
/// Numbers a [`FogUnit`] holds, all its channels' models together (firmware-core's
/// `Dims::floats` summed): as shipped, six exact 140-point models of 4 inputs and 16 monomials
/// (255 KB). Set it to what the product's unit blob needs (`trainer inspect unit.bin` prints it)
/// and regenerate the header.
pub const FOG_UNIT_NUMBERS: usize = FOG_UNIT_MAX_CHANNELS
    * (7 * FOG_MAX_INPUTS + FOG_MAX_MONOMIALS + 2 + 140 * FOG_MAX_INPUTS + 140 + 140 * 141 / 2);
/// 8-byte words of a [`FogUnit`]: its numbers (4 bytes each), about 240 bytes per channel for
/// its name, sizes, features, exponents, error model and limits, and 256 for the sensor's ID, the shared
/// features and the decoded marker (a compile-time check below holds it to the real size on
/// every target).
#[allow(clippy::manual_div_ceil)]
pub const FOG_UNIT_WORDS: usize = (FOG_UNIT_NUMBERS + 1) / 2 + 36 * FOG_UNIT_MAX_CHANNELS + 40;

/// The decoded model at the header's capacities.
type Inner = Model<FOG_MAX_INPUTS, { FOG_MAX_MONOMIALS * FOG_MAX_INPUTS }, FOG_MODEL_FLOATS>;
/// The decoded unit at the header's capacities.
type UnitInner = StaticUnit<
    FOG_UNIT_MAX_CHANNELS,
    FOG_MAX_INPUTS,
    { FOG_MAX_MONOMIALS * FOG_MAX_INPUTS },
    FOG_UNIT_NUMBERS,
>;

/// 8-byte words of a [`FogModel`]: the model's flat array (4 bytes a number) and 256 bytes for
/// its sizes, features, exponents, error model, limits and the decoded marker (a compile-time
/// check below holds it to the real size on every target).
// Rounding up by hand: cbindgen writes the expression into the header, where no method exists.
#[allow(clippy::manual_div_ceil)]
pub const FOG_MODEL_WORDS: usize = (FOG_MODEL_FLOATS + 1) / 2 + 32;
/// 8-byte words of a [`FogState`]: the variance's scratch (a number per centre) and 256 bytes for
/// the feature pipeline's memory and the reset marker.
#[allow(clippy::manual_div_ceil)]
pub const FOG_STATE_WORDS: usize = (FOG_MAX_CENTRES + 1) / 2 + 32;

/// Storage for one decoded model: opaque, aligned, at least as large as the model it holds.
#[repr(C)]
pub struct FogModel {
    words: [u64; FOG_MODEL_WORDS],
}

/// Storage for one decoded unit: opaque, aligned, at least as large as the unit it holds.
#[repr(C)]
pub struct FogUnit {
    words: [u64; FOG_UNIT_WORDS],
}

/// Storage for the running state of one model's channel, or of a whole unit (its channels share
/// one): opaque.
#[repr(C)]
pub struct FogState {
    words: [u64; FOG_STATE_WORDS],
}

/// What a [`FogState`] holds.
struct State {
    features: FeatureState,
    scratch: [f32; FOG_MAX_CENTRES],
}

const _: () = assert!(size_of::<Inner>() <= size_of::<FogModel>());
const _: () = assert!(align_of::<Inner>() <= align_of::<FogModel>());
const _: () = assert!(size_of::<UnitInner>() < size_of::<FogUnit>());
const _: () = assert!(align_of::<UnitInner>() <= align_of::<FogUnit>());
const _: () = assert!(size_of::<State>() <= size_of::<FogState>());
const _: () = assert!(align_of::<State>() <= align_of::<FogState>());

/// The outcome of every call: 0 is success, each error of the Rust interface has its own code.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FogResult {
    /// Success.
    FogOk = 0,
    /// A pointer argument was null.
    FogErrNull = 1,
    /// `BlobError::BadMagic`: not a model blob.
    FogErrBadMagic = 2,
    /// `BlobError::UnsupportedVersion`: a format version this firmware does not read.
    FogErrUnsupportedVersion = 3,
    /// `BlobError::Truncated`.
    FogErrTruncated = 4,
    /// `BlobError::TrailingBytes`.
    FogErrTrailingBytes = 5,
    /// `BlobError::CrcMismatch`: corrupted.
    FogErrCrcMismatch = 6,
    /// `BlobError::CapacityExceeded`: the model needs more than the header's capacities.
    FogErrCapacityExceeded = 7,
    /// `BlobError::Malformed`.
    FogErrMalformed = 8,
    /// `BlobError::InconsistentDimensions`.
    FogErrInconsistentDimensions = 9,
    /// `BlobError::NonFinite`: a NaN or infinite number in the blob.
    FogErrNonFinite = 10,
    /// `BlobError::InvalidParameter`: a number out of its domain.
    FogErrInvalidParameter = 11,
    /// `BlobError::BufferTooSmall`.
    FogErrBufferTooSmall = 12,
    /// `BlobError::NoSequence`: a version-3 blob cannot go into a calibration slot.
    FogErrNoSequence = 13,
    /// `PredictError::ScratchTooSmall` (cannot happen at the header's capacities).
    FogErrScratchTooSmall = 14,
    /// The model storage does not hold a decoded model.
    FogErrNoModel = 15,
    /// The state storage was not initialized by `fog_state_reset`.
    FogErrNoState = 16,
    /// `SlotError::NoValidSlot`: neither calibration slot holds a valid model.
    FogErrNoValidSlot = 17,
    /// `SlotError::TooLarge`: the blob is larger than a slot.
    FogErrSlotTooSmall = 18,
    /// `SlotError::BufferTooSmall`: the buffer given is smaller than a slot.
    FogErrSlotBufferTooSmall = 19,
    /// `SlotError::Flash(FlashError::OutOfRange)`: an address outside the device.
    FogErrFlashOutOfRange = 20,
    /// `SlotError::Flash(FlashError::Device)`: the flash driver reported a failure.
    FogErrFlashDevice = 21,
    /// `SlotError::Verify`: the slot read back differs from the blob written.
    FogErrVerify = 22,
    /// `SlotError::Layout`: the slots do not fit the device (a length that is not a whole
    /// number of sectors, a slot not on a sector boundary, slots that overlap, a slot beyond the
    /// device); nothing was read, erased or programmed.
    FogErrLayout = 23,
    /// `fog_abi_check`: the caller was built against another header (other capacities, other
    /// sizes) than the library.
    FogErrAbi = 24,
    /// `PredictError::TooFewOutputs`: fewer outputs than the unit has channels.
    FogErrTooFewOutputs = 25,
    /// `PredictError::ResultsTooShort`: room for fewer predictions than the unit has channels.
    FogErrResultsTooShort = 26,
    /// No channel of that index in the unit.
    FogErrNoChannel = 27,
    /// Not a result: holds the enum to 32 bits whatever the C compiler's enum size
    /// (`-fshort-enums`, the Arm EABI's default, or not).
    FogResultWidth = 0x7FFF_FFFF,
}

/// A prediction's validity, as `firmware_core::Status`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FogStatus {
    /// Inputs inside the trained range.
    FogValid = 0,
    /// An input outside the trained range: usable, flag it. The mean follows the blob's rule
    /// beyond the range (hold: the model held at the range's edge, as PX4 and ArduPilot clip the
    /// temperature, its pure linear terms in the output and the time since power-on following
    /// them; tangent: held, the prior mean continued along its tangent; follow: the GP's own
    /// prediction, as every blob before format 6); the bias variance grows with the distance (an
    /// input only a linear term reads, such as a time drift's, follows it, its variance growing by
    /// the square of what it added past the edge).
    FogExtrapolating = 1,
    /// A stateful input's history is not to be trusted (time jump, stuck sensor): settling.
    FogDegraded = 2,
    /// A reading that cannot be true: NaN or infinite, a temperature outside the sensor's rated
    /// range (the blob's limits, by default −55…125 °C; −100…200 °C whatever they say), an output
    /// beyond its full scale; or a blob whose numbers make the mean or variance overflow. The
    /// mean is 0: do not use it.
    FogFault = 3,
    /// Not a status: holds the enum to 32 bits whatever the C compiler's enum size.
    FogStatusWidth = 0x7FFF_FFFF,
}

/// One compensated sample, with the two variances of the σ contract (docs/firmware.md, "What
/// the variance means"), output units², never negative.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FogPrediction {
    /// The compensated rate, output units (°/s).
    pub mean: f32,
    /// Variance of its slowly varying error (the GP's latent variance, the model error the
    /// training data showed, and another power-on's bias and scale factor where the blob states
    /// them): a mean over any window keeps it. A Kalman filter's bias-state
    /// uncertainty.
    pub bias_variance: f32,
    /// White noise of this one sample: a mean of N samples has 1/N of it
    /// (`fog_noise_of_mean`). A Kalman filter's measurement noise.
    pub noise_variance: f32,
    /// Its validity.
    pub status: FogStatus,
}

/// What a unit's channel measures, as `firmware_core::Quantity`: the unit of its means.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FogQuantity {
    /// A gyro's angular rate, °/s.
    FogAngularRate = 0,
    /// An accelerometer's specific force, m/s².
    FogSpecificForce = 1,
    /// Not a quantity: holds the enum to 32 bits whatever the C compiler's enum size.
    FogQuantityWidth = 0x7FFF_FFFF,
}

/// A decoded unit: its channels, the sensor it was calibrated for and where.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FogUnitInfo {
    /// Channels.
    pub channels: u32,
    /// The trained temperature range, °C: lowest.
    pub temp_min_c: f32,
    /// Highest.
    pub temp_max_c: f32,
    /// The sensor's ID, NUL-terminated (empty for a one-channel model blob).
    pub sensor_id: [u8; FOG_SENSOR_ID_CHARS],
}

/// One channel of a decoded unit.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FogChannelInfo {
    /// Its name, NUL-terminated.
    pub name: [u8; FOG_NAME_CHARS],
    /// What it measures.
    pub quantity: FogQuantity,
    /// Its model's sizes.
    pub dims: FogDims,
}

/// Bytes of a channel's name in C, its NUL included: the unit blob's 16 and one.
pub const FOG_NAME_CHARS: usize = 17;
/// Bytes of a sensor's ID in C, its NUL included: the unit blob's 32 and one.
pub const FOG_SENSOR_ID_CHARS: usize = 33;
const _: () =
    assert!(FOG_NAME_CHARS == NAME_BYTES + 1 && FOG_SENSOR_ID_CHARS == SENSOR_ID_BYTES + 1);

/// A model's sizes.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FogDims {
    /// Centres.
    pub centres: u32,
    /// Inputs.
    pub inputs: u32,
    /// Prior-mean monomials.
    pub monomials: u32,
}

impl From<BlobError> for FogResult {
    fn from(e: BlobError) -> Self {
        match e {
            BlobError::BadMagic => Self::FogErrBadMagic,
            BlobError::UnsupportedVersion(_) => Self::FogErrUnsupportedVersion,
            BlobError::Truncated => Self::FogErrTruncated,
            BlobError::TrailingBytes => Self::FogErrTrailingBytes,
            BlobError::CrcMismatch => Self::FogErrCrcMismatch,
            BlobError::CapacityExceeded { .. } => Self::FogErrCapacityExceeded,
            BlobError::Malformed => Self::FogErrMalformed,
            BlobError::InconsistentDimensions => Self::FogErrInconsistentDimensions,
            BlobError::NonFinite(_) => Self::FogErrNonFinite,
            BlobError::InvalidParameter => Self::FogErrInvalidParameter,
            BlobError::BufferTooSmall => Self::FogErrBufferTooSmall,
            BlobError::NoSequence(_) => Self::FogErrNoSequence,
            // `BlobError` is non-exhaustive: a variant added later reads as malformed until it
            // gets its own code.
            _ => Self::FogErrMalformed,
        }
    }
}

impl From<PredictError> for FogResult {
    fn from(e: PredictError) -> Self {
        match e {
            PredictError::ScratchTooSmall { .. } => Self::FogErrScratchTooSmall,
            PredictError::TooFewOutputs { .. } => Self::FogErrTooFewOutputs,
            PredictError::ResultsTooShort { .. } => Self::FogErrResultsTooShort,
        }
    }
}

impl From<Quantity> for FogQuantity {
    fn from(q: Quantity) -> Self {
        match q {
            Quantity::AngularRate => Self::FogAngularRate,
            Quantity::SpecificForce => Self::FogSpecificForce,
        }
    }
}

impl From<SlotError> for FogResult {
    fn from(e: SlotError) -> Self {
        match e {
            SlotError::NoValidSlot => Self::FogErrNoValidSlot,
            SlotError::TooLarge { .. } => Self::FogErrSlotTooSmall,
            SlotError::BufferTooSmall => Self::FogErrSlotBufferTooSmall,
            SlotError::Blob(b) => b.into(),
            SlotError::Flash(FlashError::OutOfRange) => Self::FogErrFlashOutOfRange,
            SlotError::Flash(FlashError::Device) => Self::FogErrFlashDevice,
            SlotError::Verify => Self::FogErrVerify,
            SlotError::Layout(_) => Self::FogErrLayout,
        }
    }
}

impl From<Status> for FogStatus {
    fn from(s: Status) -> Self {
        match s {
            Status::Valid => Self::FogValid,
            Status::Extrapolating => Self::FogExtrapolating,
            Status::Degraded => Self::FogDegraded,
            Status::Fault => Self::FogFault,
        }
    }
}

/// Marks a [`FogModel`] as holding a decoded model: its first word, written after the model,
/// outside the model's own bytes. Storage the C side zeroed (or never decoded into) lacks it.
const DECODED: u64 = 0x464F_475F_4D4F_444C;

/// Opaque storage that holds a decoded value (a model or a unit) at its start and, in the word
/// after it, the marker [`DECODED`] while it does.
trait Holds {
    /// What it holds.
    type Inner: Calibration;
    /// The word after the value: the marker's.
    const MARK_AT: usize;
    /// The value holding nothing.
    fn empty() -> Self::Inner;
    /// Its words.
    fn words(&self) -> &[u64];
    /// Its words, to write.
    fn words_mut(&mut self) -> &mut [u64];
}

impl Holds for FogModel {
    type Inner = Inner;
    const MARK_AT: usize = size_of::<Inner>().div_ceil(8);

    fn empty() -> Inner {
        Inner::new()
    }

    fn words(&self) -> &[u64] {
        &self.words
    }

    fn words_mut(&mut self) -> &mut [u64] {
        &mut self.words
    }
}

impl Holds for FogUnit {
    type Inner = UnitInner;
    const MARK_AT: usize = size_of::<UnitInner>().div_ceil(8);

    fn empty() -> UnitInner {
        UnitInner::new()
    }

    fn words(&self) -> &[u64] {
        &self.words
    }

    fn words_mut(&mut self) -> &mut [u64] {
        &mut self.words
    }
}

const _: () = assert!(<FogModel as Holds>::MARK_AT < FOG_MODEL_WORDS);
const _: () = assert!(<FogUnit as Holds>::MARK_AT < FOG_UNIT_WORDS);

/// Decodes the blob of `len` bytes at `blob` into `storage` (`fog_model_decode`,
/// `fog_unit_decode`). On any error (a null `blob` included) `storage` is left holding nothing,
/// whatever it held before.
///
/// # Safety
/// As the functions that call it: `storage` points to writable storage of its type; `blob` to
/// `len` readable bytes. Either may be null (`FogErrNull`).
unsafe fn decode_in<S: Holds>(storage: *mut S, blob: *const u8, len: usize) -> FogResult {
    if storage.is_null() {
        return FogResult::FogErrNull;
    }
    if blob.is_null() {
        // SAFETY: `storage` is non-null and points to storage the caller lets us write.
        unsafe { forget(&mut *storage) };
        return FogResult::FogErrNull;
    }
    // SAFETY: the caller guarantees `blob` points to `len` readable bytes (checked non-null).
    let bytes = unsafe { core::slice::from_raw_parts(blob, len) };
    // SAFETY: `storage` is non-null and points to storage the caller lets us write; the
    // reference lives for this call only.
    let inner = unsafe { emptied(&mut *storage) };
    match inner.decode_into(bytes) {
        Ok(()) => {
            // SAFETY: as in `emptied`: the storage is ours for this call.
            unsafe { mark(&mut *storage) };
            FogResult::FogOk
        }
        Err(e) => e.into(),
    }
}

/// Decodes the blob of `len` bytes at `blob` into `model`: a model blob, or a unit blob of one
/// channel (what `trainer fit` writes for one channel's data). On any error (a null `blob`
/// included, or a unit of several channels: `fog_unit_decode` takes it) `model` is left holding
/// no model, whatever it held before.
///
/// # Safety
/// `model` points to a writable `FogModel`; `blob` to `len` readable bytes. Either may be null
/// (`FogErrNull`).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_model_decode(
    model: *mut FogModel,
    blob: *const u8,
    len: usize,
) -> FogResult {
    // SAFETY: forwarded from the caller.
    unsafe { decode_in(model, blob, len) }
}

/// The storage as a value that holds nothing yet, unmarked: the value is decoded in place, so the
/// stack never holds a copy of it (at these capacities a model's copy would be 137 KB, more stack
/// than a Cortex-M4 has, a unit's 255 KB). Storage that already holds one is emptied where it is;
/// anything else (a zeroed `static`, a refused blob's leftovers) gets an empty value's few header
/// bytes, written in place.
///
/// # Safety
/// `storage` is exclusively ours for the lifetime of the reference returned.
unsafe fn emptied<S: Holds>(storage: &mut S) -> &mut S::Inner {
    let words = storage.words_mut();
    let marked = words[S::MARK_AT] == DECODED;
    words[S::MARK_AT] = 0;
    let inner = words.as_mut_ptr().cast::<S::Inner>();
    if marked {
        // SAFETY: the marker is written only over a valid value at the start of the storage
        // (it fits and aligns: compile-time checks above).
        let inner = unsafe { &mut *inner };
        inner.clear();
        inner
    } else {
        // SAFETY: the storage fits and aligns the value; `write` neither reads nor drops the
        // bytes that were there. An empty value's arrays are uninitialized (heapless vectors of
        // length 0), so only its sizes and lengths are stored.
        unsafe {
            inner.write(S::empty());
            &mut *inner
        }
    }
}

/// Marks `storage` as holding a decoded value.
fn mark<S: Holds>(storage: &mut S) {
    storage.words_mut()[S::MARK_AT] = DECODED;
}

/// Leaves `storage` holding nothing: its marker cleared, so every call sees `FogErrNoModel`.
fn forget<S: Holds>(storage: &mut S) {
    storage.words_mut()[S::MARK_AT] = 0;
}

/// The value in `storage`, if it holds one.
///
/// # Safety
/// `storage` is null or points to readable, initialized storage of its type (decoded into, or
/// zeroed).
unsafe fn decoded<'a, S: Holds + 'a>(storage: *const S) -> Result<&'a S::Inner, FogResult> {
    if storage.is_null() {
        return Err(FogResult::FogErrNull);
    }
    // SAFETY: non-null, readable per the caller; shared for the call.
    let storage = unsafe { &*storage };
    let words = storage.words();
    if words[S::MARK_AT] != DECODED {
        return Err(FogResult::FogErrNoModel);
    }
    // SAFETY: the marker is written only after a decode wrote a valid value at the start of
    // this storage, and cleared before anything else writes there.
    Ok(unsafe { &*words.as_ptr().cast::<S::Inner>() })
}

/// Marks a [`FogState`] that `fog_state_reset` initialized: its last word, outside the `State`.
/// "FOG_ST" and the layout's number, 2 since the feature state tracks the heating rate: a state
/// an earlier build stored is refused (`FogErrNoState`), not read in another layout.
const RESET: u64 = 0x464F_475F_5354_0002;

const _: () = assert!(size_of::<State>() < 8 * (FOG_STATE_WORDS - 1));

/// The state in `state`, if `fog_state_reset` initialized it.
///
/// # Safety
/// `state` is null or points to a writable `FogState`, initialized (by `fog_state_reset`, or
/// zeroed as a C `static` is).
unsafe fn state<'a>(state: *mut FogState) -> Result<&'a mut State, FogResult> {
    if state.is_null() {
        return Err(FogResult::FogErrNull);
    }
    // SAFETY: non-null, writable and initialized per the caller; exclusive for the call.
    let storage = unsafe { &mut *state };
    if storage.words[FOG_STATE_WORDS - 1] != RESET {
        return Err(FogResult::FogErrNoState);
    }
    // SAFETY: the marker is written only after `fog_state_reset` wrote a `State` at the start of
    // this storage (it fits and is aligned: compile-time checks above).
    Ok(unsafe { &mut *storage.words.as_mut_ptr().cast::<State>() })
}

/// Resets a channel's state: call it at a power-on, before the first sample, where the state was
/// not kept through the power-off (`fog_state_power_on` where it was), and to initialize a new
/// `FogState`.
///
/// # Safety
/// `state` is null (`FogErrNull`) or points to a writable `FogState` (initialized or not).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_state_reset(state: *mut FogState) -> FogResult {
    if state.is_null() {
        return FogResult::FogErrNull;
    }
    let fresh = State {
        features: FeatureState::default(),
        scratch: [0.0; FOG_MAX_CENTRES],
    };
    // SAFETY: non-null and writable per the caller; exclusive for the call.
    let storage = unsafe { &mut *state };
    // SAFETY: the storage fits and aligns `State` (compile-time checks); `write` does not read
    // or drop the bytes that were there.
    unsafe { core::ptr::write(storage.words.as_mut_ptr().cast::<State>(), fresh) };
    storage.words[FOG_STATE_WORDS - 1] = RESET;
    FogResult::FogOk
}

/// The gyro was switched off and on again and `state` kept through it (its bytes stored at
/// power-down and restored before this call): the next sample is a power-on, and the coil
/// estimate and the play cross the time off along a straight line from the last reading to the
/// next (firmware-core's `FeatureState::power_on`). Needs a clock that ran while the gyro was
/// off (`fog_compensate`); where there is none, or nothing was stored, call `fog_state_reset`
/// instead.
///
/// # Safety
/// `state` is null (`FogErrNull`) or points to a writable `FogState`, initialized (by
/// `fog_state_reset`, or zeroed as a C `static` is: then `FogErrNoState`).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_state_power_on(state: *mut FogState) -> FogResult {
    // SAFETY: forwarded from the caller.
    match unsafe { self::state(state) } {
        Ok(s) => {
            s.features.power_on();
            FogResult::FogOk
        }
        Err(e) => e,
    }
}

/// Compensates one sample (time in s, temperature in °C, the gyro's output) with the model,
/// through the channel's state: the feature pipeline, then mean and variances.
///
/// Which clock: where the state is kept through power-offs (`fog_state_power_on`), `time_s` is a
/// clock that keeps running while the gyro is off (a real-time clock), so the coil estimate can
/// cross the time off; where the state is reset at every power-on (`fog_state_reset`), a time
/// since power-on does. A time no later than the last one after `fog_state_power_on` (no time
/// off) says the clock did not run: the state starts again from that sample and its outputs are `FOG_DEGRADED` until its
/// filters settle. Time since power-on for the model's warm-up and drift inputs is counted from
/// the first sample after a power-on, whichever clock.
///
/// # Safety
/// `model` points to a `FogModel` and `channel` to a `FogState`, each initialized (by its
/// function, or zeroed as a C `static` is: then `FogErrNoModel` / `FogErrNoState`); `out` to a
/// writable `FogPrediction`; any may be null (`FogErrNull`).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_compensate(
    model: *const FogModel,
    channel: *mut FogState,
    time_s: f64,
    temp_c: f32,
    output: f32,
    out: *mut FogPrediction,
) -> FogResult {
    if out.is_null() {
        return FogResult::FogErrNull;
    }
    // SAFETY: the caller's contract on `model` and `channel`, forwarded.
    let (model, channel) = match unsafe { (decoded(model), state(channel)) } {
        (Ok(m), Ok(s)) => (m, s),
        (Err(e), _) | (_, Err(e)) => return e,
    };
    let sample = Sample {
        time_s,
        temp_c,
        output,
    };
    match model.compensate(&sample, &mut channel.features, &mut channel.scratch) {
        Ok(p) => {
            let prediction = FogPrediction {
                mean: p.mean,
                bias_variance: p.bias_variance,
                noise_variance: p.noise_variance,
                status: p.status.into(),
            };
            // SAFETY: `out` is non-null and writable per the caller.
            unsafe { out.write(prediction) };
            FogResult::FogOk
        }
        Err(e) => e.into(),
    }
}

/// A model's sizes as C reads them.
fn fog_dims(Dims { m, d, p }: Dims) -> FogDims {
    FogDims {
        centres: u32::try_from(m).unwrap_or(u32::MAX),
        inputs: u32::try_from(d).unwrap_or(u32::MAX),
        monomials: u32::try_from(p).unwrap_or(u32::MAX),
    }
}

/// The decoded model's sizes.
///
/// # Safety
/// `model` points to an initialized `FogModel` (decoded into, or zeroed), `out` to a writable
/// `FogDims`; either may be null.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_model_dims(model: *const FogModel, out: *mut FogDims) -> FogResult {
    if out.is_null() {
        return FogResult::FogErrNull;
    }
    // SAFETY: the caller's contract on `model`, forwarded.
    let model = match unsafe { decoded(model) } {
        Ok(m) => m,
        Err(e) => return e,
    };
    let dims = fog_dims(model.dims());
    // SAFETY: `out` is non-null and writable per the caller.
    unsafe { out.write(dims) };
    FogResult::FogOk
}

/// The noise variance of a mean over `window_s` seconds of compensated samples, output units²:
/// the sample noise divided by the samples in the window (not divided where the blob does not
/// say its sample interval). The variance of the mean is this plus the mean of the samples'
/// `bias_variance`.
///
/// # Safety
/// `model` points to an initialized `FogModel` (decoded into, or zeroed), `out` to a writable
/// `float`; either may be null.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_noise_of_mean(
    model: *const FogModel,
    window_s: f32,
    out: *mut f32,
) -> FogResult {
    if out.is_null() {
        return FogResult::FogErrNull;
    }
    // SAFETY: the caller's contract on `model`, forwarded.
    let model = match unsafe { decoded(model) } {
        Ok(m) => m,
        Err(e) => return e,
    };
    // SAFETY: `out` is non-null and writable per the caller.
    unsafe { out.write(model.error_model().noise_of_mean(window_s)) };
    FogResult::FogOk
}

/// Checks that the caller was built against the header this library was: call it once at
/// start-up, as `FOG_ABI_CHECK()` does with the caller's `sizeof`s and capacities.
/// `FogErrAbi` where any differs (a header edited to other capacities, a library not rebuilt):
/// then nothing else is safe to call.
// Each size and capacity a parameter of its own: the macro passes them as the caller's header
// states them, in C and C++ alike (a struct literal would need C99's compound literals).
#[allow(clippy::too_many_arguments)]
#[unsafe(no_mangle)]
pub extern "C" fn fog_abi_check(
    model_bytes: usize,
    unit_bytes: usize,
    state_bytes: usize,
    prediction_bytes: usize,
    max_centres: u32,
    max_inputs: u32,
    max_monomials: u32,
    unit_channels: u32,
    unit_numbers: u32,
) -> FogResult {
    let ours = (
        [
            size_of::<FogModel>(),
            size_of::<FogUnit>(),
            size_of::<FogState>(),
            size_of::<FogPrediction>(),
        ],
        [
            FOG_MAX_CENTRES,
            FOG_MAX_INPUTS,
            FOG_MAX_MONOMIALS,
            FOG_UNIT_MAX_CHANNELS,
            FOG_UNIT_NUMBERS,
        ],
    );
    let theirs = (
        [model_bytes, unit_bytes, state_bytes, prediction_bytes],
        [
            max_centres,
            max_inputs,
            max_monomials,
            unit_channels,
            unit_numbers,
        ]
        .map(|v| v as usize),
    );
    if ours == theirs {
        FogResult::FogOk
    } else {
        FogResult::FogErrAbi
    }
}

mod flash;
mod unit;

pub use flash::{FogFlash, FogLayout, FogSlot, fog_slots_boot, fog_slots_update};
pub use unit::{
    fog_unit_channel, fog_unit_compensate, fog_unit_decode, fog_unit_info, fog_unit_noise_of_mean,
    fog_unit_slots_boot, fog_unit_slots_update,
};

#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // firmware-core has no panics on its data paths (its lints deny them); this is for the
    // linker. A fault loops, for the watchdog.
    loop {}
}
