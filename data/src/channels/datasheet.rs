//! A channel's datasheet: the figures that one power-on's calibration data cannot show, which a
//! user states for the σ of every blob (`fit`'s and `investigate`'s flags, or a channels file's
//! `[[channel]]`), one definition for both.

/// A datasheet's figure that cannot be one: its field (a channels file's key; the flag's name
/// with `-` for `_`), and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{field} {why}")]
pub struct InvalidFigure {
    /// The field.
    pub field: &'static str,
    /// Why not.
    pub why: &'static str,
}

impl InvalidFigure {
    /// The command-line flag that states the field.
    pub fn flag(&self) -> String {
        format!("--{}", self.field.replace('_', "-"))
    }
}

/// The largest scale-factor repeatability a σ states, ppm: a scale that varies by its whole size
/// from one power-on to the next is no sensor's.
const MAX_PPM: f64 = 1e6;

/// The longest sensor lag a σ states, s: a sensor a day behind its element reads no temperature of
/// it at all.
const MAX_LAG_S: f64 = 86_400.0;

/// What a datasheet states that one power-on's calibration data cannot show (docs/uncertainty.md,
/// "What the data cannot show"), as `fit` and `investigate` take it, from their flags or a
/// channels file's channel, in the channel's quantity's unit (°/s, m/s²). Each `None` where it
/// is not stated: then measured where the data show it, else assumed (another power-on's bias,
/// the growth beyond the range, the leg not trained; the scale factor where the residuals err in
/// proportion to the output, else left out and said; a sensor lag of 30 s).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Datasheet {
    /// The bias's run-to-run repeatability, 1σ (`--repeatability`).
    pub repeatability: Option<f64>,
    /// The scale factor's run-to-run repeatability, 1σ, ppm (`--scale-repeatability`).
    pub scale_repeatability: Option<f64>,
    /// The bias's temperature coefficient, per °C (`--tempco`).
    pub tempco: Option<f64>,
    /// The gap between the heating and the cooling leg at one temperature (`--hysteresis`).
    pub hysteresis: Option<f64>,
    /// How far the temperature sensor lags the sensing element, s (`--sensor-lag`): the time
    /// constant of the heat's path from one to the other.
    pub sensor_lag_s: Option<f64>,
}

impl Datasheet {
    /// Whether it states a figure in one channel's units, which channels in other units cannot
    /// share: all but the scale factor's ppm and a 0, which means the same in every unit (a bias
    /// that repeats exactly, one that does not move with temperature, no heating/cooling gap).
    pub fn in_one_channels_units(&self) -> bool {
        let units = |v: Option<f64>| v.is_some_and(|v| v != 0.0);
        units(self.repeatability) || units(self.tempco) || units(self.hysteresis)
    }

    /// Each figure this one states, else `other`'s: a channel's own before the command's.
    pub fn or(self, other: Self) -> Self {
        Self {
            repeatability: self.repeatability.or(other.repeatability),
            scale_repeatability: self.scale_repeatability.or(other.scale_repeatability),
            tempco: self.tempco.or(other.tempco),
            hysteresis: self.hysteresis.or(other.hysteresis),
            sensor_lag_s: self.sensor_lag_s.or(other.sensor_lag_s),
        }
    }

    /// The first figure that cannot be one: each is a number not below 0, the scale factor's at
    /// most 10⁶ ppm (100 %), the sensor lag at most a day.
    pub fn check(&self) -> Result<(), InvalidFigure> {
        let plain = |v: Option<f64>| v.is_none_or(|t| t.is_finite() && t >= 0.0);
        let invalid = |field, why| Err(InvalidFigure { field, why });
        if !plain(self.repeatability) {
            invalid("repeatability", "must be a σ: a number not below 0")
        } else if !self
            .scale_repeatability
            .is_none_or(|r| (0.0..=MAX_PPM).contains(&r))
        {
            invalid(
                "scale_repeatability",
                "must be a σ in ppm: a number from 0 to 1e6 (100 %)",
            )
        } else if !plain(self.tempco) {
            invalid(
                "tempco",
                "must be a number not below 0, in the channel's units per °C",
            )
        } else if !plain(self.hysteresis) {
            invalid(
                "hysteresis",
                "must be a number not below 0, in the channel's units",
            )
        } else if !self
            .sensor_lag_s
            .is_none_or(|s| (0.0..=MAX_LAG_S).contains(&s))
        {
            invalid(
                "sensor_lag",
                "must be a time constant in seconds: a number from 0 to 86400 (a day)",
            )
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_channels_own_figures_come_before_the_commands_and_each_is_checked() {
        let channel = Datasheet {
            tempco: Some(0.03),
            scale_repeatability: Some(300.0),
            ..Datasheet::default()
        };
        let command = Datasheet {
            repeatability: Some(0.01),
            scale_repeatability: Some(800.0),
            tempco: Some(0.05),
            hysteresis: None,
            sensor_lag_s: Some(90.0),
        };
        assert_eq!(
            channel.or(command),
            Datasheet {
                repeatability: Some(0.01),
                scale_repeatability: Some(300.0),
                tempco: Some(0.03),
                hysteresis: None,
                sensor_lag_s: Some(90.0),
            }
        );
        // A 0 means the same in every unit; the ppm are no channel's units.
        let alike = Datasheet {
            repeatability: Some(0.0),
            scale_repeatability: Some(300.0),
            tempco: Some(0.0),
            hysteresis: Some(0.0),
            sensor_lag_s: Some(30.0),
        };
        assert!(!alike.in_one_channels_units());
        assert!(channel.in_one_channels_units());
        assert_eq!(command.check(), Ok(()));
        let bad = |sheet: Datasheet| sheet.check().err().map(|e| e.field);
        let nan = Datasheet {
            tempco: Some(f64::NAN),
            ..Datasheet::default()
        };
        assert_eq!(bad(nan), Some("tempco"));
        let too_large = Datasheet {
            scale_repeatability: Some(2e6),
            ..Datasheet::default()
        };
        assert_eq!(bad(too_large), Some("scale_repeatability"));
        assert_eq!(
            too_large.check().unwrap_err().flag(),
            "--scale-repeatability"
        );
        let negative = Datasheet {
            hysteresis: Some(-1.0),
            ..Datasheet::default()
        };
        assert_eq!(bad(negative), Some("hysteresis"));
        let late = Datasheet {
            sensor_lag_s: Some(1e6),
            ..Datasheet::default()
        };
        assert_eq!(bad(late), Some("sensor_lag"));
        assert_eq!(late.check().unwrap_err().flag(), "--sensor-lag");
    }
}
