use super::*;

fn at(time_s: f64, temp_c: f32) -> Sample {
    Sample {
        time_s,
        temp_c,
        output: -0.25,
    }
}

#[test]
fn inputs_follow_the_feature_order() {
    let mut out = [0.0f32; 3];
    let mut state = FeatureState::default();
    let features = [Feature::Voltage, Feature::Temperature];
    assert_eq!(
        compute(&features, &at(3.0, 21.5), &mut state, &mut out),
        Status::Valid
    );
    assert_eq!(out, [-0.25, 21.5, 0.0]);
    assert_eq!(
        compute(&features, &at(3.0, 21.5), &mut state, &mut out[..1]),
        Status::Fault
    );
}

/// Runs a 1 Hz ramp of `rate` °C/min from 20 °C for `n` samples; returns the last inputs.
fn ramp(features: &[Feature], rate: f32, n: u32) -> [f32; 4] {
    let mut state = FeatureState::default();
    let mut out = [0.0f32; 4];
    for k in 0..n {
        let s = at(100.0 + f64::from(k), 20.0 + rate * k as f32 / 60.0);
        assert_ne!(compute(features, &s, &mut state, &mut out), Status::Fault);
    }
    out
}

#[test]
fn the_leg_follows_heating_and_cooling_whatever_the_inputs() {
    let mut state = FeatureState::default();
    let mut out = [0.0f32; 1];
    assert_eq!(state.leg(), 0.0);
    let mut run = |state: &mut FeatureState, from: u32, temps: &[f32]| {
        for (k, t) in temps.iter().enumerate() {
            let s = at(f64::from(from) + k as f64, *t);
            assert_eq!(
                compute(&[Feature::Voltage], &s, state, &mut out),
                Status::Valid
            );
        }
    };
    run(&mut state, 0, &[20.0, 20.5, 21.0, 22.0, 23.0]);
    assert_eq!(state.leg(), 1.0);
    // A turn: half the play's width back is half-way, its full width a cooling leg.
    run(&mut state, 5, &[22.5]);
    assert_eq!(state.leg(), 0.5);
    run(&mut state, 6, &[21.5, 21.0]);
    assert_eq!(state.leg(), -1.0);
    // A soak keeps it.
    run(&mut state, 8, &[21.0; 20]);
    assert_eq!(state.leg(), -1.0);
    // Kept through a power cycle, as the play of the ThermalState input.
    state.power_on();
    run(&mut state, 100, &[21.0]);
    assert_eq!(state.leg(), -1.0);
}

#[test]
fn the_heating_rate_is_a_temperature_rate_whatever_the_inputs_and_starts_again_at_power_on() {
    let features = [Feature::TemperatureRate {
        tau_s: HEATING_TAU_S,
    }];
    let (mut state, mut rate) = (FeatureState::default(), FeatureState::default());
    assert_eq!((state.heating_rate(), state.heating()), (0.0, None));
    let (mut none, mut out) = ([0.0f32; 1], [0.0f32; 1]);
    let mut run = |state: &mut FeatureState, rate: &mut FeatureState, from: u32, n: u32| {
        for k in from..from + n {
            let s = at(f64::from(k), 20.0 + 1.5 * k as f32 / 60.0);
            assert_ne!(
                compute(&[Feature::Voltage], &s, state, &mut none),
                Status::Fault
            );
            assert_ne!(compute(&features, &s, rate, &mut out), Status::Fault);
            // The same filter as the model's input of that time constant, bit for bit, read into
            // the model error once it has settled after the power-on.
            assert_eq!(state.heating_rate(), out[0]);
            let settled = state.time_on_s() >= HEATING_SETTLE_S;
            assert_eq!(state.heating(), settled.then_some((s.temp_c, out[0])));
        }
    };
    run(&mut state, &mut rate, 0, 900);
    assert!(state.heating().is_some());
    assert!(
        (state.heating_rate() - 1.5).abs() < 0.01,
        "{}",
        state.heating_rate()
    );
    // A fault leaves it as it was.
    let before = state.heating_rate();
    let bad = at(900.0, f32::NAN);
    assert_eq!(compute(&[], &bad, &mut state, &mut []), Status::Fault);
    assert_eq!(state.heating_rate(), before);
    // A power-on with the state kept: from rest again, as the input.
    state.power_on();
    rate.power_on();
    run(&mut state, &mut rate, 1000, 1);
    assert_eq!((state.heating_rate(), state.heating()), (0.0, None));
}

#[test]
fn temperature_rate_settles_on_the_ramp_rate() {
    let out = ramp(&[Feature::TemperatureRate { tau_s: 60.0 }], 0.8, 1200);
    // The 1 s steps lag the continuous filter by half a step: 0.8·(1 − 0.5/60).
    assert!((out[0] - 0.8 * (1.0 - 0.5 / 60.0)).abs() < 1e-3, "{out:?}");
    // Started at rest.
    let out = ramp(&[Feature::TemperatureRate { tau_s: 60.0 }], 0.8, 1);
    assert_eq!(out[0], 0.0);
}

#[test]
fn coil_estimate_trails_a_ramp_by_its_lag() {
    let out = ramp(
        &[
            Feature::CoilTemperature { tau_s: 300.0 },
            Feature::Temperature,
        ],
        1.0,
        3600,
    );
    // 1 °C/min for 5 min of lag: 5 °C behind.
    assert!((out[1] - out[0] - 5.0).abs() < 0.01, "{out:?}");
}

#[test]
fn time_features_count_from_the_first_sample() {
    let f = [Feature::PowerOnDecay { tau_s: 600.0 }, Feature::TimeOn];
    let out = ramp(&f, 0.0, 1801);
    assert!((out[0] - (-3.0f32).exp()).abs() < 1e-6, "{out:?}");
    assert!((out[1] - 0.5).abs() < 1e-6);
}

#[test]
fn thermal_state_remembers_the_last_excursion_through_a_soak() {
    let f = [Feature::ThermalState { width_c: 2.0 }];
    let mut state = FeatureState::default();
    let mut out = [0.0f32; 1];
    let mut feed = |time: f64, temp: f32, out: &mut [f32; 1]| {
        assert_ne!(compute(&f, &at(time, temp), &mut state, out), Status::Fault);
    };
    feed(0.0, 20.0, &mut out);
    assert_eq!(out[0], 0.0);
    feed(1.0, 30.0, &mut out);
    assert_eq!(out[0], 1.0);
    feed(5000.0, 30.0, &mut out);
    assert_eq!(out[0], 1.0, "heated state kept through a soak");
    feed(5001.0, 29.0, &mut out);
    assert_eq!(out[0], 0.5);
    feed(5002.0, 10.0, &mut out);
    assert_eq!(out[0], -1.0);
}

#[test]
fn reset_makes_the_next_sample_a_power_on() {
    let f = [Feature::TimeOn, Feature::TemperatureRate { tau_s: 30.0 }];
    let mut state = FeatureState::default();
    let mut out = [0.0f32; 2];
    assert_eq!(
        compute(&f, &at(0.0, 20.0), &mut state, &mut out),
        Status::Valid
    );
    // An hour without samples is a time jump.
    assert_eq!(
        compute(&f, &at(3600.0, 25.0), &mut state, &mut out),
        Status::Degraded
    );
    assert_eq!(out[0], 1.0);
    state.reset();
    assert_eq!(
        compute(&f, &at(7200.0, 25.0), &mut state, &mut out),
        Status::Valid
    );
    assert_eq!(out, [0.0, 0.0]);
}

/// An hour of heating at 1 °C/min from 20 °C at 1 Hz through `f`: the state at its end.
fn heated(f: &[Feature]) -> FeatureState {
    let mut state = FeatureState::default();
    let mut out = [0.0f32; 3];
    for k in 0..=3600 {
        let s = at(f64::from(k), 20.0 + k as f32 / 60.0);
        assert_eq!(compute(f, &s, &mut state, &mut out), Status::Valid);
    }
    state
}

const KEPT: [Feature; 3] = [
    Feature::CoilTemperature { tau_s: 600.0 },
    Feature::TimeOn,
    Feature::ThermalState { width_c: 1.0 },
];

/// The exact answer of [`KEPT`]'s 600 s lag, from its estimate in `heated` (80 °C at 3600 s),
/// after a straight line to `t1` over `dt_s`.
fn lag_across(heated: &FeatureState, dt_s: f64, t1: f64) -> f64 {
    let mut last = [0.0f32; 3];
    // The last sample again: no time passes.
    assert_eq!(
        compute(&KEPT, &at(3600.0, 80.0), &mut heated.clone(), &mut last),
        Status::Valid
    );
    let (tau, t0) = (600.0, 80.0);
    let e = (-dt_s / tau).exp();
    t1 - (t1 - t0) * tau / dt_s * (1.0 - e) + (f64::from(last[0]) - t0) * e
}

#[test]
fn a_kept_state_crosses_a_power_off_along_a_straight_line() {
    let state = heated(&KEPT);
    let mut out = [0.0f32; 3];
    // Off for 20 minutes; back on 5 °C cooler than the last reading (80 °C).
    let back = at(3600.0 + 1200.0, 75.0);
    let mut kept = state.clone();
    kept.power_on();
    assert_eq!(compute(&KEPT, &back, &mut kept, &mut out), Status::Degraded);
    assert_eq!(out[1], 0.0, "time since power-on starts again");
    // From the coil 10 °C (less the half-step lag) behind the ramp.
    let exact = lag_across(&state, 1200.0, 75.0);
    assert!(
        (f64::from(out[0]) - exact).abs() < 1e-3,
        "{out:?} against {exact}"
    );
    assert!(
        out[0] > 75.0,
        "the coil kept warming towards the sensor, then passed it"
    );
    assert_eq!(out[2], -1.0, "5 °C of cooling moved the play");
    // Degraded for three lags, then valid.
    let statuses: std::vec::Vec<Status> = (1..=1900)
        .map(|k| {
            let s = at(4800.0 + f64::from(k), 75.0 + k as f32 * 1e-3);
            compute(&KEPT, &s, &mut kept, &mut out)
        })
        .collect();
    assert!(all(&statuses, 0, 1799, Status::Degraded));
    assert!(all(&statuses, 1799, 1900, Status::Valid));
    // A reset state starts the coil at the sensor and the play centred.
    let mut cold = state;
    cold.reset();
    assert_eq!(compute(&KEPT, &back, &mut cold, &mut out), Status::Valid);
    assert_eq!(out, [75.0, 0.0, 0.0]);
}

#[test]
fn lost_samples_are_crossed_along_a_straight_line() {
    let mut state = heated(&KEPT);
    let exact = lag_across(&state, 600.0, 70.0);
    let mut out = [0.0f32; 3];
    // Ten minutes lost, no power-off: 80 → 70 °C.
    assert_eq!(
        compute(&KEPT, &at(4200.0, 70.0), &mut state, &mut out),
        Status::Degraded
    );
    assert!(
        (f64::from(out[0]) - exact).abs() < 1e-3,
        "{out:?} against {exact}"
    );
    assert!(
        (out[1] - 4200.0 / 3600.0).abs() < 1e-6,
        "no power-on: t_on runs on"
    );
}

#[test]
fn the_temperature_rate_starts_again_from_rest_at_a_power_on() {
    let f = [Feature::TemperatureRate { tau_s: 60.0 }];
    let mut state = heated(&f);
    state.power_on();
    let mut out = [0.0f32; 1];
    assert_eq!(
        compute(&f, &at(4800.0, 75.0), &mut state, &mut out),
        Status::Degraded
    );
    assert_eq!(out[0], 0.0);
}

#[test]
fn a_clock_that_stopped_while_off_starts_the_state_again_and_says_so() {
    let mut kept = heated(&KEPT);
    kept.power_on();
    let mut out = [0.0f32; 3];
    // A time since power-on passed after a power-on with the state kept: it went back.
    assert_eq!(
        compute(&KEPT, &at(12.0, 30.0), &mut kept, &mut out),
        Status::Degraded
    );
    assert_eq!(out, [30.0, 0.0, 0.0]);
    // A power-on with no time off at all says the same.
    let mut same = heated(&KEPT);
    let last = same.times.unwrap().1;
    same.power_on();
    assert_eq!(
        compute(&KEPT, &at(last, 30.0), &mut same, &mut out),
        Status::Degraded
    );
    // Degraded while the restarted filters settle (three of the slowest τ), then valid.
    let settle = settle_s(&KEPT);
    let mut last = Status::Degraded;
    let mut t = 12.0;
    while t < 12.0 + settle + 2.0 {
        t += 1.0;
        // A reading that moves, as a real sensor's does (a fixed one is a stuck sensor).
        last = compute(&KEPT, &at(t, 30.0 + 1e-3 * t as f32), &mut kept, &mut out);
        if t < 12.0 + settle - 1.0 {
            assert_eq!(last, Status::Degraded, "{t}");
        }
    }
    assert_eq!(last, Status::Valid);
}

#[test]
fn the_calibration_run_stays_marked_where_its_power_on_starts_the_state_again() {
    let mut state = FeatureState::default();
    let mut out = [0.0f32; 3];
    for t in [0.0, 10.0] {
        assert_eq!(
            compute(&KEPT, &at(t, 30.0), &mut state, &mut out),
            Status::Valid
        );
    }
    state.power_on();
    state.calibration_run();
    // A clock that did not run through the power-off: the state starts again.
    assert_eq!(
        compute(&KEPT, &at(5.0, 30.0), &mut state, &mut out),
        Status::Degraded
    );
    assert!(state.in_calibration_run());
}

#[test]
fn a_power_on_with_the_state_kept_ends_neither_settling_nor_a_stuck_reading() {
    let coil = [Feature::CoilTemperature { tau_s: 60.0 }];
    let mut out = [0.0f32; 3];
    // A time jump at 4000 s: degraded for three τ (180 s); a power cycle of 19 s at 4001 s,
    // under a jump, leaves 160 s of it.
    let mut state = FeatureState::default();
    for t in 0..=100 {
        let reading = at(f64::from(t), 20.0 + 0.01 * t as f32);
        assert_ne!(
            compute(&coil, &reading, &mut state, &mut out),
            Status::Fault
        );
    }
    assert_eq!(
        compute(&coil, &at(4000.0, 22.0), &mut state, &mut out),
        Status::Degraded
    );
    assert_eq!(
        compute(&coil, &at(4001.0, 22.01), &mut state, &mut out),
        Status::Degraded
    );
    state.power_on();
    let statuses: std::vec::Vec<Status> = (4020..=4180)
        .map(|t| {
            let reading = at(f64::from(t), 22.0 + 0.001 * (t - 4000) as f32);
            compute(&coil, &reading, &mut state, &mut out)
        })
        .collect();
    // Time since power-on starts at 4020 s: degraded until 160 s from there.
    assert!(all(&statuses, 0, 160, Status::Degraded), "{statuses:?}");
    assert_eq!(statuses[160], Status::Valid);
    // A reading stuck for 700 s stays stuck across a power cycle of 10 s.
    let mut stuck = FeatureState::default();
    for t in 0..=700 {
        assert_ne!(
            compute(&RATE, &at(f64::from(t), 25.0), &mut stuck, &mut out),
            Status::Fault
        );
    }
    stuck.power_on();
    assert_eq!(
        compute(&RATE, &at(710.0, 25.0), &mut stuck, &mut out),
        Status::Degraded
    );
    assert_eq!(
        compute(&RATE, &at(711.0, 25.1), &mut stuck, &mut out),
        Status::Degraded,
        "a stuck reading freed: the filters settle"
    );
}

#[test]
fn a_stored_state_is_the_state() {
    let state = heated(&KEPT);
    let mut buf = [0u8; 128];
    let bytes = postcard::to_slice(&state, &mut buf).unwrap();
    let back: FeatureState = postcard::from_bytes(bytes).unwrap();
    assert_eq!(back, state);
}

/// Feeds a 1 Hz ramp of 0.5 °C/min through `f` from `start`, with `sample` editing each
/// sample (time, temperature) by its index; returns each sample's status and the last inputs.
fn run(
    f: &[Feature],
    n: usize,
    mut sample: impl FnMut(usize, &mut Sample),
    state: &mut FeatureState,
) -> (std::vec::Vec<Status>, [f32; 2]) {
    let mut out = [0.0f32; 2];
    let statuses = (0..n)
        .map(|k| {
            let mut s = at(k as f64, 20.0 + 0.5 * k as f32 / 60.0);
            sample(k, &mut s);
            compute(f, &s, state, &mut out)
        })
        .collect();
    (statuses, out)
}

const RATE: [Feature; 2] = [Feature::TemperatureRate { tau_s: 60.0 }, Feature::TimeOn];

/// Samples `from..to` of `statuses` all equal `want`.
fn all(statuses: &[Status], from: usize, to: usize, want: Status) -> bool {
    statuses[from..to].iter().all(|s| *s == want)
}

#[test]
fn non_finite_or_impossible_readings_are_faults_that_leave_the_state_alone() {
    for bad in [f32::NAN, f32::INFINITY, -300.0, 1e30] {
        let mut state = FeatureState::default();
        let (statuses, out) = run(
            &RATE,
            1200,
            |k, s| {
                if (600..610).contains(&k) {
                    s.temp_c = bad;
                }
                if k == 620 {
                    s.output = f32::NAN;
                }
                if k == 630 {
                    s.time_s = f64::NAN;
                }
            },
            &mut state,
        );
        assert!(all(&statuses, 600, 610, Status::Fault), "{bad}");
        assert_eq!(statuses[620], Status::Fault);
        assert_eq!(statuses[630], Status::Fault);
        // Ten lost seconds are no time jump: the filter continues, and the output is valid.
        assert!(all(&statuses, 610, 620, Status::Valid), "{bad}");
        assert!(all(&statuses, 631, 1200, Status::Valid));
        assert!((out[0] - 0.5).abs() < 0.01, "rate {} after {bad}", out[0]);
        assert!((out[1] - 1199.0 / 3600.0).abs() < 1e-6);
    }
}

#[test]
fn a_clock_running_backwards_resynchronizes_and_settles() {
    let mut state = FeatureState::default();
    // At sample 500 the counter wraps: time restarts from 0 (no power-on).
    let (statuses, out) = run(
        &RATE,
        1500,
        |k, s| {
            if k >= 500 {
                s.time_s -= 10_000.0;
            }
        },
        &mut state,
    );
    assert!(all(&statuses, 0, 500, Status::Valid));
    // Degraded for three filter time constants, then valid again.
    assert!(all(&statuses, 500, 680, Status::Degraded));
    assert!(all(&statuses, 680, 1500, Status::Valid));
    // Time since power-on ran on as if nothing happened.
    assert!((out[1] - 1499.0 / 3600.0).abs() < 1e-6, "{out:?}");
    assert!((out[0] - 0.5).abs() < 0.01, "{out:?}");
}

#[test]
fn a_time_jump_is_degraded_until_the_filters_settle() {
    let mut state = FeatureState::default();
    let (statuses, out) = run(
        &RATE,
        1500,
        |k, s| {
            if k >= 700 {
                s.time_s += 3600.0;
            }
        },
        &mut state,
    );
    assert!(all(&statuses, 0, 700, Status::Valid));
    assert!(all(&statuses, 700, 880, Status::Degraded));
    assert!(all(&statuses, 880, 1500, Status::Valid));
    assert!((out[0] - 0.5).abs() < 0.01, "{out:?}");
    assert!((out[1] - (1499.0 + 3600.0) / 3600.0).abs() < 1e-6);
}

#[test]
fn a_stuck_temperature_sensor_is_flagged_and_recovers() {
    let mut state = FeatureState::default();
    // The sensor freezes at sample 300 for 20 minutes, then reads again.
    let (statuses, out) = run(
        &RATE,
        3000,
        |k, s| {
            if (300..1500).contains(&k) {
                s.temp_c = 20.0 + 0.5 * 300.0 / 60.0;
            }
        },
        &mut state,
    );
    assert!(all(&statuses, 0, 900, Status::Valid));
    assert!(all(&statuses, 900, 1500, Status::Degraded));
    assert!(all(&statuses, 1500, 1680, Status::Degraded));
    assert!(all(&statuses, 1680, 3000, Status::Valid));
    assert!((out[0] - 0.5).abs() < 0.01, "{out:?}");
}

#[test]
fn a_changed_sample_rate_is_followed_exactly() {
    let mut state = FeatureState::default();
    // 1 Hz, then 10 Hz, then one sample every 20 s: the filter advances by the actual step.
    let time = |k: usize| match k {
        0..600 => k as f64,
        600..6600 => 600.0 + (k - 600) as f64 * 0.1,
        _ => 1200.0 + (k - 6600) as f64 * 20.0,
    };
    let mut out = [0.0f32; 2];
    for k in 0..6700 {
        let t = time(k);
        let s = at(t, 20.0 + 0.5 * (t / 60.0) as f32);
        assert_eq!(
            compute(&RATE, &s, &mut state, &mut out),
            Status::Valid,
            "{k}"
        );
        if k == 6599 || k == 6699 {
            // Past the first filter time constants, the rate is the ramp's (less the lag of
            // half a step at 20 s steps).
            assert!((out[0] - 0.5).abs() < 0.1, "{k}: {out:?}");
        }
    }
}
