//! The C functions called as C calls them: null pointers, storage never initialized, a real blob,
//! and one result code per Rust error.

use std::collections::HashSet;

use firmware_core::{BlobError, PredictError};
use fog_ffi::*;

const BLOB: &[u8] = include_bytes!("../../doc/gyro.bin");

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
    assert!(codes.insert(FogResult::from(PredictError::ScratchTooSmall { needed: 1 }) as i32));
    for own in [
        FogResult::FogOk,
        FogResult::FogErrNull,
        FogResult::FogErrNoModel,
        FogResult::FogErrNoState,
        FogResult::FogErrLayout,
        FogResult::FogErrAbi,
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
    let ok = fog_abi_check(
        size_of::<FogModel>(),
        size_of::<FogState>(),
        size_of::<FogPrediction>(),
        FOG_MAX_CENTRES as u32,
        FOG_MAX_INPUTS as u32,
        FOG_MAX_MONOMIALS as u32,
    );
    assert_eq!(ok, FogResult::FogOk);
    // A header edited to 140 centres, the library not rebuilt.
    let other = fog_abi_check(
        size_of::<FogModel>() - 8,
        size_of::<FogState>(),
        size_of::<FogPrediction>(),
        140,
        FOG_MAX_INPUTS as u32,
        FOG_MAX_MONOMIALS as u32,
    );
    assert_eq!(other, FogResult::FogErrAbi);
    // Every status and result is 32 bits on every target.
    assert_eq!(size_of::<FogResult>(), 4);
    assert_eq!(size_of::<FogStatus>(), 4);
    assert_eq!(size_of::<FogPrediction>(), 16);
}
