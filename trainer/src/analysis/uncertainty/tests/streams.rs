//! A stream's out-of-sample residuals, as the firmware predicts them.

use super::*;
use crate::analysis::uncertainty::streams::{leg_states, stream_series, tracked};

#[test]
fn a_streams_residuals_are_its_minutes_as_the_firmware_predicts_them() {
    use crate::data::points::Points;
    use crate::models::gp::{GpConfig, GpModel};
    // A table over 0…20 °C at −10…10 °/s, and its blob.
    let (mut t, mut v, mut w, mut g) = (vec![], vec![], vec![], vec![]);
    for k in 0..11 {
        for rate in [-10.0, -5.0, 0.0, 5.0, 10.0] {
            t.push(2.0 * k as f64);
            w.push(rate);
            v.push(0.05 * rate + 1e-3 * 2.0 * k as f64);
            g.push(k.to_string());
        }
    }
    let points = Points::new(t, v, w, g, None, true, None);
    let model = GpModel::fit(points.inputs(), &points.target(), &GpConfig::default()).unwrap();
    let blob = export::to_blob(&model, points.features()).unwrap();
    let fw = fog_data::replay::decode(&blob).unwrap();
    let k = export::temperature_input(fw.features()).unwrap();
    let [lo, hi] = fw.trained_range(k).unwrap();
    // Two minutes at 2 Hz turning at 5 °/s, the gyro reading 5.2: the first at 10 °C, the second
    // at 50 °C, one and a half widths beyond the range.
    let mut stream = at_rest(240, 0.5);
    for i in 0..240 {
        stream.temp_c[i] = if i < 120 { 10.0 } else { 50.0 };
        stream.rate_dps[i] = 5.0;
        stream.voltage_v[i] = 0.26 + 1e-3 * stream.temp_c[i];
    }
    let hours: Vec<f64> = (0..240).map(|i| 1.0 + i as f64 / 7200.0).collect();
    let series = |var: f64| {
        let noise = SampleNoise {
            var,
            interval_s: 0.5,
        };
        stream_series(ResidualSource::Stream, &blob, &stream, &hours, noise).unwrap()
    };
    let (noisy, quiet) = (series(6.0), series(0.0));
    let [inside, beyond] = noisy.residuals.as_slice() else {
        panic!("{:?}", noisy.residuals);
    };
    // e(x)² is the firmware's: 0 inside, the temperature's distance in widths, squared, beyond.
    assert_eq!(inside.excess2, 0.0);
    let width = f64::from(hi - lo);
    let e2 = ((50.0 - f64::from(hi)) / width).powi(2);
    assert!(
        e2 > 2.0 && (beyond.excess2 / e2 - 1.0).abs() < 1e-4,
        "{} {e2}",
        beyond.excess2
    );
    // Each minute's error is the firmware's mean less the reference, its hours their mean, and
    // its base variance the latent one and the noise of a mean over its 60 s: 6 × 0.5 / 60.
    let predicted = fog_data::replay::means(&fw, &stream);
    for ((r, q), part) in noisy
        .residuals
        .iter()
        .zip(&quiet.residuals)
        .zip([0..120, 120..240])
    {
        let n = part.len() as f64;
        let error = part
            .clone()
            .map(|i| f64::from(predicted.rate_dps[i]) - 5.0)
            .sum::<f64>()
            / n;
        assert!(
            (r.error - error).abs() <= 1e-6 * error.abs(),
            "{} {error}",
            r.error
        );
        // The fixture's own check: the gyro reads 0.2 °/s high.
        assert!((error - 0.2).abs() < 0.02, "{error}");
        let h = part.map(|i| hours[i]).sum::<f64>() / n;
        assert!((r.hours - h).abs() < 1e-12);
        assert!(
            (r.base_var - q.base_var - 0.05).abs() < 1e-9,
            "{} {}",
            r.base_var,
            q.base_var
        );
        assert_eq!(r.output, 5.0);
    }
}

/// A log of two power-ons, read once with a clock that ran on through the power-off (a gap) and
/// once with one that started again (time jumps back), as every replay reads them
/// (`fog_data::replay::restarts`): the gyro is powered on again at the gap, and the
/// heating/cooling state is kept across it (a leg persists through a power-off as through a
/// soak); where the clock started again, the state starts afresh, as after a reset. No sample is
/// refused. The second power-on starts where the first stopped heating and cools from there.
#[test]
fn the_heating_cooling_state_crosses_a_power_off_as_the_replay_reads_it() {
    let n = 1200;
    let temp: Vec<f64> = (0..2 * n)
        .map(|i| {
            let k = (i % n) as f64 / n as f64;
            if i < n {
                20.0 + 10.0 * k
            } else {
                30.0 - 10.0 * k
            }
        })
        .collect();
    let states = |time: Vec<f64>| {
        let stream =
            Stream::from_columns(time, temp.clone(), vec![0.0; 2 * n], vec![0.0; 2 * n]).unwrap();
        let states = leg_states(&stream);
        assert!(states.iter().all(Option::is_some), "a sample refused");
        let on = tracked(&stream, firmware_core::FeatureState::time_on_s);
        (states.into_iter().flatten().collect::<Vec<f32>>(), on)
    };
    let (ran_on, on) = states((0..2 * n).map(|i| (i + (i / n) * 3600) as f64).collect());
    assert_eq!(on[n], Some(0.0), "powered on again at the gap");
    assert_eq!(on[n - 1], Some((n - 1) as f64));
    assert_eq!(ran_on[n - 1], 1.0, "heated");
    assert_eq!(ran_on[n], 1.0, "the play kept across the power-off");
    assert_eq!(ran_on[2 * n - 1], -1.0, "cooled");
    let (again, _) = states((0..2 * n).map(|i| (i % n) as f64).collect());
    assert_eq!(again[..n], ran_on[..n]);
    assert_eq!(again[n], 0.0, "started afresh");
    assert_eq!(again[2 * n - 1], -1.0, "cooled");
}
