//! The heating term: the band of heating rates a training stream held, as the firmware reads
//! them, and the model error a stated sensor lag puts outside it.

use super::*;
use crate::analysis::uncertainty::heating::{ASSUMED_LAG_S, HeatingBand, rates, table_rates};
use crate::data::points::Points;

/// A warm-up read at 1 Hz: from 10 °C, heating at 2 °C/min and slowing by 0.1 °C/min each
/// minute (a rate that falls as the temperature rises), for 20 minutes, then a soak.
fn warm_up() -> Stream {
    let n = 1800;
    let mut temp = Vec::with_capacity(n);
    let mut t = 10.0;
    for i in 0..n {
        temp.push(t);
        let minute = i as f64 / 60.0;
        t += (2.0 - 0.1 * minute).max(0.0) / 60.0;
    }
    Stream::from_columns(
        (0..n).map(|i| i as f64).collect(),
        temp,
        vec![0.0; n],
        vec![0.0; n],
    )
    .unwrap()
}

#[test]
fn the_band_is_the_rates_the_training_held_at_each_temperature() {
    let stream = warm_up();
    let samples = rates(&stream);
    // The firmware's filter: at power-on the rate starts from rest, and is read from 6 minutes
    // on, when it follows the rate two minutes (its time constant) late: at minute 10, minute
    // 8's 1.2 °C/min.
    assert_eq!(samples.len(), stream.len() - 360);
    assert!((samples[240].1 - 1.2).abs() < 0.02, "{:?}", samples[240]);
    let band = HeatingBand::of(&samples).unwrap();
    // Heating slows as it warms: the line falls with the temperature.
    assert!(band.rate_per_c < 0.0, "{band:?}");
    // Read over the temperatures it held, from minute 6 on.
    let last = samples[samples.len() - 1].0;
    assert_eq!((band.temp_min_c, band.temp_max_c), (samples[0].0, last));
    assert!((last - stream.temp_c[1799]).abs() < 1e-5);
    // Every rate but the 0.5 % at each end lies inside it.
    let about = |(t, r): (f64, f64)| r - (band.rate_at_0c + band.rate_per_c * t);
    let outside = samples
        .iter()
        .filter(|s| !(band.min..=band.max).contains(&about(**s)))
        .count();
    assert!(outside <= samples.len() / 100, "{outside}");
    // At one temperature, a flat line: rates say nothing of a change with it.
    let soak: Vec<(f64, f64)> = (0..100).map(|i| (25.0, 0.01 * (i % 3) as f64)).collect();
    let flat = HeatingBand::of(&soak).unwrap();
    assert_eq!(flat.rate_per_c, 0.0);
    let (lo, hi) = (flat.rate_at_0c + flat.min, flat.rate_at_0c + flat.max);
    assert!(
        (lo + 0.05).abs() < 1e-12 && (hi - 0.07).abs() < 1e-12,
        "{flat:?}"
    );
    assert_eq!(HeatingBand::of(&[]), None);
    // A table's few soaks beside the warm-up's thousands of samples, at the warm-up's
    // temperatures: taken as one set, they fall into its tail and out of the band; as parts,
    // each one's quantiles count, and every soak lies inside.
    let soaks: Vec<(f64, f64)> = (0..6).map(|i| (12.0 + 4.0 * f64::from(i), 0.0)).collect();
    let inside = |band: &HeatingBand| {
        soaks
            .iter()
            .all(|s| (band.min..=band.max).contains(&about_of(band, *s)))
    };
    let pooled: Vec<(f64, f64)> = samples.iter().chain(&soaks).copied().collect();
    assert!(!inside(&HeatingBand::of(&pooled).unwrap()));
    let parts = HeatingBand::of_parts(&[&samples, &soaks]).unwrap();
    assert!(inside(&parts), "{parts:?}");
    // An empty part counts for nothing; no samples at all, no band.
    assert_eq!(
        HeatingBand::of_parts(&[&samples, &[]]),
        HeatingBand::of(&samples)
    );
    assert_eq!(HeatingBand::of_parts(&[&[], &[]]), None);
}

/// A rate's distance from `band`'s line at its temperature, °C/min.
fn about_of(band: &HeatingBand, (t, r): (f64, f64)) -> f64 {
    r - (band.rate_at_0c + band.rate_per_c * t)
}

#[test]
fn a_sensor_lag_stated_or_assumed_sets_the_term_outside_the_band() {
    let noise = SampleNoise {
        var: 1e-6,
        interval_s: 1.0,
    };
    let stream = warm_up();
    let mut c = calibrate(&[], noise, Prior::NONE);
    // A lag stated before the band is known waits for it: no term, said as not used; then
    // the band comes and the stated lag sets the term, none assumed. A model that changes
    // 0.02 °/s per °C: 90 s of lag are 1.5 min, 0.03 °/s per °C/min.
    c.set_sensor_lag(Some(90.0));
    assert_eq!(c.error_model.heating_var, 0.0);
    assert!(c.skipped_lines(true).join("").contains("not used"));
    c.set_heating(&rates(&stream), (0.02, 0.0));
    assert!((c.heating.std_per_c_per_min - 0.03).abs() < 1e-12);
    assert_eq!(c.heating.sensor_lag_s, Some(90.0));
    assert!(!c.assumed.contains(&"heating"));
    c.set_sensor_lag(None);
    let band = c.heating.band.unwrap();
    assert_eq!(c.error_model.heating_rate_min, band.min as f32);
    assert_eq!(c.error_model.heating_rate_per_c, band.rate_per_c as f32);
    // None stated: 30 s assumed, and said, whichever came first.
    assert!((c.heating.std_per_c_per_min - 0.01).abs() < 1e-12);
    assert_eq!(c.heating.sensor_lag_s, Some(ASSUMED_LAG_S));
    assert!(c.assumed.contains(&"heating"));
    assert!(c.skipped_lines(true).is_empty());
    let words = c.describe("°/s");
    assert!(words.contains("assumed: a sensor lag of 30 s") && words.contains("--sensor-lag"));
    c.set_sensor_lag(Some(90.0));
    assert!(!c.assumed.contains(&"heating"));
    assert!((c.heating.std_per_c_per_min - 0.03).abs() < 1e-12);
    assert_eq!(c.error_model.heating_var, (0.03f64 * 0.03) as f32);
    assert_eq!(c.error_model.heating_scale_var, 0.0);
    assert!(c.skipped_lines(true).is_empty());
    let words = c.describe("°/s");
    assert!(words.contains("the stated sensor lag, 90 s"), "{words}");
    // At 25 °C heating 1 °C/min faster than the band allows: 0.03 °/s more, in quadrature.
    let e = c.error_model;
    let top = e.heating_rate_at_0c + e.heating_rate_per_c * 25.0 + e.heating_rate_max;
    let at = |rate| Conditions {
        heating: Some((25.0, rate)),
        ..Conditions::at_hours(0.0)
    };
    let grown = e.model_error(0.0, 0.0, at(top + 1.0)) - e.model_error(0.0, 0.0, at(top));
    assert!((f64::from(grown) / 9e-4 - 1.0).abs() < 1e-4, "{grown}");
    // A model whose change per °C grows with the output, 100 ppm of it per °C: 150 ppm of the
    // output per °C/min beyond the band at 90 s.
    c.set_heating(&rates(&stream), (0.02, 100e-6));
    assert!((c.heating.scale_ppm_per_c_per_min - 150.0).abs() < 1e-9);
    assert_eq!(c.error_model.heating_scale_var, (150e-6f64 * 150e-6) as f32);
    let y = 50.0f32;
    let scaled = e.model_error(0.0, y, at(top + 1.0)) - e.model_error(0.0, y, at(top));
    assert!((f64::from(scaled) / 9e-4 - 1.0).abs() < 1e-4, "{scaled}");
    let e = c.error_model;
    let scaled = e.model_error(0.0, y, at(top + 1.0)) - e.model_error(0.0, y, at(top));
    let expected = 9e-4 + (150e-6 * 50.0f64).powi(2);
    assert!(
        (f64::from(scaled) / expected - 1.0).abs() < 1e-4,
        "{scaled}"
    );
    // Without the training's rates (power-ons too short) a stated lag has nothing to be outside
    // of: no term, and the line says the lag is not used.
    let mut short = calibrate(&[], noise, Prior::NONE);
    short.set_sensor_lag(Some(90.0));
    assert_eq!(short.error_model.heating_var, 0.0);
    let line = short.skipped_lines(true).join("\n");
    assert!(line.contains("not used"), "{line}");
    short.set_sensor_lag(None);
    assert!(short.assumed.is_empty() && short.heating.sensor_lag_s.is_none());
    let line = short.skipped_lines(true).join("\n");
    assert!(line.contains("are not known"), "{line}");
    // A stated 0: no term, said.
    c.set_sensor_lag(Some(0.0));
    assert_eq!(c.error_model.heating_var, 0.0);
    let line = c.skipped_lines(true).join("\n");
    assert!(line.contains("is 0"), "{line}");
}

/// A log of two power-ons, the second 12 °C colder than the first ended, its clock started
/// again: the heating rate starts from rest at each power-on, as the firmware's replay has it,
/// and no sample of a power-on's first 6 minutes is read into the band.
#[test]
fn each_power_on_of_a_log_starts_the_rate_again_as_the_replay_does() {
    let n = 1200;
    let time: Vec<f64> = (0..2 * n).map(|i| (i % n) as f64).collect();
    let temp: Vec<f64> = (0..2 * n)
        .map(|i| {
            let (start, k) = if i < n { (30.0, i) } else { (20.0, i - n) };
            start + k as f64 / 600.0
        })
        .collect();
    let stream = Stream::from_columns(time, temp, vec![0.0; 2 * n], vec![0.0; 2 * n]).unwrap();
    let samples = rates(&stream);
    assert_eq!(samples.len(), 2 * (n - 360));
    // Every rate read is the ramp's 0.1 °C/min, settled: none carries the 10 °C step between
    // the power-ons.
    assert!(
        samples.iter().all(|(_, r)| (r - 0.1).abs() < 0.01),
        "{:?}",
        samples.iter().map(|(_, r)| *r).fold(f64::NAN, f64::max)
    );
}

/// A rate table's points at `temp_c`, recorded at `time_s` where given.
fn table(temp_c: &[f64], time_s: Option<Vec<f64>>) -> Points {
    let n = temp_c.len();
    let group = vec!["a".to_owned(); n];
    Points::new(
        temp_c.to_vec(),
        vec![0.4; n],
        vec![0.0; n],
        group,
        None,
        true,
        time_s,
    )
}

#[test]
fn a_tables_points_state_their_rates_as_soaks_without_their_times() {
    // Two plateaus of three points 3 minutes apart, the chamber stepping 20 °C between them in 6
    // minutes: each plateau's edge reads its plateau (0), not the step (3.3 °C/min).
    let plateaus = [10.0, 10.0, 10.0, 30.0, 30.0, 30.0];
    let times = vec![0.0, 180.0, 360.0, 720.0, 900.0, 1080.0];
    let read = table_rates(&table(&plateaus, Some(times)));
    assert_eq!(read.len(), 6);
    assert!(read.iter().all(|&(_, r)| r == 0.0), "{read:?}");
    // One row per plateau, half an hour apart: each a soak, not the ramps between them.
    let one_each = table(&[10.0, 30.0, 50.0], Some(vec![0.0, 1800.0, 3600.0]));
    assert!(table_rates(&one_each).iter().all(|&(_, r)| r == 0.0));
    // A turntable that drifts 1.25 °C every 5 minutes reads 0.25 °C/min at every point.
    let drift: Vec<f64> = (0..6).map(|i| 40.0 + 1.25 * f64::from(i)).collect();
    let every_five_minutes = (0..6).map(|i| 300.0 * f64::from(i)).collect();
    let read = table_rates(&table(&drift, Some(every_five_minutes)));
    assert!(
        read.iter().all(|&(_, r)| (r - 0.25).abs() < 1e-12),
        "{read:?}"
    );
    // Rows 20 s apart heating 0.1 °C/min, read by a sensor of 0.0625 °C steps: two rows in a
    // row read a step as 0.19 °C/min or none; rows two minutes apart read 0.09–0.13.
    let quantized: Vec<f64> = (0..60)
        .map(|i| ((20.0 + f64::from(i) / 30.0) / 0.0625).floor() * 0.0625)
        .collect();
    let rows = (0..60).map(|i| 20.0 * f64::from(i)).collect();
    let read = table_rates(&table(&quantized, Some(rows)));
    assert_eq!(read.len(), 60);
    assert!(
        read.iter().all(|&(_, r)| (r - 0.1).abs() < 0.04),
        "{read:?}"
    );
    // A run's rows read no other run's: a drifting run, then a run of one row 27.5 °C warmer
    // 5 minutes later, which reads as a soak (without the runs told apart, 5.5 °C/min).
    let mut runs = table(
        &[10.0, 11.25, 12.5, 40.0],
        Some(vec![0.0, 300.0, 600.0, 900.0]),
    );
    runs.run = vec![0, 0, 0, 1];
    let read = table_rates(&runs);
    assert!(
        read[..3].iter().all(|&(_, r)| (r - 0.25).abs() < 1e-12),
        "{read:?}"
    );
    assert_eq!(read[3].1, 0.0, "{read:?}");
    // Without times, soaks: the band is 0 ± its margin, and the σ line says it was assumed.
    let points = table(&drift, None);
    assert!(table_rates(&points).iter().all(|&(_, r)| r == 0.0));
    let noise = SampleNoise {
        var: 1e-6,
        interval_s: 0.0,
    };
    let mut c = calibrate(&[], noise, Prior::NONE);
    c.set_fitted_heating(&[&table_rates(&points)], (0.02, 0.0), true);
    let band = c.heating.band.unwrap();
    assert_eq!((band.rate_at_0c, band.rate_per_c), (0.0, 0.0));
    assert!(
        band.min < 0.0 && band.max > 0.0 && band.max < 0.1,
        "{band:?}"
    );
    assert!(c.heating.soaks_assumed && c.assumed.contains(&"heating"));
    let words = c.describe("°/s");
    assert!(words.contains("taken as soaks"), "{words}");
    // A stream's band read after it (a table's model beside a log) is the log's own.
    c.set_heating(&rates(&warm_up()), (0.02, 0.0));
    assert!(!c.heating.soaks_assumed);
    assert!(!c.describe("°/s").contains("taken as soaks"));
}

/// What a fit on a table, on logs pooled, or on both states it was fitted at
/// ([`crate::analysis::uncertainty::tables::state_fitted_conditions`]): a timed table's rates
/// (not soaks), an untimed one's soaks (said), the logs' rates and legs, and no legs where a
/// table's rows are among the points (a soak's state is not known).
#[test]
fn a_fit_states_the_rates_and_legs_of_the_table_and_logs_it_holds() {
    use crate::analysis::uncertainty::tables::state_fitted_conditions;
    use crate::models::gp::{GpConfig, GpModel};
    // A turntable drifting 0.25 °C/min over 10…23.75 °C, a row a minute at −10…10 °/s.
    let (mut t, mut v, mut w, mut g, mut s) = (vec![], vec![], vec![], vec![], vec![]);
    for minute in 0..55 {
        let temp = 10.0 + 0.25 * f64::from(minute);
        let rate = [-10.0, -5.0, 0.0, 5.0, 10.0][minute as usize % 5];
        t.push(temp);
        w.push(rate);
        v.push(0.05 * rate + 1e-3 * temp);
        g.push((minute / 5).to_string());
        s.push(60.0 * f64::from(minute));
    }
    let timed = Points::new(t, v, w, g, None, true, Some(s));
    let model = GpModel::fit(timed.inputs(), &timed.target(), &GpConfig::default()).unwrap();
    let blob = export::to_blob(&model, timed.features()).unwrap();
    let fw = fog_data::replay::decode(&blob).unwrap();
    let noise = SampleNoise {
        var: 1e-6,
        interval_s: 1.0,
    };
    let stated = |points: &Points, logs: &[&Stream]| {
        let mut c = calibrate(&[], noise, Prior::NONE);
        state_fitted_conditions(&mut c, (points, &model, &*fw), logs);
        c
    };
    // The rates the band holds at a temperature, °C/min.
    let rates_at = |c: &Calibration, t: f64| {
        let b = c.heating.band.unwrap();
        let line = b.rate_at_0c + b.rate_per_c * t;
        (line + b.min, line + b.max)
    };
    // The table alone, with its times: its drift, no soaks; without them, soaks, said.
    let c = stated(&timed, &[]);
    assert!(!c.heating.soaks_assumed, "{:?}", c.heating);
    assert!(rates_at(&c, 15.0).0 > 0.1, "{:?}", c.heating);
    assert!(c.legs_trained.is_none());
    let mut untimed = timed.clone();
    untimed.time_s = None;
    let c = stated(&untimed, &[]);
    assert!(c.heating.soaks_assumed, "{:?}", c.heating);
    assert!(rates_at(&c, 15.0).0 < 0.0, "{:?}", c.heating);
    // Points that are a log's alone (run 0, the log given): its rates, near 1.5 °C/min where it
    // is cold, and its legs (heating only).
    let log = warm_up();
    let c = stated(&untimed, &[&log]);
    assert!(!c.heating.soaks_assumed, "{:?}", c.heating);
    assert!(rates_at(&c, 20.0).1 > 1.0, "{:?}", c.heating);
    assert!(
        c.legs_trained.is_some_and(|(lo, _)| lo >= 0.0),
        "{:?}",
        c.legs_trained
    );
    // The table's rows (run 0) pooled with the log's points (run 1): the soaks and the log's
    // rates in one band, and no legs.
    let mut pooled = untimed.clone();
    pooled.run[50..].iter_mut().for_each(|r| *r = 1);
    let c = stated(&pooled, &[&log]);
    let (lo, hi) = rates_at(&c, 20.0);
    assert!(
        c.heating.soaks_assumed && lo < 0.0 && hi > 1.0,
        "{:?}",
        c.heating
    );
    assert!(c.legs_trained.is_none());
}
