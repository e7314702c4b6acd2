use super::*;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// A table of `temps` × rates ±10, ±40, grouped by `group`.
fn table(temps: &[f64], group: impl Fn(usize) -> String) -> Points {
    let (mut t, mut v, mut w, mut g) = (vec![], vec![], vec![], vec![]);
    for (k, &temp) in temps.iter().enumerate() {
        for rate in [-40.0, -10.0, 10.0, 40.0] {
            t.push(temp);
            w.push(rate);
            v.push(0.05 * rate * (1.0 + 1e-4 * temp) + 0.002 * temp + 1e-5 * (k as f64));
            g.push(group(k));
        }
    }
    Points::new(t, v, w, g, None, true, None)
}

#[test]
fn a_group_that_cannot_be_left_out_is_skipped_with_the_reason_not_fatal() {
    let cfg = EvalConfig::default();
    // Three groups, the last alone at 40 °C: leaving it out leaves 0.5 °C of the table.
    let temps = [10.0, 10.3, 10.5, 40.0];
    let p = table(&temps, |k| ["a", "a", "b", "c"][k].to_owned());
    let e = evaluate(&p, Method::Gpr, &cfg, &()).unwrap();
    assert_eq!(e.per_temperature.len(), 2, "{:?}", e.skipped);
    assert_eq!(e.skipped.len(), 1, "{:?}", e.skipped);
    assert!(e.skipped[0].contains("too few to fit"), "{:?}", e.skipped);
    assert!(e.rmse_dps.is_finite());
    // One group: leave-one-group-out is skipped, point LOO is not.
    let p = table(&[10.0, 20.0, 30.0, 40.0], |_| "all".to_owned());
    let e = evaluate(&p, Method::Gpr, &cfg, &()).unwrap();
    assert!(e.per_temperature.is_empty());
    assert!(e.skipped[0].contains("one group"), "{:?}", e.skipped);
    assert!(e.rmse_dps.is_finite());
}

#[test]
fn qq_correlation_separates_normal_from_skewed() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let normal: Vec<f64> = (0..140).map(|_| StandardNormal.sample(&mut rng)).collect();
    let skewed: Vec<f64> = normal.iter().map(|v: &f64| v.exp()).collect();
    let (qn, qs) = (qq_correlation(&normal), qq_correlation(&skewed));
    assert!(qn > 0.97, "normal {qn}");
    assert!(qs < 0.93, "log-normal {qs}");
}

#[test]
fn fig2_finds_the_curvature_of_a_quadratic_temperature_response() {
    let mut p = Points::new(vec![], vec![], vec![], vec![], None, true, None);
    for &t in &[-30.0, 0.0, 30.0, 60.0] {
        for &w in &[-10.0, 10.0] {
            p.temp_c.push(t);
            p.rate_dps.push(w);
            p.voltage_v.push(0.04 * w + 1e-6 * t * t);
            p.group.push(String::new());
            p.run.push(0);
        }
    }
    let f = fig2(&p);
    assert!((f.scale_factor_mv_per_dps - 40.0).abs() < 1e-9);
    // A line through 1e-6·t² at t = −30, 0, 30, 60 (slope 3e-5 V/°C) misses by ±0.9 mV.
    let worst = f.worst.unwrap();
    assert!((worst.worst_mv - 0.9).abs() < 1e-9, "{}", worst.worst_mv);
}
