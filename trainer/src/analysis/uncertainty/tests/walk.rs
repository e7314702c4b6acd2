//! The bias's random walk: one stretch of it in a forward split, a log or a part of it in its
//! Allan deviation.

use super::*;
use crate::analysis::uncertainty::streams::{
    WalkReading, allan_walk, holds_still, part_walk, rate_random_walk,
};
use fog_data::stream::Stream;

#[test]
fn the_allan_deviation_reads_a_random_walk_a_white_noise_hides() {
    // Two days at 1 Hz: white noise of 1e-3 per sample (an ARW of 0.06 °/√h) and a walk of
    // K = 0.5 (°/h)/√h. The walk reads within 30 % of it; the noise alone shows none.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    let n = 2 * 86_400;
    let k = 0.5 / 3600.0;
    let step = k / 3600.0_f64.sqrt();
    let time: Vec<f64> = (0..n).map(f64::from).collect();
    let mut walk = 0.0;
    let mut white = Vec::with_capacity(n as usize);
    let mut both = Vec::with_capacity(n as usize);
    for _ in 0..n {
        walk += step * unit.sample(&mut rng);
        let w = 1e-3 * unit.sample(&mut rng);
        white.push(w);
        both.push(w + walk);
    }
    let read = rate_random_walk(&time, &both).sqrt() * 3600.0;
    assert!((read / 0.5 - 1.0).abs() < 0.3, "read {read} (°/h)/√h");
    assert_eq!(rate_random_walk(&time, &white), 0.0);
}

#[test]
fn a_walk_the_split_fits_too_small_ships_the_allan_deviations() {
    // Residuals with no growth in time: the split fits no walk. The training log's Allan
    // deviation read one: it ships, and the fit is kept beside it.
    let r = residuals(600, 3, |_, _| 0.01);
    let series = [Series {
        source: ResidualSource::Forward,
        residuals: r,
    }];
    let noise = SampleNoise {
        var: 1e-4,
        interval_s: 1.0,
    };
    let walk = 4e-4;
    let c = calibrate(
        &series,
        noise,
        PRIOR.with_walk(walk, WalkReading::ForwardSplit),
    );
    assert_eq!(c.error_model.walk_var_per_h, walk as f32, "{c:?}");
    let fitted = c.walk_fitted_std.expect("the split's walk kept");
    assert!(fitted * fitted < walk, "{fitted}");
    assert!(!c.fitted_terms.contains(&"walk"), "{c:?}");
    // The σ line says whose errors the Allan deviation read.
    assert_eq!(c.walk_read, Some(WalkReading::ForwardSplit));
    assert!(
        c.describe("°/s")
            .contains("Allan deviation of the forward split's model's errors over the part")
    );
    // A walk the split fits larger than the Allan deviation's ships as fitted.
    let grows = residuals(600, 3, |_, h| (1e-4 + 0.01 * h).sqrt());
    let series = [Series {
        source: ResidualSource::Forward,
        residuals: grows,
    }];
    let c = calibrate(&series, noise, PRIOR.with_walk(1e-5, WalkReading::WholeLog));
    assert!(c.error_model.walk_var_per_h > 1e-5, "{c:?}");
    assert_eq!(c.walk_fitted_std, None);
    assert_eq!(c.walk_read, None);
    // With too few residuals for any fit, the Allan deviation's walk is stated all the same.
    let c = calibrate(
        &series[..0],
        noise,
        PRIOR.with_walk(walk, WalkReading::WholeLog),
    );
    assert_eq!(c.error_model.walk_var_per_h, walk as f32);
    assert_eq!(c.measured, ["walk"]);
    assert_eq!(c.walk_read, Some(WalkReading::WholeLog));
    assert!(
        c.describe("°/s")
            .contains("from the Allan deviation of the model's errors over it)")
    );
    // Residuals that never reach the walk's covariate fit none: the Allan's ships, and no fit is
    // said to be beside it.
    let mut early = residuals(600, 3, |_, _| 0.01);
    for r in &mut early {
        r.hours = 0.0;
    }
    let series = [Series {
        source: ResidualSource::Forward,
        residuals: early,
    }];
    let c = calibrate(&series, noise, PRIOR.with_walk(walk, WalkReading::WholeLog));
    assert_eq!(c.error_model.walk_var_per_h, walk as f32);
    assert_eq!(c.walk_fitted_std, None);
    assert!(
        c.describe("°/s").contains("the residuals fitted none"),
        "{c:?}"
    );
}

/// A stream of `n` samples at 1 Hz at rest, whose clock jumps back to 0 at `restart` (a power
/// cycle), with `rate` as its reference.
fn at_rest(n: usize, restart: usize, rate: impl Fn(usize) -> f64) -> Stream {
    let time = (0..n)
        .map(|i| if i < restart { i } else { i - restart } as f64)
        .collect();
    Stream::from_columns(
        time,
        vec![20.0; n],
        vec![0.0; n],
        (0..n).map(rate).collect(),
    )
    .unwrap()
}

#[test]
fn another_power_ons_bias_is_a_step_not_a_walk() {
    // White noise and, after a power cycle half-way, a bias 0.01 higher: one run of it would
    // rise as a walk does. Each power-on is a run of its own, and neither shows a walk.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    let n = 2 * 86_400;
    let stream = at_rest(n, n / 2, |_| 0.0);
    let e: Vec<f64> = (0..n)
        .map(|i| 1e-3 * unit.sample(&mut rng) + if i < n / 2 { 0.0 } else { 0.01 })
        .collect();
    let time: Vec<f64> = (0..n).map(|i| i as f64).collect();
    assert!(rate_random_walk(&time, &e) > 0.0, "one run holds the step");
    assert_eq!(allan_walk(&stream, e, 1e-3), 0.0);
}

#[test]
fn the_walk_is_read_only_where_the_reference_holds_still() {
    assert!(holds_still(&[0.0; 10], 1e-3));
    assert!(
        holds_still(&[1.0, 1.0, f64::NAN], 1e-3),
        "gravity, a minute left out"
    );
    let table = [80.0, -80.0, 0.0];
    assert!(!holds_still(&table, 1e-3), "a rate table");
    assert!(!holds_still(&[f64::NAN; 4], 1e-3), "no reference");
    assert!(!holds_still(&[0.0; 4], f64::NAN), "no noise");
    // A table's log reads no walk, whatever its errors.
    let n = 86_400;
    let stream = at_rest(n, n, |i| if (i / 90) % 2 == 0 { 80.0 } else { -80.0 });
    let walk: Vec<f64> = (0..n).map(|i| (i as f64).sqrt() * 1e-4).collect();
    assert_eq!(allan_walk(&stream, walk, 1e-3), 0.0);
}

/// Three days at 1 Hz with `rate` as the reference: white noise of 1e-3 per sample and a walk of
/// K = 0.5 (°/h)/√h as errors; a forward split scores the last day (errors and reference NaN
/// before it).
fn walking_split(rate: impl Fn(usize) -> f64) -> (Stream, Stream, Vec<f64>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    let n = 3 * 86_400;
    let step = 0.5 / 3600.0 / 3600.0_f64.sqrt();
    let mut walk = 0.0;
    let cut = 2 * n / 3;
    let errors = (0..n)
        .map(|i| {
            walk += step * unit.sample(&mut rng);
            let e = walk + 1e-3 * unit.sample(&mut rng);
            if i < cut { f64::NAN } else { e }
        })
        .collect();
    let train = at_rest(n, n, rate);
    let mut part = train.clone();
    for r in &mut part.rate_dps[..cut] {
        *r = f64::NAN;
    }
    (train, part, errors)
}

#[test]
fn a_walk_is_read_on_the_part_a_split_scored() {
    // The day scored is one stretch: its Allan deviation reads the walk there, within 30 %.
    let (train, part, errors) = walking_split(|_| 0.0);
    let read = part_walk(&train, &part, errors, 1e-3).sqrt() * 3600.0;
    assert!((read / 0.5 - 1.0).abs() < 0.3, "read {read} (°/h)/√h");
}

#[test]
fn a_part_at_rest_of_a_log_that_moved_reads_no_walk() {
    // The table spun at 80 °/s on the first day and rests from then on, the day scored too: the
    // part alone holds still, the log does not, and no walk is read.
    let (train, part, errors) = walking_split(|i| if i < 86_400 { 80.0 } else { 0.0 });
    assert!(
        allan_walk(&part, errors.clone(), 1e-3) > 0.0,
        "the part alone"
    );
    assert_eq!(part_walk(&train, &part, errors, 1e-3), 0.0);
}
