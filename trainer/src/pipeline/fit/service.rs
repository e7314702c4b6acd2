//! What a fitted blob states for service, written into it last: the sensor's limits (beyond
//! which a reading is a fault), a datasheet's figures (the bias and scale of another power-on,
//! the growth beyond the trained range, the leg not trained; each assumed where nothing states
//! or measures it: [`Calibration::state`]), and the mean's rule beyond the trained range (chosen
//! on the training data unless asked).

use firmware_core::blob::{Beyond, Limits};
use fog_data::channels::Channel;
use fog_data::replay;

use super::Service;
use crate::analysis::beyond::{self, BeyondChoice};
use crate::analysis::uncertainty::Calibration;
use crate::data::points::Points;
use crate::firmware::export;
use crate::models::gp::GpConfig;

impl Service {
    /// This service for `channel`: its own datasheet's figures and full scale (a channels file's
    /// `[[channel]]`), each where it states one, else the command's.
    pub fn for_channel(&self, channel: &Channel) -> Self {
        Self {
            full_scale: channel.full_scale.map(|f| f as f32).or(self.full_scale),
            sheet: channel.datasheet.or(self.sheet),
            ..self.clone()
        }
    }

    /// The blob's limits.
    pub fn limits(&self) -> Limits {
        let (temp_min_c, temp_max_c) = self
            .rated_temp
            .unwrap_or((Limits::DEFAULT.temp_min_c, Limits::DEFAULT.temp_max_c));
        Limits {
            temp_min_c,
            temp_max_c,
            full_scale: self.full_scale.unwrap_or(0.0),
        }
    }

    /// The rule beyond the trained range: as asked, or chosen on `points` (fitted as `gp`).
    pub fn beyond(&self, points: &Points, gp: &GpConfig) -> BeyondChoice {
        let asked = |rule, name| BeyondChoice {
            rule,
            inside_c: None,
            scored: 0,
            rmse: None,
            verdict: format!("{name} as asked (--beyond)"),
        };
        match self.beyond {
            None => beyond::choose(points, gp),
            Some(Beyond::Tangent) => asked(Beyond::Tangent, "along the tangent"),
            Some(Beyond::Hold) => asked(Beyond::Hold, "held at the edge"),
            Some(Beyond::Follow) => asked(Beyond::Follow, "the GP's own prediction"),
        }
    }

    /// `blob` (its σ `calibration`) with the limits, the datasheet's figures and the rule beyond
    /// the trained range written in.
    pub fn apply(
        &self,
        blob: &[u8],
        calibration: &mut Calibration,
        beyond: Beyond,
    ) -> anyhow::Result<Vec<u8>> {
        calibration.state(&self.sheet, blob, beyond)?;
        let blob = calibration.apply(blob)?;
        let limits = self.limits();
        let blob = export::with_limits(&blob, &limits)?;
        let fw = replay::decode(&blob).map_err(|_| {
            anyhow::anyhow!(
                "the training data hold readings beyond the sensor's limits (rated {}…{} °C{}): \
                 a reading that was recorded is possible; widen --rated-temp or --full-scale",
                limits.temp_min_c,
                limits.temp_max_c,
                if limits.full_scale > 0.0 {
                    format!(", full scale ±{}", limits.full_scale)
                } else {
                    String::new()
                }
            )
        })?;
        debug_assert_eq!(fw.limits(), limits);
        Ok(export::with_beyond(&blob, beyond)?)
    }
}
