//! Another power-on's scale factor: what the residuals' error in proportion to the output
//! assumes, and what it must not take for one.

use super::*;

/// What the residuals' model states is no model error: residuals drawn from exactly the variance
/// their model states, which grows with the output (its latent variance at the table's edge, say),
/// show no error in proportion to it; nor do residuals whose error is alike at every rate. (Each
/// squared error less the stated variance, clipped at 0, found 341 ppm in the first.)
#[test]
fn an_error_the_model_states_or_alike_at_every_rate_is_no_scale() {
    let noise = SampleNoise {
        var: 1e-6,
        interval_s: 1.0,
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    let mut draw = |var: &dyn Fn(f64) -> f64, stated: &dyn Fn(f64) -> f64| -> Vec<Residual> {
        (0..2000)
            .map(|i| {
                let y = 80.0 * ((i % 17) as f64 / 8.0 - 1.0);
                Residual {
                    error: var(y).sqrt() * unit.sample(&mut rng),
                    base_var: stated(y),
                    excess2: 0.0,
                    output2: y * y,
                    output: y,
                    hours: 0.0,
                }
            })
            .collect()
    };
    let stated = |y: f64| 1e-4 + (500e-6 * y).powi(2);
    for residuals in [draw(&stated, &stated), draw(&|_| 1e-4, &|_| 1e-6)] {
        let c = calibrate(
            &[Series {
                source: ResidualSource::Forward,
                residuals,
            }],
            noise,
            Prior::NONE,
        );
        assert_eq!(c.residual_scale_ppm, 0.0, "{c:?}");
    }
}

/// Residuals that show no error in proportion to the output, at outputs that move (±80, 60 s
/// means that each hold a whole sweep, or points): one power-on assumes another's scale as large
/// at their RMS as another power-on's bias, never none; a bias stated 0 leaves it out too.
#[test]
fn a_scale_the_residuals_cannot_show_is_assumed_as_large_as_the_bias_at_their_rms() {
    let noise = SampleNoise {
        var: 1e-6,
        interval_s: 1.0,
    };
    let mut r = residuals(600, 9, |_, _| 0.0);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    let unit = Gauss::new(0.0, 1.0).unwrap();
    for x in r.iter_mut() {
        // Every 60 s mean sweeps ±80: the same mean square, a mean of 0.
        (x.output2, x.output) = (80.0 * 80.0 / 2.0, 0.0);
        // A hair beyond the range, as a sweep's extreme rates lie beyond the trimmed one.
        x.excess2 = 1e-4;
        x.error = 1e-2 * unit.sample(&mut rng);
    }
    let series = [Series {
        source: ResidualSource::Forward,
        residuals: r,
    }];
    let mut c = calibrate(&series, noise, Prior::NONE);
    assert_eq!(c.residual_scale_ppm, 0.0, "{c:?}");
    assert!((c.output_rms - 80.0 / 2f64.sqrt()).abs() < 1e-9, "{c:?}");
    c.assume_turn_on();
    c.assume_scale();
    assert_eq!(c.assumed, ["turn-on", "scale"]);
    let ppm = c.turn_on_std / c.output_rms * 1e6;
    assert!(
        (c.scale_repeatability_ppm / ppm - 1.0).abs() < 1e-9,
        "{c:?}"
    );
    // An error of 1e-2 at every rate, half of it another power-on's: about 7e-3 at RMS 57.
    assert!((60.0..250.0).contains(&c.scale_repeatability_ppm), "{c:?}");
    assert!(c.describe("°/s").contains("as large at their outputs' RMS"));
    assert_eq!(c.scale_skipped(false), None);
    let mut zero = calibrate(&series, noise, Prior::NONE);
    zero.turn_on(Some(0.0));
    zero.scale(None);
    assert_eq!(zero.scale_repeatability_ppm, 0.0);
    let why = zero.scale_skipped(false).unwrap();
    assert!(
        why.contains("bias, which it would be assumed as large as"),
        "{why}"
    );
}

/// Residuals inside the trained range that err in proportion to the output (500 ppm of rates up
/// to ±80, beside 0.01 at every rate): one power-on assumes another's scale factor as large, its
/// variance once; at rest, or measured by runs left out, nothing is assumed.
#[test]
fn one_power_on_assumes_another_ones_scale_as_large_as_its_error_in_proportion() {
    let noise = SampleNoise {
        var: 1e-6,
        interval_s: 1.0,
    };
    let series = |source, moving: bool| {
        let mut r = residuals(2000, 9, |_, _| 0.0);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let unit = Gauss::new(0.0, 1.0).unwrap();
        for (i, x) in r.iter_mut().enumerate() {
            let y = if moving {
                80.0 * ((i % 17) as f64 / 8.0 - 1.0)
            } else {
                1.0
            };
            (x.output2, x.output) = (y * y, y);
            x.excess2 = 0.0;
            x.error = (1e-4 + (500e-6 * y).powi(2)).sqrt() * unit.sample(&mut rng);
        }
        [Series {
            source,
            residuals: r,
        }]
    };
    let mut one = calibrate(&series(ResidualSource::Forward, true), noise, Prior::NONE);
    assert!(
        (one.residual_scale_ppm / 500.0 - 1.0).abs() < 0.1,
        "{one:?}"
    );
    // A hair beyond the range, as a 60 s mean over a sweep lies, still inside for it; a tenth of
    // a width beyond, not.
    let near = |excess2: f64| {
        let mut s = series(ResidualSource::Forward, true);
        for r in &mut s[0].residuals {
            r.excess2 = excess2;
        }
        calibrate(&s, noise, Prior::NONE).residual_scale_ppm
    };
    assert!((near(1e-4) / 500.0 - 1.0).abs() < 0.1, "{}", near(1e-4));
    assert_eq!(near(1e-2), 0.0);
    one.assume_turn_on();
    one.assume_scale();
    assert_eq!(one.assumed, ["turn-on", "scale"]);
    let ppm = one.residual_scale_ppm * 1e-6;
    let var = f64::from(one.error_model.scale_var);
    assert!((var / (ppm * ppm) - 1.0).abs() < 1e-5, "{var}");
    assert!(
        one.describe("°/s")
            .contains("as large as the residuals' model error")
    );
    assert_eq!(one.scale_skipped(false), None);
    // A datasheet's figure replaces it.
    one.scale(Some(800.0));
    assert_eq!(one.assumed, ["turn-on"]);
    assert_eq!(one.scale_repeatability_ppm, 800.0);
    // At rest the residuals cannot show it: nothing is assumed, and the fit says it skipped it.
    let mut rest = calibrate(&series(ResidualSource::Forward, false), noise, Prior::NONE);
    rest.assume_scale();
    assert_eq!((rest.scale_repeatability_ppm, rest.assumed.len()), (0.0, 0));
    let why = rest.scale_skipped(false).unwrap();
    assert!(why.starts_with("the outputs barely move"), "{why}");
    // A datasheet's 0 is stated, not skipped.
    assert_eq!(rest.scale_skipped(true), None);
    let none = Calibration::assumed(noise, Prior::NONE, String::new());
    let why = none.scale_skipped(false).unwrap();
    assert!(why.starts_with("too few out-of-sample residuals"), "{why}");
    // Measured by runs left out, nothing is assumed either.
    let mut runs = calibrate(&series(ResidualSource::Runs, true), noise, Prior::NONE);
    assert!(runs.residual_scale_ppm > 0.0, "{runs:?}");
    runs.scale(None);
    assert_eq!(runs.error_model.scale_var, 0.0);
    let why = runs.scale_skipped(false).unwrap();
    assert!(why.starts_with("the runs left out hold it"), "{why}");
}
