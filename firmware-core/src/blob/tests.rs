use super::*;
use crate::error::Storage;
use crate::model::{Conditions, Model};
use crate::testing::{Reference, as_v4};

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

/// sample noise, interval, floor, extrapolation, walk, trend, turn-on, leg and its range, scale,
/// the extrapolation's scale part, the heating term and its band.
const GOLDEN_ERROR: ErrorModel = ErrorModel {
    sample_noise_var: 1e-4,
    sample_interval_s: 0.5,
    floor_var: 2e-6,
    extrapolation_var: 3e-5,
    walk_var_per_h: 4e-7,
    trend_var_per_h2: 0.0,
    turn_on_var: 5e-6,
    leg_var: 6e-6,
    leg_min: 0.25,
    leg_max: 1.0,
    scale_var: 7e-8,
    extrapolation_scale_var: 8e-7,
    heating_var: 9e-6,
    heating_scale_var: 1e-8,
    heating_rate_at_0c: 0.1,
    heating_rate_per_c: -0.01,
    heating_rate_min: -0.2,
    heating_rate_max: 0.3,
    heating_temp_min_c: 0.0,
    heating_temp_max_c: 30.0,
};

/// [`GOLDEN_ERROR`] as a blob before format 9 reads: no heating term, no band.
const NO_HEATING: ErrorModel = ErrorModel {
    heating_var: 0.0,
    heating_scale_var: 0.0,
    heating_rate_at_0c: 0.0,
    heating_rate_per_c: 0.0,
    heating_rate_min: 0.0,
    heating_rate_max: 0.0,
    heating_temp_min_c: 0.0,
    heating_temp_max_c: 0.0,
    ..GOLDEN_ERROR
};

/// A rated range and a full scale.
const GOLDEN_LIMITS: Limits = Limits {
    temp_min_c: -40.0,
    temp_max_c: 85.0,
    full_scale: 10.0,
};

#[test]
fn golden_bytes_pin_the_encoding() {
    let payload = Payload {
        features: [Feature::TemperatureRate { tau_s: 60.0 }].as_slice(),
        exponents: [0u8].as_slice(),
        floats: GOLDEN.as_slice(),
        beyond: Beyond::Tangent,
        error: GOLDEN_ERROR,
        limits: GOLDEN_LIMITS,
    };
    let dims = Dims { m: 1, d: 1, p: 1 };
    assert_eq!(dims.floats(), 13);
    let mut buf = [0u8; 200];
    let n = encode(dims, &payload, &mut buf).unwrap();
    let mut expected: Vec<u8> = vec![b'F', b'O', b'G', b'B', 9, 0, 1, 0, 1, 1, 0, 0, 0, 0];
    expected.extend([154, 0, 0, 0]);
    let mut digest = CRC32.digest();
    digest.update(&expected[4..]);
    digest.update(&buf[HEADER_LEN..n]);
    expected.extend(digest.finalize().to_le_bytes());
    // features: len 1, variant 2 with its f32 parameter; exponents: len 1, 0; floats: len 13,
    // then f32 LE.
    expected.extend([1, 2]);
    expected.extend(60.0f32.to_le_bytes());
    expected.extend([1, 0, 13]);
    for v in &GOLDEN {
        expected.extend(v.to_le_bytes());
    }
    // Beyond the range: variant 1, the tangent.
    expected.push(1);
    for v in GOLDEN_ERROR
        .numbers()
        .iter()
        .chain(&GOLDEN_LIMITS.numbers())
    {
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

#[test]
fn a_version_4_blob_still_decodes_with_its_noise_as_the_only_error() {
    let good = Reference::small().blob();
    let old = as_v4(&good);
    let model = Small::decode(&old).unwrap();
    assert_eq!(read_header(&old).unwrap().version, V4);
    let [_, noise] = model.variances();
    assert_eq!(model.error_model(), ErrorModel::noise_only(noise));
    let mut stamped = old.clone();
    set_sequence(&mut stamped, 7).unwrap();
    assert_eq!(read_header(&stamped).unwrap().sequence, 7);
    let new = Small::decode(&good).unwrap();
    let mut scratch = [0.0f32; 5];
    let (a, b) = (
        model.predict(&[12.5, 0.4], &mut scratch).unwrap(),
        new.predict(&[12.5, 0.4], &mut scratch).unwrap(),
    );
    assert_eq!(a.mean, b.mean);
    assert_eq!(a.noise_variance, noise);
}

#[test]
fn a_version_5_blob_still_decodes_without_turn_on_leg_or_scale_terms_and_with_the_default_limits() {
    let r = Reference::small();
    let good = r.blob_with_error(GOLDEN_ERROR);
    let old = crate::testing::as_v5(&good);
    assert_eq!(read_header(&old).unwrap().version, V5);
    let model = Small::decode(&old).unwrap();
    assert_eq!(
        model.error_model(),
        ErrorModel {
            turn_on_var: 0.0,
            leg_var: 0.0,
            leg_min: -1.0,
            leg_max: 1.0,
            scale_var: 0.0,
            extrapolation_scale_var: 0.0,
            ..NO_HEATING
        }
    );
    assert_eq!(model.limits(), Limits::DEFAULT);
    assert_eq!(
        set_error_model(&mut old.clone(), &GOLDEN_ERROR),
        Err(BlobError::UnsupportedVersion(V5))
    );
}

/// The reference model with the golden error model, limits and rule beyond the range, and the
/// same as a blob of an older `version` (made by `older`), whose limits and rule read back.
fn golden_and_older(older: fn(&[u8]) -> Vec<u8>, version: u16) -> (Reference, Vec<u8>, Vec<u8>) {
    let r = Reference::small();
    let mut good = r.blob_with_error(GOLDEN_ERROR);
    set_limits(&mut good, &GOLDEN_LIMITS).unwrap();
    set_beyond(&mut good, Beyond::Tangent).unwrap();
    let old = older(&good);
    assert_eq!(read_header(&old).unwrap().version, version);
    let model = Small::decode(&old).unwrap();
    assert_eq!(model.limits(), GOLDEN_LIMITS);
    assert_eq!(model.beyond(), Beyond::Tangent);
    (r, good, old)
}

#[test]
fn a_version_6_blob_still_decodes_without_a_scale_term() {
    let (_, good, old) = golden_and_older(crate::testing::as_v6, V6);
    let model = Small::decode(&old).unwrap();
    assert_eq!(
        model.error_model(),
        ErrorModel {
            scale_var: 0.0,
            extrapolation_scale_var: 0.0,
            ..NO_HEATING
        }
    );
    let new = Small::decode(&good).unwrap();
    let mut scratch = [0.0f32; 5];
    let (a, b) = (
        model.predict(&[12.5, 0.4], &mut scratch).unwrap(),
        new.predict(&[12.5, 0.4], &mut scratch).unwrap(),
    );
    assert_eq!(a.mean, b.mean);
    let scale = GOLDEN_ERROR.scale_var * b.mean * b.mean;
    assert!(scale > 0.0);
    assert!((b.bias_variance - a.bias_variance - scale).abs() <= 1e-3 * scale);
    assert_eq!(
        set_error_model(&mut old.clone(), &GOLDEN_ERROR),
        Err(BlobError::UnsupportedVersion(V6))
    );
}

#[test]
fn a_version_7_blob_still_decodes_without_the_extrapolations_scale_part() {
    let (r, good, old) = golden_and_older(crate::testing::as_v7, V7);
    let model = Small::decode(&old).unwrap();
    assert_eq!(
        model.error_model(),
        ErrorModel {
            extrapolation_scale_var: 0.0,
            ..NO_HEATING
        }
    );
    let new = Small::decode(&good).unwrap();
    let mut scratch = [0.0f32; 5];
    // Inside the trained range the two agree to the bit; beyond it the new blob adds
    // extrapolation_scale · y² · e².
    let inside = [12.5, 0.4];
    assert_eq!(
        model.predict(&inside, &mut scratch).unwrap(),
        new.predict(&inside, &mut scratch).unwrap()
    );
    // A quarter of the width beyond, inside the rated temperatures.
    let beyond = [(r.max[0] + 0.25 * (r.max[0] - r.min[0])) as f32, 0.4];
    let (a, b) = (
        model.predict(&beyond, &mut scratch).unwrap(),
        new.predict(&beyond, &mut scratch).unwrap(),
    );
    assert_eq!(a.mean, b.mean);
    let part = GOLDEN_ERROR.extrapolation_scale_var * b.mean * b.mean * 0.0625;
    assert!(part > 0.0);
    assert!(
        (b.bias_variance - a.bias_variance - part).abs() <= 1e-3 * part,
        "{a:?} {b:?} {part}"
    );
    assert_eq!(
        set_error_model(&mut old.clone(), &GOLDEN_ERROR),
        Err(BlobError::UnsupportedVersion(V7))
    );
}

#[test]
fn a_version_8_blob_still_decodes_without_a_heating_term() {
    let (_, good, old) = golden_and_older(crate::testing::as_v8, V8);
    let model = Small::decode(&old).unwrap();
    assert_eq!(model.error_model(), NO_HEATING);
    let new = Small::decode(&good).unwrap();
    let mut scratch = [0.0f32; 5];
    let x = [12.5, 0.4];
    // The band at 12.5 °C is 0.1 − 0.125 + [−0.2, 0.3] °C/min: a rate of 0.1 lies inside it, one
    // of 1.0 lies 0.725 above it.
    let at = |rate| Conditions {
        heating: Some((12.5, rate)),
        ..Conditions::at_hours(0.0)
    };
    let inside = model.predict_in(&x, at(0.1), &mut scratch).unwrap();
    assert_eq!(inside, new.predict_in(&x, at(0.1), &mut scratch).unwrap());
    assert_eq!(inside, model.predict_in(&x, at(1.0), &mut scratch).unwrap());
    let faster = new.predict_in(&x, at(1.0), &mut scratch).unwrap();
    assert_eq!(faster.mean, inside.mean);
    let part = (GOLDEN_ERROR.heating_var + GOLDEN_ERROR.heating_scale_var * inside.mean.powi(2))
        * 0.725
        * 0.725;
    assert!(GOLDEN_ERROR.heating_scale_var * inside.mean.powi(2) > 1e-3 * part);
    assert!(
        (faster.bias_variance - inside.bias_variance - part).abs() <= 1e-3 * part,
        "{inside:?} {faster:?} {part}"
    );
    // As far below the band: the same.
    let slower = new
        .predict_in(&x, at(-0.225 - 0.725), &mut scratch)
        .unwrap();
    assert!((slower.bias_variance - faster.bias_variance).abs() <= 1e-3 * part);
    // Beyond the temperatures the band was read at, its line is read at their edge: at 50 °C
    // as at 30 °C, where 1.0 °C/min lies 0.9 above it (the line continued would give 1.1).
    let mut warm = |t: f32, rate| {
        let at = Conditions {
            heating: Some((t, rate)),
            ..Conditions::at_hours(0.0)
        };
        new.predict_in(&x, at, &mut scratch).unwrap().bias_variance
    };
    assert_eq!(warm(50.0, 1.0), warm(30.0, 1.0));
    let e = GOLDEN_ERROR;
    assert!((e.heating_excess(50.0, 1.0) - 0.9).abs() < 1e-6);
    // At −20 °C, the line at 0 °C: −1.0 °C/min lies 0.9 below its lower edge, 0.1 − 0.2.
    assert!((e.heating_excess(-20.0, -1.0) - 0.9).abs() < 1e-6);
    assert_eq!(
        set_error_model(&mut old.clone(), &GOLDEN_ERROR),
        Err(BlobError::UnsupportedVersion(V8))
    );
}

#[test]
fn the_rule_beyond_the_range_written_into_a_blob_is_the_one_decoded() {
    let r = Reference::small();
    let mut b = r.blob();
    assert_eq!(Small::decode(&b).unwrap().beyond(), Beyond::Hold);
    set_beyond(&mut b, Beyond::Tangent).unwrap();
    let model = Small::decode(&b).unwrap();
    assert_eq!(model.beyond(), Beyond::Tangent);
    assert_eq!(model.error_model(), r.error);
    assert_eq!(model.limits(), Limits::DEFAULT);
    // Older blobs were evaluated as the GP predicts beyond the range.
    let old = crate::testing::as_v5(&b);
    assert_eq!(Small::decode(&old).unwrap().beyond(), Beyond::Follow);
    // A byte that is no rule is a malformed blob.
    let at = b.len() - 4 * (ErrorModel::NUMBERS + Limits::NUMBERS) - 1;
    b[at] = 7;
    reseal(&mut b);
    assert_eq!(Small::decode(&b).unwrap_err(), BlobError::Malformed);
}

#[test]
fn limits_written_into_a_blob_are_the_ones_decoded_and_checked() {
    let r = Reference::small();
    let mut b = r.blob();
    assert_eq!(Small::decode(&b).unwrap().limits(), Limits::DEFAULT);
    set_limits(&mut b, &GOLDEN_LIMITS).unwrap();
    let model = Small::decode(&b).unwrap();
    assert_eq!(model.limits(), GOLDEN_LIMITS);
    // The error model is untouched by the limits written after it.
    assert_eq!(model.error_model(), r.error);
    let inverted = Limits {
        temp_min_c: 30.0,
        temp_max_c: 20.0,
        full_scale: 0.0,
    };
    assert_eq!(
        set_limits(&mut b, &inverted),
        Err(BlobError::InvalidParameter)
    );
    let nan = Limits {
        full_scale: f32::NAN,
        ..GOLDEN_LIMITS
    };
    assert_eq!(set_limits(&mut b, &nan), Err(BlobError::NonFinite(2)));
    // Edited behind the check: the decoder refuses them, numbered after the error model's.
    let at = b.len() - 4;
    b[at..].copy_from_slice(&(-1.0f32).to_le_bytes());
    reseal(&mut b);
    assert_eq!(Small::decode(&b).unwrap_err(), BlobError::InvalidParameter);
    b[at..].copy_from_slice(&f32::INFINITY.to_le_bytes());
    reseal(&mut b);
    let n = Dims { m: 5, d: 2, p: 3 }.floats();
    assert_eq!(
        Small::decode(&b).unwrap_err(),
        BlobError::NonFinite(n + ErrorModel::NUMBERS + 2)
    );
}

#[test]
fn an_error_model_written_into_a_blob_is_the_one_encoded() {
    let r = Reference::small();
    let mut b = r.blob_with_error(ErrorModel::noise_only(1e-6));
    set_error_model(&mut b, &GOLDEN_ERROR).unwrap();
    assert_eq!(b, r.blob_with_error(GOLDEN_ERROR));
    assert_eq!(Small::decode(&b).unwrap().error_model(), GOLDEN_ERROR);
    let bad = ErrorModel {
        floor_var: f32::INFINITY,
        ..GOLDEN_ERROR
    };
    assert_eq!(set_error_model(&mut b, &bad), Err(BlobError::NonFinite(2)));
    let mut old = as_v4(&b);
    assert_eq!(
        set_error_model(&mut old, &GOLDEN_ERROR),
        Err(BlobError::UnsupportedVersion(V4))
    );
}

#[test]
fn the_error_model_is_checked_like_the_other_numbers() {
    let bad = |error: ErrorModel| {
        let r = Reference::small();
        Small::decode(&r.blob_with_error(error)).unwrap_err()
    };
    let n = Dims { m: 5, d: 2, p: 3 }.floats();
    let nan = ErrorModel {
        walk_var_per_h: f32::NAN,
        ..GOLDEN_ERROR
    };
    assert_eq!(bad(nan), BlobError::NonFinite(n + 4));
    let negative = ErrorModel {
        floor_var: -1.0,
        ..GOLDEN_ERROR
    };
    assert_eq!(bad(negative), BlobError::InvalidParameter);
    let legs = ErrorModel {
        leg_min: 0.5,
        leg_max: 0.25,
        ..GOLDEN_ERROR
    };
    assert_eq!(bad(legs), BlobError::InvalidParameter);
    let beyond = ErrorModel {
        leg_max: 1.5,
        ..GOLDEN_ERROR
    };
    assert_eq!(bad(beyond), BlobError::InvalidParameter);
    let scale = ErrorModel {
        scale_var: -1e-8,
        ..GOLDEN_ERROR
    };
    assert_eq!(bad(scale), BlobError::InvalidParameter);
    let extrapolation_scale = ErrorModel {
        extrapolation_scale_var: -1e-8,
        ..GOLDEN_ERROR
    };
    assert_eq!(bad(extrapolation_scale), BlobError::InvalidParameter);
    let heating = ErrorModel {
        heating_var: -1e-8,
        ..GOLDEN_ERROR
    };
    assert_eq!(bad(heating), BlobError::InvalidParameter);
    let band = ErrorModel {
        heating_rate_min: 0.4,
        ..GOLDEN_ERROR
    };
    assert_eq!(bad(band), BlobError::InvalidParameter);
    let temps = ErrorModel {
        heating_temp_min_c: 40.0,
        ..GOLDEN_ERROR
    };
    assert_eq!(bad(temps), BlobError::InvalidParameter);
}

/// The same model as a version-3 blob: 18-byte header, CRC over the payload alone.
fn as_v3(blob: &[u8]) -> Vec<u8> {
    let blob = as_v4(blob);
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
    assert_eq!(
        Small::decode(&old).unwrap(),
        Small::decode(&as_v4(&good)).unwrap()
    );
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
