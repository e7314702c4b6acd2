//! The reference paper's calibration protocol: soaked temperatures × rate-table rates.
//!
//! For each of the 10 chamber temperatures (−30 … 60 °C, in ascending order as a chamber would run
//! them) the gyro soaks for two hours; then for each of the 14 rates (±1, 2, 5, 10, 20, 40, 80 °/s)
//! a zero-rate position test of 120 s precedes a 120 s rate test, both sampled at 1 Hz. A rate
//! point is the mean of its 120 samples; `rate_dps` is the true inertial rate (table rate plus
//! earth rate). Position tests are written only when asked for (they are separate tests in the
//! paper, and the paper's 140 points hold none), as rows with zero table rate.
//!
//! A hidden effect ([`crate::gyro::effects`]) acts here as it would in a real calibration, so a
//! static model fitted on these points is what a user would have today: the gyro is switched on at
//! the start of each soak (so the tests run 2–3 h after power-on: warm-up has decayed, in-run drift
//! has not), the coil is soaked (no temperature rate, no lag), and the hysteresis state is the one
//! the chamber's last move left (−30 °C is reached by cooling from the ambient 25 °C, every later
//! setpoint by heating).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::gyro::effects::{EffectPlant, Hidden};
use crate::gyro::plant::{GyroParams, Noise, TurnOn};

/// Chamber setpoints of the paper, °C.
pub const TEMPERATURES_C: [f64; 10] = [-30.0, -20.0, -10.0, -5.0, 0.0, 5.0, 10.0, 20.0, 40.0, 60.0];
/// Table rates of the paper, °/s.
pub const RATES_DPS: [f64; 14] = [
    -80.0, -40.0, -20.0, -10.0, -5.0, -2.0, -1.0, 1.0, 2.0, 5.0, 10.0, 20.0, 40.0, 80.0,
];
/// Samples per point (2 min at 1 Hz).
pub const SAMPLES_PER_POINT: u32 = 120;
/// Soak before the first test at each temperature, s.
const SOAK_S: f64 = 7200.0;
/// Chamber temperature before the protocol starts, °C.
const AMBIENT_C: f64 = 25.0;

/// One averaged rate-table point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Mean temperature-sensor reading, °C.
    pub temp_c: f64,
    /// Mean gyro output, V.
    pub voltage_v: f64,
    /// True inertial rate (table rate plus earth rate), °/s.
    pub rate_dps: f64,
    /// Chamber setpoint, °C.
    pub setpoint_c: f64,
    /// Table rate commanded, °/s (0 for a position test).
    pub table_rate_dps: f64,
}

/// Runs the paper protocol on one gyro with a hidden `effect`; noise from `seed`.
pub fn run(
    params: &GyroParams,
    effect: impl Into<Hidden>,
    seed: u64,
    position_tests: bool,
) -> Vec<Point> {
    let mut noise = Noise::new(params, seed);
    let mut points = Vec::new();
    let mut plant = EffectPlant::new(effect, AMBIENT_C);
    let turn_on = params.turn_on(seed, 0);
    let mut previous = AMBIENT_C;
    for &setpoint in &TEMPERATURES_C {
        noise.advance(params, SOAK_S);
        plant.soak(setpoint + params.self_heating_c, setpoint > previous);
        previous = setpoint;
        let mut t_on = SOAK_S;
        for &table_rate in &RATES_DPS {
            let position = average(
                params,
                &mut noise,
                &plant,
                (setpoint, 0.0),
                turn_on,
                &mut t_on,
            );
            if position_tests {
                points.push(position);
            }
            let point = average(
                params,
                &mut noise,
                &plant,
                (setpoint, table_rate),
                turn_on,
                &mut t_on,
            );
            points.push(point);
        }
    }
    points
}

/// One point at a soaked `setpoint`: the mean of 2 min of samples with the table turning at
/// `table_rate`, the gyro on for `t_on` s (advanced by the samples taken) with the power-on's
/// turn-on bias and scale `turn_on`.
fn average(
    params: &GyroParams,
    noise: &mut Noise,
    plant: &EffectPlant,
    (setpoint, table_rate): (f64, f64),
    turn_on: TurnOn,
    t_on: &mut f64,
) -> Point {
    // Soaked: housing and coil sit at the chamber air plus the electronics' self-heating.
    let t_gyro = setpoint + params.self_heating_c;
    let rate = table_rate + params.earth_rate_dps();
    let (mut t, mut v) = (0.0, 0.0);
    for _ in 0..SAMPLES_PER_POINT {
        let s = noise.sample(
            params,
            t_gyro,
            t_gyro,
            rate,
            plant.bias_dps(*t_on) + turn_on.dps(rate),
        );
        *t_on += 1.0;
        t += s.temp_c;
        v += s.voltage_v;
    }
    let n = f64::from(SAMPLES_PER_POINT);
    Point {
        temp_c: t / n,
        voltage_v: v / n,
        rate_dps: rate,
        setpoint_c: setpoint,
        table_rate_dps: table_rate,
    }
}

/// Range of [`scattered`] setpoints, °C, and of its table rates, ±°/s: the paper's extremes.
pub const SCATTER_RANGE: ([f64; 2], f64) = ([-30.0, 60.0], 80.0);

/// `n` rate-table points at setpoints and table rates drawn uniformly over the paper's ranges
/// ([`SCATTER_RANGE`]), each soaked like the paper's and averaged over 2 min: a calibration
/// of any size, for measuring how fits scale (docs/performance.md). Draws and noise from `seed`.
pub fn scattered(
    params: &GyroParams,
    effect: impl Into<Hidden>,
    seed: u64,
    n: usize,
) -> Vec<Point> {
    let mut draws = ChaCha8Rng::seed_from_u64(seed ^ 0x5CA7_7E2D);
    let mut noise = Noise::new(params, seed);
    let mut plant = EffectPlant::new(effect, AMBIENT_C);
    let mut previous = AMBIENT_C;
    let turn_on = params.turn_on(seed, 0);
    let ([t_lo, t_hi], w_max) = SCATTER_RANGE;
    (0..n)
        .map(|_| {
            let setpoint = draws.random_range(t_lo..t_hi);
            let table_rate = draws.random_range(-w_max..w_max);
            noise.advance(params, SOAK_S);
            plant.soak(setpoint + params.self_heating_c, setpoint > previous);
            previous = setpoint;
            let point = (setpoint, table_rate);
            average(params, &mut noise, &plant, point, turn_on, &mut { SOAK_S })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gyro::effects::Effect;

    #[test]
    fn protocol_has_140_points_and_optional_position_tests() {
        let p = GyroParams::nominal();
        assert_eq!(run(&p, Effect::None, 1, false).len(), 140);
        let with = run(&p, Effect::None, 1, true);
        assert_eq!(with.len(), 280);
        assert_eq!(
            with.iter().filter(|pt| pt.table_rate_dps == 0.0).count(),
            140
        );
    }

    #[test]
    fn same_seed_same_points_other_seed_other_noise() {
        let p = GyroParams::nominal();
        assert_eq!(
            run(&p, Effect::None, 3, false),
            run(&p, Effect::None, 3, false)
        );
        assert_ne!(
            run(&p, Effect::None, 3, false),
            run(&p, Effect::None, 4, false)
        );
    }

    #[test]
    fn scattered_points_cover_the_ranges_and_repeat_by_seed() {
        let p = GyroParams::nominal();
        let pts = scattered(&p, Effect::None, 2, 300);
        assert_eq!(pts, scattered(&p, Effect::None, 2, 300));
        let ([lo, hi], w) = SCATTER_RANGE;
        assert!(pts.iter().all(|x| (lo..hi).contains(&x.setpoint_c)));
        assert!(pts.iter().all(|x| x.table_rate_dps.abs() < w));
        // Spread, not clustered: every tenth of the temperature range holds some.
        for k in 0..10 {
            let a = lo + (hi - lo) * f64::from(k) / 10.0;
            let b = a + (hi - lo) / 10.0;
            assert!(
                pts.iter().any(|x| (a..b).contains(&x.setpoint_c)),
                "{a}…{b}"
            );
        }
    }

    #[test]
    fn points_follow_the_scale_factor() {
        let p = GyroParams::nominal();
        let pts = run(&p, Effect::None, 5, false);
        for pt in &pts {
            let t = pt.setpoint_c + p.self_heating_c;
            let expected = p.output_voltage(t, pt.rate_dps + p.bias_dps(t));
            // 2-min mean noise ≈ 0.6 °/h plus bias instability and rate random walk, a few °/h:
            // far below 0.01 °/s.
            assert!((pt.voltage_v - expected).abs() < 0.01 * p.scale_factor_v_per_dps);
            assert!((pt.temp_c - pt.setpoint_c - p.self_heating_c).abs() < 0.05);
        }
    }
}
