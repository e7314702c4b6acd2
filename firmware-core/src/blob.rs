//! The model blob: the one definition of what the trainer exports and the firmware loads.
//!
//! # Layout (format version 4)
//!
//! ```text
//! offset size  field
//!  0      4    magic "FOGB"
//!  4      2    format version, u16 little-endian (4)
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
//! ([`crate::slots`]). Version 3 blobs (18-byte header without the sequence, CRC over the payload
//! alone) are still read, as sequence 0. The payload is three postcard sequences
//! (each a varint length, then the elements): the `d` input features (enum index, then the f32
//! parameter of the stateful ones), the `p·d`
//! prior-mean exponents (u8, row per monomial), and one flat array of little-endian f32:
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
//! last. The trainer moves every pure linear monomial of the prior mean here (measured in
//! `trainer/benches/f32_study`: 1.2–2e-5 → 4e-6 °/s).
//!
//! Version 3 adds the stateful features. An input the kernel ignores (one that enters only through
//! its raw linear term, as the additive terms of an extended model do) has length scale
//! [`IGNORED_LENGTH_SCALE`] and centre coordinate 0: its distance term underflows to exactly 0 in
//! f32, so the kernel is the static model's. Version 4 adds the sequence number, for the two
//! power-safe calibration slots. A change of this layout bumps
//! [`FORMAT_VERSION`]; a golden-bytes test pins the encoding.

use core::fmt;
use core::marker::PhantomData;
use core::ops::Range;

use serde::de::{self, DeserializeSeed, SeqAccess, Visitor};
use serde::{Deserialize, Serialize};

use crate::error::BlobError;

/// First four bytes of every blob.
pub const MAGIC: [u8; 4] = *b"FOGB";
/// The format version this crate writes (it also reads [`V3`]).
pub const FORMAT_VERSION: u16 = 4;
/// The previous format version, still read: no sequence number, CRC over the payload alone.
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
pub struct Payload<Fe, Ex, Fl> {
    /// Input features, in input order.
    pub features: Fe,
    /// Prior-mean exponents, `p` rows of `d`.
    pub exponents: Ex,
    /// All numbers, in the layout of the module doc.
    pub floats: Fl,
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
/// [`BlobError::Malformed`], as postcard refuses a sequence longer than its container.
pub(crate) fn read_payload<'de, Fe, Ex>(
    payload: &'de [u8],
    mut number: impl FnMut(f32) -> Result<(), ()>,
) -> Result<(Fe, Ex), BlobError>
where
    Fe: Deserialize<'de>,
    Ex: Deserialize<'de>,
{
    let mut decoder = postcard::Deserializer::from_bytes(payload);
    let fields = serde::Deserializer::deserialize_tuple(
        &mut decoder,
        3,
        PayloadFields {
            number: &mut number,
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

/// [`read_payload`]'s visitor: features and exponents by value, numbers one at a time.
struct PayloadFields<'a, Fe, Ex, F> {
    number: &'a mut F,
    fields: PhantomData<(Fe, Ex)>,
}

impl<'de, Fe, Ex, F> Visitor<'de> for PayloadFields<'_, Fe, Ex, F>
where
    Fe: Deserialize<'de>,
    Ex: Deserialize<'de>,
    F: FnMut(f32) -> Result<(), ()>,
{
    type Value = (Fe, Ex);

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a model payload")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let missing = |i| de::Error::invalid_length(i, &"three fields");
        let features = seq.next_element()?.ok_or_else(|| missing(0))?;
        let exponents = seq.next_element()?.ok_or_else(|| missing(1))?;
        seq.next_element_seed(Numbers(self.number))?
            .ok_or_else(|| missing(2))?;
        Ok((features, exponents))
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
    let (m, d, p) = (
        u16::try_from(dims.m).map_err(|_| BlobError::InvalidParameter)?,
        u8::try_from(dims.d).map_err(|_| BlobError::InvalidParameter)?,
        u8::try_from(dims.p).map_err(|_| BlobError::InvalidParameter)?,
    );
    let (header, body) = buf
        .split_at_mut_checked(HEADER_LEN)
        .ok_or(BlobError::BufferTooSmall)?;
    let len = postcard::to_slice(payload, body)
        .map_err(|_| BlobError::BufferTooSmall)?
        .len();
    u32::try_from(len).map_err(|_| BlobError::BufferTooSmall)?;
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

/// The CRC of a version-4 blob: header bytes [`CHECKED`], then the payload.
fn checksum(header: &[u8], payload: &[u8]) -> u32 {
    let mut digest = CRC32.digest();
    digest.update(header.get(CHECKED).unwrap_or(&[]));
    digest.update(payload);
    digest.finalize()
}

/// Writes the payload length and CRC into a version-4 header: what [`encode`] and
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

/// Stamps `sequence` into a valid version-4 blob and reseals it. A version-3 blob has no room
/// for one: [`BlobError::NoSequence`].
pub fn set_sequence(blob: &mut [u8], sequence: u32) -> Result<(), BlobError> {
    let header = read_header(blob)?;
    if header.version != FORMAT_VERSION {
        return Err(BlobError::NoSequence(header.version));
    }
    let dst = blob
        .get_mut(SEQUENCE_AT..SEQUENCE_AT + 4)
        .ok_or(BlobError::Truncated)?;
    dst.copy_from_slice(&sequence.to_le_bytes());
    reseal(blob);
    Ok(())
}

/// The length in bytes, header included, that the header at the start of `bytes` declares for
/// its blob (either version), unchecked: how much of a flash slot to give [`read_header`].
pub fn declared_len(bytes: &[u8]) -> Option<usize> {
    let version = u16::from_le_bytes(le(bytes, 4).ok()?);
    let (len_at, header_len) = match version {
        FORMAT_VERSION => (LEN_AT, HEADER_LEN),
        V3 => (10, V3_HEADER_LEN),
        _ => return None,
    };
    let len = usize::try_from(u32::from_le_bytes(le(bytes, len_at).ok()?)).ok()?;
    header_len.checked_add(len)
}

/// A checked header: dimensions, sequence and the payload bytes it covers.
pub struct Header<'a> {
    /// Format version ([`FORMAT_VERSION`] or [`V3`]).
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

/// Checks magic, version, payload length and CRC; returns the dimensions, the sequence and the
/// payload. Reads [`FORMAT_VERSION`] and [`V3`].
pub fn read_header(bytes: &[u8]) -> Result<Header<'_>, BlobError> {
    if bytes.len() < V3_HEADER_LEN {
        return Err(BlobError::Truncated);
    }
    if le::<4>(bytes, 0)? != MAGIC {
        return Err(BlobError::BadMagic);
    }
    let version = u16::from_le_bytes(le(bytes, 4)?);
    // (length, CRC, payload) offsets of the two layouts; V3 has no sequence.
    let (len_at, crc_at, header_len, sequence) = match version {
        FORMAT_VERSION => (
            LEN_AT,
            CRC_AT,
            HEADER_LEN,
            u32::from_le_bytes(le(bytes, SEQUENCE_AT)?),
        ),
        V3 => (10, 14, V3_HEADER_LEN, 0),
        other => return Err(BlobError::UnsupportedVersion(other)),
    };
    let dims = Dims {
        m: usize::from(u16::from_le_bytes(le(bytes, 6)?)),
        d: usize::from(le::<1>(bytes, 8)?[0]),
        p: usize::from(le::<1>(bytes, 9)?[0]),
    };
    let len = usize::try_from(u32::from_le_bytes(le(bytes, len_at)?))
        .map_err(|_| BlobError::Truncated)?;
    let crc = u32::from_le_bytes(le(bytes, crc_at)?);
    let payload = bytes.get(header_len..).ok_or(BlobError::Truncated)?;
    match payload.len().cmp(&len) {
        core::cmp::Ordering::Less => return Err(BlobError::Truncated),
        core::cmp::Ordering::Greater => return Err(BlobError::TrailingBytes),
        core::cmp::Ordering::Equal => {}
    }
    let expected = if version == V3 {
        CRC32.checksum(payload)
    } else {
        checksum(bytes, payload)
    };
    if expected != crc {
        return Err(BlobError::CrcMismatch);
    }
    if dims.d == 0 {
        return Err(BlobError::InconsistentDimensions);
    }
    Ok(Header {
        version,
        dims,
        sequence,
        payload,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Storage;
    use crate::model::Model;
    use crate::testing::Reference;

    type Small = Model<2, 6, 64>;

    /// A hand-edited blob with its payload length and CRC made consistent again.
    fn resealed(mut b: Vec<u8>) -> Vec<u8> {
        reseal(&mut b);
        b
    }

    /// offset scale min max length prior raw_hi raw_lo σf² σn² centre weight factor.
    const GOLDEN: [f32; 13] = [
        0.0, 1.0, -1.0, 1.0, 2.0, 0.5, 0.25, 1e-9, 0.01, 0.0, 3.0, 1.0, 1.0,
    ];

    #[test]
    fn golden_bytes_pin_the_encoding() {
        let payload = Payload {
            features: [Feature::TemperatureRate { tau_s: 60.0 }].as_slice(),
            exponents: [0u8].as_slice(),
            floats: GOLDEN.as_slice(),
        };
        let dims = Dims { m: 1, d: 1, p: 1 };
        assert_eq!(dims.floats(), 13);
        let mut buf = [0u8; 128];
        let n = encode(dims, &payload, &mut buf).unwrap();
        let mut expected: Vec<u8> = vec![b'F', b'O', b'G', b'B', 4, 0, 1, 0, 1, 1, 0, 0, 0, 0];
        expected.extend([61, 0, 0, 0]);
        let mut digest = CRC32.digest();
        digest.update(&expected[4..]);
        digest.update(&buf[HEADER_LEN..n]);
        expected.extend(digest.finalize().to_le_bytes());
        // features: len 1, variant 2 with its f32 parameter; exponents: len 1, 0; floats: len 13,
        // then f32 LE.
        expected.extend([1, 2]);
        expected.extend(60.0f32.to_le_bytes());
        expected.extend([1, 0, 13]);
        for v in GOLDEN {
            expected.extend(v.to_le_bytes());
        }
        assert_eq!(&buf[..n], expected.as_slice());
        // CRC-32/ISO-HDLC check value, so the flavour cannot drift.
        assert_eq!(CRC32.checksum(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn a_good_blob_decodes() {
        let m = Small::decode(&Reference::small().blob()).unwrap();
        assert_eq!(m.dims(), Dims { m: 5, d: 2, p: 3 });
        assert_eq!(m.features(), &[Feature::Temperature, Feature::Voltage]);
    }

    #[test]
    fn every_defect_has_its_error() {
        let good = Reference::small().blob();
        let with = |f: &dyn Fn(&mut Vec<u8>)| {
            let mut b = good.clone();
            f(&mut b);
            Small::decode(&b).unwrap_err()
        };
        assert_eq!(with(&|b| b[0] = b'X'), BlobError::BadMagic);
        assert_eq!(with(&|b| b[4] = 1), BlobError::UnsupportedVersion(1));
        assert_eq!(with(&|b| b.truncate(b.len() - 1)), BlobError::Truncated);
        assert_eq!(with(&|b| b.truncate(10)), BlobError::Truncated);
        assert_eq!(with(&|b| b.push(0)), BlobError::TrailingBytes);
        assert_eq!(with(&|b| b[40] ^= 0x10), BlobError::CrcMismatch);
        let garbage = resealed([&good[..HEADER_LEN], &[0xFF; 8]].concat());
        assert_eq!(Small::decode(&garbage).unwrap_err(), BlobError::Malformed);
        let mut wrong_m = good.clone();
        wrong_m[6] = 4;
        assert_eq!(Small::decode(&wrong_m).unwrap_err(), BlobError::CrcMismatch);
        let wrong_m = resealed(wrong_m);
        assert_eq!(
            Small::decode(&wrong_m).unwrap_err(),
            BlobError::InconsistentDimensions
        );
        let nan = Reference::small().blob_with(|f| f[7] = f32::NAN);
        assert_eq!(Small::decode(&nan).unwrap_err(), BlobError::NonFinite(7));
        let zero_scale = Reference::small().blob_with(|f| f[2] = 0.0);
        assert_eq!(
            Small::decode(&zero_scale).unwrap_err(),
            BlobError::InvalidParameter
        );
        let bad_diag = Reference::small().blob_with(|f| *f.last_mut().unwrap() = -1.0);
        assert_eq!(
            Small::decode(&bad_diag).unwrap_err(),
            BlobError::InvalidParameter
        );
    }

    /// The same model as a version-3 blob: 18-byte header, CRC over the payload alone.
    fn as_v3(blob: &[u8]) -> Vec<u8> {
        let payload = &blob[HEADER_LEN..];
        let mut v3 = blob[..10].to_vec();
        v3[4..6].copy_from_slice(&V3.to_le_bytes());
        v3.extend(u32::try_from(payload.len()).unwrap().to_le_bytes());
        v3.extend(CRC32.checksum(payload).to_le_bytes());
        v3.extend(payload);
        v3
    }

    #[test]
    fn a_version_3_blob_still_decodes_as_sequence_0_and_cannot_take_one() {
        let good = Reference::small().blob();
        let mut old = as_v3(&good);
        assert_eq!(Small::decode(&old).unwrap(), Small::decode(&good).unwrap());
        let header = read_header(&old).unwrap();
        assert_eq!((header.version, header.sequence), (V3, 0));
        assert_eq!(set_sequence(&mut old, 1), Err(BlobError::NoSequence(3)));
        old[30] ^= 1;
        assert_eq!(Small::decode(&old).unwrap_err(), BlobError::CrcMismatch);
    }

    #[test]
    fn the_sequence_is_stamped_and_checked_by_the_crc() {
        let mut b = Reference::small().blob();
        assert_eq!(read_header(&b).unwrap().sequence, 0);
        set_sequence(&mut b, 0xDEAD_BEEF).unwrap();
        assert_eq!(read_header(&b).unwrap().sequence, 0xDEAD_BEEF);
        assert_eq!(
            Small::decode(&b).unwrap(),
            Small::decode(&Reference::small().blob()).unwrap()
        );
        for bit in 0..32 {
            let mut flipped = b.clone();
            flipped[SEQUENCE_AT + bit / 8] ^= 1 << (bit % 8);
            assert_eq!(read_header(&flipped).err(), Some(BlobError::CrcMismatch));
        }
    }

    #[test]
    fn a_blob_larger_than_the_capacity_is_refused_not_truncated() {
        let b = Reference::small().blob();
        let needed = Dims { m: 5, d: 2, p: 3 }.floats();
        assert_eq!(
            Model::<2, 6, 32>::decode(&b).unwrap_err(),
            BlobError::CapacityExceeded {
                what: Storage::Floats,
                needed,
                capacity: 32
            }
        );
        assert!(matches!(
            Model::<1, 6, 64>::decode(&b).unwrap_err(),
            BlobError::CapacityExceeded {
                what: Storage::Inputs,
                ..
            }
        ));
        assert!(matches!(
            Model::<2, 4, 64>::decode(&b).unwrap_err(),
            BlobError::CapacityExceeded {
                what: Storage::Exponents,
                ..
            }
        ));
    }
}
