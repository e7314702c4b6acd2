//! An ArduPilot DataFlash log's sensors: every instance `I` of the `IMU` message (`GyrX/Y/Z` in
//! rad/s, `AccX/Y/Z` in m/s², `T` in °C; older logs' `IMU2`, `IMU3` for instances 1 and 2), read
//! by `ardupilot-binlog` from the whole messages [`super::framing`] passes on; and the `TCLR`
//! rows the firmware's own temperature learning writes (`INS_TCALn_ENABLE` 2: per instance `I`
//! and sensor type `SType`, 0 the accelerometer and 1 the gyro, the mean `X`, `Y`, `Z` of the
//! samples over each 0.5 °C of warming at their mid temperature `Temp`, the accelerometer's less
//! its first mean), read as sensors of their own (`tclr-gyro0`, `tclr-accel0`), taken only when
//! named ([`Sensor::learned`]). The raw `GYR`, `ACC` and `BARO` messages are counted.
//!
//! An `IMU` message is what the firmware compensated, in the vehicle's axes: on reading, its axes
//! are turned back to the board's where the board is mounted rotated (`AHRS_ORIENTATION`,
//! [`BoardRotation`]), and where the firmware's own temperature correction was on while it logged
//! (`INS_TCALn_ENABLE` 1) the correction the log's `PARM` messages describe is undone ([`Tcal`]),
//! both as ArduPilot's `tempcal_IMU.py` does, so that a fit sees the sensor's own output in the
//! axes the autopilot's parameters apply in.

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::rc::Rc;

use firmware_core::Quantity;

use super::error::{Damage, Progress, RecordedError, open};
use super::framing::{Filtered, Frame, Framing, read_full};
use super::rotation::{self, BoardRotation};
use super::sensor::{Axis, Collected, Correction, Mounting, Sensor};

/// A format message's type byte, and its whole length (header included).
const FMT: u8 = 0x80;
const FMT_LEN: usize = 89;
/// The messages read as sensors, and their instance where the name gives it.
const IMUS: [(&str, u8); 3] = [("IMU", 0), ("IMU2", 1), ("IMU3", 2)];
/// The temperature learning's rows, read as sensors of their own.
const LEARNING: &str = "TCLR";
/// The parameters, read for the temperature correction the firmware applied.
const PARAMETERS: &str = "PARM";
/// The messages counted and listed.
const COUNTED: [&str; 3] = ["GYR", "ACC", "BARO"];

/// What the frames showed: each type's name and length, and how many messages of each.
#[derive(Default)]
struct Types {
    formats: HashMap<u8, (String, usize)>,
    counts: BTreeMap<String, usize>,
}

/// DataFlash framing: `A3 95 type`, then the type's declared length less those 3 bytes.
struct Frames {
    types: Rc<RefCell<Types>>,
}

impl Framing for Frames {
    fn next(&mut self, r: &mut impl std::io::Read) -> Result<Frame, String> {
        let mut msg = vec![0u8; 3];
        match read_full(r, &mut msg)? {
            0 => return Ok(Frame::End),
            3 => {}
            n => return Err(format!("a message header cut after {n} of its 3 bytes")),
        }
        if msg[..2] != [0xA3, 0x95] {
            return Err(format!(
                "no message header (A3 95) but {:02X} {:02X}: the bytes are corrupt from here",
                msg[0], msg[1]
            ));
        }
        let kind = msg[2];
        let mut types = self.types.borrow_mut();
        let (name, len) = match (kind, types.formats.get(&kind)) {
            (FMT, _) => ("FMT".to_owned(), FMT_LEN),
            (_, Some((name, len))) => (name.clone(), *len),
            (_, None) => {
                return Err(format!(
                    "a message of type {kind} that no format (FMT) defined before it"
                ));
            }
        };
        msg.resize(len.max(3), 0);
        let n = read_full(r, &mut msg[3..])?;
        if n < len.saturating_sub(3) {
            return Err(format!(
                "a {name} message of {len} bytes cut after {}",
                n + 3
            ));
        }
        if kind == FMT {
            let ty = msg[3];
            let length = usize::from(msg[4]);
            let text = String::from_utf8_lossy(&msg[5..9]);
            let fmt_name = text.trim_end_matches('\0').to_owned();
            if length < 3 {
                return Err(format!(
                    "a format for {fmt_name} of {length} bytes, shorter than a header"
                ));
            }
            types.formats.insert(ty, (fmt_name, length));
            return Ok(Frame::Message(msg, true));
        }
        let keep =
            [LEARNING, PARAMETERS].contains(&name.as_str()) || IMUS.iter().any(|(n, _)| *n == name);
        if keep || COUNTED.contains(&name.as_str()) {
            *types.counts.entry(name).or_default() += 1;
        }
        Ok(Frame::Message(msg, keep))
    }
}

/// One instance's samples as they are read.
#[derive(Default)]
struct Samples {
    time_s: Vec<f64>,
    temp_c: Vec<f64>,
    axes: [Vec<f64>; 6],
}

/// The axes of an `IMU` message: field, channel name, quantity, factor to the project's units.
const AXES: [(&str, &str, Quantity, f64); 6] = [
    (
        "GyrX",
        "gyr.x",
        Quantity::AngularRate,
        180.0 / std::f64::consts::PI,
    ),
    (
        "GyrY",
        "gyr.y",
        Quantity::AngularRate,
        180.0 / std::f64::consts::PI,
    ),
    (
        "GyrZ",
        "gyr.z",
        Quantity::AngularRate,
        180.0 / std::f64::consts::PI,
    ),
    ("AccX", "acc.x", Quantity::SpecificForce, 1.0),
    ("AccY", "acc.y", Quantity::SpecificForce, 1.0),
    ("AccZ", "acc.z", Quantity::SpecificForce, 1.0),
];

/// What a log's entries hold for its sensors, gathered entry by entry: each IMU instance's samples
/// (turned back to the board's axes, with the correction undone where it was on) and each `TCLR`
/// sensor's, with the parameters that say how.
#[derive(Default)]
struct Gathered {
    by_instance: BTreeMap<u8, Samples>,
    learned: BTreeMap<(u8, u8), Samples>,
    tcal: Tcal,
    corrected: BTreeMap<u8, Correction>,
    mounted: BTreeMap<u8, Mounting>,
}

impl Gathered {
    /// Takes entry `e`: a parameter, a `TCLR` row or an IMU sample; any other is passed over.
    fn take(&mut self, e: &ardupilot_binlog::Entry) {
        let number = |field| {
            e.get_u64(field)
                .or_else(|| e.get_i64(field).map(|i| i as u64))
        };
        if e.name == PARAMETERS {
            if let (Some(name), Some(value)) = (e.get_str("Name"), e.get_f64("Value")) {
                self.tcal.set(name, value);
            }
            return;
        }
        let Some(t) = e.timestamp_usec.or_else(|| e.get_u64("TimeUS")) else {
            return;
        };
        if e.name == LEARNING {
            let (Some(i), Some(kind @ (TCLR_ACCEL | TCLR_GYRO))) = (number("I"), number("SType"))
            else {
                return;
            };
            let s = self.learned.entry((kind as u8, i as u8)).or_default();
            s.time_s.push(t as f64 * 1e-6);
            s.temp_c.push(e.get_f64("Temp").unwrap_or(f64::NAN));
            let k = if kind == TCLR_GYRO { AXES[0].3 } else { 1.0 };
            for (a, field) in s.axes.iter_mut().zip(["X", "Y", "Z"]) {
                a.push(e.get_f64(field).map_or(f64::NAN, |v| v * k));
            }
            return;
        }
        let Some(&(_, default)) = IMUS.iter().find(|(n, _)| *n == e.name) else {
            return;
        };
        let instance = number("I").map_or(default, |i| i as u8);
        let s = self.by_instance.entry(instance).or_default();
        let temp_c = e.get_f64("T").unwrap_or(f64::NAN);
        let undo = self.tcal.undo(instance, temp_c);
        if let Some((how, _)) = undo {
            self.corrected.entry(instance).or_insert(how);
        }
        if let Some(m) = &self.tcal.mounting {
            self.mounted.entry(instance).or_insert_with(|| m.clone());
        }
        s.time_s.push(t as f64 * 1e-6);
        s.temp_c.push(temp_c);
        let logged = AXES.map(|(field, ..)| e.get_f64(field).unwrap_or(f64::NAN));
        let own = self.tcal.board_axes(logged);
        for (j, (a, (.., k))) in s.axes.iter_mut().zip(AXES).enumerate() {
            let applied = undo.map_or(0.0, |(_, by)| by[j]);
            a.push((own[j] + applied) * k);
        }
    }

    /// The sensors gathered: each IMU instance, then each `TCLR` sensor.
    fn sensors(self) -> Vec<Sensor> {
        let Self {
            by_instance,
            learned,
            corrected,
            mounted,
            ..
        } = self;
        let imus = by_instance.into_iter().map(|(i, s)| {
            let axes = AXES
                .iter()
                .map(|&(field, name, quantity, _)| (field, name, quantity));
            Sensor {
                correction: corrected.get(&i).copied(),
                mounting: mounted.get(&i).cloned(),
                ..sensor(format!("imu{i}"), "IMU", i, ("T", s), axes, false)
            }
        });
        let learning = learned.into_iter().map(|((kind, i), s)| {
            let (short, quantity) = if u64::from(kind) == TCLR_GYRO {
                ("gyro", Quantity::AngularRate)
            } else {
                ("accel", Quantity::SpecificForce)
            };
            let axes = [("X", "x"), ("Y", "y"), ("Z", "z")]
                .into_iter()
                .map(|(field, name)| (field, name, quantity));
            sensor(
                format!("tclr-{short}{i}"),
                LEARNING,
                i,
                ("Temp", s),
                axes,
                true,
            )
        });
        imus.chain(learning).collect()
    }
}

/// Reads `path`'s sensors ([`Recorded::read`](super::Recorded::read)).
pub(super) fn read(path: &Path, progress: Progress<'_>) -> Result<Collected, RecordedError> {
    let (file, total) = open(path)?;
    let damage = Rc::new(RefCell::new(None::<Damage>));
    let types = Rc::new(RefCell::new(Types::default()));
    let frames = Frames {
        types: Rc::clone(&types),
    };
    let filtered = Filtered::new(file, total, frames, Rc::clone(&damage), progress);
    let mut gathered = Gathered::default();
    // The frames passed on are whole and typed: an entry the parser refuses is skipped.
    for e in ardupilot_binlog::Reader::new(filtered).flatten() {
        gathered.take(&e);
    }
    let damage = damage.borrow_mut().take();
    let types = types.borrow();
    let sensors = gathered.sensors();
    let others = types
        .counts
        .iter()
        .filter(|(name, _)| COUNTED.contains(&name.as_str()))
        .map(|(name, n)| (name.clone(), *n))
        .collect();
    Ok((sensors, others, damage))
}

/// `TCLR`'s sensor types.
const TCLR_ACCEL: u64 = 0;
const TCLR_GYRO: u64 = 1;

/// One instance's samples as a sensor: its name, message, instance, temperature field and
/// samples, and its axes (field, channel name, quantity) in the samples' order.
fn sensor<'a>(
    name: String,
    topic: &str,
    instance: u8,
    (temp_field, s): (&'static str, Samples),
    axes: impl Iterator<Item = (&'static str, &'a str, Quantity)>,
    learned: bool,
) -> Sensor {
    Sensor {
        name,
        topic: topic.to_owned(),
        instance,
        device_id: None,
        id_changes: Vec::new(),
        time_field: "TimeUS",
        temp_field,
        temp_c: if s.temp_c.iter().any(|t| t.is_finite()) {
            s.temp_c
        } else {
            Vec::new()
        },
        time_s: s.time_s,
        unreadable: 0,
        axes: axes
            .zip(s.axes)
            .map(|((field, name, quantity), values)| Axis {
                name: name.to_owned(),
                field,
                quantity,
                values,
            })
            .collect(),
        learned,
        correction: None,
        mounting: None,
    }
}

/// ArduPilot's temperature correction and board rotation as the log's `PARM` messages set them,
/// the values last set (`INS_TCALn_*` for instance n − 1, `INS_ACCn_CALTEMP`, `INS_GYRn_CALTEMP`,
/// `AHRS_ORIENTATION` and a custom rotation's angles). Undone as `tempcal_IMU.py` undoes it, in
/// the board's axes: the firmware subtracted
/// p(T) − p(T_cal) from each axis, p(x) = (c₁d + c₂d² + c₃d³)·10⁻⁶ with d = x − 35 °C, T and T_cal
/// clipped to [TMIN, TMAX] (`AP_InertialSensor_tempcal.cpp`); with no calibration temperature of
/// its own a sensor's is 35 °C, and one below −80 °C means none was applied.
#[derive(Debug, Default)]
struct Tcal {
    /// Per instance, the values last set.
    imus: BTreeMap<u8, TcalImu>,
    /// The parameters the board's rotation is read from ([`rotation::is_parameter`]).
    mounting_parameters: BTreeMap<String, f64>,
    /// The board's rotation they give: `None` for none, else turned back or not known.
    mounting: Option<Mounting>,
}

/// One instance's correction parameters.
#[derive(Debug, Clone, Copy)]
struct TcalImu {
    enable: f64,
    range: (f64, f64),
    /// `[accelerometer, gyro][power − 1][axis]`.
    coeff: [[[f64; 3]; 3]; 2],
    /// The accelerometer's and the gyro's calibration temperatures.
    cal_temp: [f64; 2],
}

impl Default for TcalImu {
    fn default() -> Self {
        // The parameters' defaults: disabled, 0…70 °C, no coefficient.
        Self {
            enable: 0.0,
            range: (0.0, 70.0),
            coeff: [[[0.0; 3]; 3]; 2],
            cal_temp: [TCAL_REFERENCE_C; 2],
        }
    }
}

/// ArduPilot's fixed reference temperature of the correction polynomial, °C.
const TCAL_REFERENCE_C: f64 = 35.0;

impl Tcal {
    /// Takes a parameter the correction depends on; others are ignored.
    fn set(&mut self, name: &str, value: f64) {
        if rotation::is_parameter(name) {
            self.mounting_parameters.insert(name.to_owned(), value);
            self.mounting = self
                .mounting_parameters
                .get("AHRS_ORIENTATION")
                .and_then(|&id| {
                    let rotation = u16::try_from(id as i64)
                        .ok()
                        .filter(|_| id.fract() == 0.0)
                        .and_then(|id| {
                            BoardRotation::ardupilot(id, |n| {
                                self.mounting_parameters.get(n).copied()
                            })
                        });
                    match rotation {
                        Some(r) if r.is_identity() => None,
                        Some(r) => Some(Mounting::TurnedBack(r)),
                        None => Some(Mounting::Unknown(id)),
                    }
                });
            return;
        }
        // 1-based in the names, the log's instance less one.
        let instance = |s: &str| s.parse::<u8>().ok().filter(|n| *n >= 1).map(|n| n - 1);
        if let Some(rest) = name.strip_prefix("INS_TCAL") {
            let Some((i, field)) = rest
                .split_once('_')
                .and_then(|(n, f)| Some((instance(n)?, f)))
            else {
                return;
            };
            let imu = self.imus.entry(i).or_default();
            match field {
                "ENABLE" => imu.enable = value,
                "TMIN" => imu.range.0 = value,
                "TMAX" => imu.range.1 = value,
                _ => {
                    let kind = match field.get(..3) {
                        Some("ACC") => 0,
                        Some("GYR") => 1,
                        _ => return,
                    };
                    let power = field.get(3..4).and_then(instance).filter(|p| *p < 3);
                    let axis = ["_X", "_Y", "_Z"]
                        .iter()
                        .position(|a| field.get(4..) == Some(a));
                    if let (Some(p), Some(axis)) = (power, axis) {
                        imu.coeff[kind][usize::from(p)][axis] = value;
                    }
                }
            }
            return;
        }
        for (kind, prefix) in ["INS_ACC", "INS_GYR"].into_iter().enumerate() {
            let n = name
                .strip_prefix(prefix)
                .and_then(|r| r.strip_suffix("_CALTEMP"));
            if let Some(i) = n.and_then(instance) {
                self.imus.entry(i).or_default().cal_temp[kind] = value;
            }
        }
    }

    /// An `IMU` message's axes (gyro x, y, z, then the accelerometer's) in the board's axes: turned
    /// back where the board is mounted rotated, as logged where it is not or the rotation is not
    /// known.
    fn board_axes(&self, [gx, gy, gz, ax, ay, az]: [f64; 6]) -> [f64; 6] {
        let Some(Mounting::TurnedBack(r)) = &self.mounting else {
            return [gx, gy, gz, ax, ay, az];
        };
        let ([gx, gy, gz], [ax, ay, az]) = (r.turn_back([gx, gy, gz]), r.turn_back([ax, ay, az]));
        [gx, gy, gz, ax, ay, az]
    }

    /// Where instance `imu`'s correction was on at temperature `temp_c`: what becomes of it, and
    /// what to add back to each of an `IMU` message's axes (gyro x, y, z in rad/s, then the
    /// accelerometer's in m/s²).
    fn undo(&self, imu: u8, temp_c: f64) -> Option<(Correction, [f64; 6])> {
        let c = self.imus.get(&imu).filter(|c| c.enable == 1.0)?;
        if let Some(Mounting::Unknown(_)) = self.mounting {
            return Some((Correction::Left, [0.0; 6]));
        }
        let poly = |kind: usize, axis: usize, t: f64| {
            // As `constrain_float`, never panicking on a range the parameters got backwards.
            let d = t.max(c.range.0).min(c.range.1) - TCAL_REFERENCE_C;
            let k = |p: usize| c.coeff[kind][p][axis];
            (k(0) * d + k(1) * d * d + k(2) * d * d * d) * 1e-6
        };
        let mut by = [0.0; 6];
        for (j, b) in by.iter_mut().enumerate() {
            let (kind, axis) = if j < 3 { (1, j) } else { (0, j - 3) };
            let cal = c.cal_temp[kind];
            if cal >= -80.0 && temp_c.is_finite() {
                *b = poly(kind, axis, temp_c) - poly(kind, axis, cal);
            }
        }
        Some((Correction::Undone, by))
    }
}
