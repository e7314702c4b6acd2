//! A stream from power-on: the gyro in a thermal chamber running soaks and ramps, on a rate table
//! stepping through the paper's rates and zero, sampled at 1 Hz, switched off and on a few times.
//!
//! Thermal model (first order, steps of 1 s; time constants from PHYSICS.md's simulator table): the
//! housing follows the chamber air with τ_h, warmed by the electronics' self-heating, which follows
//! H while the gyro is on and 0 while it is off, with τ_w:
//!
//! ```text
//! dT_h/dt = (T_air + Q − T_h) / τ_h        dQ/dt = (H·on − Q) / τ_w
//! ```
//!
//! The temperature sensor reads the housing; without an effect the coil is at the housing
//! temperature, so a static model's residual is noise. Every transient error is an effect of its
//! own ([`crate::gyro::effects`], docs/design.md §5): the coil lagging the housing (`sensor-lag`),
//! a bias from the coil's temperature rate (`thermal-rate`), a warm-up after each power-on,
//! hysteresis, in-run drift.
//!
//! A static log (`room`) lays the gyro at rest on a bench in a room's daily swing instead: the log
//! a bias stability (Allan deviation) run records, the commonest a gyro's user has, whose halves
//! test what one power-on's model does over days. Its rate program is drawn, from a random stream
//! of its own that the noise does not share, and left unused.
//!
//! The chamber program (−30…60 °C at 0.5–1 °C/min, heating and cooling, soaks between) and the rate
//! program (each of the paper's 14 rates and zero, 90 s each, in an order shuffled per cycle by the
//! seed) are fixed by `StreamConfig`; a thermal chamber's air tracks its setpoint closely, so the
//! air temperature is the program itself. While the gyro is off nothing is logged: the stream's
//! `time_s` (the chamber clock) jumps, which is how a log shows a power cycle, and the firmware's
//! stateful inputs restart there.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use crate::gyro::effects::{EffectPlant, Hidden};
use crate::gyro::paper::RATES_DPS;
use crate::gyro::plant::{GyroParams, Noise, TurnOn};

/// Housing time constant τ_h against the chamber air, s (PHYSICS.md: 5 min, range 2–10).
pub const HOUSING_TAU_S: f64 = 300.0;
/// Time constant τ_w of the self-heating after power-on, s (PHYSICS.md: 15 min, range 5–30).
pub const SELF_HEATING_TAU_S: f64 = 900.0;
/// How long the table holds each rate, s.
pub const RATE_HOLD_S: u32 = 90;

/// One segment of the chamber program: go to `target_c` at `rate_c_per_min`, then hold `soak_min`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Setpoint to reach, °C.
    pub target_c: f64,
    /// Ramp rate, °C/min (magnitude).
    pub rate_c_per_min: f64,
    /// Soak once there, minutes.
    pub soak_min: f64,
}

/// The gyro switched off at `at_min` (program time) for `off_min` minutes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerOff {
    /// When, minutes into the program.
    pub at_min: f64,
    /// For how long, minutes.
    pub off_min: f64,
}

/// The chamber program, starting from `start_c` at power-on.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamConfig {
    /// Chamber air at power-on, °C.
    pub start_c: f64,
    /// Soak at the start, minutes.
    pub initial_soak_min: f64,
    /// Ramps and soaks, in order.
    pub segments: Vec<Segment>,
    /// Power cycles.
    pub power_offs: Vec<PowerOff>,
    /// Logging starts with the gyro long on at `start_c`: housing and coil at the air plus the
    /// self-heating, no warm-up left. Otherwise at power-on, cold: all at the air.
    pub warm_start: bool,
    /// The gyro lies at rest (it senses the earth rate alone) instead of on the rate table.
    pub at_rest: bool,
}

/// Go to `target_c` at `rate_c_per_min`, then hold `soak_min`.
fn seg(target_c: f64, rate_c_per_min: f64, soak_min: f64) -> Segment {
    Segment {
        target_c,
        rate_c_per_min,
        soak_min,
    }
}

impl Default for StreamConfig {
    /// 8.75 hours: soak at 25 °C, cool to −30 at 1 °C/min, heat to 60 at 0.5 °C/min, cool to 0 at
    /// 0.75 °C/min, heat to 40 at 1 °C/min, each followed by a soak; switched off for 15–20 min in
    /// three of the soaks, so there are four power-ons.
    fn default() -> Self {
        let off = |at_min, off_min| PowerOff { at_min, off_min };
        Self {
            start_c: 25.0,
            initial_soak_min: 30.0,
            segments: vec![
                seg(-30.0, 1.0, 40.0),
                seg(60.0, 0.5, 40.0),
                seg(0.0, 0.75, 30.0),
                seg(40.0, 1.0, 30.0),
            ],
            power_offs: vec![off(95.0, 20.0), off(310.0, 15.0), off(427.0, 13.0)],
            warm_start: false,
            at_rest: false,
        }
    }
}

impl StreamConfig {
    /// The long-ramp design, 30.7 hours: logged from a warm start at 60 °C (40 min soak), then
    /// eight legs between 60 and −30 °C at 0.5 °C/min with a 45 min soak at each end, never
    /// switched off. Unlike [`Self::default`] it has no power-on and spends most of its time on
    /// slow ramps: 110,400 samples.
    pub fn ramps() -> Self {
        let leg = |target_c| Segment {
            target_c,
            rate_c_per_min: 0.5,
            soak_min: 45.0,
        };
        Self {
            start_c: 60.0,
            initial_soak_min: 40.0,
            segments: (0..8)
                .map(|i| leg(if i % 2 == 0 { -30.0 } else { 60.0 }))
                .collect(),
            power_offs: Vec::new(),
            warm_start: true,
            at_rest: false,
        }
    }

    /// The commonest calibration log, 340 minutes from one power-on (cold, at 25 °C) and never
    /// switched off: a 20 min soak, cooling to −20 °C at 0.75 °C/min, a 30 min soak, heating to
    /// 60 °C at 0.5 °C/min, a 30 min soak, cooling to 40 °C at 1 °C/min and a 20 min soak. A
    /// warm-up is over in its first hour and never comes back.
    pub fn power_on() -> Self {
        Self::from_power_on(
            25.0,
            20.0,
            vec![
                seg(-20.0, 0.75, 30.0),
                seg(60.0, 0.5, 30.0),
                seg(40.0, 1.0, 20.0),
            ],
        )
    }

    /// A log that ends before its transient: 60 minutes from power-on at 25 °C, a 10 min soak
    /// and a ramp to 0 °C at 0.5 °C/min.
    pub fn short() -> Self {
        Self::from_power_on(25.0, 10.0, vec![seg(0.0, 0.5, 0.0)])
    }

    /// A warm-up alone: 180 minutes at 25 °C from power-on.
    pub fn warm_up() -> Self {
        Self::from_power_on(25.0, 180.0, Vec::new())
    }

    /// A cool-down alone: from power-on at 60 °C, a 20 min soak, cooling to −20 °C at
    /// 0.5 °C/min and a 20 min soak (200 minutes).
    pub fn cool_down() -> Self {
        Self::from_power_on(60.0, 20.0, vec![seg(-20.0, 0.5, 20.0)])
    }

    /// A static log, as a bias stability (Allan deviation) run records one: the gyro at rest on
    /// a bench for three days from one cold power-on, in a room whose air swings between 21 and
    /// 25 °C once a day (warming through the day, cooling through the night: 12 hours each way).
    /// No table turns, so a model of it is a bias model (`trainer fit --scale-factor`).
    pub fn room() -> Self {
        let half_day = |target_c| seg(target_c, 4.0 / (12.0 * 60.0), 0.0);
        Self {
            at_rest: true,
            ..Self::from_power_on(
                21.0,
                0.0,
                (0..6)
                    .map(|i| half_day(if i % 2 == 0 { 25.0 } else { 21.0 }))
                    .collect(),
            )
        }
    }

    /// A program logged from one cold power-on, never switched off.
    fn from_power_on(start_c: f64, initial_soak_min: f64, segments: Vec<Segment>) -> Self {
        Self {
            start_c,
            initial_soak_min,
            segments,
            power_offs: Vec::new(),
            warm_start: false,
            at_rest: false,
        }
    }

    /// Chamber air temperature at time `t` s after power-on.
    pub fn air_c(&self, t: f64) -> f64 {
        let mut at = self.initial_soak_min * 60.0;
        let mut temp = self.start_c;
        if t <= at {
            return temp;
        }
        for s in &self.segments {
            let ramp_s = (s.target_c - temp).abs() / s.rate_c_per_min * 60.0;
            if t <= at + ramp_s {
                return temp + (s.target_c - temp).signum() * s.rate_c_per_min * (t - at) / 60.0;
            }
            at += ramp_s;
            temp = s.target_c;
            at += s.soak_min * 60.0;
            if t <= at {
                return temp;
            }
        }
        temp
    }

    /// Whether the gyro is on at time `t` s.
    pub fn powered(&self, t: f64) -> bool {
        !self
            .power_offs
            .iter()
            .any(|p| t >= p.at_min * 60.0 && t < (p.at_min + p.off_min) * 60.0)
    }

    /// Length of the program, s.
    pub fn duration_s(&self) -> f64 {
        let mut temp = self.start_c;
        let mut total = self.initial_soak_min * 60.0;
        for s in &self.segments {
            total += (s.target_c - temp).abs() / s.rate_c_per_min * 60.0 + s.soak_min * 60.0;
            temp = s.target_c;
        }
        total
    }
}

/// One 1 Hz row of a stream, with the truth behind it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Time on the chamber's clock, s (jumps over power-offs).
    pub time_s: f64,
    /// Temperature-sensor reading, °C.
    pub temp_c: f64,
    /// Gyro output, V.
    pub voltage_v: f64,
    /// True inertial rate (table rate plus earth rate), °/s.
    pub rate_dps: f64,
    /// Chamber air, °C.
    pub air_c: f64,
    /// Coil temperature, °C.
    pub coil_c: f64,
    /// Commanded table rate, °/s.
    pub table_rate_dps: f64,
}

/// Simulates the stream with a hidden `effect`; noise and rate order from `seed`.
pub fn run(
    params: &GyroParams,
    cfg: &StreamConfig,
    effect: impl Into<Hidden>,
    seed: u64,
) -> Vec<Row> {
    let mut noise = Noise::new(params, seed);
    let mut order_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7261_7465);
    let earth = params.earth_rate_dps();
    let mut rates: Vec<f64> = Vec::new();
    let n = cfg.duration_s().floor() as u64;
    let mut heat = if cfg.warm_start {
        params.self_heating_c
    } else {
        0.0
    };
    let mut housing = cfg.start_c + heat;
    let mut plant = EffectPlant::new(effect, housing);
    let mut t_on = 0.0;
    let (mut power_ons, mut turn_on) = (0, TurnOn::default());
    let mut rows = Vec::with_capacity(n as usize + 1);
    for k in 0..=n {
        let t = k as f64;
        let air = cfg.air_c(t);
        if k % u64::from(RATE_HOLD_S) == 0 && rates.is_empty() {
            rates = std::iter::once(0.0).chain(RATES_DPS).collect();
            rates.shuffle(&mut order_rng);
        }
        let table = if cfg.at_rest {
            0.0
        } else {
            rates.last().copied().unwrap_or(0.0)
        };
        if k % u64::from(RATE_HOLD_S) == u64::from(RATE_HOLD_S) - 1 {
            rates.pop();
        }
        let on = cfg.powered(t);
        if on {
            if t_on == 0.0 {
                turn_on = params.turn_on(seed, power_ons);
                power_ons += 1;
            }
            let rate = table + earth;
            let coil = plant.coil_c();
            let s = noise.sample(
                params,
                coil,
                housing,
                rate,
                plant.bias_dps(t_on) + turn_on.dps(rate),
            );
            rows.push(Row {
                time_s: t,
                temp_c: s.temp_c,
                voltage_v: s.voltage_v,
                rate_dps: rate,
                air_c: air,
                coil_c: coil,
                table_rate_dps: table,
            });
            t_on += 1.0;
        } else {
            noise.advance(params, 1.0);
            t_on = 0.0;
        }
        let target = if on { params.self_heating_c } else { 0.0 };
        heat += (target - heat) / SELF_HEATING_TAU_S;
        housing += (air + heat - housing) / HOUSING_TAU_S;
        plant.step(housing, 1.0);
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gyro::effects::Effect;

    #[test]
    fn chamber_program_ramps_and_soaks() {
        let c = StreamConfig::default();
        assert_eq!(c.air_c(0.0), 25.0);
        assert_eq!(c.air_c(1800.0), 25.0);
        assert!((c.air_c(1800.0 + 600.0) - 15.0).abs() < 1e-9);
        assert_eq!(c.air_c(1800.0 + 55.0 * 60.0 + 1200.0), -30.0);
        let hours = c.duration_s() / firmware_core::units::SECONDS_PER_HOUR;
        assert!((8.0..9.0).contains(&hours), "{hours} h");
        assert!(c.powered(0.0) && !c.powered(100.0 * 60.0) && c.powered(115.0 * 60.0));
        assert_eq!(c.air_c(c.duration_s() + 10.0), 40.0);
    }

    #[test]
    fn the_ramp_design_is_eight_slow_legs_from_a_warm_start() {
        let c = StreamConfig::ramps();
        assert_eq!(c.duration_s(), 110_400.0);
        assert_eq!(c.air_c(40.0 * 60.0 + 60.0 * 60.0), 30.0);
        let p = GyroParams::nominal();
        let short = StreamConfig {
            segments: c.segments[..1].to_vec(),
            ..c
        };
        let rows = run(&p, &short, Effect::None, 3);
        // Warm from the first sample: the coil starts at the air plus the self-heating.
        assert!((rows[0].coil_c - (60.0 + p.self_heating_c)).abs() < 1e-9);
        assert!(rows.windows(2).all(|w| w[1].time_s - w[0].time_s == 1.0));
    }

    #[test]
    fn the_room_design_is_three_days_at_rest_through_daily_swings() {
        let c = StreamConfig::room();
        assert_eq!(c.duration_s(), 3.0 * 24.0 * 3600.0);
        assert_eq!(c.air_c(0.0), 21.0);
        assert!((c.air_c(12.0 * 3600.0) - 25.0).abs() < 1e-9);
        assert!((c.air_c(30.0 * 3600.0) - 23.0).abs() < 1e-9);
        let p = GyroParams::nominal();
        let day = StreamConfig {
            segments: c.segments[..2].to_vec(),
            ..c
        };
        let rows = run(&p, &day, Effect::None, 5);
        assert_eq!(rows.len(), 24 * 3600 + 1);
        assert!(rows.iter().all(|r| r.table_rate_dps == 0.0));
        assert!(rows.iter().all(|r| r.rate_dps == p.earth_rate_dps()));
    }

    #[test]
    fn stream_is_deterministic_and_covers_rates_and_temperatures() {
        let p = GyroParams::nominal();
        let cfg = StreamConfig {
            start_c: 20.0,
            initial_soak_min: 5.0,
            segments: vec![Segment {
                target_c: 30.0,
                rate_c_per_min: 1.0,
                soak_min: 30.0,
            }],
            power_offs: Vec::new(),
            warm_start: false,
            at_rest: false,
        };
        let a = run(&p, &cfg, Effect::None, 4);
        assert_eq!(a, run(&p, &cfg, Effect::None, 4));
        assert_eq!(a.len(), 45 * 60 + 1);
        let mut seen: Vec<f64> = a.iter().map(|r| r.table_rate_dps).collect();
        seen.sort_by(f64::total_cmp);
        seen.dedup();
        assert_eq!(seen.len(), 15, "14 rates and zero");
        // The housing lags the air on the ramp and settles at air + self-heating in the soak.
        let ramp_end = &a[15 * 60];
        assert!(ramp_end.coil_c < ramp_end.air_c + p.self_heating_c - 3.0);
        let last = a.last().unwrap();
        assert!(
            (last.coil_c - (30.0 + p.self_heating_c)).abs() < 0.5,
            "{last:?}"
        );
    }
}
