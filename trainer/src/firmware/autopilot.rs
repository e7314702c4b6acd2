//! The thermal calibration the autopilots take: a cubic in temperature per axis, written as PX4's
//! `TC_*` parameters and ArduPilot's `INS_TCALn_*` parameters, beside the project's own blob.
//!
//! Both firmwares evaluate the same family, a cubic in the sensor's temperature clipped to the
//! calibrated range, and subtract it from the raw reading:
//!
//! - PX4 (`TemperatureCompensation::calc_thermal_offsets_3D`): offset = X0 + X1·d + X2·d² + X3·d³,
//!   d = clip(T, TMIN, TMAX) − TREF, in rad/s and m/s²; the sensor's device ID in `TC_*_ID`.
//! - ArduPilot (`AP_InertialSensor_TCal::correct_*`): v −= P(clip(T) − 35) − P(clip(T_cal) − 35),
//!   P(d) = (c1·d + c2·d² + c3·d³)·1e-6, with no constant term: the constant is the boot-time gyro
//!   calibration's and the accelerometer calibration's, taken at their own temperature T_cal.
//!
//! The cubic itself ([`Cubic::fit`]) is fitted as every model here is, on the training part of the
//! log with its handled minutes left out, and weighted so that no temperature counts more because
//! the board lingered there: the samples are averaged in [`BINS`] equal temperature bins and each
//! bin's mean counts once (the reason PX4's script resamples over temperature, PR #14091).

use std::fmt::Write as _;

use firmware_core::Quantity;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Equal-width temperature bins the training samples are averaged in before the cubic is fitted.
pub const BINS: usize = 200;
/// The reference temperature of ArduPilot's polynomial, °C (`TEMP_REFERENCE`).
pub const ARDUPILOT_TREF_C: f64 = 35.0;
/// ArduPilot's coefficients are stored ×1e6 (`SCALE_FACTOR`).
pub const ARDUPILOT_SCALE: f64 = 1e6;

/// Why a cubic cannot be fitted.
#[derive(Debug, thiserror::Error)]
pub enum CubicError {
    /// Too few distinct temperatures.
    #[error(
        "{bins} of {of} temperature bins hold samples ({span_c:.2} °C spanned): a cubic needs 4"
    )]
    TooNarrow {
        /// Non-empty bins.
        bins: usize,
        /// Bins asked (samples, unbinned).
        of: usize,
        /// Temperature span, °C.
        span_c: f64,
    },
}

/// One axis's thermal offset: a cubic in T − `tref_c`, T clipped to [`tmin_c`, `tmax_c`], in the
/// channel's quantity's unit (°/s or m/s²).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Cubic {
    /// Coldest temperature calibrated, °C.
    pub tmin_c: f64,
    /// Warmest temperature calibrated, °C.
    pub tmax_c: f64,
    /// The expansion point, °C: mid-range, as PX4's script takes it.
    pub tref_c: f64,
    /// Coefficients of (T − tref)^0 … ^3.
    pub coef: [f64; 4],
}

impl Cubic {
    /// The cubic through the temperature-binned means of `offset` (the output less its
    /// reference) against `temp_c`, [`BINS`] bins; samples not finite are left out.
    pub fn fit(temp_c: &[f64], offset: &[f64]) -> Result<Self, CubicError> {
        Self::binned(temp_c, offset, BINS)
    }

    /// The cubic through the means of `offset` in `bins` equal temperature bins, each counted
    /// once.
    pub fn binned(temp_c: &[f64], offset: &[f64], bins: usize) -> Result<Self, CubicError> {
        let pairs = finite(temp_c, offset);
        let (tmin_c, tmax_c) = range(&pairs);
        let span_c = (tmax_c - tmin_c).max(0.0);
        let mut sums = vec![(0.0, 0.0, 0usize); bins.max(1)];
        let last = sums.len() - 1;
        for &(t, y) in &pairs {
            let k = if span_c > 0.0 {
                (((t - tmin_c) / span_c * sums.len() as f64) as usize).min(last)
            } else {
                0
            };
            sums[k].0 += t;
            sums[k].1 += y;
            sums[k].2 += 1;
        }
        let means: Vec<(f64, f64)> = sums
            .iter()
            .filter(|s| s.2 > 0)
            .map(|&(t, y, n)| (t / n as f64, y / n as f64))
            .collect();
        Self::through(&means, (tmin_c, tmax_c), bins)
    }

    /// The least-squares cubic through every finite pair, each counted once.
    pub fn unweighted(temp_c: &[f64], offset: &[f64]) -> Result<Self, CubicError> {
        let pairs = finite(temp_c, offset);
        let r = range(&pairs);
        Self::through(&pairs, r, pairs.len())
    }

    /// The least-squares cubic through `points`, over the range `(tmin, tmax)`, expanded about
    /// its middle (`of`: how many bins or samples were asked, for the error).
    fn through(
        points: &[(f64, f64)],
        (tmin_c, tmax_c): (f64, f64),
        of: usize,
    ) -> Result<Self, CubicError> {
        let span_c = tmax_c - tmin_c;
        let distinct = {
            let mut t: Vec<f64> = points.iter().map(|p| p.0).collect();
            t.sort_by(f64::total_cmp);
            t.dedup();
            t.len()
        };
        if distinct < 4 || span_c.is_nan() || span_c <= 0.0 {
            return Err(CubicError::TooNarrow {
                bins: distinct.min(of),
                of,
                span_c: if span_c.is_finite() {
                    span_c.max(0.0)
                } else {
                    0.0
                },
            });
        }
        // Fitted in d / half-span, in [−1, 1], so the normal equations stay well conditioned,
        // then scaled back to powers of d.
        let tref_c = 0.5 * (tmin_c + tmax_c);
        let half = 0.5 * span_c;
        let a = DMatrix::from_fn(points.len(), 4, |i, j| {
            ((points[i].0 - tref_c) / half).powi(j as i32)
        });
        let b = DVector::from_iterator(points.len(), points.iter().map(|m| m.1));
        let c = a
            .svd(true, true)
            .solve(&b, 1e-12)
            .unwrap_or_else(|_| DVector::zeros(4));
        Ok(Self {
            tmin_c,
            tmax_c,
            tref_c,
            coef: std::array::from_fn(|j| c[j] / half.powi(j as i32)),
        })
    }

    /// The offset at `temp_c`, clipped to the calibrated range as both firmwares clip it.
    pub fn at(&self, temp_c: f64) -> f64 {
        let d = temp_c.clamp(self.tmin_c, self.tmax_c) - self.tref_c;
        self.coef[0] + d * (self.coef[1] + d * (self.coef[2] + d * self.coef[3]))
    }

    /// The same cubic's coefficients in powers of (T − `t0`).
    pub fn about(&self, t0: f64) -> [f64; 4] {
        let s = t0 - self.tref_c;
        let [c0, c1, c2, c3] = self.coef;
        [
            c0 + s * (c1 + s * (c2 + s * c3)),
            c1 + s * (2.0 * c2 + 3.0 * s * c3),
            c2 + 3.0 * s * c3,
            c3,
        ]
    }

    /// The cubic in another unit: every coefficient times `k`.
    fn scaled(&self, k: f64) -> Self {
        Self {
            coef: self.coef.map(|c| c * k),
            ..*self
        }
    }
}

/// The pairs where both are finite.
fn finite(temp_c: &[f64], offset: &[f64]) -> Vec<(f64, f64)> {
    temp_c
        .iter()
        .zip(offset)
        .filter(|(t, y)| t.is_finite() && y.is_finite())
        .map(|(&t, &y)| (t, y))
        .collect()
}

/// The coldest and warmest temperature of `pairs`.
fn range(pairs: &[(f64, f64)]) -> (f64, f64) {
    pairs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(t, _)| {
            (lo.min(t), hi.max(t))
        })
}

/// One sensor instance's calibration, as the autopilots index it.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct SensorCubics {
    /// Its name (`gyro0`, `imu1`).
    pub name: String,
    /// Its instance in the log (PX4's `TC_G{i}`, ArduPilot's `INS_TCAL{i+1}`).
    pub instance: u8,
    /// Its device ID, where the log gives one (PX4's `TC_*_ID`).
    pub device_id: Option<u32>,
    /// Each axis's cubic. A gyro's three axes are those whose quantity is angular rate, in x, y,
    /// z order; likewise an accelerometer's.
    pub axes: Vec<AxisCubic>,
    /// Its axes are the vehicle's, not the board's the autopilots apply their parameters in: an
    /// ArduPilot log whose board rotation could not be turned back
    /// ([`Mounting::Unknown`](fog_data::autopilot::Mounting::Unknown)). Not in the JSON: its
    /// parameter files are then not written, and that is said.
    #[serde(skip)]
    #[schemars(skip)]
    pub vehicle_axes: bool,
}

/// One axis's cubic, in °/s or m/s².
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct AxisCubic {
    /// The channel's name.
    pub name: String,
    /// What it measures.
    pub quantity: Quantity,
    /// Its cubic.
    #[serde(flatten)]
    pub cubic: Cubic,
}

impl SensorCubics {
    /// Its three axes measuring `q`, in x, y, z order, in the autopilots' units (rad/s, m/s²);
    /// `None` unless it has exactly three.
    fn triad(&self, q: Quantity) -> Option<[Cubic; 3]> {
        let k = match q {
            Quantity::AngularRate => std::f64::consts::PI / 180.0,
            Quantity::SpecificForce => 1.0,
        };
        let mut axes: Vec<(&str, Cubic)> = self
            .axes
            .iter()
            .filter(|a| a.quantity == q)
            .map(|a| (a.name.as_str(), a.cubic.scaled(k)))
            .collect();
        axes.sort_by_key(|(name, _)| name.chars().last());
        <[(&str, Cubic); 3]>::try_from(axes)
            .ok()
            .map(|a| a.map(|(_, c)| c))
    }
}

/// PX4's `.params` file, as `Tools/process_sensor_caldata.py` writes it (a tab-separated line per
/// parameter: vehicle, component, name, value, type 6 for an integer and 9 for a float), with
/// `TC_G_ENABLE` and `TC_A_ENABLE` set where a gyro or an accelerometer is calibrated (the
/// script leaves them to the user). Sensors without three axes of a kind are skipped for it.
pub fn px4_params(sensors: &[SensorCubics]) -> String {
    let mut out = String::from(
        "# Sensor thermal compensation parameters\n#\n# Vehicle-Id Component-Id Name Value Type\n",
    );
    let line = |out: &mut String, name: &str, value: String, int: bool| {
        let _ = writeln!(out, "1\t1\t{name}\t{value}\t{}", if int { 6 } else { 9 });
    };
    for (letter, q) in [("A", Quantity::SpecificForce), ("G", Quantity::AngularRate)] {
        let mut any = false;
        for s in sensors {
            let Some(triad) = s.triad(q) else { continue };
            any = true;
            let p = format!("TC_{letter}{}", s.instance);
            // The firmware compares the ID as an unsigned device ID stored in an int32.
            let id = s.device_id.unwrap_or(0) as i32;
            line(&mut out, &format!("{p}_ID"), id.to_string(), true);
            let [x, ..] = triad;
            line(&mut out, &format!("{p}_TMIN"), f(x.tmin_c), false);
            line(&mut out, &format!("{p}_TMAX"), f(x.tmax_c), false);
            line(&mut out, &format!("{p}_TREF"), f(x.tref_c), false);
            for (axis, c) in triad.iter().enumerate() {
                for (power, v) in c.coef.iter().enumerate() {
                    line(&mut out, &format!("{p}_X{power}_{axis}"), f(*v), false);
                }
            }
        }
        if any {
            line(
                &mut out,
                &format!("TC_{letter}_ENABLE"),
                "1".to_owned(),
                true,
            );
        }
    }
    out
}

/// A float as the parameter files take it: the shortest text that reads back as the same f32
/// (the firmwares store f32).
fn f(v: f64) -> String {
    format!("{:?}", v as f32)
}

/// ArduPilot's `tcal.parm`, as `Tools/scripts/tempcal_IMU.py` writes it: per IMU (`INS_TCAL1`
/// for instance 0), `ENABLE`, `TMIN`, `TMAX`, then `ACC1..3_X/Y/Z` and `GYR1..3_X/Y/Z`, the
/// coefficients of (T − 35 °C)^1..3 ×1e6 in m/s² and rad/s. A ULog's gyro and accelerometer of
/// the same instance make one IMU; its range is where both were calibrated.
pub fn ardupilot_parm(sensors: &[SensorCubics]) -> String {
    let mut imus: Vec<u8> = sensors.iter().map(|s| s.instance).collect();
    imus.sort_unstable();
    imus.dedup();
    let mut out = String::new();
    for i in imus {
        let of = |q| {
            sensors
                .iter()
                .filter(|s| s.instance == i)
                .find_map(|s| s.triad(q))
        };
        let (acc, gyr) = (of(Quantity::SpecificForce), of(Quantity::AngularRate));
        let all: Vec<&Cubic> = acc.iter().chain(gyr.iter()).flatten().collect();
        let Some(first) = all.first() else { continue };
        let tmin = all.iter().map(|c| c.tmin_c).fold(first.tmin_c, f64::max);
        let tmax = all.iter().map(|c| c.tmax_c).fold(first.tmax_c, f64::min);
        let n = u32::from(i) + 1;
        // Written to 0.1 °C, inward: the firmware never evaluates the cubic beyond what it saw.
        let (tmin, tmax) = ((tmin * 10.0).ceil() / 10.0, (tmax * 10.0).floor() / 10.0);
        let _ = writeln!(out, "INS_TCAL{n}_ENABLE 1");
        let _ = writeln!(out, "INS_TCAL{n}_TMIN {tmin:.1}");
        let _ = writeln!(out, "INS_TCAL{n}_TMAX {tmax:.1}");
        for (kind, triad) in [("ACC", acc), ("GYR", gyr)] {
            let Some(triad) = triad else { continue };
            let about: Vec<[f64; 4]> = triad.iter().map(|c| c.about(ARDUPILOT_TREF_C)).collect();
            for power in 1..=3 {
                for (axis, c) in ["X", "Y", "Z"].iter().zip(&about) {
                    let _ = writeln!(
                        out,
                        "INS_TCAL{n}_{kind}{power}_{axis} {:.9}",
                        c[power] * ARDUPILOT_SCALE
                    );
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cubic of known coefficients, sampled as a board warming from a soak is: fast through
    /// the cold part, lingering as it settles warm.
    fn lingering() -> (Vec<f64>, Vec<f64>, impl Fn(f64) -> f64) {
        let truth = |t: f64| {
            0.02 + 1e-3 * (t - 30.0) - 2e-5 * (t - 30.0).powi(2) + 3e-7 * (t - 30.0).powi(3)
        };
        let temp: Vec<f64> = (0..20_000)
            .map(|i| -10.0 + 70.0 * (1.0 - (-5.0 * f64::from(i) / 20_000.0).exp()))
            .collect();
        let y = temp.iter().map(|&t| truth(t)).collect();
        (temp, y, truth)
    }

    #[test]
    fn the_cubic_is_recovered_and_reexpanded_exactly() {
        let (temp, y, truth) = lingering();
        let every = Cubic::unweighted(&temp, &y).unwrap();
        let binned = Cubic::fit(&temp, &y).unwrap();
        assert_eq!(binned.tmin_c, -10.0);
        assert!(
            binned.tmax_c > 59.0 && binned.tmax_c < 60.0,
            "{}",
            binned.tmax_c
        );
        for t in [-10.0, 0.0, 25.0, 50.0] {
            assert!((every.at(t) - truth(t)).abs() < 1e-12, "{t}");
            // A bin's mean of a curve is not the curve at the bin's mean temperature: off by
            // its curvature times the bin's spread, here below 1e-6.
            assert!((binned.at(t) - truth(t)).abs() < 1e-6, "{t}");
        }
        // Clipped beyond the range, as the firmwares clip.
        assert_eq!(binned.at(-40.0), binned.at(binned.tmin_c));
        let a = binned.about(35.0);
        let d = 12.5 - 35.0;
        let p = a[0] + a[1] * d + a[2] * d * d + a[3] * d * d * d;
        assert!((p - binned.at(12.5)).abs() < 1e-13);
    }

    #[test]
    fn no_temperature_counts_more_because_the_board_lingered_there() {
        // A bias a cubic cannot follow exactly (a knee at 20 °C), sampled mostly warm: every
        // sample counted alone, the fit bends to the warm end and misses the cold one.
        let (temp, _, truth) = lingering();
        let bias = |t: f64| truth(t) + 0.01 * (1.0 + ((t - 20.0) / 2.0).tanh());
        let y: Vec<f64> = temp.iter().map(|&t| bias(t)).collect();
        // Its RMS error over the range, every degree alike.
        let worst = |c: &Cubic| {
            let e2: f64 = (0..=700)
                .map(|i| {
                    let t = -10.0 + f64::from(i) * 69.0 / 700.0;
                    (c.at(t) - bias(t)).powi(2)
                })
                .sum();
            (e2 / 701.0).sqrt()
        };
        let (binned, every) = (
            worst(&Cubic::fit(&temp, &y).unwrap()),
            worst(&Cubic::unweighted(&temp, &y).unwrap()),
        );
        // Measured: 3.14e-3 against 3.51e-3 (0.89×).
        assert!(
            binned < 0.95 * every,
            "binned {binned:.2e}, every sample {every:.2e}"
        );
    }

    #[test]
    fn a_cubic_needs_four_temperatures() {
        let e = Cubic::fit(&[20.0, 20.0, 21.0], &[0.0, 0.1, 0.2]).unwrap_err();
        assert!(e.to_string().contains("2 of 200 temperature bins"), "{e}");
        let e = Cubic::unweighted(&[20.0, 21.0, 22.0], &[0.0; 3]).unwrap_err();
        assert!(e.to_string().contains("3 of 3"), "{e}");
    }
}
