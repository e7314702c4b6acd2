//! A log's sensor instance as a calibration sees it: its axes in the project's units, its time
//! and temperature, and what about it a calibration must be told ([`Finding`]).

use firmware_core::Quantity;
use firmware_core::units::STANDARD_GRAVITY;

use super::error::Damage;
use crate::stream::{self, Stream};

/// One axis of a sensor instance.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// Its channel name (`x`, `gyr.x`, `acc.z`).
    pub name: String,
    /// The log's field it was read from (`x`, `GyrX`).
    pub field: &'static str,
    /// What it measures (its values in °/s or m/s²).
    pub quantity: Quantity,
    /// Its samples, converted to the quantity's unit.
    pub values: Vec<f64>,
}

/// One sensor instance of a log: a unit whose channels are its axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Its name in the project (`gyro0`, `accel1`, `imu0`): the topic or message and instance.
    pub name: String,
    /// The topic or message type it was read from (`sensor_gyro`, `IMU`).
    pub topic: String,
    /// Its instance in the log.
    pub instance: u8,
    /// The device ID it reported first (ULog), where it reports one.
    pub device_id: Option<u32>,
    /// Where the device ID changes mid-log: (time s from the first sample, the new ID).
    pub id_changes: Vec<(f64, u32)>,
    /// The log's field its sample times were read from (`timestamp_sample`, `timestamp`,
    /// `TimeUS`), in µs.
    pub time_field: &'static str,
    /// Sample times, s from the log's start.
    pub time_s: Vec<f64>,
    /// The log's field its temperature was read from (`temperature`, `T`).
    pub temp_field: &'static str,
    /// Its temperature, °C; empty where the log has no temperature for it.
    pub temp_c: Vec<f64>,
    /// Its axes.
    pub axes: Vec<Axis>,
    /// Samples left out because their temperature or an axis was not a number.
    pub unreadable: usize,
    /// A second record of a sensor the log also holds whole: the means the autopilot's own
    /// temperature learning logged (ArduPilot's `TCLR`, one per 0.5 °C of warming). Taken only
    /// when named, or where the log holds nothing else ([`Channels::of_log`](crate::channels::Channels::of_log)).
    pub learned: bool,
    /// The autopilot's own temperature correction was on while it logged (ArduPilot's
    /// `INS_TCALn_ENABLE` 1): whether it was undone on reading, so that the samples are the
    /// sensor's own ([`Correction`]).
    pub correction: Option<Correction>,
    /// The board's rotation in the vehicle (ArduPilot's `AHRS_ORIENTATION`), where the log's axes
    /// are the vehicle's: `None` where they are the board's.
    pub mounting: Option<Mounting>,
}

/// A board mounted rotated in the vehicle, whose log holds the vehicle's axes.
#[derive(Debug, Clone, PartialEq)]
pub enum Mounting {
    /// Its axes were turned back to the board's on reading, as `tempcal_IMU.py` turns them: the
    /// axes the autopilot's temperature correction and its parameters apply in.
    TurnedBack(super::BoardRotation),
    /// Left as the vehicle's: its `AHRS_ORIENTATION` (this value) is no rotation ArduPilot
    /// defines, or a custom one whose angles the log does not give.
    Unknown(f64),
}

/// What became of the temperature correction the autopilot applied while it logged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Correction {
    /// Undone, as `tempcal_IMU.py` undoes it, from the parameters the log's `PARM` messages set.
    Undone,
    /// Left in: the board is mounted rotated by a rotation that cannot be turned back
    /// ([`Mounting::Unknown`]), so the logged axes are the vehicle's and the parameters the
    /// board's.
    Left,
}

impl Sensor {
    /// Its ID in a unit blob (at most 32 bytes): the device ID where the log gives one, else the
    /// name.
    pub fn sensor_id(&self) -> String {
        match self.device_id {
            Some(id) => format!("{} {id}", self.name),
            None => self.name.clone(),
        }
    }

    /// Where its `field` comes from in the log, as a person reads it: `sensor_gyro[0].x`.
    pub fn field_source(&self, field: &str) -> String {
        format!("{}[{}].{field}", self.topic, self.instance)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// True when it has no sample.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// One stream per axis, sharing the time and temperature, the handled minutes screened on
    /// every axis as in a channels file's log ([`Channels::load_log`](crate::channels::Channels::load_log)). Each sample's "line" is its
    /// 1-based ordinal among the sensor's samples.
    pub fn streams(&self, references: &[f64]) -> Vec<Stream> {
        let lines: Vec<u64> = (1..=self.len() as u64).collect();
        let (step_s, mut time_issues) = stream::time_checks(&self.time_s, &lines);
        if self.learned {
            // A learning row closes each 0.5 °C of warming however long it took: a long interval
            // is a board warming slowly, not a pause or a power cycle.
            time_issues.retain(|i| !matches!(i, stream::TimeIssue::Gap { .. }));
        }
        let mut data: Vec<(Vec<f64>, Vec<f64>)> = self
            .axes
            .iter()
            .zip(references)
            .map(|(a, &r)| (a.values.clone(), vec![r; self.len()]))
            .collect();
        let handled = stream::screen_unit_handling(&self.time_s, &mut data, &lines);
        data.into_iter()
            .map(|(voltage_v, rate_dps)| Stream {
                time_s: self.time_s.clone(),
                temp_c: self.temp_c.clone(),
                voltage_v,
                rate_dps,
                lines: lines.clone(),
                step_s,
                time_issues: time_issues.clone(),
                handled: handled.clone(),
                history: 0,
                after_s: None,
            })
            .collect()
    }

    /// Leaves out the samples whose temperature (where it has one) or an axis is not a number.
    pub(super) fn keep_numbers(&mut self) {
        let keep: Vec<bool> = (0..self.len())
            .map(|i| {
                self.temp_c.get(i).is_none_or(|t| t.is_finite())
                    && self.axes.iter().all(|a| a.values[i].is_finite())
            })
            .collect();
        let lost = keep.iter().filter(|k| !**k).count();
        if lost == 0 {
            return;
        }
        let pick = |v: &mut Vec<f64>| {
            if v.len() == keep.len() {
                let mut k = keep.iter();
                v.retain(|_| *k.next().unwrap_or(&false));
            }
        };
        pick(&mut self.time_s);
        pick(&mut self.temp_c);
        for a in &mut self.axes {
            pick(&mut a.values);
        }
        self.unreadable += lost;
    }

    /// What a calibration must be told about this sensor: each finding as (kind, what of this
    /// sensor), so that a log's sensors alike are said in one line ([`Recorded::notes`](super::Recorded::notes)): no
    /// temperature, a temperature in whole degrees, a span under [`MIN_SPAN_C`], samples that are
    /// not numbers, a device ID that changes.
    pub fn findings(&self) -> Vec<(Finding, String)> {
        let mut out = Vec::new();
        let name = &self.name;
        if self.temp_c.is_empty() {
            out.push((Finding::NoTemperature, name.clone()));
        } else {
            if self.temp_c.len() > 1 && self.temp_c.iter().all(|t| t.fract() == 0.0) {
                out.push((Finding::WholeDegrees, name.clone()));
            }
            let (lo, hi) = self
                .temp_c
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &t| {
                    (lo.min(t), hi.max(t))
                });
            if hi - lo < MIN_SPAN_C {
                out.push((
                    Finding::NarrowSpan,
                    format!("{name} {:.1} °C ({lo:.1} to {hi:.1})", hi - lo),
                ));
            }
        }
        if self.unreadable > 0 {
            out.push((
                Finding::NotNumbers,
                format!("{name} {} samples", self.unreadable),
            ));
        }
        match self.correction {
            Some(Correction::Undone) => out.push((Finding::CorrectionUndone, name.clone())),
            Some(Correction::Left) => out.push((Finding::CorrectionLeft, name.clone())),
            None => {}
        }
        match &self.mounting {
            Some(Mounting::TurnedBack(r)) => out.push((
                Finding::TurnedBack,
                format!("{name} (AHRS_ORIENTATION {}, {})", r.id, r.name),
            )),
            Some(Mounting::Unknown(id)) => out.push((
                Finding::MountingUnknown,
                format!("{name} (AHRS_ORIENTATION {id})"),
            )),
            None => {}
        }
        if let Some(&(t, id)) = self.id_changes.first() {
            out.push((
                Finding::IdChanges,
                format!(
                    "{name} at {t:.1} s ({} to {id}{})",
                    self.device_id.unwrap_or_default(),
                    if self.id_changes.len() > 1 {
                        format!(", and {} more times", self.id_changes.len() - 1)
                    } else {
                        String::new()
                    }
                ),
            ));
        }
        out
    }
}

/// What a calibration must be told about a sensor of a log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Finding {
    /// The log records no temperature for it.
    NoTemperature,
    /// Its temperature is in whole degrees.
    WholeDegrees,
    /// Its temperature spans less than [`MIN_SPAN_C`].
    NarrowSpan,
    /// Some samples were not numbers.
    NotNumbers,
    /// Its device ID changes mid-log.
    IdChanges,
    /// The autopilot's temperature correction, on while it logged, was undone.
    CorrectionUndone,
    /// The autopilot's temperature correction, on while it logged, could not be undone.
    CorrectionLeft,
    /// Its axes were turned back from the vehicle's to the board's.
    TurnedBack,
    /// Its axes are the vehicle's, the board's rotation not known.
    MountingUnknown,
}

impl Finding {
    /// The line that says it, of the sensors `which`.
    pub(super) fn line(self, which: &str) -> String {
        match self {
            Self::NoTemperature => {
                format!("no temperature recorded for {which}: no thermal model can be fitted to it")
            }
            Self::WholeDegrees => format!(
                "the temperature of {which} is quantized to whole degrees: the model sees the \
                 1 °C steps, and a lag fitted on them is coarse"
            ),
            Self::NarrowSpan => format!(
                "the temperature spans under the {MIN_SPAN_C:.0} °C a thermal calibration needs: \
                 {which}; the curve beyond is a guess"
            ),
            Self::NotNumbers => {
                format!("samples left out, their temperature or an axis not a number: {which}")
            }
            Self::CorrectionUndone => format!(
                "logged with ArduPilot's temperature correction on (INS_TCALn_ENABLE 1): {which}; \
                 the correction its parameters applied is undone, as tempcal_IMU.py does, so the \
                 fit sees the sensor's own output"
            ),
            Self::CorrectionLeft => format!(
                "logged with ArduPilot's temperature correction on (INS_TCALn_ENABLE 1) and the \
                 board mounted by a rotation that cannot be turned back: {which}; the correction \
                 is left in (its parameters are in the board's axes, the log's in the vehicle's), \
                 so a fit is of what the correction left, not of the sensor"
            ),
            Self::TurnedBack => format!(
                "the board is mounted rotated in the vehicle: {which}; the logged axes (the \
                 vehicle's) are turned back to the board's, as tempcal_IMU.py does, where the \
                 autopilot's temperature correction and its parameters apply"
            ),
            Self::MountingUnknown => format!(
                "the board's rotation is none ArduPilot defines, or a custom one whose angles the \
                 log does not give: {which}; its axes are left as logged (the vehicle's), and \
                 no autopilot parameter file is written from them (the firmware applies one in \
                 the board's axes)"
            ),
            Self::IdChanges => format!(
                "the device ID changes: {which}; another sensor answered as this instance, and \
                 its samples are read as one sensor's"
            ),
        }
    }
}

/// The smallest temperature span a thermal calibration should cover (PX4's and ArduPilot's
/// guides ask for a cold soak well below and a warm-up well above the flying range).
pub const MIN_SPAN_C: f64 = 10.0;

/// An accelerometer axis's reference on a board at rest: the component of gravity along it, taken
/// as −g, 0 or +g, whichever is nearest the median of its first minute (a board level to within a
/// few degrees; its tilt is a constant the model takes as bias).
pub fn gravity_reference(time_s: &[f64], values: &[f64]) -> f64 {
    let t0 = time_s.first().copied().unwrap_or(0.0);
    let mut first: Vec<f64> = time_s
        .iter()
        .zip(values)
        .take_while(|(t, _)| **t - t0 < 60.0)
        .map(|(_, v)| *v)
        .filter(|v| v.is_finite())
        .collect();
    first.sort_by(f64::total_cmp);
    let median = first.get(first.len() / 2).copied().unwrap_or(0.0);
    [-STANDARD_GRAVITY, 0.0, STANDARD_GRAVITY]
        .into_iter()
        .min_by(|a, b| (a - median).abs().total_cmp(&(b - median).abs()))
        .unwrap_or(0.0)
}

/// What a format's reader returns: the sensors, the other sensor topics with their counts, and
/// the damage where the log stops being readable.
pub(super) type Collected = (Vec<Sensor>, Vec<(String, usize)>, Option<Damage>);
