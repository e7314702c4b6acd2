//! The unit blob: every channel of a sensor unit (the three gyro and three accelerometer axes of
//! an IMU, or a FOG's coils) in one blob, under one version, CRC and sequence number, so that one
//! calibration slot holds the whole unit and an update replaces all of it or none. The one
//! definition of its format; the decoded form is [`crate::unit::Unit`].
//!
//! # Layout (unit format version 2)
//!
//! ```text
//! offset size  field
//!  0      4    magic "FOGU"
//!  4      2    unit format version, u16 LE (2)
//!  6      1    c: channels (1 or more)
//!  7      1    d: most inputs of any channel
//!  8      2    m: most centres of any channel, u16 LE (the variance scratch a sample needs)
//! 10      4    sequence number, u32 LE (0 as exported; a calibration slot stamps its own)
//! 14      4    payload length in bytes, u32 LE
//! 18      4    CRC-32/ISO-HDLC of bytes 4..18 and the payload, u32 LE
//! 22      …    payload: postcard encoding of [`UnitPayload`]
//! ```
//!
//! The envelope (sequence, length and CRC at the model blob's offsets) is the model blob's, so a
//! calibration slot stores either kind the same way ([`super::read_sealed`]). The payload: the
//! numbers of all channels' flat arrays together (u32, so storage too small for them is refused
//! before a channel is read), the sensor's ID (at most [`SENSOR_ID_BYTES`] of UTF-8: the part
//! number or serial the firmware can check the blob against), the unit's trained temperature range
//! (two f32, °C: where every channel was calibrated), then the channels in order, each with its
//! name (at most [`NAME_BYTES`]), its [`Quantity`], its sizes m, d and p, and its model: the
//! payload of a model blob of the current format ([`super::FORMAT_VERSION`], the layout of
//! [`super`]) as a byte string. A channel's model is therefore exactly the model blob the trainer
//! checked on its own, and decodes through the same code. Versions 4, 3, 2 and 1, whose channels
//! hold model payloads of format [`super::V8`], [`super::V7`], [`super::V6`] and [`super::V5`], are
//! still read.

use serde::{Deserialize, Serialize};

use super::{Dims, FORMAT_VERSION, HEADER_LEN, LEN_AT, read_header as read_model_header};
use crate::error::BlobError;
use crate::units::Quantity;

/// First four bytes of a unit blob.
pub const MAGIC: [u8; 4] = *b"FOGU";
/// The unit format version this crate writes (it also reads [`V4`], [`V3`], [`V2`] and [`V1`]).
pub const VERSION: u16 = 5;
/// The previous unit format version, still read: its channels' models are of format
/// [`super::V8`].
pub const V4: u16 = 4;
/// The unit format version before it, still read: its channels' models are of format
/// [`super::V7`].
pub const V3: u16 = 3;
/// The unit format version before it, still read: its channels' models are of format
/// [`super::V6`].
pub const V2: u16 = 2;
/// The unit format version before it, still read: its channels' models are of format
/// [`super::V5`].
pub const V1: u16 = 1;
/// Longest channel name, bytes of UTF-8.
pub const NAME_BYTES: usize = 16;
/// Longest sensor ID, bytes of UTF-8.
pub const SENSOR_ID_BYTES: usize = 32;

/// The payload, generic over the container of its channels: a heapless vector in the firmware,
/// an iterator's adapter when the trainer writes it. Both encode to the same bytes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct UnitPayload<'a, Ch> {
    /// Numbers in all channels' flat arrays together.
    pub numbers: u32,
    /// The sensor's ID.
    pub sensor_id: &'a str,
    /// The trained temperature range, °C: (lowest, highest).
    pub temperature_c: [f32; 2],
    /// The channels, in order.
    pub channels: Ch,
}

/// One channel of a unit blob as encoded.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
pub struct ChannelEntry<'a> {
    /// Its name (`gyro.x`, `acc.z`, `coil`).
    pub name: &'a str,
    /// What it measures.
    pub quantity: Quantity,
    /// Centres.
    pub m: u16,
    /// Inputs.
    pub d: u8,
    /// Prior-mean monomials.
    pub p: u8,
    /// The model blob payload of [`FORMAT_VERSION`]. Postcard writes a sequence of bytes as its
    /// length and the bytes, which is how it reads a borrowed byte string back.
    pub model: &'a [u8],
}

impl ChannelEntry<'_> {
    /// The channel's model sizes.
    pub fn dims(&self) -> Dims {
        Dims {
            m: usize::from(self.m),
            d: usize::from(self.d),
            p: usize::from(self.p),
        }
    }
}

/// A channel to encode: its name, its quantity and its model blob (format
/// [`FORMAT_VERSION`], as the trainer exported and checked it).
#[derive(Debug, Clone, Copy)]
pub struct ChannelBlob<'a> {
    /// Its name, at most [`NAME_BYTES`].
    pub name: &'a str,
    /// What it measures.
    pub quantity: Quantity,
    /// Its model blob.
    pub model: &'a [u8],
}

/// The channels as the payload encodes them, from their model blobs (checked by [`encode`]
/// before it serializes them).
struct Entries<'a>(&'a [ChannelBlob<'a>]);

impl Serialize for Entries<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0.iter().map(|c| {
            let (dims, payload) = read_model_header(c.model)
                .map(|h| (h.dims, h.payload))
                .unwrap_or((Dims { m: 0, d: 0, p: 0 }, &[]));
            ChannelEntry {
                name: c.name,
                quantity: c.quantity,
                m: u16::try_from(dims.m).unwrap_or(u16::MAX),
                d: u8::try_from(dims.d).unwrap_or(u8::MAX),
                p: u8::try_from(dims.p).unwrap_or(u8::MAX),
                model: payload,
            }
        }))
    }
}

/// Writes the unit blob of `channels` (with the sensor's ID and the trained temperature range)
/// into `buf`; returns the number of bytes written. Every channel's model is a valid blob of
/// [`FORMAT_VERSION`] (else its error); a name or ID too long, no channel, more than 255, or a
/// range that is not one is [`BlobError::InvalidParameter`].
pub fn encode(
    sensor_id: &str,
    temperature_c: [f32; 2],
    channels: &[ChannelBlob<'_>],
    buf: &mut [u8],
) -> Result<usize, BlobError> {
    let c = u8::try_from(channels.len()).map_err(|_| BlobError::InvalidParameter)?;
    let [lo, hi] = temperature_c;
    if c == 0
        || sensor_id.len() > SENSOR_ID_BYTES
        || !(lo.is_finite() && hi.is_finite() && lo <= hi)
    {
        return Err(BlobError::InvalidParameter);
    }
    let (mut numbers, mut most_d, mut most_m) = (0usize, 0usize, 0usize);
    for ch in channels {
        let h = read_model_header(ch.model)?;
        if h.version != FORMAT_VERSION {
            return Err(BlobError::UnsupportedVersion(h.version));
        }
        if ch.name.is_empty() || ch.name.len() > NAME_BYTES {
            return Err(BlobError::InvalidParameter);
        }
        numbers += h.dims.floats();
        most_d = most_d.max(h.dims.d);
        most_m = most_m.max(h.dims.m);
    }
    let payload = UnitPayload {
        numbers: u32::try_from(numbers).map_err(|_| BlobError::InvalidParameter)?,
        sensor_id,
        temperature_c,
        channels: Entries(channels),
    };
    let (header, body) = buf
        .split_at_mut_checked(HEADER_LEN)
        .ok_or(BlobError::BufferTooSmall)?;
    let len = postcard::to_slice(&payload, body)
        .map_err(|_| BlobError::BufferTooSmall)?
        .len();
    u32::try_from(len).map_err(|_| BlobError::BufferTooSmall)?;
    let d = u8::try_from(most_d).map_err(|_| BlobError::InvalidParameter)?;
    let m = u16::try_from(most_m).map_err(|_| BlobError::InvalidParameter)?;
    let mut h = [0u8; LEN_AT];
    h[..4].copy_from_slice(&MAGIC);
    h[4..6].copy_from_slice(&VERSION.to_le_bytes());
    h[6] = c;
    h[7] = d;
    h[8..10].copy_from_slice(&m.to_le_bytes());
    // Bytes 10..14, the sequence, stay 0.
    header
        .get_mut(..LEN_AT)
        .ok_or(BlobError::BufferTooSmall)?
        .copy_from_slice(&h);
    let blob = buf
        .get_mut(..HEADER_LEN + len)
        .ok_or(BlobError::BufferTooSmall)?;
    super::reseal(blob);
    Ok(HEADER_LEN + len)
}

/// A checked unit header: its sizes, its sequence and the payload bytes the CRC covers.
#[derive(Debug, Clone, Copy)]
pub struct UnitHeader<'a> {
    /// Channels.
    pub channels: usize,
    /// Most inputs of any channel.
    pub most_inputs: usize,
    /// Most centres of any channel: the variance scratch a sample needs.
    pub most_centres: usize,
    /// Sequence number.
    pub sequence: u32,
    /// The format of its channels' model payloads: [`FORMAT_VERSION`], or [`super::V8`],
    /// [`super::V7`], [`super::V6`] and [`super::V5`] in a unit blob of version [`V4`], [`V3`],
    /// [`V2`] and [`V1`].
    pub model_version: u16,
    /// The CRC-checked payload.
    pub payload: &'a [u8],
}

/// Checks a unit blob's envelope (magic, version, length, CRC) and returns its header. A model
/// blob is not a unit blob ([`BlobError::BadMagic`]).
pub fn read_header(bytes: &[u8]) -> Result<UnitHeader<'_>, BlobError> {
    let sealed = super::read_sealed(bytes)?;
    if sealed.magic != MAGIC {
        return Err(BlobError::BadMagic);
    }
    let h = sealed.header;
    let byte = |i: usize| h.get(i).copied().ok_or(BlobError::Truncated);
    let channels = usize::from(byte(6)?);
    if channels == 0 {
        return Err(BlobError::InconsistentDimensions);
    }
    Ok(UnitHeader {
        channels,
        most_inputs: usize::from(byte(7)?),
        most_centres: usize::from(u16::from_le_bytes([byte(8)?, byte(9)?])),
        sequence: sealed.sequence,
        model_version: match sealed.version {
            V1 => super::V5,
            V2 => super::V6,
            V3 => super::V7,
            V4 => super::V8,
            _ => FORMAT_VERSION,
        },
        payload: sealed.payload,
    })
}

/// Decodes a unit payload into at most `C` channel entries (borrowing the payload's bytes), and
/// checks it against its header: the channel count and the largest sizes.
pub fn read_payload<'a, const C: usize>(
    header: &UnitHeader<'a>,
) -> Result<UnitPayload<'a, heapless::Vec<ChannelEntry<'a>, C>>, BlobError> {
    let (payload, rest): (UnitPayload<'a, heapless::Vec<ChannelEntry<'a>, C>>, _) =
        postcard::take_from_bytes(header.payload).map_err(|_| BlobError::Malformed)?;
    if !rest.is_empty() {
        return Err(BlobError::TrailingBytes);
    }
    let entries = &payload.channels;
    let most = |f: fn(&ChannelEntry<'_>) -> usize| entries.iter().map(f).max().unwrap_or(0);
    if entries.len() != header.channels
        || most(|e| usize::from(e.d)) != header.most_inputs
        || most(|e| usize::from(e.m)) != header.most_centres
        || entries.iter().map(|e| e.dims().floats()).sum::<usize>() != payload.numbers as usize
    {
        return Err(BlobError::InconsistentDimensions);
    }
    let [lo, hi] = payload.temperature_c;
    if payload.sensor_id.len() > SENSOR_ID_BYTES
        || entries
            .iter()
            .any(|e| e.name.is_empty() || e.name.len() > NAME_BYTES)
        || !(lo.is_finite() && hi.is_finite() && lo <= hi)
    {
        return Err(BlobError::InvalidParameter);
    }
    Ok(payload)
}
