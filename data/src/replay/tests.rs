use super::*;

/// The firmware-integration example's model.
const GYRO: &[u8] = include_bytes!("../../../firmware-core/doc/gyro.bin");

fn stream(rate: &[f64], step: f64) -> Stream {
    let n = rate.len();
    Stream {
        time_s: (0..n).map(|i| i as f64 * step).collect(),
        temp_c: vec![20.0; n],
        voltage_v: vec![0.0; n],
        rate_dps: rate.to_vec(),
        lines: (2..n as u64 + 2).collect(),
        step_s: step,
        time_issues: vec![],
        handled: vec![],
        history: 0,
        after_s: None,
    }
}

/// `log` switched off for ten minutes before sample `at`, its clock running on.
fn power_cycled(log: &Stream, at: usize) -> Stream {
    let mut cycled = log.clone();
    for t in &mut cycled.time_s[at..] {
        *t += 600.0;
    }
    cycled.time_issues.push(TimeIssue::Gap {
        line: cycled.lines[at],
        step_s: 601.0,
    });
    cycled
}

#[test]
fn scores_follow_their_definitions() {
    // 120 samples at 1 Hz: error +1 in the first minute, −1 in the second, one unscored row.
    let mut rate = vec![0.0; 120];
    rate[5] = f64::NAN;
    let s = stream(&rate, 1.0);
    // σ 1 for the first 30 samples, 0.1 after: bias 0.75 + noise 0.25, and 0.0075 + 0.0025.
    let comp = Compensated {
        rate_dps: (0..120).map(|i| if i < 60 { 1.0 } else { -1.0 }).collect(),
        bias_var: (0..120)
            .map(|i| if i < 30 { 0.75 } else { 0.0075 })
            .collect(),
        noise_var: (0..120)
            .map(|i| if i < 30 { 0.25 } else { 0.0025 })
            .collect(),
        status: vec![Status::Valid; 120],
        error: ErrorModel {
            sample_interval_s: 1.0,
            ..ErrorModel::noise_only(0.25)
        },
    };
    let sc = score(&s, &comp);
    assert_eq!(sc.n, 119);
    assert_eq!(sc.n_unscored, 1);
    assert!((sc.rmse_dps - 1.0).abs() < 1e-12);
    assert!((sc.rmse_60s_dps - 1.0).abs() < 1e-12);
    assert_eq!(sc.n_blocks, 2);
    assert!((sc.coverage_2sigma - 29.0 / 119.0).abs() < 1e-12);
    assert_eq!(sc.sigma_samples.within_2sigma, sc.coverage_2sigma);
    assert!((sc.sigma_samples.within_1sigma - 29.0 / 119.0).abs() < 1e-12);
    // First block: mean bias (29·0.75 + 30·0.0075)/59 and 0.25/59 of noise: σ ≈ 0.61, error 1.
    // Second: 0.0075 + 0.25/60: σ ≈ 0.108, error −1.
    let first = ((29.0 * 0.75 + 30.0 * 0.0075) / 59.0 + 0.25 / 59.0f64).sqrt();
    assert_eq!(sc.sigma_60s.n, 2);
    assert_eq!(sc.sigma_60s.within_2sigma, 0.5);
    assert_eq!(sc.sigma_60s.within_1sigma, 0.0);
    assert!(sc.sigma_60s.median_sigma > 0.5 * first);
    // Every sample inside the trained range: the split holds both blocks, nothing beyond.
    assert_eq!(sc.sigma_60s_in_range, Some(sc.sigma_60s));
    assert_eq!(sc.sigma_60s_beyond, None);
    let line = crate::sigma::describe_by_range(sc.sigma_60s_in_range.as_ref(), None);
    assert!(
        line.contains("inside the trained range 2 at 50% within 2σ") && line.ends_with("none"),
        "{line}"
    );
    // The second minute beyond it: each part scores its own block.
    let beyond = Compensated {
        status: (0..120)
            .map(|i| {
                if i < 60 {
                    Status::Valid
                } else {
                    Status::Extrapolating
                }
            })
            .collect(),
        ..comp.clone()
    };
    let split = score(&s, &beyond);
    assert_eq!(split.sigma_60s, sc.sigma_60s);
    let (inside, beyond) = (
        split.sigma_60s_in_range.unwrap(),
        split.sigma_60s_beyond.unwrap(),
    );
    assert_eq!((inside.n, inside.within_2sigma), (1, 1.0));
    assert!((inside.rmse - 1.0).abs() < 1e-12);
    assert_eq!((beyond.n, beyond.within_2sigma), (1, 0.0));
    assert!((beyond.rmse - 1.0).abs() < 1e-12);
    assert_eq!(split.n_extrapolating, 60);
    let line = crate::sigma::describe_by_range(Some(&inside), Some(&beyond));
    assert!(
        line.contains("inside the trained range 1 at 100% within 2σ")
            && line.ends_with("beyond it 1 at 0% within 2σ, median σ 0.11× the RMS error"),
        "{line}"
    );
    let one = decode_unit(GYRO).unwrap();
    let csv = unit_csv(&one, &[&s], std::slice::from_ref(&comp));
    assert!(
        csv.starts_with("time_s,temp_c,voltage_v,rate_dps,comp_rate_dps,"),
        "{csv}"
    );
    assert!(csv.lines().nth(6).unwrap().starts_with("5,20,0,,"), "{csv}");
    // What the figures leave out, in one line: a fault is not scored, nor a row without a
    // reference.
    let mut faulty = comp.clone();
    faulty.status[7] = Status::Fault;
    faulty.status[8] = Status::Extrapolating;
    assert_eq!(
        score(&s, &faulty).counted(),
        "(118 samples scored, 1 extrapolating; left out: 1 fault, 0 handled, 1 without a \
         reference)"
    );
}

#[test]
fn a_clock_in_milliseconds_read_as_seconds_is_named_as_the_reason_for_degraded() {
    // 1 Hz samples whose time column is in ms, mapped as s: every step is 1,000 "s".
    let s = stream(&[0.0; 300], 1000.0);
    let comp = replay(&decode(GYRO).unwrap(), &s);
    let sc = score(&s, &comp);
    assert!(sc.n_degraded > 250, "{}", sc.n_degraded);
    let why = degraded_reason(&s, &sc).unwrap();
    assert!(
        why.contains("1000 s apart") && why.contains("milliseconds"),
        "{why}"
    );
    assert!(degraded_reason(&stream(&[0.0; 300], 1.0), &sc).is_none());
}

#[test]
fn the_mean_path_gives_the_replays_rates_statuses_and_score_bit_for_bit() {
    // Temperatures from inside the trained range to far beyond it, across a power-on.
    let mut s = stream(&[0.0; 400], 1.0);
    for (i, t) in s.temp_c.iter_mut().enumerate() {
        *t = -60.0 + 0.5 * i as f64;
    }
    let model = decode(GYRO).unwrap();
    let (full, means) = (replay(&model, &s), means(&model, &s));
    assert_eq!(full.rate_dps, means.rate_dps);
    assert_eq!(full.status, means.status);
    assert_eq!(means.rmse_60s_dps(&s), score(&s, &full).rmse_60s_dps);
    assert!(means.excess2.iter().any(|&e| e > 0.0));
    assert!(means.excess2.contains(&0.0));
}

#[test]
fn samples_evaluated_side_by_side_are_those_of_one_at_a_time_bit_for_bit() {
    // Not a whole number of batches or lanes; inside the trained range and far beyond it,
    // with one reading that cannot be true and a power cycle (a 10-minute gap).
    let mut s = stream(&[0.0; 403], 1.0);
    for (i, (t, v)) in s.temp_c.iter_mut().zip(&mut s.voltage_v).enumerate() {
        *t = -60.0 + 0.5 * i as f64;
        *v = (0.1 * i as f64).sin();
    }
    s.temp_c[7] = f64::NAN;
    for t in &mut s.time_s[150..] {
        *t += 600.0;
    }
    s.time_issues.push(TimeIssue::Gap {
        line: s.lines[150],
        step_s: 601.0,
    });
    let model = decode(GYRO).unwrap();
    let mut scratch = vec![0.0f32; model.dims().m];
    let (mut alone, mut mean_path) = (Compensated::default(), Vec::new());
    walk(&s, false, |_, sample, state, _| {
        mean_path.push(model.compensate_mean(sample, &mut state.clone()));
        alone.push(&model.compensate(sample, state, &mut scratch).unwrap());
    });
    let bits = |c: &Compensated, i: usize| {
        (
            c.rate_dps[i].to_bits(),
            c.bias_var[i].to_bits(),
            c.noise_var[i].to_bits(),
            c.status[i],
        )
    };
    let full = replay(&model, &s);
    let unit = replay_unit(&decode_unit(GYRO).unwrap(), &[&s], false);
    let wanted: Vec<bool> = (0..s.len()).map(|i| i % 3 != 0).collect();
    let (means, part) = replay_where(&model, &s, &wanted);
    assert!(alone.status.contains(&Status::Fault));
    assert!(alone.status.contains(&Status::Extrapolating));
    assert_eq!(restarts(&s).iter().filter(|r| **r).count(), 1);
    for (i, (&wanted, (m, excess2))) in wanted.iter().zip(&mean_path).enumerate() {
        assert_eq!(bits(&full, i), bits(&alone, i), "sample {i}");
        assert_eq!(bits(&unit[0], i), bits(&alone, i), "sample {i}");
        let batched = (means.rate_dps[i], means.status[i], means.excess2[i]);
        assert_eq!(
            (batched.0.to_bits(), batched.1, batched.2.to_bits()),
            (m.mean.to_bits(), m.status, excess2.to_bits()),
            "sample {i}"
        );
        if wanted {
            assert_eq!(bits(&part, i), bits(&alone, i), "sample {i}");
        } else {
            assert_eq!((part.rate_dps[i], part.status[i]), (m.mean, m.status));
            assert!(part.bias_var[i].is_nan());
        }
    }
}

#[test]
fn block_means_cancel_white_errors() {
    let rate = vec![0.0; 600];
    let s = stream(&rate, 1.0);
    let comp = Compensated {
        rate_dps: (0..600)
            .map(|i| if i % 2 == 0 { 0.5 } else { -0.5 })
            .collect(),
        bias_var: vec![0.0; 600],
        noise_var: vec![1.0; 600],
        status: vec![Status::Valid; 600],
        error: ErrorModel::noise_only(1.0),
    };
    let sc = score(&s, &comp);
    assert!((sc.rmse_dps - 0.5).abs() < 1e-12);
    assert!(sc.rmse_60s_dps < 1e-12);
}

#[test]
fn a_window_is_replayed_after_its_history_and_written_without_it() {
    // An hour at 1 Hz, cooling from beyond the model's trained range (−26…64 °C) into it; the
    // window is its last half hour. The model's error grows as a random walk since power-on.
    let mut log = stream(&[0.0; 3600], 1.0);
    for (i, t) in log.temp_c.iter_mut().enumerate() {
        *t = 80.0 - 0.02 * i as f64;
    }
    let part = log.window("1800:".parse().unwrap());
    let alone = Stream {
        time_s: log.time_s[1800..].to_vec(),
        temp_c: log.temp_c[1800..].to_vec(),
        voltage_v: log.voltage_v[1800..].to_vec(),
        rate_dps: log.rate_dps[1800..].to_vec(),
        lines: log.lines[1800..].to_vec(),
        ..stream(&[], 1.0)
    };
    let mut blob = GYRO.to_vec();
    let error = ErrorModel {
        walk_var_per_h: 1e-4,
        ..decode(GYRO).unwrap().error_model()
    };
    firmware_core::blob::set_error_model(&mut blob, &error).unwrap();
    let unit = decode_unit(&blob).unwrap();
    // The held-out part of the calibration's own power-on: its time terms count from the
    // window's start, as the trainer fitted them (the hours since the data a model saw).
    let held_out = replay_unit(&unit, &[&part], true);
    let cut = replay_unit(&unit, &[&alone], true);
    for i in 0..1800 {
        assert_eq!(
            held_out[0].bias_var[1800 + i].to_bits(),
            cut[0].bias_var[i].to_bits(),
            "sample {i}"
        );
    }
    // In service they count from the power-on, half an hour before the window.
    let service = replay_unit(&unit, &[&part], false);
    let grown = service[0].bias_var[1800] - replay_unit(&unit, &[&alone], false)[0].bias_var[0];
    assert!((grown - 0.5e-4).abs() < 1e-6, "{grown}");
    // The history is replayed, never scored, counted or written: its first minutes lie beyond
    // the trained range, the window's none.
    let scored = score(&part, &held_out[0]);
    assert_eq!((scored.n, scored.n_unscored), (1800, 0));
    let beyond = |c: &Compensated| {
        c.status
            .iter()
            .filter(|s| **s == Status::Extrapolating)
            .count()
    };
    assert!(beyond(&held_out[0]) > 600, "{}", beyond(&held_out[0]));
    assert_eq!(scored.n_extrapolating, 0);
    let csv = unit_csv(&unit, &[&part], &held_out);
    assert_eq!(csv.lines().count(), 1 + 1800);
    assert!(csv.lines().nth(1).unwrap().starts_with("1800,"));
    // A power cycle in the history (ten minutes off before the window's power-on): the window is
    // still the calibration's own power-on, its time terms counted from its start.
    let cycled = power_cycled(&log, 1000);
    let part = cycled.window("2400:".parse().unwrap());
    assert_eq!(part.history, 1800);
    let after = replay_unit(&unit, &[&part], true);
    assert_eq!(
        after[0].bias_var[1800].to_bits(),
        cut[0].bias_var[0].to_bits()
    );
}

#[test]
fn a_window_before_the_calibrations_data_counts_its_hours_back_from_its_end() {
    // An hour at 1 Hz inside the trained range; the model's error grows as a random walk.
    let log = stream(&[0.0; 3600], 1.0);
    let mut blob = GYRO.to_vec();
    let error = ErrorModel {
        walk_var_per_h: 1e-4,
        turn_on_var: 1e-3,
        ..decode(GYRO).unwrap().error_model()
    };
    firmware_core::blob::set_error_model(&mut blob, &error).unwrap();
    let unit = decode_unit(&blob).unwrap();
    let model = decode(&blob).unwrap();
    // One model's replay and a unit's agree sample for sample.
    let var = |s: &Stream, own: bool| {
        let v = replay_unit(&unit, &[s], own).remove(0).bias_var;
        let one = replay_run(&model, s, own).bias_var;
        assert!(v.iter().zip(&one).all(|(a, b)| a.to_bits() == b.to_bits()));
        v
    };
    // The first half, fitted on the second: its time terms count back from its end, where the
    // data fitted begin; in service, from the power-on.
    let head = log.window(":1800".parse().unwrap());
    assert_eq!(head.after_s, Some(1800.0));
    let held_out = var(&head, true);
    let back = held_out[0] - held_out[1799];
    assert!((back - 1e-4 * 1799.0 / 3600.0).abs() < 1e-7, "{back}");
    let service = var(&head, false);
    assert!((service[1799] - service[0] - 1e-4 * 1799.0 / 3600.0).abs() < 1e-7);
    // A window between the data: from the nearer of its ends.
    let middle = var(&log.window("1200:2400".parse().unwrap()), true);
    assert!(middle[1800] > middle[1200] && middle[1800] > middle[2399]);
    assert!((middle[1200] - middle[2399]).abs() < 1e-7);
    // A power cycle in the first half (ten minutes off): the calibration's power-on is the one
    // the data go on from, the window's last; before it, another power-on's, as in service.
    let cycled = power_cycled(&log, 900);
    let head = cycled.window(":2400".parse().unwrap());
    let (held_out, service) = (var(&head, true), var(&head, false));
    assert!((0..900).all(|i| held_out[i].to_bits() == service[i].to_bits()));
    assert!(
        held_out[900] + 5e-4 < service[900],
        "{} {}",
        held_out[900],
        service[900]
    );
    // Data on both sides, a power cycle inside: the window's first power-on counts forward from
    // its start, its last back from its end.
    let cycled = power_cycled(&log, 1800);
    let both = cycled.window("900:3000".parse().unwrap());
    assert_eq!((both.history, both.after_s), (900, Some(3000.0)));
    let both_ways = var(&both, true);
    let walked = |i: usize, hours: f64| both_ways[i] - both_ways[900] - (1e-4 * hours) as f32;
    assert!(walked(1799, 899.0 / 3600.0).abs() < 1e-7);
    assert!(walked(1800, 600.0 / 3600.0).abs() < 1e-7);
    assert!(walked(2399, 1.0 / 3600.0).abs() < 1e-7);
    // Three power-ons: the middle one is another's, as in service.
    let thrice = power_cycled(&power_cycled(&log, 1200), 2400);
    let window = thrice.window("600:4500".parse().unwrap());
    assert_eq!((window.history, window.after_s), (600, Some(4500.0)));
    let (own, service) = (var(&window, true), var(&window, false));
    assert!((1200..2400).all(|i| own[i].to_bits() == service[i].to_bits()));
    assert!(own[1199] + 5e-4 < service[1199] && own[2400] + 5e-4 < service[2400]);
}

#[test]
fn each_sample_left_out_is_counted_once_and_a_block_goes_where_most_of_it_lies() {
    // Two minutes at 1 Hz, at rest. The first: one row without a reference, a window handled
    // (10…20 s) holding a fault, and a fault with a reference. The second: half its rows
    // without a reference, 20 of the other 30 beyond the trained range.
    let mut rate = vec![0.0; 120];
    rate[5] = f64::NAN;
    for r in &mut rate[60..90] {
        *r = f64::NAN;
    }
    let mut s = stream(&rate, 1.0);
    s.exclude(&["10:20".parse().unwrap()]).unwrap();
    let mut status = vec![Status::Valid; 120];
    status[15] = Status::Fault;
    status[30] = Status::Fault;
    for st in &mut status[90..110] {
        *st = Status::Extrapolating;
    }
    let comp = Compensated {
        rate_dps: vec![0.01; 120],
        bias_var: vec![1e-4; 120],
        noise_var: vec![1e-4; 120],
        status,
        error: ErrorModel {
            sample_interval_s: 1.0,
            ..ErrorModel::noise_only(1e-4)
        },
    };
    let sc = score(&s, &comp);
    assert_eq!(
        (sc.n, sc.n_fault, sc.n_handled, sc.n_unscored),
        (78, 2, 9, 31)
    );
    assert_eq!(sc.n + sc.n_fault + sc.n_handled + sc.n_unscored, 120);
    assert_eq!(sc.n_extrapolating, 20);
    // The first block lies inside the range; the second, 30 rows scored, mostly beyond it.
    assert_eq!(sc.n_blocks, 2);
    assert_eq!(sc.sigma_60s_in_range.map(|c| c.n), Some(1));
    assert_eq!(sc.sigma_60s_beyond.map(|c| c.n), Some(1));
}
