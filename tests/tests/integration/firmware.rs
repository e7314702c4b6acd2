//! The exported blob is the model: firmware-core (f32) against the trainer (f64), issue 3's
//! must-show figures, on units the trainer has not been tuned on.

use firmware_sim::gyro::{effects::Effect, paper, plant::GyroParams};
use trainer::data::points::POINT_FEATURES;
use trainer::firmware::export::{self, Agreement};
use trainer::models::gp::{GpConfig, GpModel};

use crate::paper::points;

fn check(label: &str, a: &Agreement, inside: bool) {
    assert!(a.all_finite, "{label}: non-finite firmware output");
    assert!(a.n > 0, "{label}: nothing compared");
    if inside {
        assert!(a.max_abs_mean_diff <= 1e-5, "{label}: mean {a:?}");
        assert!(a.max_rel_var_diff <= 1e-3, "{label}: variance {a:?}");
        assert_eq!(a.n_extrapolating, 0, "{label}: {a:?}");
    } else {
        // Beyond the range the figures may be worse, but every input must be flagged.
        assert_eq!(a.n_extrapolating, a.n, "{label}: {a:?}");
        assert!(a.max_abs_mean_diff < 1e-3, "{label}: mean {a:?}");
    }
}

#[test]
fn firmware_agrees_with_the_host_inside_the_trained_range_and_flags_beyond_it() {
    let units = [
        ("nominal", GyroParams::nominal(), 13),
        ("random 31", GyroParams::random_unit(31), 31),
        ("random 32", GyroParams::random_unit(32), 32),
    ];
    for (name, params, seed) in units {
        let train = points(&paper::run(&params, Effect::None, seed, false));
        let m = GpModel::fit(train.inputs(), &train.target(), &GpConfig::default()).unwrap();
        let blob = export::to_blob(&m, &POINT_FEATURES).unwrap();
        let fw = fog_data::replay::decode(&blob).unwrap();
        assert_eq!(fw.dims().m, 140);
        assert_eq!(fw.features(), &POINT_FEATURES);
        let r = export::agreement_report(&m, &fw, train.inputs(), &export::Extension::default());
        check(&format!("{name} training"), &r.training, true);
        check(&format!("{name} grid"), &r.grid_inside, true);
        assert!(r.grid_inside.n_var > 0, "{name}: no variance compared");
        check(&format!("{name} beyond"), &r.grid_beyond, false);
    }
}

#[test]
fn an_extended_blob_is_the_static_model_plus_its_additive_terms() {
    use firmware_core::{Feature, FeatureState, Sample};
    use trainer::firmware::export::{Extension, Term};
    let train = points(&paper::run(&GyroParams::nominal(), Effect::None, 5, false));
    let m = GpModel::fit(train.inputs(), &train.target(), &GpConfig::default()).unwrap();
    let fw = fog_data::replay::decode(&export::to_blob(&m, &POINT_FEATURES).unwrap()).unwrap();
    let extension = Extension {
        temperature: None,
        terms: vec![Term::bias(Feature::TimeOn, -2e-3, (0.0, 10.0))],
        offset: 1e-3,
    };
    let blob = export::to_blob_extended(&m, &POINT_FEATURES, &extension).unwrap();
    let ext = fog_data::replay::decode(&blob).unwrap();
    assert_eq!(
        ext.features(),
        &[Feature::Temperature, Feature::Voltage, Feature::TimeOn]
    );
    let (mut s0, mut s1) = (FeatureState::default(), FeatureState::default());
    let mut scratch = vec![0.0f32; 140];
    for (k, hours) in [0.0f64, 1.0, 5.0].into_iter().enumerate() {
        let sample = Sample {
            time_s: hours * 3600.0,
            temp_c: 10.0 + 5.0 * k as f32,
            output: 0.5 - 0.3 * k as f32,
        };
        let a = fw.compensate(&sample, &mut s0, &mut scratch).unwrap();
        let b = ext.compensate(&sample, &mut s1, &mut scratch).unwrap();
        let expected = f64::from(a.mean) + 1e-3 - 2e-3 * hours;
        assert!(
            (f64::from(b.mean) - expected).abs() < 2e-6,
            "{hours} h: {b:?} vs {expected}"
        );
        // The kernel ignores the added input: the variance is the static model's.
        assert!(
            (b.bias_variance - a.bias_variance).abs() <= 1e-6 * a.bias_variance.abs().max(1e-12)
        );
    }
}

/// A blob of format 4, written before blobs carried an error model, still loads and compensates
/// as it did: its noise variance is its sample noise and it adds no model error (issue 44). The
/// same model of format 5 (before blobs carried limits), of format 6 (before the scale term), of
/// format 7 (before the extrapolation's scale part), of format 8 (before the heating term) and of
/// format 9 gives the same means and variances.
#[test]
fn a_format_4_blob_still_loads_with_the_variance_it_stated() {
    let old = include_bytes!("../../../firmware-core/doc/gyro-v4.bin");
    let new = include_bytes!("../../../firmware-core/doc/gyro.bin");
    let (a, b) = (
        fog_data::replay::decode(old).unwrap(),
        fog_data::replay::decode(new).unwrap(),
    );
    let [_, noise] = a.variances();
    assert_eq!(
        a.error_model(),
        firmware_core::ErrorModel::noise_only(noise)
    );
    assert_eq!(firmware_core::blob::read_header(new).unwrap().version, 9);
    let v8 = include_bytes!("../../../firmware-core/doc/gyro-v8.bin");
    assert_eq!(firmware_core::blob::read_header(v8).unwrap().version, 8);
    let f = fog_data::replay::decode(v8).unwrap();
    assert_eq!(f.error_model(), b.error_model());
    assert_eq!((f.beyond(), f.limits()), (b.beyond(), b.limits()));
    let v7 = include_bytes!("../../../firmware-core/doc/gyro-v7.bin");
    assert_eq!(firmware_core::blob::read_header(v7).unwrap().version, 7);
    let e = fog_data::replay::decode(v7).unwrap();
    assert_eq!(e.error_model(), b.error_model());
    assert_eq!((e.beyond(), e.limits()), (b.beyond(), b.limits()));
    let v6 = include_bytes!("../../../firmware-core/doc/gyro-v6.bin");
    assert_eq!(firmware_core::blob::read_header(v6).unwrap().version, 6);
    let d = fog_data::replay::decode(v6).unwrap();
    assert_eq!(d.error_model(), b.error_model());
    assert_eq!((d.beyond(), d.limits()), (b.beyond(), b.limits()));
    let v5 = include_bytes!("../../../firmware-core/doc/gyro-v5.bin");
    assert_eq!(firmware_core::blob::read_header(v5).unwrap().version, 5);
    let c = fog_data::replay::decode(v5).unwrap();
    assert_eq!(c.error_model(), b.error_model());
    assert_eq!(c.beyond(), b.beyond());
    let mut scratch = [0.0f32; 24];
    for (t, v) in [(25.0f32, 0.38f32), (-20.0, -1.2), (55.0, 2.0)] {
        let (pa, pb) = (
            a.predict_at(&[t, v], 3.0, &mut scratch).unwrap(),
            b.predict(&[t, v], &mut scratch).unwrap(),
        );
        assert_eq!(c.predict(&[t, v], &mut scratch).unwrap(), pb);
        assert_eq!(d.predict(&[t, v], &mut scratch).unwrap(), pb);
        assert_eq!(e.predict(&[t, v], &mut scratch).unwrap(), pb);
        assert_eq!(f.predict(&[t, v], &mut scratch).unwrap(), pb);
        assert_eq!(pa.noise_variance, noise);
        assert!((pa.mean - pb.mean).abs() < 1e-3, "{t} {v}: {pa:?} {pb:?}");
        // No model error: the bias variance is the latent one at any time since power-on.
        assert_eq!(
            pa.bias_variance,
            a.predict(&[t, v], &mut scratch).unwrap().bias_variance
        );
    }
}
