use super::*;
use crate::testing::Reference;

type Small = Model<2, 6, 64>;

#[test]
fn f32_mean_and_variance_follow_the_f64_reference() {
    let r = Reference::small();
    let m = Small::decode(&r.blob()).unwrap();
    let mut scratch = [0.0f32; 8];
    for t in [-30.0f32, -5.0, 12.5, 40.0, 60.0] {
        for v in [-3.0f32, -0.7, 0.0, 0.4, 2.9] {
            let x = [f64::from(t), f64::from(v)];
            let (mean, var) = r.predict(x);
            let hours = 2.5f32;
            let p = m.predict_at(&[t, v], hours, &mut scratch).unwrap();
            let expected = if (-30.0..=60.0).contains(&t) {
                Status::Valid
            } else {
                Status::Extrapolating
            };
            assert_eq!(p.status, expected);
            assert!(
                (f64::from(p.mean) - mean).abs() < 1e-5,
                "{t} {v}: {} vs {mean}",
                p.mean
            );
            assert!(p.bias_variance >= 0.0);
            let bias = var + r.model_error(x, mean, f64::from(hours));
            assert!(
                (f64::from(p.bias_variance) - bias).abs() < 1e-3 * r.signal_var,
                "{t} {v}: {} vs {bias}",
                p.bias_variance
            );
            assert_eq!(p.noise_variance, r.error.sample_noise_var);
            assert_eq!(p.variance(), p.bias_variance + p.noise_variance);
            assert_eq!(m.predict_mean(&[t, v]).mean, p.mean);
        }
    }
}

#[test]
fn compensate_runs_the_feature_pipeline() {
    let m = Small::decode(&Reference::small().blob()).unwrap();
    let mut scratch = [0.0f32; 5];
    let sample = Sample {
        time_s: 10.0,
        temp_c: 12.5,
        output: 0.4,
    };
    let p = m
        .compensate(&sample, &mut FeatureState::default(), &mut scratch)
        .unwrap();
    // The first sample: power-on, the heating/cooling play centred (state 0), no heating rate
    // read until it has settled.
    let at = Conditions {
        hours: 0.0,
        leg: Some(0.0),
        heating: None,
        another_power_on: true,
    };
    assert_eq!(p, m.predict_in(&[12.5, 0.4], at, &mut scratch).unwrap());
}

#[test]
fn the_calibrations_own_power_on_leaves_out_another_ones_bias_and_scale() {
    let r = Reference::small();
    let m = Small::decode(&r.blob()).unwrap();
    let mut scratch = [0.0f32; 5];
    let sample = Sample {
        time_s: 10.0,
        temp_c: 12.5,
        output: 0.4,
    };
    let (mut service, mut own) = (FeatureState::default(), FeatureState::default());
    own.calibration_run();
    let a = m.compensate(&sample, &mut service, &mut scratch).unwrap();
    let b = m.compensate(&sample, &mut own, &mut scratch).unwrap();
    assert_eq!(a.mean, b.mean);
    let gap = a.bias_variance - b.bias_variance;
    // Its bias, and its scale at the output.
    let expected = r.error.turn_on_var + r.error.scale_var * a.mean * a.mean;
    assert!(r.error.scale_var * a.mean * a.mean > 1e-3 * expected);
    assert!((gap - expected).abs() < 1e-3 * expected, "{gap} {expected}");
    // After a power cycle every power-on is another.
    own.power_on();
    assert!(!own.in_calibration_run());
    let later = Sample {
        time_s: 500.0,
        ..sample
    };
    let c = m.compensate(&later, &mut own, &mut scratch).unwrap();
    assert!(
        (c.bias_variance - a.bias_variance).abs() < 1e-3 * expected,
        "{c:?} {a:?}"
    );
}

#[test]
fn variance_vanishes_at_a_centre_and_grows_with_the_distance_beyond_the_range() {
    let r = Reference::small();
    let m = Small::decode(&r.blob()).unwrap();
    let mut scratch = [0.0f32; 5];
    let c = r.centres[2];
    let x = [
        (c[0] * r.scale[0] + r.offset[0]) as f32,
        (c[1] * r.scale[1] + r.offset[1]) as f32,
    ];
    let p = m.predict(&x, &mut scratch).unwrap();
    let floor = r.error.floor_var + r.error.turn_on_var + r.error.scale_var * p.mean * p.mean;
    let at_centre = p.bias_variance - floor;
    assert!(at_centre < 1e-3 * r.signal_var as f32, "{at_centre}");
    // 40 °C beyond a 90 °C range: the mean and latent variance of the edge, e² = (40/90)².
    let edge = m.predict(&[60.0, 0.0], &mut scratch).unwrap();
    let beyond = m.predict(&[100.0, 0.0], &mut scratch).unwrap();
    assert_eq!(beyond.status, Status::Extrapolating);
    assert_eq!(beyond.mean, edge.mean);
    let grown = beyond.bias_variance - edge.bias_variance;
    let expected = (r.error.extrapolation_var
        + r.error.extrapolation_scale_var * edge.mean * edge.mean)
        * (40.0f32 / 90.0).powi(2);
    assert!(
        (grown - expected).abs() < 1e-3 * expected,
        "{grown} {expected}"
    );
    // Further out, σ keeps growing and the mean stays the edge's.
    let far = m.predict(&[120.0, 0.0], &mut scratch).unwrap();
    assert_eq!(far.status, Status::Extrapolating);
    assert_eq!(far.mean, edge.mean);
    assert!(far.bias_variance > beyond.bias_variance);
}

#[test]
fn beyond_the_trained_rates_the_variance_grows_with_the_output_and_the_distance_under_every_rule() {
    // The output's own input beyond its trained ±3 V (a width of 6): e² counts its distance, so
    // the extrapolation's scale part grows as y²·e², y the compensated output (held or along the
    // tangent alike), one width out and ten.
    let r = Reference::small();
    let e = r.error;
    let mut scratch = [0.0f32; 5];
    for rule in [Beyond::Hold, Beyond::Tangent] {
        let mut b = r.blob();
        blob::set_beyond(&mut b, rule).unwrap();
        let m = Small::decode(&b).unwrap();
        let edge = m.predict(&[20.0, 3.0], &mut scratch).unwrap();
        // What every power-on adds at the edge, less the latent variance the kernel reads there.
        let at = |y: f32| e.floor_var + e.turn_on_var + e.scale_var * y * y;
        let latent = edge.bias_variance - at(edge.mean);
        for widths in [1.0f32, 10.0] {
            let p = m
                .predict(&[20.0, 3.0 + 6.0 * widths], &mut scratch)
                .unwrap();
            assert_eq!(p.status, Status::Extrapolating, "{rule:?} {widths}");
            let grown = p.bias_variance - latent - at(p.mean);
            let expected = (e.extrapolation_var + e.extrapolation_scale_var * p.mean * p.mean)
                * widths
                * widths;
            assert!(
                (grown - expected).abs() < 1e-3 * expected,
                "{rule:?} {widths}: {grown} {expected}"
            );
        }
    }
}

#[test]
fn following_the_gp_ten_widths_colder_the_variance_is_its_own_and_the_assumed_growth() {
    // A calibration on a narrow band (20…25 °C, a width of 5) replayed one and ten widths
    // colder under `follow`: the mean is the GP's own there, finite, and the bias variance its
    // latent variance plus every power-on's terms and (extrapolation + scale·y²)·e², e the
    // distance in widths: the growth the trainer assumed, scaled by its rule's share.
    let mut r = Reference::small();
    (r.min[0], r.max[0]) = (20.0, 25.0);
    let mut b = r.blob();
    blob::set_beyond(&mut b, Beyond::Follow).unwrap();
    let m = Small::decode(&b).unwrap();
    let mut scratch = [0.0f32; 5];
    for widths in [1.0f64, 10.0] {
        let x = [20.0 - 5.0 * widths, 0.4];
        let p = m
            .predict(&[x[0] as f32, x[1] as f32], &mut scratch)
            .unwrap();
        assert_eq!(p.status, Status::Extrapolating, "{widths}");
        let (mean, latent) = r.predict(x);
        assert!(
            (f64::from(p.mean) - mean).abs() < 1e-5,
            "{widths}: {} {mean}",
            p.mean
        );
        let expected = latent + r.model_error(x, mean, 0.0);
        let grown = (f64::from(r.error.extrapolation_var)
            + f64::from(r.error.extrapolation_scale_var) * mean * mean)
            * widths
            * widths;
        // Ten widths out, the growth is most of it.
        assert!(
            widths < 10.0 || grown > 0.9 * expected,
            "{widths}: {grown} {expected}"
        );
        assert!(
            (f64::from(p.bias_variance) - expected).abs() < 1e-3 * expected,
            "{widths}: {} {expected}",
            p.bias_variance
        );
    }
}

#[test]
fn beyond_the_range_the_output_keeps_its_scale_factor_and_the_temperature_is_held() {
    let r = Reference::small();
    let m = Small::decode(&r.blob()).unwrap();
    // The output's raw linear term follows it past the trained ±3: its slope stays the
    // scale factor's, while the kernel and prior read the edge.
    let at = |t: f32, v: f32| m.predict_mean(&[t, v]);
    let edge = at(20.0, 3.0);
    let beyond = at(20.0, 4.0);
    assert_eq!(beyond.status, Status::Extrapolating);
    let slope = beyond.mean - edge.mean;
    let scale = r.raw[1] as f32;
    assert!((slope - scale).abs() < 1e-4 * scale, "{slope} {scale}");
    // A temperature below the coldest trained is held there, linear term included.
    assert_eq!(at(-45.0, 0.5).mean, at(-30.0, 0.5).mean);
    assert_eq!(at(-45.0, 0.5).status, Status::Extrapolating);
}

#[test]
fn an_input_only_linear_terms_read_follows_its_value_beyond_the_range() {
    // The second input as an extension's additive one: ignored by the kernel, its slope the
    // raw linear coefficient.
    let mut r = Reference::small();
    r.length[1] = f64::from(blob::IGNORED_LENGTH_SCALE);
    let features = [
        Feature::Temperature,
        Feature::TemperatureRate { tau_s: 60.0 },
    ];
    let m = Small::decode(&r.blob_of(features)).unwrap();
    let at = |rate: f32| m.predict_mean(&[20.0, rate]);
    let (edge, beyond) = (at(3.0), at(5.0));
    assert_eq!(beyond.status, Status::Extrapolating);
    let slope = (beyond.mean - edge.mean) / 2.0;
    // Its raw linear term and its prior monomial 0.5·z, both followed.
    let expected = (r.raw[1] + r.prior[2] / r.scale[1]) as f32;
    assert!(
        (slope - expected).abs() < 1e-3 * expected,
        "{slope} {expected}"
    );
}

#[test]
fn an_input_only_linear_terms_read_grows_the_variance_by_what_it_followed() {
    // An extension's time drift: ignored by the kernel and the prior mean (its monomial z₁
    // replaced by z₀²), read by its raw linear term alone over a trained −3…3 h.
    let mut r = Reference::small();
    r.length[1] = f64::from(blob::IGNORED_LENGTH_SCALE);
    r.exponents = vec![0, 0, 1, 0, 2, 0];
    let m = Small::decode(&r.blob_of([Feature::Temperature, Feature::TimeOn])).unwrap();
    let mut scratch = [0.0f32; 5];
    let mut at = |t: f32, h: f32| m.predict(&[t, h], &mut scratch).unwrap();
    let (inside, edge, beyond) = (at(20.0, 1.0), at(20.0, 3.0), at(20.0, 5.0));
    assert_eq!((inside.status, edge.status), (Status::Valid, Status::Valid));
    assert_eq!(beyond.status, Status::Extrapolating);
    // Two hours past the edge the drift followed adds raw₁ · 2 to the mean, and its square to
    // the variance: nothing through e(x)², which would have added extrapolation · (2/6)².
    // (Another power-on's scale term grows with the mean followed, as at any output.)
    let followed = 2.0 * r.raw[1];
    let scale = f64::from(r.error.scale_var)
        * (f64::from(beyond.mean).powi(2) - f64::from(edge.mean).powi(2));
    let grown = f64::from(beyond.bias_variance - edge.bias_variance);
    let expected = followed * followed + scale;
    assert!(
        (grown - expected).abs() < 1e-5 * expected,
        "{grown} {expected}"
    );
    // Inside the range, nothing is added: the latent variance plus the model error at
    // e(x)² = 0, as the f64 reference gives them.
    let expected =
        r.predict([20.0, 1.0]).1 + r.model_error([20.0, 1.0], f64::from(inside.mean), 0.0);
    assert!((f64::from(inside.bias_variance) - expected).abs() < 1e-6 * expected);
    // A temperature beyond its range still grows by e(x)², held at the edge's mean.
    let (warm, hot) = (at(60.0, 1.0), at(70.0, 1.0));
    assert_eq!(
        (warm.status, hot.status),
        (Status::Valid, Status::Extrapolating)
    );
    assert_eq!(hot.mean, warm.mean);
    let e = &r.error;
    let y2 = f64::from(hot.mean).powi(2);
    let e2 = (10.0f64 / 90.0).powi(2);
    let expected =
        (f64::from(e.extrapolation_var) + f64::from(e.extrapolation_scale_var) * y2) * e2;
    let grown = f64::from(hot.bias_variance - warm.bias_variance);
    assert!(
        (grown - expected).abs() < 1e-3 * expected,
        "{grown} {expected}"
    );
    // Years since power-on: the distance is capped as the widths are, never a fault.
    let far = at(20.0, 1e9);
    assert_eq!(far.status, Status::Extrapolating);
    assert!(far.bias_variance.is_finite() && far.mean.is_finite());
    // Side by side, the same variances bit for bit.
    let queries = [[20.0f32, 1.0], [20.0, 5.0], [70.0, 1.0], [20.0, 1e9]];
    let prepared = queries.map(|x| Prepared::<2>::inputs(&x, Conditions::at_hours(0.0)));
    let mut lanes = vec![0.0f32; m.evaluate_scratch_len()];
    let mut out = [Evaluation::NONE; 4];
    m.evaluate(&prepared, &mut lanes, &mut out).unwrap();
    for (x, e) in queries.iter().zip(&out) {
        let one = m.predict(x, &mut [0.0f32; 5]).unwrap();
        assert_eq!(
            (e.prediction.bias_variance.to_bits(), e.prediction.status),
            (one.bias_variance.to_bits(), one.status),
            "{x:?}"
        );
    }
}

#[test]
fn the_tangent_continues_the_prior_mean_from_the_edge_to_first_order() {
    let r = Reference::small();
    let mut b = r.blob();
    blob::set_beyond(&mut b, Beyond::Tangent).unwrap();
    let m = Small::decode(&b).unwrap();
    let held = Small::decode(&r.blob()).unwrap();
    // 10 °C above the trained 60 °C at V = 0.5: the held value plus the prior's slope in T
    // (its z_T monomial's coefficient over T's scale, and the raw term) times 10 °C.
    let (edge, beyond) = (m.predict_mean(&[60.0, 0.5]), m.predict_mean(&[70.0, 0.5]));
    assert_eq!(beyond.status, Status::Extrapolating);
    let slope = (r.prior[1] / r.scale[0] + r.raw[0]) as f32;
    let expected = edge.mean + 10.0 * slope;
    assert!(
        (beyond.mean - expected).abs() < 1e-5,
        "{} {expected}",
        beyond.mean
    );
    // Held, the same sample is the edge's value.
    assert_eq!(held.predict_mean(&[70.0, 0.5]).mean, edge.mean);
}

#[test]
fn only_a_reading_that_cannot_be_true_is_a_fault() {
    let r = Reference::small();
    let mut b = r.blob();
    let limits = Limits {
        temp_min_c: -40.0,
        temp_max_c: 85.0,
        full_scale: 5.0,
    };
    blob::set_limits(&mut b, &limits).unwrap();
    let m = Small::decode(&b).unwrap();
    let mut scratch = [0.0f32; 5];
    // Far from the calibration (−30…60 °C, ±3), inside the sensor's limits: a reading.
    for x in [[-40.0f32, 0.0], [85.0, 0.0], [20.0, 5.0], [20.0, -5.0]] {
        let p = m.predict(&x, &mut scratch).unwrap();
        assert_eq!(p.status, Status::Extrapolating, "{x:?}");
        assert!(p.mean.is_finite() && p.mean != 0.0 && p.bias_variance.is_finite());
    }
    for x in [[-40.5f32, 0.0], [85.5, 0.0], [20.0, 5.5], [20.0, -5.5]] {
        assert_eq!(
            m.predict(&x, &mut scratch).unwrap().status,
            Status::Fault,
            "{x:?}"
        );
    }
    // The default limits: −55…125 °C, no full scale.
    let m = Small::decode(&r.blob()).unwrap();
    assert_eq!(m.predict_mean(&[-55.0, 1e6]).status, Status::Extrapolating);
    assert_eq!(m.predict_mean(&[-55.5, 0.0]).status, Status::Fault);
    assert_eq!(m.predict_mean(&[125.5, 0.0]).status, Status::Fault);
}

#[test]
fn a_bias_models_unbounded_output_is_still_held_to_its_full_scale() {
    // The output as a bias model carries it: read by its linear term alone, at any value.
    let mut r = Reference::small();
    r.length[1] = f64::from(blob::IGNORED_LENGTH_SCALE);
    r.min[1] = -1e30;
    r.max[1] = 1e30;
    let mut b = r.blob();
    let limits = Limits {
        full_scale: 5.0,
        ..Limits::DEFAULT
    };
    blob::set_limits(&mut b, &limits).unwrap();
    let m = Small::decode(&b).unwrap();
    assert_eq!(m.predict_mean(&[20.0, 4.0]).status, Status::Valid);
    assert_eq!(m.predict_mean(&[20.0, -5.5]).status, Status::Fault);
}

#[test]
fn a_heating_cooling_state_the_calibration_did_not_hold_grows_the_variance() {
    let r = Reference::small();
    let m = Small::decode(&r.blob()).unwrap();
    let mut scratch = [0.0f32; 5];
    let mut at = |leg| {
        m.predict_in(
            &[20.0, 0.5],
            Conditions {
                hours: 1.0,
                leg,
                heating: None,
                another_power_on: true,
            },
            &mut scratch,
        )
        .unwrap()
    };
    // Trained on states 0.5…1 (heating): a full cooling state is 1.5 of the swing of 2 away.
    let trained = at(None);
    assert_eq!(at(Some(0.75)), trained);
    let cooling = at(Some(-1.0));
    let grown = cooling.bias_variance - trained.bias_variance;
    let expected = r.error.leg_var * 0.75 * 0.75;
    assert!(
        (grown - expected).abs() < 1e-3 * expected,
        "{grown} {expected}"
    );
    assert_eq!(cooling.mean, trained.mean);
}

#[test]
fn a_heating_rate_outside_the_calibrations_band_grows_the_variance() {
    let r = Reference::small();
    let m = Small::decode(&r.blob()).unwrap();
    let mut scratch = [0.0f32; 5];
    // Trained on −0.5…0.5 °C/min at every temperature: heating at 2 °C/min for ten minutes (five
    // of the heating rate's time constants) reads as 2 °C/min less e⁻⁵ of it, and half a step's
    // lag of the 1 s samples held over their step.
    let mut state = FeatureState::default();
    let mut last = None;
    for i in 0..=600 {
        let sample = Sample {
            time_s: f64::from(i),
            temp_c: 10.0 + 2.0 * i as f32 / 60.0,
            output: 0.4,
        };
        last = Some((
            sample,
            m.compensate(&sample, &mut state, &mut scratch).unwrap(),
        ));
    }
    let (sample, p) = last.unwrap();
    let (temp, rate) = state.heating().unwrap();
    assert_eq!(temp, sample.temp_c);
    assert!((rate - 2.0).abs() < 0.03, "{rate}");
    let x = [sample.temp_c, sample.output];
    let at = |heating| Conditions {
        heating,
        ..Conditions::of(&state)
    };
    assert_eq!(
        p,
        m.predict_in(&x, at(Some((temp, rate))), &mut scratch)
            .unwrap()
    );
    let held = m
        .predict_in(&x, at(Some((temp, 0.5))), &mut scratch)
        .unwrap();
    assert_eq!(held, m.predict_in(&x, at(None), &mut scratch).unwrap());
    let grown = p.bias_variance - held.bias_variance;
    let expected = (r.error.heating_var + r.error.heating_scale_var * p.mean * p.mean)
        * (rate - 0.5)
        * (rate - 0.5);
    assert!(r.error.heating_scale_var * p.mean * p.mean > 1e-3 * expected);
    assert!(
        (grown - expected).abs() < 1e-3 * expected,
        "{grown} {expected}"
    );
    assert_eq!(p.mean, held.mean);
}

#[test]
fn bad_inputs_are_flagged_never_nan() {
    let m = Small::decode(&Reference::small().blob()).unwrap();
    let mut scratch = [0.0f32; 5];
    for x in [
        [f32::NAN, 0.0],
        [20.0, f32::INFINITY],
        [f32::NEG_INFINITY, 0.0],
    ] {
        let p = m.predict(&x, &mut scratch).unwrap();
        assert_eq!(p.status, Status::Fault);
        assert!(p.mean.is_finite() && p.variance().is_finite());
    }
    assert_eq!(m.predict_mean(&[20.0]).status, Status::Fault);
    let out = m.predict(&[70.0, 0.0], &mut scratch).unwrap();
    assert_eq!(out.status, Status::Extrapolating);
    assert!(out.mean.is_finite());
    // Past the trained span's width, still a reading (it was a fault up to format 5).
    let out = m.predict(&[-125.0 + 70.0, 0.0], &mut scratch).unwrap();
    assert_eq!(out.status, Status::Extrapolating);
    assert_eq!(
        m.predict(&[20.0, 0.0], &mut [0.0; 4]),
        Err(PredictError::ScratchTooSmall { needed: 5 })
    );
}
