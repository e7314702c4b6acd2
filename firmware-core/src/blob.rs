//! The model blob: the one definition of what the trainer exports and the firmware loads.
//!
//! # Layout (format version 9)
//!
//! ```text
//! offset size  field
//!  0      4    magic "FOGB"
//!  4      2    format version, u16 little-endian (9)
//!  6      2    m: number of centres, u16 LE
//!  8      1    d: number of inputs
//!  9      1    p: number of prior-mean monomials
//! 10      4    sequence number, u32 LE (0 as exported; a calibration slot stamps its own)
//! 14      4    payload length in bytes, u32 LE
//! 18      4    CRC-32/ISO-HDLC of bytes 4..18 and the payload, u32 LE
//! 22      …    payload: postcard encoding of [`Payload`]
//! ```
//!
//! The dimensions sit in the header so that a blob too large for the integrator's capacities is
//! refused by a typed error before anything is decoded. The CRC covers the header after the magic,
//! so a flipped bit in the sequence number or the sizes is caught like one in the payload; the
//! magic is outside it because a calibration slot writes it last, as its commit
//! ([`crate::slots`]). Version 8, 7, 6 and 5 blobs (the same header, an error model of twelve,
//! eleven, ten and six numbers; version 5 without limits or rule beyond the range), version 4
//! blobs (no error model) and version 3 blobs (18-byte header without the sequence, CRC over the
//! payload alone, read as sequence 0) are still read: the error model's terms they lack are 0 (4
//! and 3 get [`ErrorModel::noise_only`] with their noise variance), their [`Limits`] the
//! stated defaults, and [`Beyond::Follow`], how they were evaluated. The payload is three postcard sequences (each a varint length, then the
//! elements): the `d` input features (enum index, then the f32 parameter of the stateful ones),
//! the `p·d` prior-mean exponents (u8, row per monomial), and one flat array of little-endian f32;
//! then what the mean does beyond the trained range ([`Beyond`], one byte), the [`ErrorModel`],
//! twenty little-endian f32 in its field order, and the [`Limits`], three.
//! The flat array:
//!
//! ```text
//! input_offset[d] input_scale[d]  z = (x − offset) / scale
//! input_min[d] input_max[d]       trained range, raw units (beyond it: extrapolating)
//! length_scales[d]                ARD length scales on z
//! prior[p]                        mean(z) = Σ_j prior_j Π_k z_k^e_jk, output units
//! raw_hi[d] raw_lo[d]             mean += Σ_k (hi_k + lo_k)·x_k on the raw inputs
//! signal_var noise_var            σ_f², σ_n² in output units²
//! centres[m·d]                    z of each centre divided by the length scales, row-major
//! weights[m]                      mean += Σ_i w_i exp(−½ |z/ℓ − c_i|²)
//! factor[m(m+1)/2]                packed rows of L = chol(K/σ_f²), for the variance
//! ```
//!
//! Latent variance: `σ_f² (1 − |v|²)` with `L v = k̃` (forward substitution; docs/design.md §4).
//! Forward substitution rather than multiplying by L⁻¹: the same cost, and the factor of a
//! well-conditioned
//! K rounds to f32 without amplifying anything (L⁻¹ grows like 1/σ_n).
//!
//! Why the raw linear terms (version 2): the output is dominated by V/S (±80 °/s), which in f32 is
//! already 5e-6 °/s per rounding. Computed on z, its coefficient, the normalization and the product
//! round three times; on the raw input, with the coefficient split into `hi + lo` (two f32 whose sum
//! carries 48 bits) and `hi·x` split exactly by an FMA, the term rounds once, when it is added
//! last. The trainer moves every pure linear monomial of the prior mean here
//! (`trainer/benches/f32_study` measures the gain).
//!
//! Version 3 adds the stateful features. An input the kernel ignores (one that enters only through
//! its raw linear term, as the additive terms of an extended model do) has length scale
//! [`IGNORED_LENGTH_SCALE`] and centre coordinate 0: its distance term underflows to exactly 0 in
//! f32, so the kernel is the static model's. Version 4 adds the sequence number, for the two
//! power-safe calibration slots. Version 5 adds the [`ErrorModel`]: what the variance of a
//! compensated sample holds besides the GP's latent variance (docs/design.md §4, "The σ
//! contract"). Version 6 adds what service meets and calibration may not have: the error model's
//! turn-on and heating/cooling-leg terms, and the sensor's [`Limits`] (what a reading that cannot
//! be true is: the only `Fault` a reading can be). Version 7 adds the error model's scale term:
//! another power-on's scale factor, an error that grows with the rate. Version 8 adds the scale part
//! of the error beyond the trained range, which grows with the rate too. Version 9 adds the heating
//! term: the error of a heating rate outside the band the calibration held, where a temperature
//! sensor lags the sensing element. A change of this layout bumps [`FORMAT_VERSION`]; a
//! golden-bytes test pins the encoding.

use core::fmt;
use core::marker::PhantomData;
use core::ops::Range;

use serde::de::{self, DeserializeSeed, SeqAccess, Visitor};
use serde::{Deserialize, Serialize};

use crate::error::BlobError;

pub mod service;
pub mod unit;

pub use service::{Beyond, ErrorModel, Limits};

/// First four bytes of every blob.
pub const MAGIC: [u8; 4] = *b"FOGB";
/// The format version this crate writes (it also reads [`V8`], [`V7`], [`V6`], [`V5`], [`V4`]
/// and [`V3`]).
pub const FORMAT_VERSION: u16 = 9;
/// The previous format version, still read: an error model of twelve numbers, no heating term.
pub const V8: u16 = 8;
/// The format version before it, still read: an error model of eleven numbers, no scale part of
/// the extrapolation.
pub const V7: u16 = 7;
/// The format version before it, still read: an error model of ten numbers, no scale term.
pub const V6: u16 = 6;
/// The format version before it, still read: an error model of six numbers, no limits.
pub const V5: u16 = 5;
/// The format version before it, still read: no error model.
pub const V4: u16 = 4;
/// The format version before it, still read: no sequence number, CRC over the payload alone.
pub const V3: u16 = 3;
/// Length scale of an input the kernel ignores (module doc).
pub const IGNORED_LENGTH_SCALE: f32 = 1e30;
/// Header bytes before the payload.
pub const HEADER_LEN: usize = 22;
/// Header bytes of a [`V3`] blob.
const V3_HEADER_LEN: usize = 18;

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// One model input, computed from the raw sample by the feature pipeline
/// ([`crate::features`] has the equations). Time constants are in seconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Feature {
    /// Temperature-sensor reading, °C.
    Temperature,
    /// Gyro output (V for an analog FOG, counts or a rate for a digital one).
    Voltage,
    /// Temperature rate, °C/min: the sensor reading differentiated through a first-order filter.
    TemperatureRate {
        /// Filter time constant, s.
        tau_s: f32,
    },
    /// Coil-temperature estimate, °C: the sensor reading through a first-order lag.
    CoilTemperature {
        /// Lag time constant, s.
        tau_s: f32,
    },
    /// Warm-up shape: exp(−t_on/τ), t_on the time since power-on.
    PowerOnDecay {
        /// Decay time constant, s.
        tau_s: f32,
    },
    /// Time since power-on, h.
    TimeOn,
    /// Heating/cooling state in [−1, 1]: a play (backlash) operator on the sensor reading.
    ThermalState {
        /// Half-width of the play, °C.
        width_c: f32,
    },
}

impl Feature {
    /// Whether it is a temperature, °C: the sensor's reading, or a coil's estimate from it (a
    /// rated range bounds both).
    pub fn is_temperature(&self) -> bool {
        matches!(self, Feature::Temperature | Feature::CoilTemperature { .. })
    }

    /// Whether its parameter is usable (finite and positive).
    pub fn is_valid(&self) -> bool {
        match *self {
            Feature::Temperature | Feature::Voltage | Feature::TimeOn => true,
            Feature::TemperatureRate { tau_s }
            | Feature::CoilTemperature { tau_s }
            | Feature::PowerOnDecay { tau_s } => tau_s.is_finite() && tau_s > 0.0,
            Feature::ThermalState { width_c } => width_c.is_finite() && width_c > 0.0,
        }
    }
}

/// The sizes of a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Dims {
    /// Centres (training points of an exact GP, inducing points of a sparse one).
    pub m: usize,
    /// Inputs.
    pub d: usize,
    /// Prior-mean monomials.
    pub p: usize,
}

impl Dims {
    /// Length of the flat f32 array: `7d + p + 2 + m·d + m + m(m+1)/2`.
    pub const fn floats(&self) -> usize {
        self.sections().factor.end
    }

    /// Where each section of the flat f32 array lies.
    pub const fn sections(&self) -> Sections {
        let (d, p, m) = (self.d, self.p, self.m);
        let offset = 0..d;
        let scale = at(offset.end, d);
        let min = at(scale.end, d);
        let max = at(min.end, d);
        let length = at(max.end, d);
        let prior = at(length.end, p);
        let raw_hi = at(prior.end, d);
        let raw_lo = at(raw_hi.end, d);
        let variances = at(raw_lo.end, 2);
        let centres = at(variances.end, m * d);
        let weights = at(centres.end, m);
        let factor = at(weights.end, m * (m + 1) / 2);
        Sections {
            offset,
            scale,
            min,
            max,
            length,
            prior,
            raw_hi,
            raw_lo,
            variances,
            centres,
            weights,
            factor,
        }
    }

    /// Length of the exponent array: `p·d`.
    pub const fn exponents(&self) -> usize {
        self.p * self.d
    }
}

/// The sections of the flat f32 array, in the order of the module doc's layout: the one
/// definition of that order. The trainer writes each section through it, the evaluator and the
/// test helpers read and write through it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sections {
    /// `input_offset[d]`.
    pub offset: Range<usize>,
    /// `input_scale[d]`.
    pub scale: Range<usize>,
    /// `input_min[d]`.
    pub min: Range<usize>,
    /// `input_max[d]`.
    pub max: Range<usize>,
    /// `length_scales[d]`.
    pub length: Range<usize>,
    /// `prior[p]`.
    pub prior: Range<usize>,
    /// `raw_hi[d]`.
    pub raw_hi: Range<usize>,
    /// `raw_lo[d]`.
    pub raw_lo: Range<usize>,
    /// `signal_var noise_var`.
    pub variances: Range<usize>,
    /// `centres[m·d]`.
    pub centres: Range<usize>,
    /// `weights[m]`.
    pub weights: Range<usize>,
    /// `factor[m(m+1)/2]`.
    pub factor: Range<usize>,
}

/// The payload, generic over its containers: heapless vectors in the firmware, slices or vectors
/// on the host. All encode to the same bytes, so this is the only definition of the format.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct Payload<Fe, Ex, Fl> {
    /// Input features, in input order.
    pub features: Fe,
    /// Prior-mean exponents, `p` rows of `d`.
    pub exponents: Ex,
    /// All numbers, in the layout of the module doc.
    pub floats: Fl,
    /// What the mean does beyond the trained range.
    pub beyond: Beyond,
    /// The variance besides the latent one.
    pub error: ErrorModel,
    /// What a reading that cannot be true is.
    pub limits: Limits,
}

/// A payload as read: its features and exponents, its error model (none in a blob of format 3 or
/// 4) and its limits (the defaults before format 6).
pub(crate) struct Read<Fe, Ex> {
    pub(crate) features: Fe,
    pub(crate) exponents: Ex,
    pub(crate) beyond: Beyond,
    pub(crate) error: Option<ErrorModel>,
    pub(crate) limits: Limits,
}

/// `len` entries from `start` (a `const` stand-in for a closure).
const fn at(start: usize, len: usize) -> Range<usize> {
    start..start + len
}

/// Reads `payload` bytes as [`Payload`] encodes them (its three fields, in order), handing each
/// number of the flat array to `number` as it is read instead of collecting them: the evaluator
/// decodes into its own storage this way. Decoding a whole `Payload` by value puts the numbers on
/// the stack and then moves them into the model, several times the model's size of stack on a
/// microcontroller whose RAM holds the model once. `number` refusing a value (storage full) is
/// [`BlobError::Malformed`], as postcard refuses a sequence longer than its container. A blob of
/// format [`V4`] or [`V3`] has no error model (`None`); one before format 6 has the default
/// limits.
pub(crate) fn read_payload<'de, Fe, Ex>(
    payload: &'de [u8],
    version: u16,
    mut number: impl FnMut(f32) -> Result<(), ()>,
) -> Result<Read<Fe, Ex>, BlobError>
where
    Fe: Deserialize<'de>,
    Ex: Deserialize<'de>,
{
    let mut decoder = postcard::Deserializer::from_bytes(payload);
    let fields = serde::Deserializer::deserialize_tuple(
        &mut decoder,
        match version {
            FORMAT_VERSION | V8 | V7 | V6 => 6,
            V5 => 4,
            _ => 3,
        },
        PayloadFields {
            number: &mut number,
            version,
            fields: PhantomData,
        },
    )
    .map_err(|_| BlobError::Malformed)?;
    // Bytes after the payload, even under a consistent length and CRC, are not a blob the trainer
    // wrote.
    let rest = decoder.finalize().map_err(|_| BlobError::Malformed)?;
    if rest.is_empty() {
        Ok(fields)
    } else {
        Err(BlobError::TrailingBytes)
    }
}

/// The fields after the numbers in a blob of format 6, 7 or 8: the rule beyond the range, an error
/// model of `N` numbers (`from` fills in the terms that format lacks) and the limits.
fn older_tail<'de, A: SeqAccess<'de>, const N: usize>(
    seq: &mut A,
    from: fn([f32; N]) -> ErrorModel,
) -> Result<(Beyond, Option<ErrorModel>, Limits), A::Error>
where
    [f32; N]: Deserialize<'de>,
{
    let missing = |i| de::Error::invalid_length(i, &"the payload's fields");
    let beyond = seq.next_element()?.ok_or_else(|| missing(3))?;
    let v: [f32; N] = seq.next_element()?.ok_or_else(|| missing(4))?;
    let limits = seq.next_element()?.ok_or_else(|| missing(5))?;
    Ok((beyond, Some(from(v)), limits))
}

/// [`read_payload`]'s visitor: features and exponents by value, numbers one at a time, then the
/// error model and the limits where the format has them.
struct PayloadFields<'a, Fe, Ex, F> {
    number: &'a mut F,
    version: u16,
    fields: PhantomData<(Fe, Ex)>,
}

impl<'de, Fe, Ex, F> Visitor<'de> for PayloadFields<'_, Fe, Ex, F>
where
    Fe: Deserialize<'de>,
    Ex: Deserialize<'de>,
    F: FnMut(f32) -> Result<(), ()>,
{
    type Value = Read<Fe, Ex>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a model payload")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let missing = |i| de::Error::invalid_length(i, &"the payload's fields");
        let features = seq.next_element()?.ok_or_else(|| missing(0))?;
        let exponents = seq.next_element()?.ok_or_else(|| missing(1))?;
        seq.next_element_seed(Numbers(self.number))?
            .ok_or_else(|| missing(2))?;
        let (beyond, error, limits) = match self.version {
            FORMAT_VERSION => (
                seq.next_element()?.ok_or_else(|| missing(3))?,
                Some(seq.next_element()?.ok_or_else(|| missing(4))?),
                seq.next_element()?.ok_or_else(|| missing(5))?,
            ),
            V8 => older_tail(&mut seq, ErrorModel::from_v8)?,
            V7 => older_tail(&mut seq, ErrorModel::from_v7)?,
            V6 => older_tail(&mut seq, ErrorModel::from_v6)?,
            V5 => {
                let v: [f32; ErrorModel::V5_NUMBERS] =
                    seq.next_element()?.ok_or_else(|| missing(3))?;
                (
                    Beyond::Follow,
                    Some(ErrorModel::from_v5(v)),
                    Limits::DEFAULT,
                )
            }
            _ => (Beyond::Follow, None, Limits::DEFAULT),
        };
        Ok(Read {
            features,
            exponents,
            beyond,
            error,
            limits,
        })
    }
}

/// The flat array, each number handed on as it is read.
struct Numbers<'a, F>(&'a mut F);

impl<'de, F: FnMut(f32) -> Result<(), ()>> DeserializeSeed<'de> for Numbers<'_, F> {
    type Value = ();

    fn deserialize<De: serde::Deserializer<'de>>(self, decoder: De) -> Result<(), De::Error> {
        decoder.deserialize_seq(self)
    }
}

impl<'de, F: FnMut(f32) -> Result<(), ()>> Visitor<'de> for Numbers<'_, F> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a sequence of f32")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        while let Some(v) = seq.next_element::<f32>()? {
            (self.0)(v).map_err(|()| de::Error::custom("more numbers than the storage holds"))?;
        }
        Ok(())
    }
}

/// Writes a blob for `payload` into `buf`; returns the number of bytes written.
pub fn encode<Fe, Ex, Fl>(
    dims: Dims,
    payload: &Payload<Fe, Ex, Fl>,
    buf: &mut [u8],
) -> Result<usize, BlobError>
where
    Fe: Serialize,
    Ex: Serialize,
    Fl: Serialize,
{
    let body = buf.get_mut(HEADER_LEN..).ok_or(BlobError::BufferTooSmall)?;
    let len = postcard::to_slice(payload, body)
        .map_err(|_| BlobError::BufferTooSmall)?
        .len();
    seal(dims, len, buf)
}

/// Writes the header of a model blob of `dims` whose payload (`len` bytes, postcard) already
/// follows it in `buf`, and seals it; returns the blob's length. What [`encode`] does after
/// serializing, and what makes a unit's channel entry a model blob of its own again.
pub fn seal(dims: Dims, len: usize, buf: &mut [u8]) -> Result<usize, BlobError> {
    let (m, d, p) = (
        u16::try_from(dims.m).map_err(|_| BlobError::InvalidParameter)?,
        u8::try_from(dims.d).map_err(|_| BlobError::InvalidParameter)?,
        u8::try_from(dims.p).map_err(|_| BlobError::InvalidParameter)?,
    );
    u32::try_from(len).map_err(|_| BlobError::BufferTooSmall)?;
    let header = buf.get_mut(..HEADER_LEN).ok_or(BlobError::BufferTooSmall)?;
    let mut h = [0u8; LEN_AT];
    let fields: [&[u8]; 6] = [
        &MAGIC,
        &FORMAT_VERSION.to_le_bytes(),
        &m.to_le_bytes(),
        &[d],
        &[p],
        &0u32.to_le_bytes(),
    ];
    let mut at = 0;
    for f in fields {
        if let Some(dst) = h.get_mut(at..at + f.len()) {
            dst.copy_from_slice(f);
        }
        at += f.len();
    }
    if let Some(dst) = header.get_mut(..LEN_AT) {
        dst.copy_from_slice(&h);
    }
    let blob = buf
        .get_mut(..HEADER_LEN + len)
        .ok_or(BlobError::BufferTooSmall)?;
    reseal(blob);
    Ok(HEADER_LEN + len)
}

/// Offset of the header's sequence number (u32 LE).
const SEQUENCE_AT: usize = 10;
/// Offset of the header's payload length (u32 LE); the CRC follows it.
const LEN_AT: usize = 14;
/// Offset of the header's CRC (u32 LE).
const CRC_AT: usize = 18;
/// The header bytes the CRC covers, before the payload: version to length.
const CHECKED: Range<usize> = 4..CRC_AT;

/// The CRC of a blob of format 4 or later: header bytes [`CHECKED`], then the payload.
fn checksum(header: &[u8], payload: &[u8]) -> u32 {
    let mut digest = CRC32.digest();
    digest.update(header.get(CHECKED).unwrap_or(&[]));
    digest.update(payload);
    digest.finalize()
}

/// Writes the payload length and CRC into a header of format 4 or later: what [`encode`] and
/// [`set_sequence`] do last, and what a tool or test that edits a blob on purpose does to reach
/// the decoder behind the integrity check. Shorter than a header: left as it is.
pub fn reseal(blob: &mut [u8]) {
    let Some((header, payload)) = blob.split_at_mut_checked(HEADER_LEN) else {
        return;
    };
    let len = u32::try_from(payload.len()).unwrap_or(u32::MAX);
    if let Some(dst) = header.get_mut(LEN_AT..LEN_AT + 4) {
        dst.copy_from_slice(&len.to_le_bytes());
    }
    let crc = checksum(header, payload);
    if let Some(dst) = header.get_mut(CRC_AT..CRC_AT + 4) {
        dst.copy_from_slice(&crc.to_le_bytes());
    }
}

/// Stamps `sequence` into a valid blob of format 4 or later (or a unit blob, [`mod@unit`]) and
/// reseals it. A version-3 blob has no room for one: [`BlobError::NoSequence`].
pub fn set_sequence(blob: &mut [u8], sequence: u32) -> Result<(), BlobError> {
    let sealed = read_sealed(blob)?;
    if sealed.magic == MAGIC && sealed.version == V3 {
        return Err(BlobError::NoSequence(sealed.version));
    }
    let dst = blob
        .get_mut(SEQUENCE_AT..SEQUENCE_AT + 4)
        .ok_or(BlobError::Truncated)?;
    dst.copy_from_slice(&sequence.to_le_bytes());
    reseal(blob);
    Ok(())
}

/// Writes `error` as the error model of a valid blob of this format and reseals it: what the
/// trainer does once it has measured a model's errors. The error model and the limits are the
/// payload's last fields, fifteen f32 that postcard writes as their little-endian bytes, so the
/// error model is the twelve before the blob's last three. A blob of an earlier format:
/// [`BlobError::UnsupportedVersion`].
pub fn set_error_model(blob: &mut [u8], error: &ErrorModel) -> Result<(), BlobError> {
    error.check()?;
    set_tail(blob, Limits::NUMBERS, &error.numbers())
}

/// Writes `limits` as the limits of a valid blob of this format and reseals it: the blob's last
/// three f32. A blob of an earlier format: [`BlobError::UnsupportedVersion`].
pub fn set_limits(blob: &mut [u8], limits: &Limits) -> Result<(), BlobError> {
    limits.check()?;
    set_tail(blob, 0, &limits.numbers())
}

/// Writes what the mean of a valid blob of this format does beyond its trained range, and
/// reseals it: one byte, before the error model and the limits. A blob of an earlier format:
/// [`BlobError::UnsupportedVersion`].
pub fn set_beyond(blob: &mut [u8], beyond: Beyond) -> Result<(), BlobError> {
    let header = read_header(blob)?;
    if header.version != FORMAT_VERSION {
        return Err(BlobError::UnsupportedVersion(header.version));
    }
    let at = blob
        .len()
        .checked_sub(4 * (ErrorModel::NUMBERS + Limits::NUMBERS) + 1)
        .filter(|&at| at >= HEADER_LEN)
        .ok_or(BlobError::Truncated)?;
    let byte = blob.get_mut(at).ok_or(BlobError::Truncated)?;
    *byte = match beyond {
        Beyond::Hold => 0,
        Beyond::Tangent => 1,
        Beyond::Follow => 2,
    };
    reseal(blob);
    Ok(())
}

/// Writes `numbers` as the f32 that end `after` numbers before the end of a valid blob of this
/// format, and reseals it.
fn set_tail(blob: &mut [u8], after: usize, numbers: &[f32]) -> Result<(), BlobError> {
    let header = read_header(blob)?;
    if header.version != FORMAT_VERSION {
        return Err(BlobError::UnsupportedVersion(header.version));
    }
    let at = blob
        .len()
        .checked_sub(4 * (after + numbers.len()))
        .filter(|&at| at >= HEADER_LEN)
        .ok_or(BlobError::Truncated)?;
    for (k, v) in numbers.iter().enumerate() {
        if let Some(dst) = blob.get_mut(at + 4 * k..at + 4 * k + 4) {
            dst.copy_from_slice(&v.to_le_bytes());
        }
    }
    reseal(blob);
    Ok(())
}

/// The length in bytes, header included, that the header at the start of `bytes` declares for
/// its blob (a model blob of any version read, or a unit blob), unchecked: how much of a flash
/// slot to give [`read_sealed`].
pub fn declared_len(bytes: &[u8]) -> Option<usize> {
    let magic = le::<4>(bytes, 0).ok()?;
    let version = u16::from_le_bytes(le(bytes, 4).ok()?);
    let (len_at, header_len) = match (magic, version) {
        (MAGIC, FORMAT_VERSION | V8 | V7 | V6 | V5 | V4)
        | (unit::MAGIC, unit::VERSION | unit::V4 | unit::V3 | unit::V2 | unit::V1) => {
            (LEN_AT, HEADER_LEN)
        }
        (MAGIC, V3) => (10, V3_HEADER_LEN),
        _ => return None,
    };
    let len = usize::try_from(u32::from_le_bytes(le(bytes, len_at).ok()?)).ok()?;
    header_len.checked_add(len)
}

/// A blob whose envelope is intact: the magic says which kind it is (a model, [`MAGIC`], or a
/// unit, [`unit::MAGIC`]), and its version, length and CRC check. Nothing past the envelope has
/// been read.
pub struct Sealed<'a> {
    /// [`MAGIC`] or [`unit::MAGIC`].
    pub magic: [u8; 4],
    /// Format version of that kind.
    pub version: u16,
    /// Sequence number (0 for a [`V3`] model blob).
    pub sequence: u32,
    /// The header, magic included.
    pub header: &'a [u8],
    /// The CRC-checked payload.
    pub payload: &'a [u8],
}

/// Checks the envelope every blob shares, whatever it holds: the magic (a model or a unit blob),
/// a version this crate reads, the payload length and the CRC. What a calibration slot checks,
/// and where [`read_header`] and [`unit::read_header`] start.
pub fn read_sealed(bytes: &[u8]) -> Result<Sealed<'_>, BlobError> {
    if bytes.len() < V3_HEADER_LEN {
        return Err(BlobError::Truncated);
    }
    let magic = le::<4>(bytes, 0)?;
    if magic != MAGIC && magic != unit::MAGIC {
        return Err(BlobError::BadMagic);
    }
    let version = u16::from_le_bytes(le(bytes, 4)?);
    // (length, CRC, payload) offsets of the two layouts; V3 has no sequence.
    let (len_at, crc_at, header_len, sequence) = match (magic, version) {
        (MAGIC, FORMAT_VERSION | V8 | V7 | V6 | V5 | V4)
        | (unit::MAGIC, unit::VERSION | unit::V4 | unit::V3 | unit::V2 | unit::V1) => (
            LEN_AT,
            CRC_AT,
            HEADER_LEN,
            u32::from_le_bytes(le(bytes, SEQUENCE_AT)?),
        ),
        (MAGIC, V3) => (10, 14, V3_HEADER_LEN, 0),
        (_, other) => return Err(BlobError::UnsupportedVersion(other)),
    };
    let len = usize::try_from(u32::from_le_bytes(le(bytes, len_at)?))
        .map_err(|_| BlobError::Truncated)?;
    let crc = u32::from_le_bytes(le(bytes, crc_at)?);
    let (header, payload) = bytes
        .split_at_checked(header_len)
        .ok_or(BlobError::Truncated)?;
    match payload.len().cmp(&len) {
        core::cmp::Ordering::Less => return Err(BlobError::Truncated),
        core::cmp::Ordering::Greater => return Err(BlobError::TrailingBytes),
        core::cmp::Ordering::Equal => {}
    }
    let expected = if magic == MAGIC && version == V3 {
        CRC32.checksum(payload)
    } else {
        checksum(bytes, payload)
    };
    if expected != crc {
        return Err(BlobError::CrcMismatch);
    }
    Ok(Sealed {
        magic,
        version,
        sequence,
        header,
        payload,
    })
}

/// A checked header: dimensions, sequence and the payload bytes it covers.
pub struct Header<'a> {
    /// Format version ([`FORMAT_VERSION`], [`V8`], [`V7`], [`V6`], [`V5`], [`V4`] or [`V3`]).
    pub version: u16,
    /// Model sizes.
    pub dims: Dims,
    /// Sequence number (0 for a [`V3`] blob).
    pub sequence: u32,
    /// The CRC-checked payload.
    pub payload: &'a [u8],
}

fn le<const N: usize>(bytes: &[u8], at: usize) -> Result<[u8; N], BlobError> {
    bytes
        .get(at..at + N)
        .and_then(|s| <[u8; N]>::try_from(s).ok())
        .ok_or(BlobError::Truncated)
}

/// Checks magic, version, payload length and CRC of a model blob; returns the dimensions, the
/// sequence and the payload. Reads [`FORMAT_VERSION`], [`V8`], [`V7`], [`V6`], [`V5`], [`V4`] and
/// [`V3`]; a
/// unit blob is not a model blob ([`BlobError::BadMagic`]: [`unit::read_header`] reads it).
pub fn read_header(bytes: &[u8]) -> Result<Header<'_>, BlobError> {
    let sealed = read_sealed(bytes)?;
    if sealed.magic != MAGIC {
        return Err(BlobError::BadMagic);
    }
    let dims = Dims {
        m: usize::from(u16::from_le_bytes(le(bytes, 6)?)),
        d: usize::from(le::<1>(bytes, 8)?[0]),
        p: usize::from(le::<1>(bytes, 9)?[0]),
    };
    if dims.d == 0 {
        return Err(BlobError::InconsistentDimensions);
    }
    Ok(Header {
        version: sealed.version,
        dims,
        sequence: sealed.sequence,
        payload: sealed.payload,
    })
}

#[cfg(test)]
mod tests;
