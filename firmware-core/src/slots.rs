//! Two calibration slots in NOR flash, so that a model update survives a power cut.
//!
//! A calibration model is data that gets replaced: at the factory, after a re-calibration, in
//! service over a serial link. Each slot holds one blob ([`crate::blob`]) whose header carries a
//! sequence number. At boot the firmware takes the valid slot with the newest sequence
//! ([`boot`]); an update ([`update`]) writes the *other* slot with the next sequence, so the model
//! in use is never touched, and commits by its last write:
//!
//! A slot holds either kind of blob: one model ([`crate::model::Model`]) or a whole unit's
//! channels ([`crate::unit::Unit`]); what the firmware decodes into says which it takes
//! ([`Calibration`]).
//!
//! 1. erase the other slot's sectors (NOR erases to 0xFF, a sector at a time);
//! 2. program the blob from byte 4 on, page by page (programming only clears bits);
//! 3. program the four magic bytes — the commit. Until they are all there the slot is not a blob.
//!
//! A power cut anywhere leaves the other slot erased, partly erased, partly programmed or
//! complete without its magic, none of which passes [`crate::blob::read_header`] (magic, then a
//! CRC over everything after it); the slot in use is intact, so the next boot takes it again. A
//! flipped bit in either slot fails that slot's CRC and boot takes the other. A slot is only ever
//! a whole blob that the trainer wrote, so a model is never a mix of two.
//!
//! **A driver that fails.** A failed read says nothing about a slot's content: it is an error,
//! never a verdict that the slot is invalid. An update whose reads fail stops before it erases
//! anything (it could otherwise pick the slot in use as the one to write); a boot whose reads
//! fail stops with the error rather than take the other slot, which would be the older model. A
//! failed erase or program stops the update before its commit, so the model in use stays. The
//! [`Layout`] is checked against the device before anything is read ([`Layout::check`]).
//!
//! The flash itself is the integrator's ([`Flash`]): a HAL's driver on the gyro, the simulated
//! NOR of `firmware-sim` in tests.

use crate::blob::{self, MAGIC};
use crate::error::BlobError;
use crate::model::Model;
use crate::unit::{Numbers, Unit};

/// What a calibration slot's blob is decoded into: a model or a unit, at the integrator's
/// capacities.
pub trait Calibration {
    /// Forgets what it holds.
    fn clear(&mut self);
    /// Decodes `blob` in place; on an error it holds nothing.
    fn decode_into(&mut self, blob: &[u8]) -> Result<(), BlobError>;
    /// Checks `blob` as [`Self::decode_into`] would, storing nothing.
    fn check(blob: &[u8]) -> Result<(), BlobError>;
}

impl<const D: usize, const E: usize, const N: usize> Calibration for Model<D, E, N> {
    fn clear(&mut self) {
        Model::clear(self);
    }

    fn decode_into(&mut self, blob: &[u8]) -> Result<(), BlobError> {
        Model::decode_into(self, blob)
    }

    fn check(blob: &[u8]) -> Result<(), BlobError> {
        Model::<D, E, N>::check(blob).map(|_| ())
    }
}

impl<const C: usize, const D: usize, const E: usize, S: Numbers> Calibration for Unit<C, D, E, S> {
    fn clear(&mut self) {
        Unit::clear(self);
    }

    fn decode_into(&mut self, blob: &[u8]) -> Result<(), BlobError> {
        Unit::decode_into(self, blob)
    }

    fn check(blob: &[u8]) -> Result<(), BlobError> {
        Unit::<C, D, E, S>::check(blob).map(|_| ())
    }
}

/// NOR flash as the slots use it. Addresses are byte offsets into the device.
pub trait Flash {
    /// Bytes of the device: every address is below it.
    fn size(&self) -> usize;
    /// Erase unit, bytes (a sector erases to 0xFF).
    fn sector(&self) -> usize;
    /// Program unit, bytes: one program operation stays inside one page.
    fn page(&self) -> usize;
    /// Reads `buf.len()` bytes at `addr`.
    fn read(&self, addr: usize, buf: &mut [u8]) -> Result<(), FlashError>;
    /// Erases the sector that starts at `addr`.
    fn erase(&mut self, addr: usize) -> Result<(), FlashError>;
    /// Programs `data` at `addr` (clearing bits only), within one page.
    fn program(&mut self, addr: usize, data: &[u8]) -> Result<(), FlashError>;
}

/// A flash operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FlashError {
    /// The address range is outside the device, or an erase address is not a sector start.
    OutOfRange,
    /// The device reported a failure (or, simulated, the power went).
    Device,
}

/// Why no model could be booted, or an update was not done.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SlotError {
    /// Neither slot holds a valid blob.
    NoValidSlot,
    /// The blob is larger than a slot.
    TooLarge {
        /// Bytes of the blob.
        blob: usize,
        /// Bytes of a slot.
        slot: usize,
    },
    /// The buffer given is smaller than a slot.
    BufferTooSmall,
    /// The blob to write is not valid for this firmware.
    Blob(BlobError),
    /// The flash failed.
    Flash(FlashError),
    /// The slot read back differs from what was written.
    Verify,
    /// The layout does not fit the device ([`Layout::check`]).
    Layout(LayoutError),
}

/// Why a [`Layout`] was refused, before anything was read, erased or programmed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LayoutError {
    /// A slot of zero bytes, or a device with a zero-byte sector or page.
    Empty,
    /// The slot length is not a whole number of sectors: erasing its last sector would erase
    /// beyond it.
    NotWholeSectors,
    /// A slot does not start on a sector boundary.
    Unaligned,
    /// The two slots overlap.
    Overlap,
    /// A slot reaches beyond the device (or beyond the address space).
    OutsideDevice,
}

impl From<FlashError> for SlotError {
    fn from(e: FlashError) -> Self {
        Self::Flash(e)
    }
}

impl From<BlobError> for SlotError {
    fn from(e: BlobError) -> Self {
        Self::Blob(e)
    }
}

impl core::fmt::Display for SlotError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoValidSlot => write!(f, "no calibration slot holds a valid model"),
            Self::TooLarge { blob, slot } => {
                write!(f, "blob of {blob} bytes does not fit a {slot}-byte slot")
            }
            Self::BufferTooSmall => write!(f, "buffer smaller than a slot"),
            Self::Blob(e) => write!(f, "blob refused: {e}"),
            Self::Flash(e) => write!(f, "flash failed: {e:?}"),
            Self::Verify => write!(f, "slot read back differs from the blob written"),
            Self::Layout(e) => write!(f, "slot layout refused: {e:?}"),
        }
    }
}

impl core::error::Error for SlotError {}

/// Where the two slots are: each `len` bytes, sector-aligned, not overlapping.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Address of slot A.
    pub a: usize,
    /// Address of slot B.
    pub b: usize,
    /// Bytes of each slot (a whole number of sectors).
    pub len: usize,
}

/// One of the two slots.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Slot {
    /// The first.
    A,
    /// The second.
    B,
}

impl Slot {
    /// The other slot.
    pub fn other(self) -> Self {
        match self {
            Self::A => Self::B,
            Self::B => Self::A,
        }
    }
}

impl Layout {
    fn addr(&self, slot: Slot) -> usize {
        match slot {
            Slot::A => self.a,
            Slot::B => self.b,
        }
    }

    /// Checks the layout against `flash`: slots of a whole, non-zero number of sectors, each
    /// starting on a sector, apart, and inside the device.
    pub fn check<F: Flash>(&self, flash: &F) -> Result<(), LayoutError> {
        let (sector, size) = (flash.sector(), flash.size());
        if self.len == 0 || sector == 0 || flash.page() == 0 {
            return Err(LayoutError::Empty);
        }
        if !self.len.is_multiple_of(sector) {
            return Err(LayoutError::NotWholeSectors);
        }
        if !self.a.is_multiple_of(sector) || !self.b.is_multiple_of(sector) {
            return Err(LayoutError::Unaligned);
        }
        let end = |start: usize| start.checked_add(self.len).filter(|&e| e <= size);
        let (Some(a_end), Some(b_end)) = (end(self.a), end(self.b)) else {
            return Err(LayoutError::OutsideDevice);
        };
        if self.a < b_end && self.b < a_end {
            return Err(LayoutError::Overlap);
        }
        Ok(())
    }
}

/// Where the model a boot took came from: which slot, with which sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Booted {
    /// The slot it came from.
    pub slot: Slot,
    /// Its sequence number.
    pub sequence: u32,
}

/// The blob in `slot`, if the slot holds a valid one: read into `buf`, checked (magic, version,
/// length, CRC); its length and sequence. A failed read is an error, not an invalid slot.
fn valid<F: Flash>(
    flash: &F,
    layout: &Layout,
    slot: Slot,
    buf: &mut [u8],
) -> Result<Option<(usize, u32)>, FlashError> {
    let Some(buf) = buf.get_mut(..layout.len) else {
        return Ok(None);
    };
    flash.read(layout.addr(slot), buf)?;
    // The header says how long the blob is; the slot's erased tail must not count as payload.
    let Some(len) = blob::declared_len(buf) else {
        return Ok(None);
    };
    Ok(buf
        .get(..len)
        .and_then(|b| blob::read_sealed(b).ok())
        .map(|h| (len, h.sequence)))
}

/// The valid slots' sequences, newest first; an error where either slot could not be read.
fn newest<F: Flash>(
    flash: &F,
    layout: &Layout,
    buf: &mut [u8],
) -> Result<[Option<(Slot, u32)>; 2], FlashError> {
    let a = valid(flash, layout, Slot::A, buf)?.map(|(_, s)| (Slot::A, s));
    let b = valid(flash, layout, Slot::B, buf)?.map(|(_, s)| (Slot::B, s));
    Ok(match (a, b) {
        (Some(x), Some(y)) if y.1 > x.1 => [b, a],
        (None, Some(_)) => [b, None],
        _ => [a, b],
    })
}

/// Boots the valid slot with the newest sequence (the other where the newest does not decode),
/// decoding it into `model` (typically a `static`: [`Model::decode_into`], or a unit's
/// [`Unit::decode_into`]). `buf` holds at least one slot. Where no slot holds a valid blob,
/// `model` holds none either; so it is where a read fails ([`SlotError::Flash`]): taking the
/// other slot then could boot the older blob, so the caller retries (module doc).
pub fn boot<F: Flash, T: Calibration>(
    flash: &F,
    layout: &Layout,
    buf: &mut [u8],
    model: &mut T,
) -> Result<Booted, SlotError> {
    model.clear();
    layout.check(flash).map_err(SlotError::Layout)?;
    if buf.len() < layout.len {
        return Err(SlotError::BufferTooSmall);
    }
    for (slot, sequence) in newest(flash, layout, buf)?.into_iter().flatten() {
        let Some((len, _)) = valid(flash, layout, slot, buf)? else {
            continue;
        };
        if let Some(Ok(())) = buf.get(..len).map(|b| model.decode_into(b)) {
            return Ok(Booted { slot, sequence });
        }
    }
    Err(SlotError::NoValidSlot)
}

/// Writes `blob` (a valid blob of format 4 or later, or a unit blob, that `T` can decode; stamped
/// here with the next sequence) into the slot not holding the newest valid one, committing by its
/// magic last (module doc). Returns
/// that slot and the sequence. `buf` holds at least one slot (it reads the slots, then verifies
/// the write). A power cut or a failure before the commit leaves the model in use as it was; a
/// read that fails before anything is erased stops the update with the error. A failure of the
/// read that verifies the commit is reported too: the new model may then be in place, and the
/// next boot says which.
pub fn update<F: Flash, T: Calibration>(
    flash: &mut F,
    layout: &Layout,
    blob: &mut [u8],
    buf: &mut [u8],
) -> Result<(Slot, u32), SlotError> {
    layout.check(flash).map_err(SlotError::Layout)?;
    if buf.len() < layout.len {
        return Err(SlotError::BufferTooSmall);
    }
    if blob.len() > layout.len {
        return Err(SlotError::TooLarge {
            blob: blob.len(),
            slot: layout.len,
        });
    }
    // Refuse what the firmware could not boot before anything is erased.
    T::check(blob)?;
    let [current, _] = newest(flash, layout, buf)?;
    let (target, sequence) = match current {
        Some((slot, s)) => (slot.other(), s.wrapping_add(1)),
        None => (Slot::A, 1),
    };
    blob::set_sequence(blob, sequence)?;
    let base = layout.addr(target);
    for sector in (0..layout.len).step_by(flash.sector().max(1)) {
        flash.erase(base + sector)?;
    }
    let body = blob.get(MAGIC.len()..).unwrap_or(&[]);
    let mut at = MAGIC.len();
    let page = flash.page();
    for chunk in page_chunks(base + at, body, page) {
        flash.program(base + at, chunk)?;
        at += chunk.len();
    }
    flash.program(base, blob.get(..MAGIC.len()).unwrap_or(&[]))?;
    let written = buf.get_mut(..blob.len()).ok_or(SlotError::BufferTooSmall)?;
    flash.read(base, written)?;
    if written != blob {
        return Err(SlotError::Verify);
    }
    Ok((target, sequence))
}

/// `data`, to be programmed from `addr`, in pieces that never cross a `page` boundary.
fn page_chunks(addr: usize, data: &[u8], page: usize) -> impl Iterator<Item = &[u8]> {
    let page = page.max(1);
    let first = (page - addr % page).min(data.len());
    let (head, tail) = data.split_at_checked(first).unwrap_or((data, &[]));
    core::iter::once(head)
        .filter(|h| !h.is_empty())
        .chain(tail.chunks(page))
}
