use super::*;
use crate::blob::HEADER_LEN;
use crate::blob::unit as format;
use crate::model::Model;
use crate::testing::{Reference, as_v4, unit_blob};

type Small = Model<2, 6, 64>;
type Three = Unit<3, 2, 6, Vec<f32, 192>>;

/// Three channels: a gyro on (T, output), a gyro on (coil temperature, output) and an
/// accelerometer on (T, output) with another error model.
fn three() -> (std::vec::Vec<u8>, [std::vec::Vec<u8>; 3]) {
    let r = Reference::small();
    let mut other = Reference::small();
    other.weights = vec![-0.1, 0.2, 0.35, 0.8, -0.4];
    other.error.floor_var = 3e-4;
    let models = [
        r.blob(),
        r.blob_of([Feature::CoilTemperature { tau_s: 300.0 }, Feature::Voltage]),
        other.blob(),
    ];
    let unit = unit_blob(
        "IMU-0042",
        &[
            ("gyro.x", Quantity::AngularRate, models[0].clone()),
            ("gyro.y", Quantity::AngularRate, models[1].clone()),
            ("acc.z", Quantity::SpecificForce, models[2].clone()),
        ],
    );
    (unit, models)
}

/// A ramp at 1 °C/min from 10 °C, each channel's output its own.
fn sample_at(k: u32) -> (f64, f32, [f32; 3]) {
    let t = 10.0 + k as f32 / 60.0;
    let w = (k as f32 * 0.05).sin();
    (
        100.0 + f64::from(k),
        t,
        [0.4 * w, -0.3 * w + 0.1, 0.2 + 0.1 * w],
    )
}

#[test]
fn each_channel_of_a_unit_computes_what_its_own_blob_does_bit_for_bit() {
    let (blob, models) = three();
    let mut unit = Three::new();
    unit.decode_into(&blob).unwrap();
    assert_eq!(unit.sensor_id(), "IMU-0042");
    assert_eq!(unit.temperature_range(), [-30.0, 60.0]);
    let names: std::vec::Vec<&str> = unit.channels().iter().map(|c| c.name()).collect();
    assert_eq!(names, ["gyro.x", "gyro.y", "acc.z"]);
    assert_eq!(unit.channels()[2].quantity(), Quantity::SpecificForce);
    // Computed once: the temperature (channels x and z) and one coil filter (y).
    assert_eq!(
        unit.shared_features(),
        &[
            Feature::Temperature,
            Feature::CoilTemperature { tau_s: 300.0 }
        ]
    );
    assert_eq!(unit.scratch_len(), 5);
    let alone: std::vec::Vec<Small> = models.iter().map(|b| Small::decode(b).unwrap()).collect();
    let mut states = [(); 3].map(|()| FeatureState::default());
    let mut state = FeatureState::default();
    let mut scratch = [0.0f32; 5];
    let mut out = [Prediction {
        mean: 0.0,
        bias_variance: 0.0,
        noise_variance: 0.0,
        status: Status::Fault,
    }; 3];
    let mut means = [(
        Mean {
            mean: 0.0,
            status: Status::Fault,
        },
        0.0f32,
    ); 3];
    let mut mean_state = FeatureState::default();
    for k in 0..3000 {
        let (time_s, temp_c, outputs) = sample_at(k);
        let sample = UnitSample {
            time_s,
            temp_c,
            outputs: &outputs,
        };
        assert_eq!(
            unit.compensate(&sample, &mut state, &mut scratch, &mut out),
            Ok(3)
        );
        assert_eq!(
            unit.compensate_mean(&sample, &mut mean_state, &mut means),
            Ok(3)
        );
        for (c, model) in alone.iter().enumerate() {
            let own = Sample {
                time_s,
                temp_c,
                output: outputs[c],
            };
            let expected = model
                .compensate(&own, &mut states[c], &mut scratch)
                .unwrap();
            assert_eq!(out[c], expected, "channel {c}, sample {k}");
            assert_eq!(means[c].0.mean, expected.mean);
            assert_eq!(means[c].0.status, expected.status);
        }
    }
    assert_eq!(unit.noise_of_mean(2, 60.0), Some(4e-6 / 60.0));
    assert_eq!(unit.noise_of_mean(3, 60.0), None);
}

#[test]
fn a_bad_output_faults_its_own_channel_and_the_calls_refuse_short_buffers() {
    let (blob, _) = three();
    let unit = {
        let mut u = Three::new();
        u.decode_into(&blob).unwrap();
        u
    };
    let mut state = FeatureState::default();
    let mut scratch = [0.0f32; 5];
    let p = Prediction {
        mean: 0.0,
        bias_variance: 0.0,
        noise_variance: 0.0,
        status: Status::Valid,
    };
    let mut out = [p; 3];
    let sample = |outputs: &'static [f32]| UnitSample {
        time_s: 1.0,
        temp_c: 20.0,
        outputs,
    };
    unit.compensate(
        &sample(&[0.1, f32::NAN, 0.2]),
        &mut state,
        &mut scratch,
        &mut out,
    )
    .unwrap();
    assert_eq!(out[1].status, Status::Fault);
    assert!(out[0].status != Status::Fault && out[2].status != Status::Fault);
    assert!(out.iter().all(|p| p.mean.is_finite()));
    assert_eq!(
        unit.compensate(&sample(&[0.1, 0.2]), &mut state, &mut scratch, &mut out),
        Err(PredictError::TooFewOutputs { needed: 3 })
    );
    assert_eq!(
        unit.compensate(
            &sample(&[0.1, 0.2, 0.3]),
            &mut state,
            &mut scratch,
            &mut out[..2]
        ),
        Err(PredictError::ResultsTooShort { needed: 3 })
    );
    assert_eq!(
        unit.compensate(
            &sample(&[0.1, 0.2, 0.3]),
            &mut state,
            &mut scratch[..4],
            &mut out
        ),
        Err(PredictError::ScratchTooSmall { needed: 5 })
    );
    // A temperature no sensor reads faults every channel.
    let hot = UnitSample {
        time_s: 2.0,
        temp_c: 500.0,
        outputs: &[0.1, 0.2, 0.3],
    };
    unit.compensate(&hot, &mut state, &mut scratch, &mut out)
        .unwrap();
    assert!(out.iter().all(|p| p.status == Status::Fault));
    // Storage that holds nothing computes nothing.
    assert_eq!(
        Three::new().compensate(&hot, &mut state, &mut scratch, &mut out),
        Ok(0)
    );
}

#[test]
fn a_single_channel_blob_loads_as_a_unit_of_one() {
    let r = Reference::small();
    let mut unit = Three::new();
    unit.decode_into(&r.blob()).unwrap();
    let [ch] = unit.channels() else {
        panic!("one channel")
    };
    assert_eq!(ch.name(), SINGLE_CHANNEL);
    assert_eq!(ch.quantity(), Quantity::AngularRate);
    assert_eq!(ch.error_model(), r.error);
    assert_eq!(unit.sensor_id(), "");
    assert_eq!(unit.temperature_range(), [-30.0, 60.0]);
    let model = Small::decode(&r.blob()).unwrap();
    let mut scratch = [0.0f32; 5];
    let mut out = [Prediction {
        mean: 0.0,
        bias_variance: 0.0,
        noise_variance: 0.0,
        status: Status::Fault,
    }; 1];
    for k in 0..200 {
        let (time_s, temp_c, outputs) = sample_at(k);
        let mut a = FeatureState::default();
        let mut b = FeatureState::default();
        unit.compensate(
            &UnitSample {
                time_s,
                temp_c,
                outputs: &outputs[..1],
            },
            &mut a,
            &mut scratch,
            &mut out,
        )
        .unwrap();
        let own = Sample {
            time_s,
            temp_c,
            output: outputs[0],
        };
        assert_eq!(
            out[0],
            model.compensate(&own, &mut b, &mut scratch).unwrap()
        );
    }
    // A blob before the error model: its noise is its sample noise, as a model decoded alone.
    let v4 = as_v4(&r.blob());
    unit.decode_into(&v4).unwrap();
    assert_eq!(
        unit.channels()[0].error_model(),
        Small::decode(&v4).unwrap().error_model()
    );
}

/// What `trainer fit` writes for one channel's data, a unit blob of one entry, decodes as that
/// channel's model where a model is asked for (`fog_model_decode` in C), and predicts bit for bit
/// what the model blob does; a unit of several channels is refused there.
#[test]
fn a_unit_blob_of_one_channel_decodes_as_its_model() {
    let r = Reference::small();
    let one = unit_blob("", &[("rate", Quantity::AngularRate, r.blob())]);
    let (ours, theirs) = (
        Small::decode(&one).unwrap(),
        Small::decode(&r.blob()).unwrap(),
    );
    assert_eq!(ours.dims(), theirs.dims());
    assert_eq!(ours.error_model(), theirs.error_model());
    assert_eq!(Small::check(&one), Small::check(&r.blob()));
    let mut scratch = [0.0f32; 5];
    let (mut a, mut b) = (FeatureState::default(), FeatureState::default());
    for k in 0..200 {
        let (time_s, temp_c, outputs) = sample_at(k);
        let sample = Sample {
            time_s,
            temp_c,
            output: outputs[0],
        };
        assert_eq!(
            ours.compensate(&sample, &mut a, &mut scratch),
            theirs.compensate(&sample, &mut b, &mut scratch)
        );
    }
    let (several, _) = three();
    assert!(matches!(
        Small::decode(&several),
        Err(BlobError::CapacityExceeded {
            what: crate::error::Storage::Channels,
            needed: 3,
            capacity: 1
        })
    ));
}

#[test]
fn capacities_refuse_a_unit_before_anything_is_stored() {
    let (blob, _) = three();
    let capacity = |what, needed, capacity| BlobError::CapacityExceeded {
        what,
        needed,
        capacity,
    };
    assert_eq!(
        Unit::<2, 2, 6, Vec<f32, 192>>::check(&blob),
        Err(capacity(Storage::Channels, 3, 2))
    );
    assert_eq!(
        Unit::<3, 2, 6, Vec<f32, 100>>::check(&blob),
        Err(capacity(Storage::Floats, 3 * 49, 100))
    );
    assert_eq!(
        Unit::<3, 1, 6, Vec<f32, 192>>::check(&blob),
        Err(capacity(Storage::Inputs, 2, 1))
    );
    assert_eq!(Three::check(&blob), Ok(3));
    let mut unit = Unit::<3, 2, 6, Vec<f32, 100>>::new();
    assert!(unit.decode_into(&blob).is_err());
    assert!(unit.channels().is_empty());
}

#[test]
fn every_defect_of_a_unit_blob_has_its_error() {
    let (good, models) = three();
    let with = |f: &dyn Fn(&mut std::vec::Vec<u8>)| {
        let mut b = good.clone();
        f(&mut b);
        Three::check(&b).unwrap_err()
    };
    assert_eq!(with(&|b| b[0] = b'X'), BlobError::BadMagic);
    assert_eq!(with(&|b| b[4] = 9), BlobError::UnsupportedVersion(9));
    assert_eq!(with(&|b| b.truncate(b.len() - 1)), BlobError::Truncated);
    assert_eq!(with(&|b| b.push(0)), BlobError::TrailingBytes);
    assert_eq!(with(&|b| b[60] ^= 0x10), BlobError::CrcMismatch);
    let resealed = |f: &dyn Fn(&mut std::vec::Vec<u8>)| {
        with(&|b| {
            f(b);
            crate::blob::reseal(b);
        })
    };
    // The header's sizes disagree with the channels.
    assert_eq!(resealed(&|b| b[6] = 2), BlobError::InconsistentDimensions);
    assert_eq!(resealed(&|b| b[8] = 4), BlobError::InconsistentDimensions);
    assert_eq!(resealed(&|b| b[6] = 0), BlobError::InconsistentDimensions);
    // The encoder refuses what the format cannot hold.
    let entry = |name| format::ChannelBlob {
        name,
        quantity: Quantity::AngularRate,
        model: &models[0],
    };
    let mut buf = [0u8; 4096];
    for (id, name) in [
        ("x", "a name far too long"),
        ("x", ""),
        (&"i".repeat(33)[..], "x"),
    ] {
        assert_eq!(
            format::encode(id, [0.0, 1.0], &[entry(name)], &mut buf),
            Err(BlobError::InvalidParameter)
        );
    }
    assert_eq!(
        format::encode("x", [1.0, 0.0], &[entry("x")], &mut buf),
        Err(BlobError::InvalidParameter)
    );
    assert_eq!(
        format::encode("x", [0.0, 1.0], &[], &mut buf),
        Err(BlobError::InvalidParameter)
    );
    assert_eq!(
        format::encode("x", [0.0, 1.0], &[entry("x")], &mut buf[..40]),
        Err(BlobError::BufferTooSmall)
    );
}

#[test]
fn golden_bytes_pin_the_unit_header() {
    let (blob, models) = three();
    // magic, version 5, 3 channels, 2 inputs at most, 5 centres at most, sequence 0.
    assert_eq!(&blob[..14], b"FOGU\x05\x00\x03\x02\x05\x00\x00\x00\x00\x00");
    let len = u32::from_le_bytes(blob[14..18].try_into().unwrap()) as usize;
    assert_eq!(blob.len(), HEADER_LEN + len);
    // Payload: 3·49 numbers (varint 147 = 0x93 0x01), the ID, the range, 3 channels.
    assert_eq!(&blob[22..25], &[0x93, 0x01, 8]);
    assert_eq!(&blob[25..33], b"IMU-0042");
    assert_eq!(&blob[33..37], &(-30.0f32).to_le_bytes());
    assert_eq!(&blob[37..41], &60.0f32.to_le_bytes());
    // The first channel: name, quantity 0, m 5 (varint), d 2, p 3, then its model's payload
    // bytes, length first (varint), exactly as its model blob holds them.
    assert_eq!(&blob[41..49], &[3, 6, b'g', b'y', b'r', b'o', b'.', b'x']);
    assert_eq!(&blob[49..53], &[0, 5, 2, 3]);
    let payload = &models[0][HEADER_LEN..];
    let n = payload.len();
    assert!(n < 0x4000);
    let at = if n < 0x80 { 54 } else { 55 };
    assert_eq!(&blob[at..at + n], payload);
    // The sequence is stamped and resealed as a model blob's.
    let mut stamped = blob.clone();
    crate::blob::set_sequence(&mut stamped, 7).unwrap();
    assert_eq!(format::read_header(&stamped).unwrap().sequence, 7);
    assert_eq!(crate::blob::declared_len(&stamped), Some(blob.len()));
}

/// The unit blob of an earlier `version` the same channels made, each channel's model payload
/// made older by `older` (version 1: format 5; version 2: format 6; version 3: format 7).
fn as_old(
    models: &[std::vec::Vec<u8>; 3],
    version: u8,
    older: fn(&[u8]) -> std::vec::Vec<u8>,
) -> std::vec::Vec<u8> {
    let made: std::vec::Vec<std::vec::Vec<u8>> = models.iter().map(|m| older(m)).collect();
    let names = [
        ("gyro.x", Quantity::AngularRate),
        ("gyro.y", Quantity::AngularRate),
        ("acc.z", Quantity::SpecificForce),
    ];
    let entries: std::vec::Vec<format::ChannelEntry<'_>> = names
        .iter()
        .zip(&made)
        .map(|((name, quantity), m)| {
            let h = blob::read_header(m).unwrap();
            format::ChannelEntry {
                name,
                quantity: *quantity,
                m: h.dims.m as u16,
                d: h.dims.d as u8,
                p: h.dims.p as u8,
                model: h.payload,
            }
        })
        .collect();
    let numbers: usize = entries.iter().map(|e| e.dims().floats()).sum();
    let payload = format::UnitPayload {
        numbers: numbers as u32,
        sensor_id: "IMU-0042",
        temperature_c: [-30.0f32, 60.0],
        channels: entries.as_slice(),
    };
    let mut buf = [0u8; 4096];
    let body = postcard::to_slice(&payload, &mut buf).unwrap();
    let mut b = b"FOGU\x01\x00\x03\x02\x05\x00\x00\x00\x00\x00".to_vec();
    b[4] = version;
    b.extend([0u8; 8]);
    b.extend_from_slice(body);
    blob::reseal(&mut b);
    b
}

#[test]
fn a_version_1_unit_blob_still_decodes_its_channels_of_format_5() {
    let (_, models) = three();
    let old = as_old(&models, 1, crate::testing::as_v5);
    let mut unit = Three::new();
    unit.decode_into(&old).unwrap();
    for (ch, m) in unit.channels().iter().zip(&models) {
        let alone = Small::decode(&crate::testing::as_v5(m)).unwrap();
        assert_eq!(ch.error_model(), alone.error_model());
        assert_eq!(ch.limits(), crate::blob::Limits::DEFAULT);
    }
    let mut scratch = [0.0f32; 5];
    let x = [12.5f32, 0.3];
    let alone = Small::decode(&crate::testing::as_v5(&models[0])).unwrap();
    assert_eq!(
        unit.predict_at(0, &x, 1.0, &mut scratch).unwrap().unwrap(),
        alone.predict_at(&x, 1.0, &mut scratch).unwrap()
    );
}

#[test]
fn a_version_2_unit_blob_still_decodes_its_channels_of_format_6() {
    let (_, models) = three();
    let old = as_old(&models, 2, crate::testing::as_v6);
    let mut unit = Three::new();
    unit.decode_into(&old).unwrap();
    for (ch, m) in unit.channels().iter().zip(&models) {
        let alone = Small::decode(&crate::testing::as_v6(m)).unwrap();
        assert_eq!(ch.error_model(), alone.error_model());
        assert_eq!(ch.error_model().scale_var, 0.0);
    }
    let mut scratch = [0.0f32; 5];
    let x = [12.5f32, 0.3];
    let alone = Small::decode(&crate::testing::as_v6(&models[0])).unwrap();
    assert_eq!(
        unit.predict_at(0, &x, 1.0, &mut scratch).unwrap().unwrap(),
        alone.predict_at(&x, 1.0, &mut scratch).unwrap()
    );
}

#[test]
fn a_version_3_unit_blob_still_decodes_its_channels_of_format_7() {
    let (_, models) = three();
    let old = as_old(&models, 3, crate::testing::as_v7);
    let mut unit = Three::new();
    unit.decode_into(&old).unwrap();
    for (ch, m) in unit.channels().iter().zip(&models) {
        let alone = Small::decode(&crate::testing::as_v7(m)).unwrap();
        assert_eq!(ch.error_model(), alone.error_model());
        assert_eq!(ch.error_model().extrapolation_scale_var, 0.0);
    }
    let mut scratch = [0.0f32; 5];
    let x = [12.5f32, 0.3];
    let alone = Small::decode(&crate::testing::as_v7(&models[0])).unwrap();
    assert_eq!(
        unit.predict_at(0, &x, 1.0, &mut scratch).unwrap().unwrap(),
        alone.predict_at(&x, 1.0, &mut scratch).unwrap()
    );
}

#[test]
fn a_version_4_unit_blob_still_decodes_its_channels_of_format_8() {
    let (_, models) = three();
    let old = as_old(&models, 4, crate::testing::as_v8);
    let mut unit = Three::new();
    unit.decode_into(&old).unwrap();
    for (ch, m) in unit.channels().iter().zip(&models) {
        let alone = Small::decode(&crate::testing::as_v8(m)).unwrap();
        assert_eq!(ch.error_model(), alone.error_model());
        assert_eq!(ch.error_model().heating_var, 0.0);
    }
    let mut scratch = [0.0f32; 5];
    let x = [12.5f32, 0.3];
    let alone = Small::decode(&crate::testing::as_v8(&models[0])).unwrap();
    assert_eq!(
        unit.predict_at(0, &x, 1.0, &mut scratch).unwrap().unwrap(),
        alone.predict_at(&x, 1.0, &mut scratch).unwrap()
    );
}
