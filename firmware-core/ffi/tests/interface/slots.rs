//! The calibration slots through C: a driver of C function pointers over RAM that behaves as NOR
//! (erase to 0xFF, programming clears bits), optionally failing every program call.

use std::ffi::c_void;

use fog_ffi::*;

const BLOB: &[u8] = include_bytes!("../../../doc/gyro.bin");
const SECTOR: usize = 4096;

/// The device behind the context pointer.
struct Device {
    cells: Vec<u8>,
    fail_programs: bool,
}

/// # Safety
/// `ctx` is a live `Device`.
unsafe fn device<'a>(ctx: *mut c_void) -> &'a mut Device {
    // SAFETY: the tests pass a pointer to a live Device as the context.
    unsafe { &mut *ctx.cast::<Device>() }
}

unsafe extern "C" fn read(ctx: *mut c_void, addr: u32, buf: *mut u8, len: usize) -> i32 {
    // SAFETY: the context is a Device; `buf` has `len` writable bytes (fog-ffi's contract).
    let (d, out) = unsafe { (device(ctx), std::slice::from_raw_parts_mut(buf, len)) };
    match d.cells.get(addr as usize..addr as usize + len) {
        Some(src) => {
            out.copy_from_slice(src);
            0
        }
        None => 1,
    }
}

unsafe extern "C" fn erase(ctx: *mut c_void, addr: u32) -> i32 {
    // SAFETY: the context is a Device.
    let d = unsafe { device(ctx) };
    match d.cells.get_mut(addr as usize..addr as usize + SECTOR) {
        Some(s) => {
            s.fill(0xFF);
            0
        }
        None => 1,
    }
}

unsafe extern "C" fn program(ctx: *mut c_void, addr: u32, data: *const u8, len: usize) -> i32 {
    // SAFETY: the context is a Device; `data` has `len` readable bytes (fog-ffi's contract).
    let (d, data) = unsafe { (device(ctx), std::slice::from_raw_parts(data, len)) };
    if d.fail_programs {
        return 2;
    }
    match d.cells.get_mut(addr as usize..addr as usize + len) {
        Some(cells) => {
            cells.iter_mut().zip(data).for_each(|(c, v)| *c &= v);
            0
        }
        None => 1,
    }
}

const LAYOUT: FogLayout = FogLayout {
    a: 0,
    b: SECTOR as u32,
    len: SECTOR as u32,
};

fn driver(device: &mut Device) -> FogFlash {
    FogFlash {
        context: (device as *mut Device).cast(),
        size: device.cells.len() as u32,
        sector: SECTOR as u32,
        page: 256,
        read: Some(read),
        erase: Some(erase),
        program: Some(program),
    }
}

fn boot(flash: &FogFlash, model: &mut FogModel) -> (FogResult, FogSlot) {
    let mut buf = vec![0u8; SECTOR];
    let mut slot = FogSlot {
        slot: 9,
        sequence: 0,
    };
    // SAFETY: every pointer is to live storage of the right type and size.
    let r = unsafe {
        fog_slots_boot(
            flash,
            &LAYOUT,
            buf.as_mut_ptr(),
            buf.len(),
            model,
            &mut slot,
        )
    };
    (r, slot)
}

fn update(flash: &FogFlash) -> (FogResult, FogSlot) {
    let (mut blob, mut buf) = (BLOB.to_vec(), vec![0u8; SECTOR]);
    let mut slot = FogSlot {
        slot: 9,
        sequence: 0,
    };
    // SAFETY: every pointer is to live storage of the right type and size.
    let r = unsafe {
        fog_slots_update(
            flash,
            &LAYOUT,
            blob.as_mut_ptr(),
            blob.len(),
            buf.as_mut_ptr(),
            buf.len(),
            &mut slot,
        )
    };
    (r, slot)
}

#[test]
fn slots_boot_and_update_through_c_function_pointers() {
    let mut device = Device {
        cells: vec![0xFF; 2 * SECTOR],
        fail_programs: false,
    };
    // SAFETY: FogModel is an array of u64, for which zero bytes are valid.
    let mut model: Box<FogModel> =
        unsafe { Box::new(std::mem::MaybeUninit::zeroed().assume_init()) };
    let flash = driver(&mut device);
    assert_eq!(boot(&flash, &mut model).0, FogResult::FogErrNoValidSlot);
    let first = FogSlot {
        slot: 0,
        sequence: 1,
    };
    assert_eq!(update(&flash), (FogResult::FogOk, first));
    assert_eq!(boot(&flash, &mut model), (FogResult::FogOk, first));
    let mut dims = FogDims {
        centres: 0,
        inputs: 0,
        monomials: 0,
    };
    // SAFETY: live storage.
    let r = unsafe { fog_model_dims(&*model, &mut dims) };
    assert_eq!(r, FogResult::FogOk);
    assert_eq!(dims.centres, 24);
    let second = FogSlot {
        slot: 1,
        sequence: 2,
    };
    assert_eq!(update(&flash), (FogResult::FogOk, second));
    assert_eq!(boot(&flash, &mut model), (FogResult::FogOk, second));

    // A flipped bit in slot B: boot takes slot A.
    device.cells[SECTOR + 300] ^= 0x20;
    let flash = driver(&mut device);
    assert_eq!(boot(&flash, &mut model), (FogResult::FogOk, first));
    device.cells[SECTOR + 300] ^= 0x20;

    // A driver that fails mid-update (slot A erased, nothing programmed) leaves the model in use,
    // slot B's, with the driver's error.
    device.fail_programs = true;
    let flash = driver(&mut device);
    assert_eq!(update(&flash).0, FogResult::FogErrFlashDevice);
    assert_eq!(boot(&flash, &mut model), (FogResult::FogOk, second));
}

#[test]
fn a_units_slots_boot_and_update_through_c_function_pointers() {
    // Six channels, each the example's model: 10 KB, three sectors a slot.
    let entries: Vec<firmware_core::blob::unit::ChannelBlob<'_>> =
        ["gyro.x", "gyro.y", "gyro.z", "acc.x", "acc.y", "acc.z"]
            .into_iter()
            .map(|name| firmware_core::blob::unit::ChannelBlob {
                name,
                quantity: firmware_core::Quantity::AngularRate,
                model: BLOB,
            })
            .collect();
    let mut unit_blob = vec![0u8; 8 * SECTOR];
    let n =
        firmware_core::blob::unit::encode("IMU-7", [0.0, 50.0], &entries, &mut unit_blob).unwrap();
    unit_blob.truncate(n);
    let layout = FogLayout {
        a: 0,
        b: 3 * SECTOR as u32,
        len: 3 * SECTOR as u32,
    };
    let mut device = Device {
        cells: vec![0xFF; 6 * SECTOR],
        fail_programs: false,
    };
    // SAFETY: FogUnit is an array of u64, for which zero bytes are valid.
    let mut unit: Box<FogUnit> = unsafe { Box::new(std::mem::MaybeUninit::zeroed().assume_init()) };
    let mut buf = vec![0u8; 3 * SECTOR];
    let mut slot = FogSlot {
        slot: 9,
        sequence: 0,
    };
    let flash = driver(&mut device);
    // SAFETY: every pointer is to live storage of the right type and size.
    unsafe {
        let mut blob = unit_blob.clone();
        let update = |blob: &mut Vec<u8>, buf: &mut Vec<u8>, slot: &mut FogSlot| {
            fog_unit_slots_update(
                &flash,
                &layout,
                blob.as_mut_ptr(),
                blob.len(),
                buf.as_mut_ptr(),
                buf.len(),
                slot,
            )
        };
        assert_eq!(update(&mut blob, &mut buf, &mut slot), FogResult::FogOk);
        assert_eq!((slot.slot, slot.sequence), (0, 1));
        // The unit's storage boots a model blob too, as one channel: the second update.
        let mut model_blob = BLOB.to_vec();
        assert_eq!(
            update(&mut model_blob, &mut buf, &mut slot),
            FogResult::FogOk
        );
        assert_eq!((slot.slot, slot.sequence), (1, 2));
        let boot = |unit: &mut FogUnit, buf: &mut Vec<u8>, slot: &mut FogSlot| {
            fog_unit_slots_boot(&flash, &layout, buf.as_mut_ptr(), buf.len(), unit, slot)
        };
        let mut info = FogUnitInfo {
            channels: 0,
            temp_min_c: 0.0,
            temp_max_c: 0.0,
            sensor_id: [0; FOG_SENSOR_ID_CHARS],
        };
        assert_eq!(boot(&mut unit, &mut buf, &mut slot), FogResult::FogOk);
        assert_eq!(slot.sequence, 2);
        assert_eq!(fog_unit_info(&*unit, &mut info), FogResult::FogOk);
        assert_eq!(info.channels, 1);
        let mut blob = unit_blob.clone();
        assert_eq!(update(&mut blob, &mut buf, &mut slot), FogResult::FogOk);
        assert_eq!(boot(&mut unit, &mut buf, &mut slot), FogResult::FogOk);
        assert_eq!((slot.slot, slot.sequence), (0, 3));
        assert_eq!(fog_unit_info(&*unit, &mut info), FogResult::FogOk);
        assert_eq!((info.channels, &info.sensor_id[..6]), (6, &b"IMU-7\0"[..]));
        // A model's storage does not take a unit blob of six channels: refused before anything
        // is erased.
        let before = device_cells(&flash);
        let mut blob = unit_blob.clone();
        let r = fog_slots_update(
            &flash,
            &layout,
            blob.as_mut_ptr(),
            blob.len(),
            buf.as_mut_ptr(),
            buf.len(),
            &mut slot,
        );
        assert_eq!(r, FogResult::FogErrCapacityExceeded);
        assert_eq!(device_cells(&flash), before);
    }
}

/// The cells behind a driver.
fn device_cells(flash: &FogFlash) -> Vec<u8> {
    // SAFETY: the tests' drivers carry a live Device as their context.
    unsafe { device(flash.context) }.cells.clone()
}
