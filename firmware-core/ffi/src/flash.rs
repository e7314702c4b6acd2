//! The calibration slots from C: the C side's flash driver behind firmware-core's `Flash` trait,
//! and booting from or updating the two power-safe slots with a model blob.

use core::ffi::c_void;

use firmware_core::slots::{self, Calibration, Flash, FlashError, Layout, Slot};

use crate::{FogModel, FogResult, Holds, Inner, emptied, forget, mark};

/// The C side's flash driver, for the calibration slots (docs/firmware.md). Each function gets
/// `context` back and returns 0 on success, 1 for an address outside the device, anything else
/// for a device failure.
#[repr(C)]
pub struct FogFlash {
    /// Passed back to every function (the driver's own state).
    pub context: *mut c_void,
    /// Bytes of the device: the slots must lie below it.
    pub size: u32,
    /// Erase unit, bytes.
    pub sector: u32,
    /// Program unit, bytes: one `program` call stays inside one page.
    pub page: u32,
    /// Reads `len` bytes at `addr` into `buf`.
    pub read: Option<unsafe extern "C" fn(*mut c_void, u32, *mut u8, usize) -> i32>,
    /// Erases the sector that starts at `addr`.
    pub erase: Option<unsafe extern "C" fn(*mut c_void, u32) -> i32>,
    /// Programs `len` bytes from `data` at `addr` (clearing bits only).
    pub program: Option<unsafe extern "C" fn(*mut c_void, u32, *const u8, usize) -> i32>,
}

/// Where the two calibration slots are: each `len` bytes (a whole number of sectors), each
/// starting on a sector, apart, inside the device. The library checks this before it reads,
/// erases or programs anything (`FogErrLayout`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FogLayout {
    /// Address of slot A.
    pub a: u32,
    /// Address of slot B.
    pub b: u32,
    /// Bytes of each slot.
    pub len: u32,
}

/// Which slot, and the sequence number of the blob in it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FogSlot {
    /// 0 for slot A, 1 for slot B.
    pub slot: u32,
    /// The blob's sequence number.
    pub sequence: u32,
}

/// The driver behind the `Flash` trait: every call goes through the C function pointers.
struct CFlash<'a>(&'a FogFlash);

fn flash_result(code: i32) -> Result<(), FlashError> {
    match code {
        0 => Ok(()),
        1 => Err(FlashError::OutOfRange),
        _ => Err(FlashError::Device),
    }
}

fn address(addr: usize) -> Result<u32, FlashError> {
    u32::try_from(addr).map_err(|_| FlashError::OutOfRange)
}

impl Flash for CFlash<'_> {
    fn size(&self) -> usize {
        self.0.size as usize
    }

    fn sector(&self) -> usize {
        self.0.sector as usize
    }

    fn page(&self) -> usize {
        self.0.page as usize
    }

    fn read(&self, addr: usize, buf: &mut [u8]) -> Result<(), FlashError> {
        let f = self.0.read.ok_or(FlashError::Device)?;
        // SAFETY: the driver's contract (`fog_slots_boot`'s): `read` may write `buf.len()` bytes
        // at `buf`, which is a live, exclusive Rust slice of that length.
        flash_result(unsafe { f(self.0.context, address(addr)?, buf.as_mut_ptr(), buf.len()) })
    }

    fn erase(&mut self, addr: usize) -> Result<(), FlashError> {
        let f = self.0.erase.ok_or(FlashError::Device)?;
        // SAFETY: the driver's contract: `erase` touches only its flash and its context.
        flash_result(unsafe { f(self.0.context, address(addr)?) })
    }

    fn program(&mut self, addr: usize, data: &[u8]) -> Result<(), FlashError> {
        let f = self.0.program.ok_or(FlashError::Device)?;
        // SAFETY: the driver's contract: `program` reads `data.len()` bytes at `data`, a live
        // Rust slice of that length.
        flash_result(unsafe { f(self.0.context, address(addr)?, data.as_ptr(), data.len()) })
    }
}

/// A slot as C numbers it: 0 for A, 1 for B.
fn slot_number(s: Slot) -> u32 {
    match s {
        Slot::A => 0,
        Slot::B => 1,
    }
}

fn layout(l: &FogLayout) -> Layout {
    Layout {
        a: l.a as usize,
        b: l.b as usize,
        len: l.len as usize,
    }
}

/// Boots the newest valid slot into `storage` (`fog_slots_boot`, `fog_unit_slots_boot`).
///
/// # Safety
/// As the functions that call it.
pub(crate) unsafe fn boot_in<S: Holds>(
    flash: *const FogFlash,
    slots_layout: *const FogLayout,
    (buf, buf_len): (*mut u8, usize),
    storage: *mut S,
    out: *mut FogSlot,
) -> FogResult {
    if storage.is_null() {
        return FogResult::FogErrNull;
    }
    if flash.is_null() || slots_layout.is_null() || buf.is_null() {
        // SAFETY: `storage` is non-null and points to storage the caller lets us write.
        unsafe { forget(&mut *storage) };
        return FogResult::FogErrNull;
    }
    // SAFETY: non-null and valid per the caller; shared or exclusive for this call as used.
    let (flash, slots_layout, inner) = unsafe { (&*flash, &*slots_layout, emptied(&mut *storage)) };
    // SAFETY: `buf` is non-null with `buf_len` writable bytes per the caller.
    let buf = unsafe { core::slice::from_raw_parts_mut(buf, buf_len) };
    match slots::boot(&CFlash(flash), &layout(slots_layout), buf, inner) {
        Ok(booted) => {
            // SAFETY: as in `emptied`: the storage is ours for this call.
            unsafe { mark(&mut *storage) };
            // SAFETY: `out` is null or writable per the caller.
            unsafe { written(out, booted.slot, booted.sequence) };
            FogResult::FogOk
        }
        Err(e) => e.into(),
    }
}

/// Writes `(slot, sequence)` to `out` unless it is null.
///
/// # Safety
/// `out` is null or points to a writable `FogSlot`.
unsafe fn written(out: *mut FogSlot, slot: Slot, sequence: u32) {
    if !out.is_null() {
        let value = FogSlot {
            slot: slot_number(slot),
            sequence,
        };
        // SAFETY: `out` is non-null and writable per the caller.
        unsafe { out.write(value) };
    }
}

/// Writes a blob that `T` can hold into the slot not in use (`fog_slots_update`,
/// `fog_unit_slots_update`).
///
/// # Safety
/// As the functions that call it.
pub(crate) unsafe fn update_with<T: Calibration>(
    flash: *const FogFlash,
    slots_layout: *const FogLayout,
    (blob, len): (*mut u8, usize),
    (buf, buf_len): (*mut u8, usize),
    out: *mut FogSlot,
) -> FogResult {
    if flash.is_null() || slots_layout.is_null() || blob.is_null() || buf.is_null() {
        return FogResult::FogErrNull;
    }
    // SAFETY: non-null and valid per the caller.
    let (flash, slots_layout) = unsafe { (&*flash, &*slots_layout) };
    // SAFETY: non-null, `len` and `buf_len` writable bytes per the caller; the two do not
    // overlap (separate buffers by the contract).
    let (blob, buf) = unsafe {
        (
            core::slice::from_raw_parts_mut(blob, len),
            core::slice::from_raw_parts_mut(buf, buf_len),
        )
    };
    match slots::update::<_, T>(&mut CFlash(flash), &layout(slots_layout), blob, buf) {
        Ok((slot, sequence)) => {
            // SAFETY: `out` is null or writable per the caller.
            unsafe { written(out, slot, sequence) };
            FogResult::FogOk
        }
        Err(e) => e.into(),
    }
}

/// Boots the calibration slot with the newest valid model into `model` (firmware-core's
/// `slots::boot`): `FogErrNoValidSlot` when neither holds one (`model` then holds no model).
///
/// # Safety
/// `flash` points to a `FogFlash` whose functions behave as documented, `layout` to a
/// `FogLayout`, `buf` to `buf_len` writable bytes (at least one slot), `model` to a writable
/// `FogModel`, `out` to a writable `FogSlot` or is null (not wanted). The others may be null
/// (`FogErrNull`).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_slots_boot(
    flash: *const FogFlash,
    slots_layout: *const FogLayout,
    buf: *mut u8,
    buf_len: usize,
    model: *mut FogModel,
    out: *mut FogSlot,
) -> FogResult {
    // SAFETY: forwarded from the caller.
    unsafe { boot_in(flash, slots_layout, (buf, buf_len), model, out) }
}

/// Writes the blob of `len` bytes at `blob` into the slot not in use, with the next sequence
/// number, committing by its last write (firmware-core's `slots::update`; the blob's header is
/// stamped in place). The model in use is untouched whatever happens; reboot to use the new one.
///
/// # Safety
/// As `fog_slots_boot`, with `blob` pointing to `len` writable bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_slots_update(
    flash: *const FogFlash,
    slots_layout: *const FogLayout,
    blob: *mut u8,
    len: usize,
    buf: *mut u8,
    buf_len: usize,
    out: *mut FogSlot,
) -> FogResult {
    // SAFETY: forwarded from the caller.
    unsafe { update_with::<Inner>(flash, slots_layout, (blob, len), (buf, buf_len), out) }
}
