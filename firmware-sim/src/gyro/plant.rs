//! The simulated open-loop fiber-optic gyro: output map, temperature dependence and noise.
//!
//! The model follows `../shared/PHYSICS.md` (simulator parameter table) and the reference paper:
//!
//! ```text
//! ω_eff = ω_in + b(T_c) + n_arw + n_bi + n_rrw                         [°/s]
//! V     = V₀ + S(T_c) · sin(K′ ω_eff) / K′ · (1 + a · sgn ω_eff) + ADC quantization
//! S(T)  = S₂₅ · (1 + c₁ (T − 25) + c₂ (T − 25)²),   K′ = K · π/180
//! ```
//!
//! - `ω_in` is the true inertial rate about the input axis: table rate plus the vertical earth rate
//!   `15.041 °/h · sin φ`.
//! - `b(T)` is a bias in rate units (°/h in the parameters), a quadratic + cubic shape in T.
//! - The sine is the open-loop FOG's response to the Sagnac phase, so V is not linear in ω; `a` is the
//!   scale-factor asymmetry between positive and negative rates.
//! - Noise (IEEE 952 terms): angle random walk (white rate noise), bias instability (first-order
//!   Gauss–Markov, correlation time 300 s), rate random walk; an 18-bit ADC over ±5 V.
//! - The temperature sensor reads the housing with white noise; during a soak, housing and coil are
//!   at the chamber temperature plus the electronics' self-heating.
//!
//! Units: temperatures in °C, rates in °/s (parameters in °/h where the literature uses it), volts.

use firmware_core::units::SECONDS_PER_HOUR;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Serialize;

/// Vertical component of the earth rate per unit sin(latitude), °/h (WGS-84 sidereal rate).
pub const EARTH_RATE_DPH: f64 = 15.041;
/// Reference temperature of the scale-factor and bias polynomials, °C.
const T_REF_C: f64 = 25.0;

/// Parameters of one gyro unit (see the module doc for the equations).
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GyroParams {
    /// Scale factor at 25 °C, V/(°/s). Paper: about 38 mV/(°/s).
    pub scale_factor_v_per_dps: f64,
    /// Linear temperature coefficient of the scale factor, 1/°C (SLD wavelength drift).
    pub sf_tc_per_c: f64,
    /// Quadratic temperature coefficient of the scale factor, 1/°C².
    pub sf_tc2_per_c2: f64,
    /// Sagnac phase per rate, s: sets the sine non-linearity of the open-loop response.
    pub sagnac_k_s: f64,
    /// Scale-factor asymmetry between positive and negative rates (dimensionless).
    pub sf_asymmetry: f64,
    /// Electronics offset at the output, V.
    pub output_offset_v: f64,
    /// Bias polynomial in u = (T − 25)/45 (°/h): b = Σ bᵢ uⁱ, i = 0…3.
    pub bias_poly_dph: [f64; 4],
    /// Angle random walk, °/√h.
    pub arw_dpsqrth: f64,
    /// Bias instability (standard deviation of the Gauss–Markov bias), °/h.
    pub bias_instability_dph: f64,
    /// Correlation time of the bias instability, s.
    pub bias_instability_tau_s: f64,
    /// Rate random walk, (°/h)/√h.
    pub rrw_dph_per_sqrth: f64,
    /// ADC resolution in bits over ±5 V.
    pub adc_bits: u32,
    /// Temperature-sensor white noise per sample, °C.
    pub temp_noise_c: f64,
    /// Self-heating of the housing above the chamber air once warmed up, °C.
    pub self_heating_c: f64,
    /// Site latitude, degrees (input axis vertical).
    pub latitude_deg: f64,
    /// Turn-on bias repeatability, °/h (1σ): each power-on adds a constant bias drawn anew, which
    /// no calibration of one power-on can see. Zero in the nominal and random units, so that
    /// their published figures hold; a unit file sets it (a tactical FOG: a few °/h).
    #[serde(default)]
    pub turn_on_bias_dph: f64,
    /// Turn-on scale-factor repeatability, ppm (1σ): each power-on scales the rate by a factor
    /// drawn anew, an error that grows with the rate (the real FOG runs differ by about 780 ppm,
    /// docs/real-data.md). Zero in the nominal and random units; a unit file sets it.
    #[serde(default)]
    pub turn_on_scale_ppm: f64,
}

impl GyroParams {
    /// The nominal unit of PHYSICS.md's parameter table: the paper's gyro as far as it is published.
    pub fn nominal() -> Self {
        Self {
            scale_factor_v_per_dps: 0.038,
            sf_tc_per_c: -300e-6,
            // 1.5 ppm/°C² (range 0–5) reproduces the paper's Fig. 2: a first-order V-vs-T fit
            // misses by about 5 mV at 80 °/s.
            sf_tc2_per_c2: 1.5e-6,
            sagnac_k_s: 0.12,
            // Negative: the paper's worst Fig. 2 error is at −80 °/s, so negative rates read larger.
            sf_asymmetry: -300e-6,
            output_offset_v: 2.0e-3,
            // 60 °/h swing over −30…60 °C with a quadratic + cubic shape.
            bias_poly_dph: [20.0, 12.0, 18.0, 14.0],
            arw_dpsqrth: 0.1,
            bias_instability_dph: 1.0,
            bias_instability_tau_s: 300.0,
            rrw_dph_per_sqrth: 0.3,
            adc_bits: 18,
            temp_noise_c: 0.05,
            self_heating_c: 4.0,
            latitude_deg: 45.0,
            turn_on_bias_dph: 0.0,
            turn_on_scale_ppm: 0.0,
        }
    }

    /// A unit drawn from the published ranges of PHYSICS.md (unit-to-unit variation), by seed.
    pub fn random_unit(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6779_726f_5f75_6e69);
        let mut draw = |lo: f64, hi: f64| lo + (hi - lo) * rng.random::<f64>();
        Self {
            scale_factor_v_per_dps: draw(0.035, 0.041),
            sf_tc_per_c: draw(-600e-6, 100e-6),
            sf_tc2_per_c2: draw(0.0, 5e-6),
            sagnac_k_s: draw(0.08, 0.15),
            sf_asymmetry: draw(50e-6, 1000e-6),
            output_offset_v: draw(-5e-3, 5e-3),
            bias_poly_dph: [
                draw(-50.0, 50.0),
                draw(-40.0, 40.0),
                draw(-40.0, 40.0),
                draw(-30.0, 30.0),
            ],
            arw_dpsqrth: draw(0.05, 0.3),
            bias_instability_dph: draw(0.3, 3.0),
            bias_instability_tau_s: 300.0,
            rrw_dph_per_sqrth: draw(0.0, 1.0),
            adc_bits: 18,
            temp_noise_c: draw(0.02, 0.1),
            self_heating_c: draw(1.0, 8.0),
            latitude_deg: draw(30.0, 60.0),
            turn_on_bias_dph: 0.0,
            turn_on_scale_ppm: 0.0,
        }
    }

    /// What power-on number `power_on` (from 0) of a run with noise `seed` adds: a constant bias,
    /// [`Self::turn_on_bias_dph`] times a standard normal draw of its own, and a scale,
    /// [`Self::turn_on_scale_ppm`] times another, so that the rest of the run's noise is the same
    /// whatever the repeatabilities.
    pub fn turn_on(&self, seed: u64, power_on: u64) -> TurnOn {
        let draw = |salt: u64| -> f64 {
            let key = seed ^ salt ^ power_on.wrapping_mul(0x9e37_79b9_7f4a_7c15);
            StandardNormal.sample(&mut ChaCha8Rng::seed_from_u64(key))
        };
        TurnOn {
            bias_dps: if self.turn_on_bias_dph == 0.0 {
                0.0
            } else {
                draw(0x7475_726e_5f6f_6e00) * self.turn_on_bias_dph / SECONDS_PER_HOUR
            },
            scale: if self.turn_on_scale_ppm == 0.0 {
                0.0
            } else {
                draw(0x7363_616c_655f_6f6e) * self.turn_on_scale_ppm * 1e-6
            },
        }
    }

    /// Vertical earth rate at the site, °/s.
    pub fn earth_rate_dps(&self) -> f64 {
        EARTH_RATE_DPH * self.latitude_deg.to_radians().sin() / SECONDS_PER_HOUR
    }

    /// Scale factor at coil temperature `t_c`, V/(°/s).
    pub fn scale_factor(&self, t_c: f64) -> f64 {
        let dt = t_c - T_REF_C;
        self.scale_factor_v_per_dps * (1.0 + self.sf_tc_per_c * dt + self.sf_tc2_per_c2 * dt * dt)
    }

    /// Temperature-dependent bias at coil temperature `t_c`, °/s.
    pub fn bias_dps(&self, t_c: f64) -> f64 {
        let u = (t_c - T_REF_C) / 45.0;
        let b = &self.bias_poly_dph;
        (b[0] + u * (b[1] + u * (b[2] + u * b[3]))) / SECONDS_PER_HOUR
    }

    /// Noise-free output voltage for an effective rate (bias and noise already added), V.
    pub fn output_voltage(&self, t_c: f64, omega_eff_dps: f64) -> f64 {
        let k = self.sagnac_k_s.to_radians();
        let response = (k * omega_eff_dps).sin() / k;
        let asym = 1.0 + self.sf_asymmetry * omega_eff_dps.signum();
        self.output_offset_v + self.scale_factor(t_c) * response * asym
    }

    fn adc_lsb_v(&self) -> f64 {
        10.0 / f64::from(1u32 << self.adc_bits.min(30))
    }
}

/// What one power-on adds to the rate the gyro senses ([`GyroParams::turn_on`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TurnOn {
    /// A constant bias, °/s.
    pub bias_dps: f64,
    /// A share of the rate: the scale factor's change from its nominal.
    pub scale: f64,
}

impl TurnOn {
    /// What it adds at the true rate `rate_dps`, °/s.
    pub fn dps(&self, rate_dps: f64) -> f64 {
        self.bias_dps + self.scale * rate_dps
    }
}

/// One 1 Hz sample as the data logger sees it, plus the truth behind it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoggedSample {
    /// Temperature-sensor reading, °C.
    pub temp_c: f64,
    /// Gyro output, V (quantized by the ADC).
    pub voltage_v: f64,
    /// True inertial rate about the input axis, earth rate included, °/s.
    pub rate_dps: f64,
}

/// The random processes of one gyro (ARW, bias instability, rate random walk, sensor noise).
///
/// Coloured processes are propagated exactly over gaps of any length, so a soak of hours costs
/// one step rather than thousands.
pub struct Noise {
    rng: ChaCha8Rng,
    markov_dps: f64,
    rrw_dps: f64,
}

impl Noise {
    /// Starts the processes from their stationary distribution (RRW from zero), by seed.
    pub fn new(params: &GyroParams, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let z: f64 = StandardNormal.sample(&mut rng);
        let markov_dps = z * params.bias_instability_dph / SECONDS_PER_HOUR;
        Self {
            rng,
            markov_dps,
            rrw_dps: 0.0,
        }
    }

    fn normal(&mut self) -> f64 {
        StandardNormal.sample(&mut self.rng)
    }

    /// Advances the coloured processes by `dt_s` seconds.
    pub fn advance(&mut self, params: &GyroParams, dt_s: f64) {
        let phi = (-dt_s / params.bias_instability_tau_s).exp();
        let sigma = params.bias_instability_dph / SECONDS_PER_HOUR;
        self.markov_dps = phi * self.markov_dps + sigma * (1.0 - phi * phi).sqrt() * self.normal();
        let rrw_per_sqrt_s = params.rrw_dph_per_sqrth / SECONDS_PER_HOUR / SECONDS_PER_HOUR.sqrt();
        self.rrw_dps += rrw_per_sqrt_s * dt_s.sqrt() * self.normal();
    }

    /// One 1 Hz sample at coil temperature `t_c` (the sensor reads `t_sensor`) and true rate.
    pub fn sample(
        &mut self,
        params: &GyroParams,
        t_c: f64,
        t_sensor: f64,
        rate_dps: f64,
        extra_bias_dps: f64,
    ) -> LoggedSample {
        // ARW N (°/√h) is white rate noise of density N·60 (°/h)/√Hz: σ = N·60/3600 °/s at 1 Hz.
        let arw = params.arw_dpsqrth * 60.0 / SECONDS_PER_HOUR * self.normal();
        let omega_eff =
            rate_dps + params.bias_dps(t_c) + self.markov_dps + self.rrw_dps + arw + extra_bias_dps;
        let lsb = params.adc_lsb_v();
        let voltage_v = (params.output_voltage(t_c, omega_eff) / lsb).round() * lsb;
        let temp_c = t_sensor + params.temp_noise_c * self.normal();
        self.advance(params, 1.0);
        LoggedSample {
            temp_c,
            voltage_v,
            rate_dps,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_bias_swing_is_about_60_dph_over_the_paper_range() {
        let p = GyroParams::nominal();
        let b: Vec<f64> = (-30..=60)
            .map(|t| p.bias_dps(f64::from(t)) * SECONDS_PER_HOUR)
            .collect();
        let swing =
            b.iter().cloned().fold(f64::MIN, f64::max) - b.iter().cloned().fold(f64::MAX, f64::min);
        assert!((40.0..80.0).contains(&swing), "swing {swing} °/h");
    }

    #[test]
    fn sine_response_compresses_large_rates() {
        let p = GyroParams::nominal();
        let v80 = p.output_voltage(25.0, 80.0) - p.output_voltage(25.0, 0.0);
        let linear = p.scale_factor(25.0) * 80.0 * (1.0 + p.sf_asymmetry);
        let deficit_dps = (linear - v80) / p.scale_factor(25.0);
        // sin(x)/x at x = 0.12·π/180·80: deficit ≈ 80·x²/6 ≈ 0.37 °/s.
        assert!((0.3..0.45).contains(&deficit_dps), "deficit {deficit_dps}");
    }

    #[test]
    fn asymmetry_scales_the_two_rate_signs_differently() {
        let p = GyroParams::nominal();
        let vp = p.output_voltage(25.0, 40.0) - p.output_offset_v;
        let vn = p.output_voltage(25.0, -40.0) - p.output_offset_v;
        let ratio = vp / -vn;
        assert!((ratio - (1.0 + p.sf_asymmetry) / (1.0 - p.sf_asymmetry)).abs() < 1e-12);
    }

    #[test]
    fn arw_sample_std_matches_the_parameter() {
        let mut p = GyroParams::nominal();
        p.bias_instability_dph = 0.0;
        p.rrw_dph_per_sqrth = 0.0;
        p.adc_bits = 30;
        let mut noise = Noise::new(&p, 7);
        let n = 20_000;
        let s = p.scale_factor(25.0);
        let rates: Vec<f64> = (0..n)
            .map(|_| {
                let smp = noise.sample(&p, 25.0, 25.0, 0.0, 0.0);
                (smp.voltage_v - p.output_voltage(25.0, p.bias_dps(25.0))) / s
            })
            .collect();
        let mean = rates.iter().sum::<f64>() / f64::from(n);
        let var = rates.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / f64::from(n - 1);
        let sigma_dph = var.sqrt() * SECONDS_PER_HOUR;
        assert!(
            (sigma_dph - 6.0).abs() < 0.2,
            "σ = {sigma_dph} °/h, expected 6"
        );
    }
}
