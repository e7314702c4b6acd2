//! The heating term: the error of a heating rate unlike the calibration's, where the temperature
//! sensor lags the sensing element.
//!
//! A sensor that lags the element by τ reads it wrong by about τ·r at a heating rate r. A
//! calibration that met one rate per temperature (a warm-up heats fast when cold and slowly when
//! warm) folds that reading error into its model, and meets no other: in service a warm-up on a
//! colder day, or a rate table's self-heating, passes the same reading at another rate, and the
//! model is wrong by its change per °C times τ times the difference. One power-on's data cannot
//! show it: the rate is a function of the temperature there, so the model cannot tell them apart
//! (on the simulated board whose second IMU's sensor lags by 90 s, another warm-up's 60 s means
//! were covered 62–69 % without it). So a stated lag (`--sensor-lag`, a datasheet's or a step
//! test's) sets it, and with none a lag of [`ASSUMED_LAG_S`] is assumed and said.
//!
//! The band of rates the training held at each temperature is a line through the (temperature,
//! heating rate) of its samples with a reference (least squares; none from the power-on's first
//! minutes, while the rate settles from rest: the firmware reads no term there either), between
//! the 0.5 % and 99.5 % quantiles of the rates about it, widened by 0.05 °C/min: a rate inside it
//! is one the model was fitted at. A rate table's points give theirs ([`table_rates`]: soaks,
//! unless their times say otherwise), and its model's change per °C at them ([`Changes`]).
//! The firmware reads the heating rate through the same filter as the trainer
//! (`firmware_core::FeatureState::heating_rate`) and adds `(heating_var + heating_scale_var · y²)
//! · h²`, h the rate's distance beyond the band (`firmware_core::ErrorModel::heating_excess`) and
//! y the output: the model's change per °C over its training samples, told apart by their
//! reference outputs into a part alike at every output and one in proportion to it (as the
//! growth beyond the range is, [`super::split_by_output`]: a gyro's scale factor changes with
//! temperature, so at 80 °/s its model changes per °C many times what it does at rest), times
//! the lag, squared.

use fog_data::replay::{self, HostModel};
use fog_data::stream::Stream;
use serde::Serialize;

use fog_data::stats::{Line, extent, mean, quantile};

use super::Calibration;
use crate::data::points::Points;
use crate::models::gp::GpModel;

/// How far the band reaches beyond the training's rates, °C/min: a temperature sensor's noise and
/// quantization through the heating rate's filter (0.0625 °C steps over its 2 min are 0.03
/// °C/min), so a soak is a band, not a line.
const MARGIN: f64 = 0.05;
/// The share of the training's rates about the line left outside the band at each end.
const TAIL: f64 = 0.005;
/// The temperature step of the model's change per °C, °C: both ways from each sample.
const STEP_C: f64 = 0.5;
/// Most samples whose change per °C is told apart by the output (every k-th of a longer log):
/// the split's likelihood is searched on a grid, a pass over them per step.
const MOST_SLOPES: usize = 5000;
/// Filter times ([`firmware_core::features::HEATING_TAU_S`]) beyond which a table's row says
/// nothing of the heating rate at another ([`table_rates`]): after four, the filter keeps 2 % of
/// a reading.
const FORGOTTEN: f64 = 4.0;
/// Seconds per minute: a lag in seconds times a rate in °C/min.
const S_PER_MIN: f64 = 60.0;
/// The sensor lag assumed where none is stated, s (a judgement): of the lags PHYSICS.md gives, a
/// die sensor's seconds, a board sensor's minute or two beside the part, a FOG coil's 5–20
/// minutes behind its housing's sensor, the short end of a sensor off the die. On the simulated
/// board (docs/uncertainty.md) it took the lagging IMU's gyro z from 62–69 % to 76–84 % and
/// widened the other IMU's σ by up to 1.14×; the MEMS log's forward split, the service
/// challenge, the simulated chamber, ramps and room logs did not change. A FOG whose coil lags
/// further needs its lag stated.
pub const ASSUMED_LAG_S: f64 = 30.0;

/// The heating rates the training held and the model error outside them (`calibration.heating`
/// in the JSON).
#[derive(Debug, Clone, Default, Serialize, schemars::JsonSchema)]
pub struct Heating {
    /// The band of heating rates the training held (`None`: not known, no term: power-ons under
    /// 6 minutes): a stream's samples', a rate table's points' ([`table_rates`]), or those of
    /// logs pooled, with a table's where one is pooled with them.
    pub band: Option<HeatingBand>,
    /// Whether the band holds a rate table's points taken as soaks, their times not read
    /// ([`table_rates`]).
    pub soaks_assumed: bool,
    /// The model's change per °C of the temperature reading over the training samples with a
    /// reference (a rate table's points), its part alike at every output, output units per °C
    /// (RMS; 0: not known).
    pub slope_per_c: f64,
    /// Its part in proportion to the output, ppm of the output per °C (0: none shows, as at
    /// rest).
    pub scale_slope_ppm_per_c: f64,
    /// How far the temperature sensor lags the sensing element, s: as stated (`--sensor-lag`, a
    /// channel's `sensor_lag`), else, where the band is known, [`ASSUMED_LAG_S`] (`heating` in
    /// `assumed`); null: neither, no term.
    pub sensor_lag_s: Option<f64>,
    /// The model error per °C/min of heating rate beyond the band, output units: `slope_per_c`
    /// times the lag in minutes (0: no term).
    pub std_per_c_per_min: f64,
    /// Its part in proportion to the output, ppm of the output per °C/min:
    /// `scale_slope_ppm_per_c` times the lag in minutes.
    pub scale_ppm_per_c_per_min: f64,
    /// The lag stated, s (`None`: none, and [`ASSUMED_LAG_S`] is assumed where the band is
    /// known): kept apart from `sensor_lag_s`, so the band and the lag may be stated in any order.
    #[serde(skip)]
    stated_lag_s: Option<f64>,
}

/// The heating rates a calibration held: `rate_at_0c + rate_per_c · T + [min, max]` °C/min at a
/// temperature T, held within the temperatures it was read at, `[temp_min_c, temp_max_c]`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, schemars::JsonSchema)]
pub struct HeatingBand {
    /// The line's rate at 0 °C, °C/min.
    pub rate_at_0c: f64,
    /// The line's change per °C, °C/min per °C.
    pub rate_per_c: f64,
    /// The band's lower edge about the line, °C/min.
    pub min: f64,
    /// The band's upper edge about the line, °C/min.
    pub max: f64,
    /// The coldest temperature of its samples, °C: colder, the line is read here.
    pub temp_min_c: f64,
    /// The warmest, °C.
    pub temp_max_c: f64,
}

impl HeatingBand {
    /// The band of `samples` (temperature °C, heating rate °C/min; module doc), `None` for none.
    /// The line is flat where the temperatures span under 0.5 °C: their rates then say
    /// nothing of a change with temperature.
    pub fn of(samples: &[(f64, f64)]) -> Option<Self> {
        Self::of_parts(&[samples])
    }

    /// The band of several sources' samples (a rate table's points, each log's samples): one
    /// line through them all, and about it the widest of each source's quantiles, so that a
    /// table's few soaks beside a log's thousands of samples, or a short log beside a long one,
    /// stay inside the band as each would alone.
    pub fn of_parts(parts: &[&[(f64, f64)]]) -> Option<Self> {
        let samples: Vec<(f64, f64)> = parts.iter().flat_map(|p| p.iter().copied()).collect();
        if samples.is_empty() {
            return None;
        }
        let (lo, hi) = extent(samples.iter().map(|(t, _)| *t));
        let flat = || Line {
            intercept: mean(&samples.iter().map(|(_, r)| *r).collect::<Vec<_>>()),
            slope: 0.0,
        };
        let line = Line::fit(samples.iter().copied())
            .filter(|_| hi - lo >= STEP_C)
            .unwrap_or_else(flat);
        let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
        for part in parts.iter().filter(|p| !p.is_empty()) {
            let mut about: Vec<f64> = part.iter().map(|(t, r)| r - line.at(*t)).collect();
            about.sort_by(f64::total_cmp);
            min = min.min(quantile(&about, TAIL));
            max = max.max(quantile(&about, 1.0 - TAIL));
        }
        Some(Self {
            rate_at_0c: line.intercept,
            rate_per_c: line.slope,
            min: min - MARGIN,
            max: max + MARGIN,
            temp_min_c: lo,
            temp_max_c: hi,
        })
    }
}

impl Calibration {
    /// States the heating rates the training stream held (`samples`: each referenced sample's
    /// temperature and heating rate, [`rates`]) and the model's change per °C over them, told
    /// apart into its part alike at every output and its part in proportion to it (`slope`:
    /// output units and relative, per °C, [`slopes`]), into the blob's band, with the term at
    /// the lag stated or assumed ([`Self::set_sensor_lag`]).
    pub fn set_heating(&mut self, samples: &[(f64, f64)], slope: (f64, f64)) {
        self.set_band(HeatingBand::of(samples), slope);
    }

    /// The band and the model's change per °C at it, as [`Self::set_heating`] states them.
    fn set_band(&mut self, band: Option<HeatingBand>, slope: (f64, f64)) {
        self.heating.band = band;
        self.heating.soaks_assumed = false;
        self.heating.slope_per_c = slope.0;
        self.heating.scale_slope_ppm_per_c = slope.1 * 1e6;
        let b = self.heating.band.unwrap_or_default();
        self.error_model.heating_rate_at_0c = b.rate_at_0c as f32;
        self.error_model.heating_rate_per_c = b.rate_per_c as f32;
        self.error_model.heating_rate_min = b.min as f32;
        self.error_model.heating_rate_max = b.max as f32;
        self.error_model.heating_temp_min_c = b.temp_min_c as f32;
        self.error_model.heating_temp_max_c = b.temp_max_c as f32;
        self.apply_lag();
    }

    /// States how far the temperature sensor lags the sensing element, `stated` seconds, or, with
    /// none, assumes [`ASSUMED_LAG_S`] where the band is known (`heating` in `assumed`): the model
    /// error per °C/min beyond the band is the model's change per °C over that lag (module doc).
    /// Where the band is not known there is no term ([`Self::heating_skipped_line`] says so).
    pub fn set_sensor_lag(&mut self, stated: Option<f64>) {
        self.heating.stated_lag_s = stated;
        self.apply_lag();
    }

    /// [`Self::set_heating`] at the rates a fit on a rate table, or on logs pooled, was fitted at
    /// (`parts`: a table's [`table_rates`], each log's [`rates`]; the band
    /// [`HeatingBand::of_parts`]), `soaks_assumed` where a table's points among them are taken
    /// as soaks, their times not read.
    pub fn set_fitted_heating(
        &mut self,
        parts: &[&[(f64, f64)]],
        slope: (f64, f64),
        soaks_assumed: bool,
    ) {
        self.set_band(HeatingBand::of_parts(parts), slope);
        self.heating.soaks_assumed = soaks_assumed && self.heating.band.is_some();
    }

    /// The term at the band and the lag as they now stand, and whether it is assumed.
    fn apply_lag(&mut self) {
        self.assumed.retain(|name| *name != "heating");
        let stated = self.heating.stated_lag_s;
        let assumed = stated.is_none() && self.heating.band.is_some();
        self.heating.sensor_lag_s = if assumed { Some(ASSUMED_LAG_S) } else { stated };
        let minutes = match (self.heating.band, self.heating.sensor_lag_s) {
            (Some(_), Some(lag)) => lag / S_PER_MIN,
            _ => 0.0,
        };
        let (std, ppm) = (
            self.heating.slope_per_c * minutes,
            self.heating.scale_slope_ppm_per_c * minutes,
        );
        self.heating.std_per_c_per_min = std;
        self.heating.scale_ppm_per_c_per_min = ppm;
        self.error_model.heating_var = (std * std) as f32;
        self.error_model.heating_scale_var = ((ppm * 1e-6).powi(2)) as f32;
        if assumed && self.heating_shows() {
            self.assumed.push("heating");
        }
    }

    /// Whether the heating term adds anything.
    fn heating_shows(&self) -> bool {
        self.heating.std_per_c_per_min > 0.0 || self.heating.scale_ppm_per_c_per_min > 0.0
    }

    /// The heating term in the σ line, where there is one.
    pub(super) fn heating_in_words(&self, units: &str) -> String {
        match (self.heating.band, self.heating.sensor_lag_s) {
            (Some(b), Some(lag)) if self.heating_shows() => {
                let h = &self.heating;
                let change = format!(
                    "times the model's change per °C, {:.3e} {units} and {:.0} ppm of the output",
                    h.slope_per_c, h.scale_slope_ppm_per_c
                );
                let source = if self.assumed.contains(&"heating") {
                    format!(
                        "assumed: a sensor lag of {lag} s, {change}; --sensor-lag states the \
                         sensor's"
                    )
                } else {
                    format!("the stated sensor lag, {lag} s, {change}")
                };
                let soaks = if h.soaks_assumed {
                    ": the table's points taken as soaks, their times not read (--map \
                     time_s=… reads them where one table is fitted, not pooled)"
                } else {
                    ""
                };
                format!(
                    "; at a heating rate outside the band the training held ({:+.2}…{:+.2} \
                     °C/min about {:.2} {:+.3}·T{soaks}), {:.3e} {units} and {:.0} ppm of the \
                     output more per °C/min ({source})",
                    b.min,
                    b.max,
                    b.rate_at_0c,
                    b.rate_per_c,
                    h.std_per_c_per_min,
                    h.scale_ppm_per_c_per_min,
                )
            }
            _ => String::new(),
        }
    }

    /// The line a command says where a heating rate unlike the calibration's adds nothing to the
    /// σ, and why; `None` where it adds its term.
    pub fn heating_skipped_line(&self) -> Option<String> {
        const UNKNOWN: &str = "the training's heating rates are not known: its power-ons too \
                               short, under 6 minutes, for the rate to settle";
        let why = match (self.heating.band, self.heating.sensor_lag_s) {
            (None, Some(_)) => format!("{UNKNOWN}; the stated sensor lag is not used"),
            (None, None) => UNKNOWN.to_owned(),
            (Some(_), _) if self.heating_shows() => return None,
            (Some(_), _) => {
                "the sensor lag is 0, or the model does not change with temperature".to_owned()
            }
        };
        Some(format!(
            "skipped: the error of a heating rate unlike the calibration's ({why})"
        ))
    }
}

/// The temperature and heating rate of every sample of `stream` with a reference whose rate the
/// firmware reads into the model error (`firmware_core::FeatureState::heating`: settled after
/// the power-on), the state carried through the whole stream and its power-ons
/// ([`super::streams::tracked`]).
pub fn rates(stream: &Stream) -> Vec<(f64, f64)> {
    super::streams::tracked(stream, firmware_core::FeatureState::heating)
        .into_iter()
        .enumerate()
        .filter(|(i, _)| stream.rate_dps[*i].is_finite())
        .filter_map(|(_, read)| read.flatten())
        .map(|(t, r)| (f64::from(t), f64::from(r)))
        .collect()
}

/// `model`'s change per °C of the temperature reading over the samples of `stream` with a
/// reference, told apart by their reference outputs into a part alike at every output (output
/// units per °C, RMS) and one in proportion to the output (relative, per °C), as
/// [`super::split_by_output`] tells the growth beyond the range apart (`noise_std`: one sample's
/// noise, below which the outputs do not move).
pub fn slopes(model: &HostModel, stream: &Stream, noise_std: f64) -> (f64, f64) {
    Changes::of_stream(model, stream).split(noise_std)
}

/// A model's squared change per °C at the samples (or points) it was fitted on, beside their
/// reference outputs: what [`slopes`] tells apart at one log's samples, and what a fit on logs
/// pooled, or on a table with logs, tells apart over all of them together ([`Changes::extend`]).
#[derive(Debug, Clone, Default)]
pub struct Changes {
    /// The change per °C, squared, at each sample.
    per_c2: Vec<f64>,
    /// Its reference output.
    output: Vec<f64>,
    /// Whether the model reads no output (a bias model, its scale factor given): its change is
    /// alike at every rate.
    bias_only: bool,
}

impl Changes {
    /// At the samples of `stream` with a reference (every k-th of a longer log, 5,000 at most),
    /// `model`'s means replayed with every reading 0.5 °C warmer and colder: a constant offset,
    /// so the heating rates stay and a coil estimate moves with the reading.
    pub fn of_stream(model: &HostModel, stream: &Stream) -> Self {
        let shifted = |by: f64| {
            let mut s = stream.clone();
            s.temp_c.iter_mut().for_each(|t| *t += by);
            replay::means(model, &s).rate_dps
        };
        let (up, down) = (shifted(STEP_C), shifted(-STEP_C));
        let referenced: Vec<usize> = (0..stream.len())
            .filter(|&i| stream.rate_dps[i].is_finite())
            .collect();
        let every = referenced.len().div_ceil(MOST_SLOPES).max(1);
        let (per_c2, output) = referenced
            .iter()
            .step_by(every)
            .map(|&i| {
                let d = (f64::from(up[i]) - f64::from(down[i])) / (2.0 * STEP_C);
                (d * d, stream.rate_dps[i])
            })
            .unzip();
        Self {
            per_c2,
            output,
            bias_only: false,
        }
    }

    /// At each of a rate table's `points`, `model`'s change per °C of its temperature input
    /// (none without one). A bias model's GP reads no output (its scale factor is given).
    pub fn of_points(model: &GpModel, points: &Points) -> Self {
        let Some(k) = points.features().iter().position(|f| f.is_temperature()) else {
            return Self::default();
        };
        let per_c2 = points
            .inputs()
            .row_iter()
            .map(|row| {
                let mut at: Vec<f64> = row.iter().copied().collect();
                let t = at[k];
                at[k] = t + STEP_C;
                let up = model.predict_mean(&at);
                at[k] = t - STEP_C;
                let d = (up - model.predict_mean(&at)) / (2.0 * STEP_C);
                d * d
            })
            .collect();
        Self {
            per_c2,
            output: points.rate_dps.clone(),
            bias_only: points.scale_factor.is_some(),
        }
    }

    /// These and `other`'s together, of one model (a bias model's stays alike at every rate).
    pub fn extend(&mut self, other: Self) {
        self.per_c2.extend(other.per_c2);
        self.output.extend(other.output);
        self.bias_only |= other.bias_only;
    }

    /// The part alike at every output (output units per °C, RMS) and the one in proportion to it
    /// (relative, per °C), `noise_std` the noise below which the outputs do not move; (0, 0) for
    /// none.
    pub fn split(&self, noise_std: f64) -> (f64, f64) {
        if self.per_c2.is_empty() {
            return (0.0, 0.0);
        }
        let (a, b) = if self.bias_only {
            (mean(&self.per_c2), 0.0)
        } else {
            super::split_by_output(&self.per_c2, &self.output, noise_std)
        };
        (a.sqrt(), b.sqrt())
    }
}

/// The temperature and heating rate (°C/min) of each point of a rate table. Where the points
/// carry their times (`--map time_s=…`), each point's rate to the nearest row of its run at
/// least the firmware's filter time before it ([`firmware_core::features::HEATING_TAU_S`]) and
/// to the one as far after it, the slower of the two. Over two minutes a sensor's quantization
/// moves the rate by no more than the band's margin (0.0625 °C steps are 0.03 °C/min), as
/// through the firmware's filter, where rows seconds apart would read each step as a rate. A
/// point at a plateau's edge reads its plateau, not the chamber's step to the next, and a
/// turntable that drifts reads its drift. A row further than four filter times away is none
/// (`FORGOTTEN`): the filter has forgotten it, and it says nothing of the rate at the point (a
/// table of one row per plateau would read the chamber's ramps between them); a point with none
/// either side is a soak, 0. Without times, 0 for every point: the points are taken as soaks, as a
/// rate table holds them (a table that drifted gives its times to be read right; runs pooled
/// keep none: they are no longer one series).
pub fn table_rates(points: &Points) -> Vec<(f64, f64)> {
    let n = points.len();
    let Some(time_s) = &points.time_s else {
        return points.temp_c.iter().map(|&t| (t, 0.0)).collect();
    };
    let apart = f64::from(firmware_core::features::HEATING_TAU_S);
    let near = |dt: f64| (apart..=FORGOTTEN * apart).contains(&dt);
    let rate = |a: usize, b: usize| {
        (points.temp_c[b] - points.temp_c[a]) / (time_s[b] - time_s[a]) * S_PER_MIN
    };
    let same_run = |a: usize, b: usize| points.run[a] == points.run[b];
    (0..n)
        .map(|i| {
            let before = (0..i)
                .rev()
                .take_while(|&a| same_run(a, i))
                .find(|&a| time_s[i] - time_s[a] >= apart)
                .filter(|&a| near(time_s[i] - time_s[a]))
                .map(|a| rate(a, i));
            let after = (i + 1..n)
                .take_while(|&b| same_run(i, b))
                .find(|&b| time_s[b] - time_s[i] >= apart)
                .filter(|&b| near(time_s[b] - time_s[i]))
                .map(|b| rate(i, b));
            let slower = before
                .into_iter()
                .chain(after)
                .min_by(|x, y| x.abs().total_cmp(&y.abs()));
            (points.temp_c[i], slower.unwrap_or(0.0))
        })
        .collect()
}
