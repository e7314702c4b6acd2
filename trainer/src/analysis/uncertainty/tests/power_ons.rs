//! Another power-on's bias measured on a training stream's power-ons, each left out in turn.

use super::*;

/// Four power-ons left out, their residuals white with `sd` about each one's `offsets`, beside
/// a forward split of the same white error.
fn left_out(offsets: &[f64], sd: f64) -> Vec<Series> {
    let mut series: Vec<Series> = offsets
        .iter()
        .enumerate()
        .map(|(k, offset)| Series {
            source: ResidualSource::PowerOn,
            residuals: residuals(200, 20 + k as u64, |_, _| sd)
                .into_iter()
                .map(|r| Residual {
                    error: r.error + offset,
                    excess2: 0.0,
                    ..r
                })
                .collect(),
        })
        .collect();
    series.push(Series {
        source: ResidualSource::Forward,
        residuals: residuals(200, 9, |_, _| sd)
            .into_iter()
            .map(|r| Residual { excess2: 0.0, ..r })
            .collect(),
    });
    series
}

const NOISE: SampleNoise = SampleNoise {
    var: 1e-6,
    interval_s: 1.0,
};

#[test]
fn power_ons_left_out_measure_the_bias_between_them_once() {
    let offsets = [0.3, -0.2, 0.1, -0.25];
    let c = calibrate(&left_out(&offsets, 0.05), NOISE, Prior::NONE);
    assert_eq!(c.power_ons_left_out, Some(4));
    assert_eq!(c.measured, ["turn-on"]);
    assert!(c.runs_measured());
    // The offsets' mean square, 0.051, widened for four draws, three degrees of freedom:
    // (t₀.₉₇₅(3) / 1.96)² ≈ 2.6; the blob carries it as the difference of two power-ons.
    let between = f64::from(c.error_model.turn_on_var);
    assert!((0.11..0.16).contains(&between), "{between}");
    assert!((c.turn_on_std.powi(2) * OWN_DRAW / between - 1.0).abs() < 1e-6);
    // The floor is the in-run error, not the offsets counted again: (0.05² + the 1e-2 stated).
    assert!(c.floor_std < 0.1, "{}", c.floor_std);
    assert!(!c.assumed.contains(&"turn-on"));
    assert!(
        c.describe("°/s")
            .contains("(measured: the mean errors of 4 power-ons left out, widened for the few)"),
        "{}",
        c.describe("°/s")
    );
    // A datasheet states it instead.
    let mut stated = c.clone();
    stated.set_turn_on(0.02);
    assert!(stated.measured.is_empty());
    assert!(stated.describe("°/s").contains("(--repeatability)"));
    // A bias that repeats exactly: nothing is said of runs left out, whose floor would hold it.
    stated.set_turn_on(0.0);
    assert!(!stated.describe("°/s").contains("another power-on's bias"));
}

#[test]
fn power_ons_alike_measure_next_to_no_bias_and_two_measure_nothing() {
    let alike = calibrate(&left_out(&[0.0; 4], 0.05), NOISE, Prior::NONE);
    assert_eq!(alike.power_ons_left_out, Some(4));
    // Only what their mean errors scatter by chance, the noise of a mean of 200.
    assert!(alike.turn_on_std < 0.01, "{}", alike.turn_on_std);
    let mut two = calibrate(&left_out(&[0.3, -0.3], 0.05), NOISE, Prior::NONE);
    assert_eq!(two.power_ons_left_out, None);
    assert!(!two.runs_measured());
    // Two power-ons left out are one degree of freedom: another's bias is assumed, as for one.
    two.assume_turn_on();
    assert!(two.assumed.contains(&"turn-on"));
}

#[test]
fn power_ons_whose_scale_differs_measure_another_ones_scale() {
    // Each power-on's error grows with the output (±1 … ±100 in turn) by a scale of its own,
    // 1000 ppm apart; their mean errors stay at 0.
    let scales = [1e-3, -1e-3, 5e-4, -5e-4];
    let mut series = left_out(&[0.0; 4], 0.002);
    for (s, scale) in series.iter_mut().zip(scales) {
        for (i, r) in s.residuals.iter_mut().enumerate() {
            let y = if i % 2 == 0 { 1.0 } else { -1.0 } * (1 + i % 100) as f64;
            r.error += scale * y;
            r.output2 = y * y;
            r.base_var = 1e-6;
            r.hours = 0.0;
        }
    }
    let c = calibrate(&series, NOISE, Prior::NONE);
    assert_eq!(c.measured, ["turn-on", "scale"]);
    // The scales' spread, 790 ppm, widened for four draws (1.6×).
    let ppm = c.scale_repeatability_ppm * OWN_DRAW.sqrt();
    assert!((800.0..1600.0).contains(&ppm), "{ppm}");
    assert!(
        c.describe("°/s")
            .contains("(measured: the error in proportion to the output of 4 power-ons left out")
    );
    assert_eq!(c.scale_skipped(false), None);
    let alike = calibrate(&left_out(&[0.0; 4], 0.05), NOISE, Prior::NONE);
    assert_eq!(alike.measured, ["turn-on"]);
    assert_eq!(
        alike.scale_skipped(false),
        Some("the power-ons left out show no error in proportion to the output")
    );
}
