//! A stream from power-on: the gyro in a thermal chamber running soaks and ramps, on a rate table
//! stepping through the paper's rates and zero, sampled at 1 Hz.
//!
//! Thermal model (first order, Euler steps of 1 s; time constants from PHYSICS.md's simulator
//! table): the housing follows the chamber air with τ_h, warmed by the electronics' self-heating H,
//! which builds up after power-on with τ_w:
//!
//! ```text
//! dT_h/dt = (T_air + H·(1 − e^{−t/τ_w}) − T_h) / τ_h
//! ```
//!
//! The temperature sensor reads the housing and the coil is at the housing temperature: this base
//! stream holds no transient effect, so a static model's residual on it is noise. Every lag between
//! what the sensor reads and what the coil feels is an effect of its own (`sensor-lag`, with Shupe
//! drift and the others, DESIGN §5): even PHYSICS.md's 1-minute sensor lag makes an error of
//! ∂ω/∂T·τ·Ṫ ≈ 0.024 °/s at 80 °/s on a 1 °C/min ramp, 50× the model's own error. Soaked, this gives
//! the same temperatures as the paper protocol.
//!
//! The chamber program (−30…60 °C at 0.5–1 °C/min, heating and cooling, soaks between) and the rate
//! program (each of the paper's 14 rates and zero, 90 s each, in an order shuffled per cycle by the
//! seed) are fixed by `StreamConfig`; a thermal chamber's air tracks its setpoint closely, so the
//! air temperature is the program itself.

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use crate::paper::RATES_DPS;
use crate::plant::{GyroParams, Noise};

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

/// The chamber program, starting from `start_c` at power-on.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamConfig {
    /// Chamber air at power-on, °C.
    pub start_c: f64,
    /// Soak at the start, minutes.
    pub initial_soak_min: f64,
    /// Ramps and soaks, in order.
    pub segments: Vec<Segment>,
}

impl Default for StreamConfig {
    /// About 10.4 hours: soak at 25 °C, cool to −30 at 1 °C/min, heat to 60 at 0.5 °C/min, cool to 0 at
    /// 0.75 °C/min, heat to 40 at 1 °C/min, each followed by a soak.
    fn default() -> Self {
        let seg = |target_c, rate_c_per_min, soak_min| Segment {
            target_c,
            rate_c_per_min,
            soak_min,
        };
        Self {
            start_c: 25.0,
            initial_soak_min: 60.0,
            segments: vec![
                seg(-30.0, 1.0, 60.0),
                seg(60.0, 0.5, 60.0),
                seg(0.0, 0.75, 45.0),
                seg(40.0, 1.0, 45.0),
            ],
        }
    }
}

impl StreamConfig {
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
    /// Time since power-on, s.
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

/// Simulates the stream; noise and rate order from `seed`.
pub fn run(params: &GyroParams, cfg: &StreamConfig, seed: u64) -> Vec<Row> {
    let mut noise = Noise::new(params, seed);
    let mut order_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7261_7465);
    let earth = params.earth_rate_dps();
    let mut rates: Vec<f64> = Vec::new();
    let n = cfg.duration_s().floor() as u64;
    let mut housing = cfg.start_c;
    let mut rows = Vec::with_capacity(n as usize + 1);
    for k in 0..=n {
        let t = k as f64;
        let air = cfg.air_c(t);
        if k % u64::from(RATE_HOLD_S) == 0 && rates.is_empty() {
            rates = std::iter::once(0.0).chain(RATES_DPS).collect();
            rates.shuffle(&mut order_rng);
        }
        let table = rates.last().copied().unwrap_or(0.0);
        if k % u64::from(RATE_HOLD_S) == u64::from(RATE_HOLD_S) - 1 {
            rates.pop();
        }
        let rate = table + earth;
        let s = noise.sample(params, housing, housing, rate, 0.0);
        rows.push(Row {
            time_s: t,
            temp_c: s.temp_c,
            voltage_v: s.voltage_v,
            rate_dps: rate,
            air_c: air,
            coil_c: housing,
            table_rate_dps: table,
        });
        let heat = params.self_heating_c * (1.0 - (-t / SELF_HEATING_TAU_S).exp());
        housing += (air + heat - housing) / HOUSING_TAU_S;
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chamber_program_ramps_and_soaks() {
        let c = StreamConfig::default();
        assert_eq!(c.air_c(0.0), 25.0);
        assert_eq!(c.air_c(3600.0), 25.0);
        assert!((c.air_c(3600.0 + 600.0) - 15.0).abs() < 1e-9);
        assert_eq!(c.air_c(3600.0 + 55.0 * 60.0 + 1800.0), -30.0);
        let hours = c.duration_s() / 3600.0;
        assert!((9.0..10.5).contains(&hours), "{hours} h");
        assert_eq!(c.air_c(c.duration_s() + 10.0), 40.0);
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
        };
        let a = run(&p, &cfg, 4);
        assert_eq!(a, run(&p, &cfg, 4));
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
