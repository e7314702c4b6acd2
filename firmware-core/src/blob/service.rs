//! What a blob states for service where its calibration did not reach, besides the GP: the model
//! error its σ carries ([`ErrorModel`]), the readings that cannot be true ([`Limits`]) and what the
//! mean does beyond the trained range ([`Beyond`]). Each is a short run of numbers after the
//! payload's, written in place by [`super::set_error_model`], [`super::set_limits`] and
//! [`super::set_beyond`].

use serde::{Deserialize, Serialize};

use crate::error::BlobError;

/// What the variance of a compensated sample holds besides the GP's latent variance (format
/// version 5, the turn-on and leg terms version 6, the scale term version 7, the extrapolation's
/// scale part version 8, the heating term version 9): the white noise of one sample, and the model
/// error the trainer measured on its own training data, predicting it forward in time, beyond the
/// temperatures fitted and across the groups left out, or, where those data could not show a
/// term, the prior it stated instead (docs/design.md §4, "The σ contract"). All variances but
/// the three scale terms' (relative²) are in output units² (°/s²); the evaluator
/// ([`crate::model`]) adds, at inputs x, compensated output y, t hours since power-on,
/// heating/cooling state s and heating rate r at temperature T,
///
/// ```text
/// bias variance  = latent(x) + floor + (extrapolation + extrapolation_scale·y²)·e(x)²
///                  + walk·t + trend·t² + leg·l(s)² + (heating + heating_scale·y²)·h(T, r)²
///                  + turn_on + scale·y²          (the last two on another power-on only)
///                  + f(x)²
/// noise variance = sample_noise (one sample of sample_interval_s)
/// ```
///
/// with e(x)² = Σ_k (distance of input k beyond its trained range / that range's width)² over
/// the inputs the kernel or the prior mean reads, f(x)² = Σ_k (what input k's raw linear term
/// added past its trained range's edge)² over those only that term reads (`crate::model`, module
/// doc: no number of its own, the blob's coefficient states it), and
/// l(s) the distance of the state s ∈ [−1, 1] ([`crate::features::FeatureState::leg`]: +1 after
/// heating, −1 after cooling) outside the states trained, [leg_min, leg_max], over the full
/// swing 2 (0.5 on a cooling leg after a heating-only calibration that started at rest), and
/// h(T, r) how far the heating rate r ([`crate::features::FeatureState::heating_rate`], °C/min)
/// lies outside the band of rates the calibration held at T: r less the band's line
/// (`heating_rate_at_0c + heating_rate_per_c · T`, T held within the temperatures the band was
/// read over), beyond [`Self::heating_rate_min`, `heating_rate_max`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ErrorModel {
    /// White noise of one sample, output units²: what averages away over a mean.
    pub sample_noise_var: f32,
    /// The sample interval `sample_noise_var` describes, s: a mean over τ seconds has
    /// `sample_noise_var · sample_interval_s / τ` of noise. 0 where it is not known (a blob of
    /// format 3 or 4): the noise is then not divided.
    pub sample_interval_s: f32,
    /// Model error everywhere, output units².
    pub floor_var: f32,
    /// Model error per trained range width beyond it, squared (output units² per width²).
    pub extrapolation_var: f32,
    /// Model error growing as a random walk with time since power-on, output units² per hour.
    pub walk_var_per_h: f32,
    /// Model error growing as a drift of unknown rate, output units² per hour².
    pub trend_var_per_h2: f32,
    /// The bias of another power-on than calibration's, output units²: twice a datasheet's
    /// run-to-run repeatability squared (the calibration's own power-on was a draw too), or,
    /// where nothing states it, as the trainer assumes it (the model error's floor), or measured
    /// on a training log's power-ons left out in turn (each one's mean error, predicted from the
    /// others); 0 where runs left out (several logs or tables) measured it (it is then in the
    /// floor). Every power-on in service is another one, so it holds at every sample.
    pub turn_on_var: f32,
    /// Model error on a heating/cooling state the calibration did not hold, at a full swing
    /// (l = 1), output units².
    pub leg_var: f32,
    /// The lowest heating/cooling state trained, in [−1, 1].
    pub leg_min: f32,
    /// The highest heating/cooling state trained, in [`Self::leg_min`], 1].
    pub leg_max: f32,
    /// The scale factor of another power-on than calibration's, relative² (the trainer writes
    /// twice a datasheet's repeatability squared, as for the bias: 100 ppm is 2e-8). Its variance
    /// at the compensated output y is `scale_var · y²`: an error that grows with the rate, which
    /// no bias term states.
    pub scale_var: f32,
    /// The part of the model error beyond the trained range that grows with the output: relative²
    /// per trained width² (at output y and e(x) widths beyond, `extrapolation_scale · y² · e²`).
    /// A gyro's scale factor changes with temperature as its bias does, so beyond the range
    /// its error grows with the rate as well as with the distance. The trainer measures it per
    /// width of temperature; e(x)² counts every input's distance, so beyond the trained rates
    /// (the output's own input) it grows as y²·e² there too, as y⁴: wide, never narrow.
    pub extrapolation_scale_var: f32,
    /// Model error per °C/min of heating rate outside the band the calibration held, squared
    /// (output units² per (°C/min)²): a temperature sensor that lags the sensing element by τ
    /// reads it wrong by τ·r, which a calibration at one rate per temperature folds into its
    /// model and a rate unlike it undoes (the trainer writes (slope · τ)², the slope the model's
    /// change per °C, its part alike at every output, τ the sensor lag). 0: no such term.
    pub heating_var: f32,
    /// The same error's part in proportion to the output, relative² per (°C/min)² (at output y,
    /// `heating_scale_var · y² · h²`): a scale factor that changes with temperature, read at the
    /// wrong one, errs in proportion to the rate.
    pub heating_scale_var: f32,
    /// The band's line: the heating rate at 0 °C, °C/min.
    pub heating_rate_at_0c: f32,
    /// The band's line: its change per °C, °C/min per °C.
    pub heating_rate_per_c: f32,
    /// The band's lower edge about its line, °C/min.
    pub heating_rate_min: f32,
    /// The band's upper edge about its line, °C/min (not below [`Self::heating_rate_min`]).
    pub heating_rate_max: f32,
    /// The coldest temperature the band was read at, °C: colder, the line is read here (a
    /// warm-up's line, continued far beyond its temperatures, would move by °C/min).
    pub heating_temp_min_c: f32,
    /// The warmest, °C (not below [`Self::heating_temp_min_c`]).
    pub heating_temp_max_c: f32,
}

impl ErrorModel {
    /// Numbers in its encoding.
    pub const NUMBERS: usize = 20;
    /// Numbers in its encoding of format [`super::V8`]: the first twelve.
    pub const V8_NUMBERS: usize = 12;
    /// Numbers in its encoding of format [`super::V7`]: the first eleven.
    pub const V7_NUMBERS: usize = 11;
    /// Numbers in its encoding of format [`super::V6`]: the first ten.
    pub const V6_NUMBERS: usize = 10;
    /// Numbers in its encoding of format [`super::V5`]: the first six.
    pub const V5_NUMBERS: usize = 6;

    /// The error model of a blob without one (format 3 or 4): its noise variance as the sample
    /// noise, at an unknown interval, and no model error. The evaluator's variances are then
    /// what they were for those blobs.
    pub const fn noise_only(noise_var: f32) -> Self {
        Self::from_v5([noise_var, 0.0, 0.0, 0.0, 0.0, 0.0])
    }

    /// A format-[`super::V5`] error model's six numbers, with no turn-on, leg or scale term.
    pub const fn from_v5(v: [f32; Self::V5_NUMBERS]) -> Self {
        Self::from_v6([v[0], v[1], v[2], v[3], v[4], v[5], 0.0, 0.0, -1.0, 1.0])
    }

    /// A format-[`super::V6`] error model's ten numbers, with no scale term.
    pub const fn from_v6(v: [f32; Self::V6_NUMBERS]) -> Self {
        Self::from_v7([
            v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], 0.0,
        ])
    }

    /// A format-[`super::V7`] error model's eleven numbers, with no scale part of the
    /// extrapolation and no heating term.
    pub const fn from_v7(v: [f32; Self::V7_NUMBERS]) -> Self {
        Self::from_v8([
            v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], 0.0,
        ])
    }

    /// A format-[`super::V8`] error model's twelve numbers, with no heating term.
    pub const fn from_v8(v: [f32; Self::V8_NUMBERS]) -> Self {
        Self {
            sample_noise_var: v[0],
            sample_interval_s: v[1],
            floor_var: v[2],
            extrapolation_var: v[3],
            walk_var_per_h: v[4],
            trend_var_per_h2: v[5],
            turn_on_var: v[6],
            leg_var: v[7],
            leg_min: v[8],
            leg_max: v[9],
            scale_var: v[10],
            extrapolation_scale_var: v[11],
            heating_var: 0.0,
            heating_scale_var: 0.0,
            heating_rate_at_0c: 0.0,
            heating_rate_per_c: 0.0,
            heating_rate_min: 0.0,
            heating_rate_max: 0.0,
            heating_temp_min_c: 0.0,
            heating_temp_max_c: 0.0,
        }
    }

    /// Its numbers, in encoding order.
    pub const fn numbers(&self) -> [f32; Self::NUMBERS] {
        [
            self.sample_noise_var,
            self.sample_interval_s,
            self.floor_var,
            self.extrapolation_var,
            self.walk_var_per_h,
            self.trend_var_per_h2,
            self.turn_on_var,
            self.leg_var,
            self.leg_min,
            self.leg_max,
            self.scale_var,
            self.extrapolation_scale_var,
            self.heating_var,
            self.heating_scale_var,
            self.heating_rate_at_0c,
            self.heating_rate_per_c,
            self.heating_rate_min,
            self.heating_rate_max,
            self.heating_temp_min_c,
            self.heating_temp_max_c,
        ]
    }

    /// The index of its first non-finite number, else whether every number is in its domain
    /// (variances and the interval not negative, −1 ≤ leg_min ≤ leg_max ≤ 1, the heating band's
    /// edges and its temperatures in order).
    pub fn check(&self) -> Result<(), BlobError> {
        let numbers = self.numbers();
        if let Some(i) = numbers.iter().position(|v| !v.is_finite()) {
            return Err(BlobError::NonFinite(i));
        }
        let legs = -1.0 <= self.leg_min && self.leg_min <= self.leg_max && self.leg_max <= 1.0;
        if legs
            && numbers.iter().take(8).all(|v| *v >= 0.0)
            && self.scale_var >= 0.0
            && self.extrapolation_scale_var >= 0.0
            && self.heating_var >= 0.0
            && self.heating_scale_var >= 0.0
            && self.heating_rate_min <= self.heating_rate_max
            && self.heating_temp_min_c <= self.heating_temp_max_c
        {
            Ok(())
        } else {
            Err(BlobError::InvalidParameter)
        }
    }

    /// Noise variance of a mean over `window_s` seconds: the sample noise divided by the samples
    /// in it (not divided where the interval is unknown, nor for a window shorter than a sample).
    pub fn noise_of_mean(&self, window_s: f32) -> f32 {
        if self.sample_interval_s > 0.0 && window_s > self.sample_interval_s {
            self.sample_noise_var * self.sample_interval_s / window_s
        } else {
            self.sample_noise_var
        }
    }

    /// l(s): how far the heating/cooling state `leg` lies outside the states trained, over the
    /// full swing (0 inside them, 1 at the far end of a one-leg calibration).
    pub fn leg_excess(&self, leg: f32) -> f32 {
        ((self.leg_min - leg).max(leg - self.leg_max).max(0.0) * 0.5).min(1.0)
    }

    /// h(T, r): how far the heating rate `rate` (°C/min) lies outside the band the calibration
    /// held at the temperature `temp_c`, °C/min (0 inside it).
    pub fn heating_excess(&self, temp_c: f32, rate: f32) -> f32 {
        // max/min, not clamp: a hand-built model whose edges are out of order must not panic.
        let t = temp_c
            .max(self.heating_temp_min_c)
            .min(self.heating_temp_max_c);
        let about = rate - (self.heating_rate_at_0c + self.heating_rate_per_c * t);
        (self.heating_rate_min - about)
            .max(about - self.heating_rate_max)
            .max(0.0)
    }

    /// The model error at `excess2` (e(x)², trained widths²) and compensated output `output` in
    /// the conditions `at`: hours since power-on, heating/cooling state (`None`: one the
    /// calibration held, no leg term), temperature and heating rate (`None`: a rate the
    /// calibration held, no heating term), and whether another power-on's bias and scale apply.
    pub fn model_error(&self, excess2: f32, output: f32, at: crate::model::Conditions) -> f32 {
        let h = at.hours.max(0.0);
        let l = at.leg.map_or(0.0, |s| self.leg_excess(s));
        let r = at.heating.map_or(0.0, |(t, r)| self.heating_excess(t, r));
        let turn_on = if at.another_power_on {
            self.turn_on_var + self.scale_var * output * output
        } else {
            0.0
        };
        self.floor_var
            + turn_on
            + (self.extrapolation_var + self.extrapolation_scale_var * output * output) * excess2
            + self.walk_var_per_h * h
            + self.trend_var_per_h2 * h * h
            + self.leg_var * l * l
            + (self.heating_var + self.heating_scale_var * output * output) * r * r
    }
}

/// What a reading that cannot be true is, for one channel (format version 6): a temperature
/// outside the sensor's rated range, an output beyond its full scale. The only readings a
/// prediction calls a `Fault`, with non-finite ones; every other reading, however far from the
/// calibration, is compensated (`Extrapolating` beyond the trained range). Blobs of format 5 and
/// before read as [`Limits::DEFAULT`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Limits {
    /// The lowest temperature the sensor can read, °C.
    pub temp_min_c: f32,
    /// The highest, °C.
    pub temp_max_c: f32,
    /// The largest magnitude of the output the sensor can give, output units (volts, counts or a
    /// rate, as the model's `Voltage` input); 0: not stated, any finite output is a reading.
    pub full_scale: f32,
}

impl Limits {
    /// Numbers in its encoding.
    pub const NUMBERS: usize = 3;
    /// What a blob states unless told otherwise: −55 … 125 °C, the widest rated range of the
    /// temperature sensors inside IMUs and gyro electronics (the military grade; industrial
    /// parts stop at −40 … 85 °C), so a reading beyond it is a broken sensor or wire whatever
    /// the part; no full scale.
    pub const DEFAULT: Self = Self {
        temp_min_c: -55.0,
        temp_max_c: 125.0,
        full_scale: 0.0,
    };

    /// Its numbers, in encoding order.
    pub const fn numbers(&self) -> [f32; Self::NUMBERS] {
        [self.temp_min_c, self.temp_max_c, self.full_scale]
    }

    /// The index of its first non-finite number, else whether it is a range (min < max) and a
    /// full scale not negative.
    pub fn check(&self) -> Result<(), BlobError> {
        if let Some(i) = self.numbers().iter().position(|v| !v.is_finite()) {
            return Err(BlobError::NonFinite(i));
        }
        if self.temp_min_c < self.temp_max_c && self.full_scale >= 0.0 {
            Ok(())
        } else {
            Err(BlobError::InvalidParameter)
        }
    }

    /// Whether a temperature reading (°C) can be true.
    pub fn temperature_ok(&self, temp_c: f32) -> bool {
        (self.temp_min_c..=self.temp_max_c).contains(&temp_c)
    }

    /// Whether an output can be true.
    pub fn output_ok(&self, output: f32) -> bool {
        output.is_finite() && (self.full_scale <= 0.0 || output.abs() <= self.full_scale)
    }
}

impl Default for Limits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What the mean does beyond the trained range (format version 6; [`crate::model`]'s module doc
/// has the rule).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "schemars", derive(schemars::JsonSchema))]
// As the trainer's JSON names it (`--beyond`): the blob stores the variant's index alone.
#[cfg_attr(feature = "schemars", schemars(rename_all = "lowercase"))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Beyond {
    /// The inputs the kernel reads held at the edge, the prior mean's too (PX4's and
    /// ArduPilot's clip of the temperature), but for the raw linear terms of the gyro output and
    /// the time since power-on.
    Hold,
    /// The kernel's inputs held at the edge, the prior mean continued from there along its
    /// tangent: the trend its coefficients, fitted on all the data, support, first order only.
    Tangent,
    /// The GP's own prediction at the inputs as they are: the kernel's part fades with the
    /// distance and the prior mean follows whole (what blobs before format 6 did).
    Follow,
}
