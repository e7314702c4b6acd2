//! A calibration in words: the σ line `fit` and `investigate` print, each term with where it
//! came from (fitted, stated, assumed).

use super::streams::WalkReading;
use super::{Calibration, ResidualSource};

impl Calibration {
    /// One line for a person.
    pub fn describe(&self, units: &str) -> String {
        let leg = match (self.one_leg(), self.hysteresis) {
            (true, _) => {
                let source = if self.assumed.contains(&"leg") {
                    "assumed; a datasheet's heating/cooling gap states it: --hysteresis"
                } else {
                    "the datasheet's heating/cooling gap"
                };
                format!(
                    "; on the heating/cooling leg the training did not hold, {:.3e} {units} more \
                     ({source})",
                    self.leg_std
                )
            }
            (false, Some(_)) if self.legs_trained.is_some() => {
                "; no leg term: the training held both heating and cooling, their gap is in the \
                 model error (the datasheet's heating/cooling gap not used)"
                    .to_owned()
            }
            (false, Some(_)) => "; no leg term: the training's heating/cooling states are not \
                                 known (a rate table's soaks, alone or pooled with logs; the \
                                 datasheet's heating/cooling gap not used)"
                .to_owned(),
            (false, None) => String::new(),
        };
        let turn_on = if self.assumed.contains(&"turn-on") {
            let size = if self.floor_std > 0.0 {
                "the model error's floor"
            } else {
                "the smallest RMS of a residual series, the floor fitted 0"
            };
            format!(
                "; another power-on's bias {:.3e} {units} (assumed: the difference of two \
                 power-ons as large as {size}; --repeatability states a datasheet's)",
                self.turn_on_std
            )
        } else if self.measured.contains(&"turn-on") {
            format!(
                "; another power-on's bias {:.3e} {units} (measured: the mean errors of {} \
                 power-ons left out, widened for the few)",
                self.turn_on_std,
                self.power_ons_left_out.unwrap_or(0)
            )
        } else if self.turn_on_std > 0.0 {
            format!(
                "; another power-on's bias {:.3e} {units} (--repeatability)",
                self.turn_on_std
            )
        } else if self.runs_measured() && self.power_ons_left_out.is_none() {
            "; another power-on's bias is in the model error (measured on the runs left out)"
                .to_owned()
        } else {
            String::new()
        };
        let scale = if self.assumed.contains(&"scale") && self.residual_scale_ppm > 0.0 {
            format!(
                "; another power-on's scale {:.0} ppm of the output (assumed: the difference of \
                 two power-ons as large as the residuals' model error in proportion to the \
                 output, {:.0} ppm; --scale-repeatability states a datasheet's)",
                self.scale_repeatability_ppm, self.residual_scale_ppm
            )
        } else if self.assumed.contains(&"scale") {
            format!(
                "; another power-on's scale {:.0} ppm of the output (assumed: the residuals show \
                 no error in proportion to the output, so as large at their outputs' RMS, \
                 {:.3e} {units}, as another power-on's bias; --scale-repeatability states a \
                 datasheet's)",
                self.scale_repeatability_ppm, self.output_rms
            )
        } else if self.measured.contains(&"scale") {
            format!(
                "; another power-on's scale {:.0} ppm of the output (measured: the error in \
                 proportion to the output of {} power-ons left out, widened for the few)",
                self.scale_repeatability_ppm,
                self.power_ons_left_out.unwrap_or(0)
            )
        } else if self.scale_repeatability_ppm > 0.0 {
            format!(
                "; another power-on's scale {:.0} ppm of the output (--scale-repeatability)",
                self.scale_repeatability_ppm
            )
        } else {
            String::new()
        };
        self.describe_terms(units) + &leg + &turn_on + &scale + &self.heating_in_words(units)
    }

    /// The residuals' sources, each kind counted once (several series of one kind together).
    fn sources_in_words(&self) -> String {
        let mut counted: Vec<(ResidualSource, usize)> = Vec::new();
        for s in &self.sources {
            match counted.iter_mut().find(|(source, _)| *source == s.source) {
                Some((_, n)) => *n += s.n,
                None => counted.push((s.source, s.n)),
            }
        }
        counted
            .iter()
            .map(|(source, n)| format!("{n} {}", source.describe()))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The white noise it states: one sample's where a log showed it, else the GP's level at a
    /// point, whose interval is not known.
    pub(super) fn noise_in_words(&self) -> String {
        if self.sample_interval_s > 0.0 {
            format!("one sample's noise {:.3e}", self.sample_noise_std)
        } else {
            format!(
                "a point's noise {:.3e} (no sample's is known)",
                self.sample_noise_std
            )
        }
    }

    fn describe_terms(&self, units: &str) -> String {
        let share = if self.extrapolation_share < 1.0 {
            format!(
                " (× {:.2}: the share of holding's miss the rule shipped missed beyond an inner \
                 fit, widened for its points)",
                self.extrapolation_share
            )
        } else {
            String::new()
        };
        let beyond = if let Some(per_c) = self.tempco_per_c {
            let scale = if self.extrapolation_scale_ppm > 0.0 {
                format!(
                    " and {:.0} ppm of the output{share}",
                    self.extrapolation_scale_ppm
                )
            } else {
                String::new()
            };
            let width = self.trained_width_c.unwrap_or(0.0);
            let stated = per_c * width;
            let source = if self.fitted_terms.contains(&"extrapolation")
                && self.extrapolation_std > stated
            {
                format!("fitted, larger than the datasheet's {per_c:.3e} {units} per °C")
            } else if self.extrapolation_std > stated * (1.0 + 1e-9) {
                format!(
                    "the datasheet's bias at {per_c:.3e} {units} per °C, and the model's own \
                     change under the rule it follows beyond the range"
                )
            } else {
                format!("datasheet: the bias at {per_c:.3e} {units} per °C")
            };
            format!(
                "{:.3e}{scale} per trained width of {width:.1} °C beyond the range ({source})",
                self.extrapolation_std
            )
        } else if self.extrapolation_scale_ppm > 0.0 {
            format!(
                "{:.3e} and {:.0} ppm of the output per trained width beyond the range{share}",
                self.extrapolation_std, self.extrapolation_scale_ppm
            )
        } else {
            format!(
                "{:.3e} per trained width beyond the range{share}",
                self.extrapolation_std
            )
        };
        let beyond = match self.extrapolation_fitted_std {
            Some(fit) => format!(
                "{beyond}, where the residuals, fewer than three a whole width beyond the \
                 range, fitted {fit:.3e} {units}: a growth near the edge, not a width out"
            ),
            None => beyond,
        };
        let noise = self.noise_in_words();
        let allan = self.measured.contains(&"walk");
        let read = match self.walk_read {
            Some(WalkReading::ForwardSplit) => {
                "the Allan deviation of the forward split's model's errors over the part it was \
                 not fitted on"
            }
            Some(WalkReading::WholeLog) => "the Allan deviation of the model's errors over it",
            None => "its Allan deviation",
        };
        let walk = match (allan, self.walk_fitted_std) {
            (true, Some(fit)) => format!(
                "{:.3e} per √h (the training log's rate random walk, from {read}; the residuals \
                 fitted {fit:.3e}, one stretch of it)",
                self.walk_std_per_sqrt_h
            ),
            (true, None) => format!(
                "{:.3e} per √h (the training log's rate random walk, from {read}; the residuals \
                 fitted none)",
                self.walk_std_per_sqrt_h
            ),
            (false, _) => format!("{:.3e} per √h", self.walk_std_per_sqrt_h),
        };
        let Some(c) = &self.coverage else {
            let walk = if allan {
                format!(
                    ", {:.3e} per √h (the training log's rate random walk, from {read})",
                    self.walk_std_per_sqrt_h
                )
            } else {
                String::new()
            };
            return format!(
                "σ: the GP's own, with {noise} and an assumed model error {:.3e} {units}, \
                 {beyond}{walk} ({}; module doc of trainer::analysis::uncertainty)",
                self.floor_std,
                self.note.as_deref().unwrap_or("no error model")
            );
        };
        let assumed = if self.assumed.is_empty() {
            String::new()
        } else {
            format!(
                "; assumed, the data could not show it: {}",
                self.assumed.join(", ")
            )
        };
        let before = self
            .before
            .map(|b| format!("{:.0}%", 100.0 * b.within_2sigma))
            .unwrap_or_default();
        format!(
            "σ calibrated on {} out-of-sample residuals of the training data ({:.1} independent; \
             {}): model error {:.3e} {units}, {beyond}, {walk}, {:.3e} per h (× {:.2} \
             for the few residuals, on the terms they fitted), {noise}; \
             ±2σ covers {:.0}% of them (the GP's own σ: {before}), median σ {:.2}× their \
             RMS{assumed}",
            self.residuals,
            self.effective,
            self.sources_in_words(),
            self.floor_std,
            self.trend_std_per_h,
            self.inflation.sqrt(),
            100.0 * c.within_2sigma,
            c.sharpness
        )
    }
}
