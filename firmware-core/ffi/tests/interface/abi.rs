//! The C functions called as C calls them: null pointers, storage never initialized, a real blob,
//! and one result code per Rust error.

use std::collections::HashSet;

use firmware_core::blob::unit;
use firmware_core::{BlobError, PredictError, Quantity};
use fog_ffi::*;

const BLOB: &[u8] = include_bytes!("../../../doc/gyro.bin");

/// Zeroed storage, as a C `static` starts.
fn zeroed<T>() -> Box<T> {
    // SAFETY: FogModel and FogState are arrays of u64, for which all-zero bytes are valid.
    unsafe { Box::new(std::mem::MaybeUninit::zeroed().assume_init()) }
}

/// A prediction no call has written yet.
fn no_prediction() -> FogPrediction {
    FogPrediction {
        mean: f32::NAN,
        bias_variance: f32::NAN,
        noise_variance: f32::NAN,
        status: FogStatus::FogFault,
    }
}

#[test]
fn a_blob_decodes_into_static_storage_and_compensates() {
    let mut model: Box<FogModel> = zeroed();
    let mut state: Box<FogState> = zeroed();
    let mut p = no_prediction();
    // SAFETY: the pointers are to live, zero-initialized storage of the right types, or null on
    // purpose.
    unsafe {
        assert_eq!(
            fog_compensate(&*model, &mut *state, 60.0, 25.0, 0.38, &mut p),
            FogResult::FogErrNoModel
        );
        assert_eq!(
            fog_model_decode(&mut *model, BLOB.as_ptr(), BLOB.len()),
            FogResult::FogOk
        );
        assert_eq!(
            fog_compensate(&*model, &mut *state, 60.0, 25.0, 0.38, &mut p),
            FogResult::FogErrNoState
        );
        assert_eq!(fog_state_reset(&mut *state), FogResult::FogOk);
        assert_eq!(
            fog_compensate(&*model, &mut *state, 60.0, 25.0, 0.38, &mut p),
            FogResult::FogOk
        );
        let mut dims = FogDims {
            centres: 0,
            inputs: 0,
            monomials: 0,
        };
        assert_eq!(fog_model_dims(&*model, &mut dims), FogResult::FogOk);
        assert_eq!((dims.centres, dims.inputs, dims.monomials), (24, 2, 7));
        assert_eq!(
            fog_model_decode(std::ptr::null_mut(), BLOB.as_ptr(), BLOB.len()),
            FogResult::FogErrNull
        );
        assert_eq!(
            fog_compensate(&*model, &mut *state, 60.0, 25.0, 0.38, std::ptr::null_mut()),
            FogResult::FogErrNull
        );
        // A refused blob leaves no model behind, not the old one.
        let mut bad = BLOB.to_vec();
        bad[100] ^= 1;
        assert_eq!(
            fog_model_decode(&mut *model, bad.as_ptr(), bad.len()),
            FogResult::FogErrCrcMismatch
        );
        assert_eq!(fog_model_dims(&*model, &mut dims), FogResult::FogErrNoModel);

        // Decoding again over what the refused blob left, and into storage full of garbage (a
        // C array on the stack, not a zeroed static), gives the same model.
        let mut garbage: Box<FogModel> = zeroed();
        std::ptr::write_bytes(&mut *garbage as *mut FogModel, 0xA5, 1);
        for storage in [&mut *model, &mut *garbage] {
            assert_eq!(
                fog_model_decode(storage, BLOB.as_ptr(), BLOB.len()),
                FogResult::FogOk
            );
            let mut again = p;
            assert_eq!(fog_state_reset(&mut *state), FogResult::FogOk);
            assert_eq!(
                fog_compensate(storage, &mut *state, 60.0, 25.0, 0.38, &mut again),
                FogResult::FogOk
            );
            assert_eq!(again.mean.to_bits(), p.mean.to_bits());
        }
    }
    // The docs/firmware.md example's figure, through C: 0.38 V at 25 °C is 9.95 °/s.
    assert_eq!(p.status, FogStatus::FogValid);
    assert!((p.mean - 9.945).abs() < 1e-3, "{p:?}");
}

#[test]
fn a_state_stored_through_a_power_off_goes_on_where_it_was() {
    let mut model: Box<FogModel> = zeroed();
    let mut state: Box<FogState> = zeroed();
    let mut p = no_prediction();
    // SAFETY: the pointers are to live storage of the right types, or null on purpose; the
    // restored state is a byte copy of an initialized one, as flash would give it back.
    unsafe {
        assert_eq!(
            fog_state_power_on(std::ptr::null_mut()),
            FogResult::FogErrNull
        );
        assert_eq!(fog_state_power_on(&mut *state), FogResult::FogErrNoState);
        assert_eq!(
            fog_model_decode(&mut *model, BLOB.as_ptr(), BLOB.len()),
            FogResult::FogOk
        );
        assert_eq!(fog_state_reset(&mut *state), FogResult::FogOk);
        for k in 0..600 {
            let t = 25.0 + k as f32 / 60.0;
            assert_eq!(
                fog_compensate(&*model, &mut *state, f64::from(k), t, 0.38, &mut p),
                FogResult::FogOk
            );
        }
        // Stored at power-down, restored at boot ten minutes later.
        let mut restored: Box<FogState> = zeroed();
        std::ptr::copy_nonoverlapping(&*state as *const FogState, &mut *restored, 1);
        assert_eq!(fog_state_power_on(&mut *restored), FogResult::FogOk);
        assert_eq!(
            fog_compensate(&*model, &mut *restored, 1200.0, 30.0, 0.38, &mut p),
            FogResult::FogOk
        );
        // This model has no filters: the same answer as from a reset state.
        let mut cold = p;
        assert_eq!(fog_state_reset(&mut *state), FogResult::FogOk);
        assert_eq!(
            fog_compensate(&*model, &mut *state, 1200.0, 30.0, 0.38, &mut cold),
            FogResult::FogOk
        );
        assert_eq!(cold.mean.to_bits(), p.mean.to_bits());
        assert_eq!(cold.status, p.status);
    }
    assert!(
        p.mean.is_finite() && p.status != FogStatus::FogFault,
        "{p:?}"
    );
}

#[test]
fn every_rust_error_has_its_own_result_code() {
    let errors = [
        BlobError::BadMagic,
        BlobError::UnsupportedVersion(9),
        BlobError::Truncated,
        BlobError::TrailingBytes,
        BlobError::CrcMismatch,
        BlobError::CapacityExceeded {
            what: firmware_core::error::Storage::Floats,
            needed: 2,
            capacity: 1,
        },
        BlobError::Malformed,
        BlobError::InconsistentDimensions,
        BlobError::NonFinite(3),
        BlobError::InvalidParameter,
        BlobError::BufferTooSmall,
        BlobError::NoSequence(3),
    ];
    let mut codes: HashSet<i32> = errors.iter().map(|&e| FogResult::from(e) as i32).collect();
    assert_eq!(codes.len(), errors.len());
    for e in [
        PredictError::ScratchTooSmall { needed: 1 },
        PredictError::TooFewOutputs { needed: 1 },
        PredictError::ResultsTooShort { needed: 1 },
    ] {
        assert!(codes.insert(FogResult::from(e) as i32), "{e:?}");
    }
    for own in [
        FogResult::FogOk,
        FogResult::FogErrNull,
        FogResult::FogErrNoModel,
        FogResult::FogErrNoState,
        FogResult::FogErrLayout,
        FogResult::FogErrAbi,
        FogResult::FogErrNoChannel,
    ] {
        assert!(codes.insert(own as i32), "{own:?}");
    }
}

#[test]
fn a_failed_decode_for_any_reason_leaves_no_model() {
    let mut model: Box<FogModel> = zeroed();
    let mut state: Box<FogState> = zeroed();
    let mut p = no_prediction();
    let mut corrupt = BLOB.to_vec();
    corrupt[100] ^= 1;
    // SAFETY: live storage of the right types, or null on purpose.
    unsafe {
        assert_eq!(fog_state_reset(&mut *state), FogResult::FogOk);
        for (blob, len, why) in [
            (std::ptr::null(), BLOB.len(), FogResult::FogErrNull),
            (
                corrupt.as_ptr(),
                corrupt.len(),
                FogResult::FogErrCrcMismatch,
            ),
            (BLOB.as_ptr(), 10, FogResult::FogErrTruncated),
        ] {
            assert_eq!(
                fog_model_decode(&mut *model, BLOB.as_ptr(), BLOB.len()),
                FogResult::FogOk
            );
            assert_eq!(fog_model_decode(&mut *model, blob, len), why);
            assert_eq!(
                fog_compensate(&*model, &mut *state, 60.0, 25.0, 0.38, &mut p),
                FogResult::FogErrNoModel,
                "{why:?}: the old model is gone"
            );
        }
    }
}

#[test]
fn a_caller_built_against_another_header_is_told_at_start_up() {
    use std::mem::size_of;
    let check = |model: usize, unit: usize, centres: u32, numbers: usize| {
        fog_abi_check(
            model,
            unit,
            size_of::<FogState>(),
            size_of::<FogPrediction>(),
            centres,
            FOG_MAX_INPUTS as u32,
            FOG_MAX_MONOMIALS as u32,
            FOG_UNIT_MAX_CHANNELS as u32,
            numbers as u32,
        )
    };
    let (model, unit) = (size_of::<FogModel>(), size_of::<FogUnit>());
    let centres = FOG_MAX_CENTRES as u32;
    assert_eq!(
        check(model, unit, centres, FOG_UNIT_NUMBERS),
        FogResult::FogOk
    );
    // A header edited to 140 centres, or to a unit of other numbers, the library not rebuilt.
    assert_eq!(
        check(model - 8, unit, 140, FOG_UNIT_NUMBERS),
        FogResult::FogErrAbi
    );
    assert_eq!(
        check(model, unit - 800, centres, FOG_UNIT_NUMBERS - 1600),
        FogResult::FogErrAbi
    );
    // Every status and result is 32 bits on every target.
    assert_eq!(size_of::<FogResult>(), 4);
    assert_eq!(size_of::<FogStatus>(), 4);
    assert_eq!(size_of::<FogPrediction>(), 16);
}

/// The channels of the unit the tests decode: an IMU's six axes, each the example's model.
const CHANNELS: [(&str, Quantity); 6] = [
    ("gyro.x", Quantity::AngularRate),
    ("gyro.y", Quantity::AngularRate),
    ("gyro.z", Quantity::AngularRate),
    ("acc.x", Quantity::SpecificForce),
    ("acc.y", Quantity::SpecificForce),
    ("acc.z", Quantity::SpecificForce),
];

/// A unit blob of [`CHANNELS`].
fn unit_blob() -> Vec<u8> {
    let channels: Vec<unit::ChannelBlob<'_>> = CHANNELS
        .iter()
        .map(|&(name, quantity)| unit::ChannelBlob {
            name,
            quantity,
            model: BLOB,
        })
        .collect();
    let mut buf = vec![0u8; 16 * BLOB.len()];
    let n = unit::encode("IMU-7", [-20.0, 70.0], &channels, &mut buf).expect("a unit blob");
    buf.truncate(n);
    buf
}

/// The text of a NUL-terminated C string.
fn text(bytes: &[u8]) -> &str {
    let end = bytes.iter().position(|&b| b == 0).expect("NUL-terminated");
    std::str::from_utf8(&bytes[..end]).expect("UTF-8")
}

#[test]
fn a_unit_blob_decodes_into_static_storage_and_compensates_every_channel_in_one_call() {
    let blob = unit_blob();
    let mut unit: Box<FogUnit> = zeroed();
    let mut model: Box<FogModel> = zeroed();
    let (mut state, mut own): (Box<FogState>, Box<FogState>) = (zeroed(), zeroed());
    let mut out = [no_prediction(); 6];
    let outputs = [0.38f32, -0.2, 0.05, 0.1, 0.0, -0.4];
    // SAFETY: live storage of the right types, or null on purpose; `outputs` and `out` hold the
    // counts passed.
    unsafe {
        let compensate = |unit: &FogUnit, state: &mut FogState, n_in, n_out, out: &mut [_]| {
            fog_unit_compensate(
                unit,
                state,
                60.0,
                25.0,
                outputs.as_ptr(),
                n_in,
                out.as_mut_ptr(),
                n_out,
            )
        };
        assert_eq!(
            compensate(&unit, &mut state, 6, 6, &mut out),
            FogResult::FogErrNoModel
        );
        assert_eq!(
            fog_unit_decode(&mut *unit, blob.as_ptr(), blob.len()),
            FogResult::FogOk
        );
        assert_eq!(
            compensate(&unit, &mut state, 6, 6, &mut out),
            FogResult::FogErrNoState
        );
        assert_eq!(fog_state_reset(&mut *state), FogResult::FogOk);
        let mut info = FogUnitInfo {
            channels: 0,
            temp_min_c: 0.0,
            temp_max_c: 0.0,
            sensor_id: [0xFF; FOG_SENSOR_ID_CHARS],
        };
        assert_eq!(fog_unit_info(&*unit, &mut info), FogResult::FogOk);
        assert_eq!(
            (info.channels, info.temp_min_c, info.temp_max_c),
            (6, -20.0, 70.0)
        );
        assert_eq!(text(&info.sensor_id), "IMU-7");
        let mut ch = FogChannelInfo {
            name: [0xFF; FOG_NAME_CHARS],
            quantity: FogQuantity::FogQuantityWidth,
            dims: FogDims {
                centres: 0,
                inputs: 0,
                monomials: 0,
            },
        };
        for (k, (name, quantity)) in CHANNELS.iter().enumerate() {
            assert_eq!(
                fog_unit_channel(&*unit, k as u32, &mut ch),
                FogResult::FogOk
            );
            assert_eq!(text(&ch.name), *name);
            assert_eq!(ch.quantity, FogQuantity::from(*quantity));
            assert_eq!((ch.dims.centres, ch.dims.inputs), (24, 2));
        }
        assert_eq!(
            fog_unit_channel(&*unit, 6, &mut ch),
            FogResult::FogErrNoChannel
        );
        assert_eq!(
            compensate(&unit, &mut state, 6, 6, &mut out),
            FogResult::FogOk
        );
        // Each channel is what its model computes alone.
        assert_eq!(
            fog_model_decode(&mut *model, BLOB.as_ptr(), BLOB.len()),
            FogResult::FogOk
        );
        for (k, &v) in outputs.iter().enumerate() {
            let mut p = no_prediction();
            assert_eq!(fog_state_reset(&mut *own), FogResult::FogOk);
            assert_eq!(
                fog_compensate(&*model, &mut *own, 60.0, 25.0, v, &mut p),
                FogResult::FogOk
            );
            assert_eq!(out[k], p, "channel {k}");
        }
        assert_eq!(out[0].status, FogStatus::FogValid);
        assert!((out[0].mean - 9.945).abs() < 1e-3, "{:?}", out[0]);
        // Short buffers are refused with nothing written.
        let before = out;
        assert_eq!(
            compensate(&unit, &mut state, 5, 6, &mut out),
            FogResult::FogErrTooFewOutputs
        );
        assert_eq!(
            compensate(&unit, &mut state, 6, 5, &mut out),
            FogResult::FogErrResultsTooShort
        );
        assert_eq!(out, before);
        let mut noise = f32::NAN;
        assert_eq!(
            fog_unit_noise_of_mean(&*unit, 5, 60.0, &mut noise),
            FogResult::FogOk
        );
        assert!(noise.is_finite() && noise >= 0.0);
        assert_eq!(
            fog_unit_noise_of_mean(&*unit, 6, 60.0, &mut noise),
            FogResult::FogErrNoChannel
        );
        // A model blob is a unit of one channel; a refused blob leaves nothing behind.
        assert_eq!(
            fog_unit_decode(&mut *unit, BLOB.as_ptr(), BLOB.len()),
            FogResult::FogOk
        );
        assert_eq!(fog_unit_info(&*unit, &mut info), FogResult::FogOk);
        assert_eq!((info.channels, text(&info.sensor_id)), (1, ""));
        let mut bad = blob.clone();
        bad[200] ^= 1;
        assert_eq!(
            fog_unit_decode(&mut *unit, bad.as_ptr(), bad.len()),
            FogResult::FogErrCrcMismatch
        );
        assert_eq!(fog_unit_info(&*unit, &mut info), FogResult::FogErrNoModel);
        assert_eq!(
            fog_unit_decode(&mut *unit, std::ptr::null(), 0),
            FogResult::FogErrNull
        );
    }
}
