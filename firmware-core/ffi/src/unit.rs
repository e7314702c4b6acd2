//! A whole sensor unit from C: a unit blob decoded into a `FogUnit`, what it holds, every channel
//! compensated in one call from one sample, and its calibration slots.

use crate::flash::{FogFlash, FogLayout, FogSlot, boot_in, update_with};
use firmware_core::{Status, UnitSample};

use crate::{
    FOG_UNIT_MAX_CHANNELS, FogChannelInfo, FogPrediction, FogResult, FogState, FogUnit,
    FogUnitInfo, UnitInner, decode_in, decoded, fog_dims,
};

/// Decodes a unit blob of `len` bytes at `blob` into `unit`, or a model blob as a unit of one
/// channel (named `rate`, angular rate). On any error (a null `blob` included) `unit` is left
/// holding nothing, whatever it held before.
///
/// # Safety
/// `unit` points to a writable `FogUnit`; `blob` to `len` readable bytes. Either may be null
/// (`FogErrNull`).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_unit_decode(
    unit: *mut FogUnit,
    blob: *const u8,
    len: usize,
) -> FogResult {
    // SAFETY: forwarded from the caller.
    unsafe { decode_in(unit, blob, len) }
}

/// Copies `text` into a NUL-terminated C string of `N` bytes (it fits: the blob format's caps).
fn c_string<const N: usize>(text: &str) -> [u8; N] {
    let mut out = [0u8; N];
    for (dst, b) in out.iter_mut().zip(text.bytes().take(N.saturating_sub(1))) {
        *dst = b;
    }
    out
}

/// The decoded unit's channels, its sensor's ID and its trained temperature range.
///
/// # Safety
/// `unit` points to an initialized `FogUnit` (decoded into, or zeroed), `out` to a writable
/// `FogUnitInfo`; either may be null.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_unit_info(unit: *const FogUnit, out: *mut FogUnitInfo) -> FogResult {
    if out.is_null() {
        return FogResult::FogErrNull;
    }
    // SAFETY: the caller's contract on `unit`, forwarded.
    let unit = match unsafe { decoded(unit) } {
        Ok(u) => u,
        Err(e) => return e,
    };
    let [lo, hi] = unit.temperature_range();
    let info = FogUnitInfo {
        channels: u32::try_from(unit.channels().len()).unwrap_or(u32::MAX),
        temp_min_c: lo,
        temp_max_c: hi,
        sensor_id: c_string(unit.sensor_id()),
    };
    // SAFETY: `out` is non-null and writable per the caller.
    unsafe { out.write(info) };
    FogResult::FogOk
}

/// Channel `index` of the decoded unit: its name, quantity and sizes (`FogErrNoChannel` beyond
/// the last).
///
/// # Safety
/// As `fog_unit_info`, with `out` pointing to a writable `FogChannelInfo`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_unit_channel(
    unit: *const FogUnit,
    index: u32,
    out: *mut FogChannelInfo,
) -> FogResult {
    if out.is_null() {
        return FogResult::FogErrNull;
    }
    // SAFETY: the caller's contract on `unit`, forwarded.
    let unit = match unsafe { decoded(unit) } {
        Ok(u) => u,
        Err(e) => return e,
    };
    let Some(ch) = unit.channels().get(index as usize) else {
        return FogResult::FogErrNoChannel;
    };
    let info = FogChannelInfo {
        name: c_string(ch.name()),
        quantity: ch.quantity().into(),
        dims: fog_dims(ch.dims()),
    };
    // SAFETY: `out` is non-null and writable per the caller.
    unsafe { out.write(info) };
    FogResult::FogOk
}

/// Compensates one sample of every channel of the unit (time in s, temperature in °C, and
/// `n_outputs` outputs, one per channel in the unit's order) through the unit's one state, into
/// `n_out` predictions (one per channel). What the channels share (the temperature features, the
/// time since power-on) is computed once; the clock is as `fog_compensate`'s. An output that is
/// not a number makes its own channel's status `FOG_FAULT`; fewer outputs or predictions than
/// channels is `FogErrTooFewOutputs` or `FogErrResultsTooShort`, with nothing computed.
///
/// # Safety
/// `unit` points to a `FogUnit` and `state` to a `FogState`, each initialized (decoded or reset,
/// or zeroed as a C `static` is); `outputs` to `n_outputs` readable floats; `out` to `n_out`
/// writable `FogPrediction`s. Any pointer may be null (`FogErrNull`).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_unit_compensate(
    unit: *const FogUnit,
    state: *mut FogState,
    time_s: f64,
    temp_c: f32,
    outputs: *const f32,
    n_outputs: usize,
    out: *mut FogPrediction,
    n_out: usize,
) -> FogResult {
    if out.is_null() || outputs.is_null() {
        return FogResult::FogErrNull;
    }
    // SAFETY: the caller's contract on `unit` and `state`, forwarded.
    let (unit, channel) = match unsafe { (decoded(unit), crate::state(state)) } {
        (Ok(u), Ok(s)) => (u, s),
        (Err(e), _) | (_, Err(e)) => return e,
    };
    // SAFETY: `outputs` is non-null with `n_outputs` readable floats per the caller.
    let outputs = unsafe { core::slice::from_raw_parts(outputs, n_outputs) };
    let mut predictions = [firmware_core::model::Prediction {
        mean: 0.0,
        bias_variance: 0.0,
        noise_variance: 0.0,
        status: Status::Fault,
    }; FOG_UNIT_MAX_CHANNELS];
    let c = unit.channels().len();
    if n_out < c {
        return FogResult::FogErrResultsTooShort;
    }
    let sample = UnitSample {
        time_s,
        temp_c,
        outputs,
    };
    match unit.compensate(
        &sample,
        &mut channel.features,
        &mut channel.scratch,
        &mut predictions,
    ) {
        Ok(n) => {
            for (k, p) in predictions.iter().take(n).enumerate() {
                let prediction = FogPrediction {
                    mean: p.mean,
                    bias_variance: p.bias_variance,
                    noise_variance: p.noise_variance,
                    status: p.status.into(),
                };
                // SAFETY: `out` is non-null with `n_out` ≥ n writable predictions per the caller.
                unsafe { out.add(k).write(prediction) };
            }
            FogResult::FogOk
        }
        Err(e) => e.into(),
    }
}

/// The noise variance of a mean over `window_s` seconds of channel `index`'s compensated
/// samples (as `fog_noise_of_mean` for a model).
///
/// # Safety
/// `unit` points to an initialized `FogUnit` (decoded into, or zeroed), `out` to a writable
/// `float`; either may be null.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_unit_noise_of_mean(
    unit: *const FogUnit,
    index: u32,
    window_s: f32,
    out: *mut f32,
) -> FogResult {
    if out.is_null() {
        return FogResult::FogErrNull;
    }
    // SAFETY: the caller's contract on `unit`, forwarded.
    let unit = match unsafe { decoded(unit) } {
        Ok(u) => u,
        Err(e) => return e,
    };
    match unit.noise_of_mean(index as usize, window_s) {
        Some(v) => {
            // SAFETY: `out` is non-null and writable per the caller.
            unsafe { out.write(v) };
            FogResult::FogOk
        }
        None => FogResult::FogErrNoChannel,
    }
}

/// Boots the calibration slot with the newest valid blob (a unit blob, or a model blob as one
/// channel) into `unit`: as `fog_slots_boot`, for a unit.
///
/// # Safety
/// As `fog_slots_boot`, with `unit` pointing to a writable `FogUnit`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_unit_slots_boot(
    flash: *const FogFlash,
    slots_layout: *const FogLayout,
    buf: *mut u8,
    buf_len: usize,
    unit: *mut FogUnit,
    out: *mut FogSlot,
) -> FogResult {
    // SAFETY: forwarded from the caller.
    unsafe { boot_in(flash, slots_layout, (buf, buf_len), unit, out) }
}

/// Writes a unit blob (or a model blob) that a `FogUnit` can hold into the slot not in use: as
/// `fog_slots_update`, checked against the unit's capacities.
///
/// # Safety
/// As `fog_slots_update`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fog_unit_slots_update(
    flash: *const FogFlash,
    slots_layout: *const FogLayout,
    blob: *mut u8,
    len: usize,
    buf: *mut u8,
    buf_len: usize,
    out: *mut FogSlot,
) -> FogResult {
    // SAFETY: forwarded from the caller.
    unsafe { update_with::<UnitInner>(flash, slots_layout, (blob, len), (buf, buf_len), out) }
}
