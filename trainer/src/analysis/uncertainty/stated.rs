//! What a datasheet states that one power-on's calibration data cannot show, and what the σ
//! assumes where nothing states or measures it (module doc of [`super`]): another power-on's
//! bias and scale factor, the growth beyond the trained range, the heating/cooling leg the
//! training did not hold. One place, [`Calibration::state`], takes every figure for every blob
//! `fit` and `investigate` ship.

use firmware_core::blob::Beyond;
use fog_data::channels::Datasheet;

use super::{BOTH_LEGS, Calibration, LEG_SPAN, OWN_DRAW, ResidualSource};
use crate::firmware::export::{self, ExportError};
use crate::models::normalize::trained_range;

impl Calibration {
    /// States the bias of another power-on: `sigma`, output units (a datasheet's run-to-run
    /// repeatability), its variance twice over added to every sample's bias variance: the
    /// calibration's own power-on was a draw too.
    pub fn set_turn_on(&mut self, sigma: f64) {
        self.assumed.retain(|name| *name != "turn-on");
        self.measured.retain(|name| *name != "turn-on");
        self.turn_on_std = sigma;
        self.error_model.turn_on_var = (OWN_DRAW * sigma * sigma) as f32;
    }

    /// States another power-on's bias as the commands take it: `repeatability`, a datasheet's
    /// ([`Self::set_turn_on`]), or, with none, assumed ([`Self::assume_turn_on`]).
    pub fn turn_on(&mut self, repeatability: Option<f64>) {
        match repeatability {
            Some(sigma) => self.set_turn_on(sigma),
            None => self.assume_turn_on(),
        }
    }

    /// Assumes the bias of another power-on where no datasheet states it (`--repeatability`) and
    /// no power-on left out measured it ([`Self::runs_measured`]): one power-on's data cannot
    /// show it, and a σ that left it out would be certain of what it never saw. The difference
    /// of two power-ons' biases is taken as large as the model error's floor (twice the
    /// repeatability's variance is the floor's once; where the floor was fitted to 0, the other
    /// terms taking the residuals up, the smallest RMS of a residual series stands in), said in
    /// `assumed` as `turn-on`. On the simulated gyro with a turn-on repeatability of 80 °/h
    /// beside a thermal swing of 60 °/h this covered another power-on's 60 s means 87–95 %
    /// (docs/uncertainty.md).
    pub fn assume_turn_on(&mut self) {
        if self.runs_measured() || self.turn_on_std > 0.0 {
            return;
        }
        let seen = self
            .sources
            .iter()
            .map(|s| s.rmse)
            .filter(|r| *r > 0.0)
            .fold(f64::INFINITY, f64::min);
        let size = if self.floor_std > 0.0 || !seen.is_finite() {
            self.floor_std
        } else {
            seen
        };
        self.set_turn_on(size / OWN_DRAW.sqrt());
        if self.turn_on_std > 0.0 {
            self.assumed.push("turn-on");
        }
    }

    /// States the scale factor of another power-on: `ppm` of the output (a datasheet's run-to-run
    /// scale-factor repeatability, 1σ), its variance twice over (as for the bias) added to every
    /// sample's bias variance in proportion to the output².
    pub fn set_scale(&mut self, ppm: f64) {
        self.assumed.retain(|name| *name != "scale");
        self.measured.retain(|name| *name != "scale");
        self.scale_repeatability_ppm = ppm;
        self.error_model.scale_var = (OWN_DRAW * (ppm * 1e-6).powi(2)) as f32;
    }

    /// States another power-on's scale factor as the commands take it: `ppm`, a datasheet's
    /// ([`Self::set_scale`]), or, with none, assumed ([`Self::assume_scale`]).
    pub fn scale(&mut self, ppm: Option<f64>) {
        match ppm {
            Some(ppm) => self.set_scale(ppm),
            None => self.assume_scale(),
        }
    }

    /// Assumes the scale factor of another power-on where no datasheet states it
    /// (`--scale-repeatability`) and no power-ons were left out ([`Self::runs_measured`]: a
    /// table's runs hold it in their floor, alike at every rate they hold; a stream's measure it),
    /// as [`Self::assume_turn_on`] assumes its bias: the difference of two power-ons' scale
    /// factors is taken as large as the residuals' own model error in proportion to the output
    /// (`residual_scale_ppm`; twice the repeatability's variance is its variance once). Where the
    /// residuals show none, but their outputs move (`output_rms`), it is taken as large at the
    /// outputs' RMS as another power-on's bias is there ([`Self::turn_on_std`], assumed or a
    /// datasheet's): one power-on cannot show either, and the scale is no less a draw of the
    /// next power-on than the bias. Said in `assumed` as `scale`. At rest (outputs that barely
    /// move), or where that bias is 0, nothing is assumed and the fit says it skipped the term. A gyro's scale factor differs from one power-on to the
    /// next as its bias does (the FOG runs in `../shared` by −765 and +792 ppm), an error that
    /// grows with the rate where a bias term states the same at every rate.
    pub fn assume_scale(&mut self) {
        if self.runs_measured() || self.scale_repeatability_ppm > 0.0 {
            return;
        }
        let ppm = if self.residual_scale_ppm > 0.0 {
            self.residual_scale_ppm / OWN_DRAW.sqrt()
        } else if self.output_rms > 0.0 {
            self.turn_on_std / self.output_rms * 1e6
        } else {
            0.0
        };
        let ppm = if ppm.is_finite() { ppm } else { 0.0 };
        self.set_scale(ppm);
        if self.scale_repeatability_ppm > 0.0 {
            self.assumed.push("scale");
        }
    }

    /// Why no scale factor of another power-on is in the σ, where none is: neither stated
    /// (`stated`: a datasheet's figure was given) nor assumed ([`Self::assume_scale`]). `None`
    /// where one is.
    pub fn scale_skipped(&self, stated: bool) -> Option<&'static str> {
        if stated || self.scale_repeatability_ppm > 0.0 {
            return None;
        }
        Some(if self.power_ons_left_out.is_some() {
            "the power-ons left out show no error in proportion to the output"
        } else if self.runs_measured() {
            "the runs left out hold it in their floor, alike at every rate they hold"
        } else if self.residuals == 0 {
            "too few out-of-sample residuals to assume it from"
        } else if self.output_rms == 0.0 {
            "the outputs barely move, as at rest: no error in proportion to them shows"
        } else {
            "the residuals show no error in proportion to the output, and another power-on's \
             bias, which it would be assumed as large as at their RMS, is 0"
        })
    }

    /// The lines a command says for the terms the σ leaves out, each with why: another
    /// power-on's scale factor where [`Self::scale_skipped`] has a reason (`stated`: a
    /// datasheet's was given), and a heating rate unlike the calibration's
    /// ([`Self::heating_skipped_line`]).
    pub fn skipped_lines(&self, stated: bool) -> Vec<String> {
        let scale = self.scale_skipped(stated).map(|why| {
            format!(
                "skipped: the scale factor of another power-on ({why}; --scale-repeatability \
                 states a datasheet's run-to-run σ, in ppm)"
            )
        });
        scale
            .into_iter()
            .chain(self.heating_skipped_line())
            .collect()
    }

    /// States what `sheet` states for the blob this calibration is for, `blob`, whose mean
    /// follows `rule` beyond the trained range, and assumes another power-on's bias and scale
    /// where nothing states or measures them ([`Self::turn_on`], [`Self::scale`]): the one place
    /// every shipped σ takes a datasheet's figures (the sensor lag: [`Self::set_sensor_lag`]).
    pub fn state(
        &mut self,
        sheet: &Datasheet,
        blob: &[u8],
        rule: Beyond,
    ) -> Result<(), ExportError> {
        let model = fog_data::replay::decode(blob)?;
        self.trained_width_c = export::temperature_input(model.features())
            .and_then(|k| model.trained_range(k))
            .map(|[lo, hi]| f64::from(hi - lo))
            .filter(|w| *w > 0.0);
        self.turn_on(sheet.repeatability);
        self.scale(sheet.scale_repeatability);
        self.set_sensor_lag(sheet.sensor_lag_s);
        if let Some(per_c) = sheet.tempco {
            let width = self.trained_width_c.ok_or(ExportError::NoTemperature)?;
            self.set_tempco(per_c, width, rule == Beyond::Hold);
        }
        if let Some(band) = sheet.hysteresis {
            self.set_hysteresis(band);
        }
        Ok(())
    }

    /// States the bias's temperature coefficient beyond the trained range: `per_c`, output units
    /// per °C (a datasheet's), over the temperature input's trained width `width_c` °C. `held`:
    /// the blob's mean is held at the range's edge beyond it, and misses a bias that moves on at
    /// that rate by `per_c` per °C: `per_c · width_c` per trained width, the extrapolation term's
    /// part alike at every output, in place of the part assumed from the model's own trend inside
    /// the range. A mean that follows a tangent or the GP there moves on by its own slope too,
    /// which may run against the bias's (a bias that turns over): the part assumed for that rule
    /// (its share k of holding's miss) is added to the datasheet's, in quadrature. The part in
    /// proportion to the output stays as it was: a bias figure says nothing of the scale factor.
    /// Where the residuals fitted the term, the larger of the fit and the datasheet's stands: they
    /// reach a fraction of a width beyond the range, the datasheet all of it. So it does where
    /// their fit, below the growth assumed, did not ship ([`Self::extrapolation_fitted_std`]):
    /// where it is the larger, it ships now, as fitted.
    pub fn set_tempco(&mut self, per_c: f64, width_c: f64, held: bool) {
        self.tempco_per_c = Some(per_c);
        self.trained_width_c = Some(width_c);
        let stated = per_c * width_c;
        let fitted = self.fitted_terms.contains(&"extrapolation");
        let bias = if fitted {
            self.extrapolation_std.max(stated)
        } else if held {
            stated
        } else {
            stated.hypot(self.extrapolation_std)
        };
        let near = self.extrapolation_fitted_std.filter(|fit| *fit > bias);
        let bias = near.unwrap_or(bias);
        self.extrapolation_std = bias;
        self.error_model.extrapolation_var = (bias * bias) as f32;
        if near.is_some() {
            self.fitted_terms.push("extrapolation");
            self.extrapolation_fitted_std = None;
        }
        if !fitted && (held || near.is_some()) && self.extrapolation_scale_ppm == 0.0 {
            self.extrapolation_share = 1.0;
            self.assumed.retain(|name| *name != "extrapolation");
        }
    }

    /// Whether the residuals came from power-ons left out: a table's runs
    /// ([`ResidualSource::Runs`]), their model error then holding another power-on's bias and
    /// scale, or a training stream's (`power_ons_left_out`), which measure them.
    pub fn runs_measured(&self) -> bool {
        self.power_ons_left_out.is_some()
            || self
                .sources
                .iter()
                .any(|s| s.source == ResidualSource::Runs)
    }

    /// States the heating/cooling states the training stream held (`states`, each sample's, as
    /// the firmware tracks them, with its temperature: [`super::streams::legs`]). A leg counts as
    /// held where its states (beyond ±0.5) span at least half of the trained temperatures
    /// (`LEG_SPAN`): a few minutes at a turn hold its state at one temperature, not the leg (a
    /// window that starts where a ramp turned from cooling to heating carries the cooling state
    /// into its first minutes, as the gyro did). A side that reached a leg without holding it is
    /// then trained no further than the centre, 0, as after a start at rest. Where one leg only is held, the
    /// error of a full swing of the state is assumed as large as the model's out-of-sample error
    /// on the leg it saw (the RMS of the residuals of the training data, or the floor where there
    /// are none), said in `assumed`; the firmware adds it in proportion to how far a state lies
    /// beyond the trained ones (half of it at a full cooling state after a heating that started
    /// at rest).
    pub fn set_legs(&mut self, states: &[(f32, f64)]) {
        if states.is_empty() {
            return;
        }
        let mut sorted: Vec<f32> = states.iter().map(|(s, _)| *s).collect();
        sorted.sort_by(f32::total_cmp);
        let at = |q: f64| {
            sorted[((q * (sorted.len() - 1) as f64).round() as usize).min(sorted.len() - 1)]
        };
        let span = |keep: &dyn Fn(f32) -> bool| {
            let (lo, hi) = trained_range(states.iter().filter(|(s, _)| keep(*s)).map(|(_, t)| *t));
            if hi >= lo { hi - lo } else { 0.0 }
        };
        let width = span(&|_| true);
        let held = |keep: &dyn Fn(f32) -> bool| span(keep) >= LEG_SPAN * width;
        let (mut lo, mut hi) = (at(0.005), at(0.995));
        let cooling = lo <= -BOTH_LEGS && held(&|s| s <= -BOTH_LEGS);
        let heating = hi >= BOTH_LEGS && held(&|s| s >= BOTH_LEGS);
        // A side that reached a leg without holding it is trained to the centre.
        if lo <= -BOTH_LEGS && !cooling {
            (lo, hi) = (0.0, hi.max(0.0));
        }
        if hi >= BOTH_LEGS && !heating {
            (lo, hi) = (lo.min(0.0), 0.0);
        }
        self.legs_trained = Some((lo, hi));
        self.error_model.leg_min = lo;
        self.error_model.leg_max = hi;
        if cooling && heating {
            self.error_model.leg_var = 0.0;
            self.leg_std = 0.0;
            return;
        }
        let seen = self.sources.iter().map(|s| s.rmse).fold(0.0, f64::max);
        self.leg_std = seen.max(self.floor_std);
        // The firmware adds leg_var·l², l the distance beyond the trained states over the full
        // swing of 2: the error of a whole swing, in proportion to the part of it not trained
        // (from a training that turned half-way, a full turn misses half as much again).
        self.error_model.leg_var = (self.leg_std * self.leg_std) as f32;
        if !self.assumed.contains(&"leg") {
            self.assumed.push("leg");
        }
    }

    /// Whether the training held one heating/cooling leg only ([`Self::set_legs`]); false
    /// where it held both, or its states are not known (a rate table's soaks, alone or pooled
    /// with logs).
    pub fn one_leg(&self) -> bool {
        self.legs_trained
            .is_some_and(|(lo, hi)| !(lo <= -BOTH_LEGS && hi >= BOTH_LEGS))
    }

    /// States the heating/cooling gap: `band`, output units (a datasheet's thermal hysteresis),
    /// the error of a full swing of the state onto a leg the training did not hold, in place of
    /// the one [`Self::set_legs`] assumed. Where the training held both legs there is no leg
    /// term, stated or not (the model has seen both); where its states are not known, none
    /// either: the σ line says so.
    pub fn set_hysteresis(&mut self, band: f64) {
        self.hysteresis = Some(band);
        if self.one_leg() {
            self.leg_std = band;
            self.error_model.leg_var = (band * band) as f32;
            self.assumed.retain(|name| *name != "leg");
        }
    }
}
