//! The unit file: a simulated gyro's parameters and hidden effects (or several axes' of one unit,
//! [`crate::gyro::axes`]), as `firmware-sim identify` writes it from measured data and `generate
//! paper|stream --unit FILE` simulates it. One definition of the format, here beside the plant it
//! parameterizes, for both programs.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::gyro::axes::Axes;
use crate::gyro::effects::Effect;
use crate::gyro::plant::GyroParams;

/// A simulated gyro: its parameters and hidden effects. The unit file's format.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Unit {
    /// The output map, temperature dependence and noise.
    pub params: GyroParams,
    /// Effects acting on it, with their fitted strengths.
    pub effects: Vec<Effect>,
}

/// A unit file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum UnitError {
    /// Unreadable.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not a unit file.
    #[error("{path}: not a unit file ({source})")]
    Format {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: serde_json::Error,
    },
    /// A number that no gyro has.
    #[error("{path}: {what} is {value}, which no gyro has")]
    Invalid {
        /// The file.
        path: std::path::PathBuf,
        /// Which parameter.
        what: &'static str,
        /// Its value.
        value: f64,
    },
}

impl Unit {
    /// Reads and checks a unit file (`identify --out`).
    pub fn load(path: &Path) -> Result<Self, UnitError> {
        let unit: Unit =
            serde_json::from_str(&read(path)?).map_err(|source| UnitError::Format {
                path: path.to_owned(),
                source,
            })?;
        check(path, &unit.params, &unit.effects)?;
        Ok(unit)
    }
}

/// A unit file as `generate --unit FILE` takes it: one gyro, or several axes (`identify
/// --channels --out`).
#[derive(Debug, Clone, PartialEq)]
pub enum UnitFile {
    /// One gyro.
    One(Unit),
    /// A unit of several axes.
    Axes(Axes),
}

impl UnitFile {
    /// Reads and checks a unit file of either kind.
    pub fn load(path: &Path) -> Result<Self, UnitError> {
        let text = read(path)?;
        if let Ok(axes) = serde_json::from_str::<Axes>(&text) {
            for a in &axes.axes {
                check(path, &a.params, &a.effects)?;
            }
            return Ok(Self::Axes(axes));
        }
        Unit::load(path).map(Self::One)
    }
}

fn read(path: &Path) -> Result<String, UnitError> {
    std::fs::read_to_string(path).map_err(|source| UnitError::Io {
        path: path.to_owned(),
        source,
    })
}

/// A gyro's parameters and effects checked: numbers that some gyro has.
fn check(path: &Path, p: &GyroParams, effects: &[Effect]) -> Result<(), UnitError> {
    let checks: [(&'static str, f64, bool); 10] = [
        (
            "turn_on_bias_dph",
            p.turn_on_bias_dph,
            p.turn_on_bias_dph.is_finite() && p.turn_on_bias_dph >= 0.0,
        ),
        (
            "turn_on_scale_ppm",
            p.turn_on_scale_ppm,
            p.turn_on_scale_ppm.is_finite() && p.turn_on_scale_ppm >= 0.0,
        ),
        (
            "scale_factor_v_per_dps",
            p.scale_factor_v_per_dps,
            p.scale_factor_v_per_dps != 0.0,
        ),
        ("sagnac_k_s", p.sagnac_k_s, p.sagnac_k_s > 0.0),
        ("arw_dpsqrth", p.arw_dpsqrth, p.arw_dpsqrth >= 0.0),
        (
            "bias_instability_dph",
            p.bias_instability_dph,
            p.bias_instability_dph >= 0.0,
        ),
        (
            "bias_instability_tau_s",
            p.bias_instability_tau_s,
            p.bias_instability_tau_s > 0.0,
        ),
        (
            "rrw_dph_per_sqrth",
            p.rrw_dph_per_sqrth,
            p.rrw_dph_per_sqrth >= 0.0,
        ),
        ("temp_noise_c", p.temp_noise_c, p.temp_noise_c >= 0.0),
        (
            "adc_bits",
            f64::from(p.adc_bits),
            (1..=30).contains(&p.adc_bits),
        ),
    ];
    for (what, value, ok) in checks {
        if !(ok && value.is_finite()) {
            return Err(UnitError::Invalid {
                path: path.to_owned(),
                what,
                value,
            });
        }
    }
    for e in effects {
        let lag = match *e {
            Effect::SensorLag { tau_min } | Effect::WarmUp { tau_min, .. } => tau_min,
            _ => 1.0,
        };
        if !(e.strength().is_finite() && lag.is_finite() && lag > 0.0) {
            return Err(UnitError::Invalid {
                path: path.to_owned(),
                what: "an effect's strength or time constant",
                value: if lag > 0.0 { e.strength() } else { lag },
            });
        }
    }
    Ok(())
}
