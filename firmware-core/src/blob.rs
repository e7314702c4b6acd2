//! The model blob: the one definition of what the trainer exports and the firmware loads.
//!
//! # Layout (format version 3)
//!
//! ```text
//! offset size  field
//!  0      4    magic "FOGB"
//!  4      2    format version, u16 little-endian (3)
//!  6      2    m: number of centres, u16 LE
//!  8      1    d: number of inputs
//!  9      1    p: number of prior-mean monomials
//! 10      4    payload length in bytes, u32 LE
//! 14      4    CRC-32/ISO-HDLC of the payload, u32 LE
//! 18      …    payload: postcard encoding of [`Payload`]
//! ```
//!
//! The dimensions sit in the header so that a blob too large for the integrator's capacities is
//! refused by a typed error before anything is decoded. The payload is three postcard sequences
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
//! f32, so the kernel is the static model's. A change of this layout bumps
//! [`FORMAT_VERSION`]; a golden-bytes test pins the encoding.

use core::ops::Range;

use serde::{Deserialize, Serialize};

use crate::error::BlobError;

/// First four bytes of every blob.
pub const MAGIC: [u8; 4] = *b"FOGB";
/// The format version this crate reads and writes.
pub const FORMAT_VERSION: u16 = 3;
/// Length scale of an input the kernel ignores (module doc).
pub const IGNORED_LENGTH_SCALE: f32 = 1e30;
/// Header bytes before the payload.
pub const HEADER_LEN: usize = 18;

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
    let fields: [&[u8]; 5] = [
        &MAGIC,
        &FORMAT_VERSION.to_le_bytes(),
        &m.to_le_bytes(),
        &[d],
        &[p],
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

/// Offset of the header's payload length (u32 LE); the CRC follows it.
const LEN_AT: usize = 10;
/// Offset of the header's CRC (u32 LE).
const CRC_AT: usize = 14;

/// Writes the payload length and CRC of the bytes after the header into the header: what
/// [`encode`] does last, and what a tool or test that edits a payload on purpose does to reach
/// the decoder behind the integrity check. Shorter than a header: left as it is.
pub fn reseal(blob: &mut [u8]) {
    let Some((header, payload)) = blob.split_at_mut_checked(HEADER_LEN) else {
        return;
    };
    let len = u32::try_from(payload.len()).unwrap_or(u32::MAX);
    let crc = CRC32.checksum(payload);
    for (at, value) in [(LEN_AT, len), (CRC_AT, crc)] {
        if let Some(dst) = header.get_mut(at..at + 4) {
            dst.copy_from_slice(&value.to_le_bytes());
        }
    }
}

/// A checked header: dimensions and the payload bytes it covers.
pub struct Header<'a> {
    /// Model sizes.
    pub dims: Dims,
    /// The CRC-checked payload.
    pub payload: &'a [u8],
}

fn le<const N: usize>(bytes: &[u8], at: usize) -> Result<[u8; N], BlobError> {
    bytes
        .get(at..at + N)
        .and_then(|s| <[u8; N]>::try_from(s).ok())
        .ok_or(BlobError::Truncated)
}

/// Checks magic, version, payload length and CRC; returns the dimensions and the payload.
pub fn read_header(bytes: &[u8]) -> Result<Header<'_>, BlobError> {
    if bytes.len() < HEADER_LEN {
        return Err(BlobError::Truncated);
    }
    if le::<4>(bytes, 0)? != MAGIC {
        return Err(BlobError::BadMagic);
    }
    let version = u16::from_le_bytes(le(bytes, 4)?);
    if version != FORMAT_VERSION {
        return Err(BlobError::UnsupportedVersion(version));
    }
    let dims = Dims {
        m: usize::from(u16::from_le_bytes(le(bytes, 6)?)),
        d: usize::from(le::<1>(bytes, 8)?[0]),
        p: usize::from(le::<1>(bytes, 9)?[0]),
    };
    let len = usize::try_from(u32::from_le_bytes(le(bytes, LEN_AT)?))
        .map_err(|_| BlobError::Truncated)?;
    let crc = u32::from_le_bytes(le(bytes, CRC_AT)?);
    let payload = bytes.get(HEADER_LEN..).ok_or(BlobError::Truncated)?;
    match payload.len().cmp(&len) {
        core::cmp::Ordering::Less => return Err(BlobError::Truncated),
        core::cmp::Ordering::Greater => return Err(BlobError::TrailingBytes),
        core::cmp::Ordering::Equal => {}
    }
    if CRC32.checksum(payload) != crc {
        return Err(BlobError::CrcMismatch);
    }
    if dims.d == 0 {
        return Err(BlobError::InconsistentDimensions);
    }
    Ok(Header { dims, payload })
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
        let crc = CRC32.checksum(&buf[HEADER_LEN..n]).to_le_bytes();
        let mut expected: Vec<u8> = vec![b'F', b'O', b'G', b'B', 3, 0, 1, 0, 1, 1, 61, 0, 0, 0];
        expected.extend(crc);
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
