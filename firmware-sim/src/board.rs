//! A simulated flight controller on the bench: two IMUs, each a three-axis gyro and a three-axis
//! accelerometer on one die with one temperature sensor, warming from a cold soak as a board
//! does when it is powered on after a night in the freezer (the thermal calibration PX4's and
//! ArduPilot's guides ask for). It records what the boards record: a PX4 ULog (`sensor_gyro`,
//! `sensor_accel` per instance, a `sensor_baro`) or an ArduPilot DataFlash log (`IMU` per
//! instance, `BARO`, and the `TCLR` rows ArduPilot's temperature learning writes as the board
//! warms), in their units (rad/s, m/s², °C).
//!
//! The two IMUs differ in what the autopilots' cubic can follow:
//!
//! - IMU 0 ([`Board::nominal`]) has a bias that is a cubic in its die temperature, read by its
//!   own sensor without lag: the autopilots' model is the truth, and a better one can only match
//!   it.
//! - IMU 1 hides two effects: its bias steps by a knee near 30 °C (a smooth step a cubic cannot
//!   bend to; ICM-42688 owners report curves like it), and its temperature sensor lags the die by
//!   [`Imu::sensor_lag_s`] (on a warming board the reading trails the bias, by more the faster it
//!   warms).
//!
//! The bias curves are the board's own and fixed; the seed draws only the noise, so two logs of
//! the same board (another power-on, another soak) share them.

use std::io::Write;

use fog_data::autopilot::BoardRotation;
use fog_data::autopilot::write::{DataFlashWriter, PX4_SENSOR_FIELDS, ULogWriter, Value};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Serialize;

/// One axis's bias against the die temperature: a cubic in T − 25 °C, plus a knee (a smooth step
/// of `knee` centred on `knee_c`, 3 °C wide), in rad/s or m/s².
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Bias {
    /// Coefficients of (T − 25)^0 … ^3.
    pub cubic: [f64; 4],
    /// The knee's height (0: none).
    pub knee: f64,
    /// The knee's centre, °C.
    pub knee_c: f64,
}

impl Bias {
    /// The bias at die temperature `t`.
    pub fn at(&self, t: f64) -> f64 {
        let d = t - 25.0;
        let [c0, c1, c2, c3] = self.cubic;
        c0 + d * (c1 + d * (c2 + d * c3))
            + self.knee * 0.5 * (1.0 + ((t - self.knee_c) / 1.5).tanh())
    }
}

/// One IMU: a gyro and an accelerometer on one die.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Imu {
    /// The gyro's device ID.
    pub gyro_id: u32,
    /// The accelerometer's device ID.
    pub accel_id: u32,
    /// Each gyro axis's bias, rad/s.
    pub gyro: [Bias; 3],
    /// Each accelerometer axis's bias, m/s² (beyond gravity, along −z on a level board).
    pub accel: [Bias; 3],
    /// The gyro's white noise per sample, rad/s.
    pub gyro_noise: f64,
    /// The accelerometer's white noise per sample, m/s².
    pub accel_noise: f64,
    /// How long the temperature sensor lags the die (first order), s; 0: none.
    pub sensor_lag_s: f64,
    /// The die's self-heating above the board, °C.
    pub self_heating_c: f64,
}

/// A flight controller: its IMUs.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Board {
    /// The IMUs, in instance order.
    pub imus: Vec<Imu>,
}

/// One thermal calibration run: the soak, the warm-up and the log's rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Run {
    /// The board's temperature at power-on, °C.
    pub soak_c: f64,
    /// Where it settles, °C.
    pub settle_c: f64,
    /// The warm-up's time constant, s.
    pub warm_up_s: f64,
    /// The log's length, s.
    pub duration_s: f64,
    /// Samples per second.
    pub rate_hz: f64,
}

impl Default for Run {
    fn default() -> Self {
        Self {
            soak_c: -10.0,
            settle_c: 60.0,
            warm_up_s: 1500.0,
            duration_s: 7200.0,
            rate_hz: 5.0,
        }
    }
}

/// A knee-less bias of these coefficients.
const fn cubic(cubic: [f64; 4]) -> Bias {
    Bias {
        cubic,
        knee: 0.0,
        knee_c: 30.0,
    }
}

impl Board {
    /// The board of the module doc: IMU 0 plain, IMU 1 with a knee and a lagging sensor.
    pub fn nominal() -> Self {
        let plain = Imu {
            gyro_id: 2_424_842,
            accel_id: 2_424_842,
            gyro: [
                cubic([2.0e-3, 6.0e-5, -1.2e-6, 1.5e-8]),
                cubic([-1.5e-3, -4.0e-5, 8.0e-7, 1.0e-8]),
                cubic([0.8e-3, 3.0e-5, 1.0e-6, -2.0e-8]),
            ],
            accel: [
                cubic([0.05, 1.2e-3, -1.0e-5, 2.0e-7]),
                cubic([-0.03, -8.0e-4, 1.5e-5, -1.0e-7]),
                cubic([0.08, 2.0e-3, 2.0e-5, -3.0e-7]),
            ],
            gyro_noise: 1.5e-4,
            accel_noise: 4.0e-3,
            sensor_lag_s: 0.0,
            self_heating_c: 2.0,
        };
        let knee = |b: Bias, knee: f64| Bias {
            knee,
            knee_c: 30.0,
            ..b
        };
        let hidden = Imu {
            gyro_id: 3_670_050,
            accel_id: 3_670_050,
            gyro: [
                knee(cubic([-1.0e-3, 5.0e-5, 6.0e-7, -1.0e-8]), 1.2e-3),
                knee(cubic([0.5e-3, -7.0e-5, -9.0e-7, 1.2e-8]), -0.9e-3),
                knee(cubic([1.2e-3, 2.0e-5, 5.0e-7, 1.0e-8]), 0.7e-3),
            ],
            accel: [
                knee(cubic([-0.04, 9.0e-4, 1.0e-5, -1.0e-7]), 0.03),
                knee(cubic([0.06, -1.0e-3, -2.0e-5, 2.0e-7]), -0.025),
                knee(cubic([-0.05, 1.5e-3, 1.0e-5, 1.5e-7]), 0.04),
            ],
            gyro_noise: 1.5e-4,
            accel_noise: 4.0e-3,
            sensor_lag_s: 90.0,
            self_heating_c: 5.0,
        };
        Self {
            imus: vec![plain, hidden],
        }
    }

    /// Every sample of `run`, per IMU: time (µs), sensor reading (°C), gyro (rad/s) and
    /// accelerometer (m/s²).
    pub fn record(&self, run: &Run, seed: u64) -> Vec<Vec<ImuSample>> {
        let n = (run.duration_s * run.rate_hz).round() as usize;
        let dt = 1.0 / run.rate_hz;
        self.imus
            .iter()
            .enumerate()
            .map(|(k, imu)| {
                let mut rng = ChaCha8Rng::seed_from_u64(seed ^ (0x1e_0000 + k as u64));
                let mut sensor = run.soak_c;
                (0..n)
                    .map(|i| {
                        let t = i as f64 * dt;
                        let board =
                            run.settle_c + (run.soak_c - run.settle_c) * (-t / run.warm_up_s).exp();
                        // The die warms with the board and by its own power after power-on.
                        let die = board + imu.self_heating_c * (1.0 - (-t / 120.0).exp());
                        sensor = if imu.sensor_lag_s > 0.0 {
                            sensor + (die - sensor) * (1.0 - (-dt / imu.sensor_lag_s).exp())
                        } else {
                            die
                        };
                        let mut noise = |sigma: f64| {
                            let z: f64 = StandardNormal.sample(&mut rng);
                            sigma * z
                        };
                        let g = imu.gyro.map(|b| b.at(die) + noise(imu.gyro_noise));
                        let mut a = imu.accel.map(|b| b.at(die) + noise(imu.accel_noise));
                        a[2] -= firmware_core::units::STANDARD_GRAVITY;
                        ImuSample {
                            time_us: 1_000_000 + (t * 1e6).round() as u64,
                            // As the sensors report it, in hundredths of a degree.
                            temp_c: (sensor * 100.0).round() / 100.0,
                            gyro: g,
                            accel: a,
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// Writes `samples` ([`Self::record`]) as a PX4 ULog.
    pub fn ulog(&self, samples: &[Vec<ImuSample>], out: impl Write) -> std::io::Result<()> {
        let mut w = ULogWriter::new(out, 0)?;
        w.format("sensor_gyro", &PX4_SENSOR_FIELDS)?;
        w.format("sensor_accel", &PX4_SENSOR_FIELDS)?;
        w.format(
            "sensor_baro",
            &[
                ("uint64_t", "timestamp"),
                ("uint64_t", "timestamp_sample"),
                ("uint32_t", "device_id"),
                ("float", "pressure"),
                ("float", "temperature"),
            ],
        )?;
        let mut ids = Vec::new();
        for k in 0..self.imus.len() {
            ids.push((
                w.subscribe("sensor_gyro", k as u8)?,
                w.subscribe("sensor_accel", k as u8)?,
            ));
        }
        let baro = w.subscribe("sensor_baro", 0)?;
        let n = samples.iter().map(Vec::len).min().unwrap_or(0);
        for i in 0..n {
            for ((imu, own), &(g, a)) in self.imus.iter().zip(samples).zip(&ids) {
                let s = &own[i];
                let row = |id: u32, xyz: [f64; 3]| {
                    [
                        Value::U64(s.time_us + 200),
                        Value::U64(s.time_us),
                        Value::U32(id),
                        Value::F32(xyz[0] as f32),
                        Value::F32(xyz[1] as f32),
                        Value::F32(xyz[2] as f32),
                        Value::F32(s.temp_c as f32),
                        Value::U32(0),
                    ]
                };
                w.data(g, &row(imu.gyro_id, s.gyro))?;
                w.data(a, &row(imu.accel_id, s.accel))?;
            }
            if let Some(s) = samples.first().map(|own| &own[i]) {
                w.data(
                    baro,
                    &[
                        Value::U64(s.time_us + 300),
                        Value::U64(s.time_us),
                        Value::U32(3_997_706),
                        Value::F32(101_325.0),
                        Value::F32(s.temp_c as f32),
                    ],
                )?;
            }
        }
        w.into_inner().flush()
    }

    /// Writes `samples` ([`Self::record`]) as an ArduPilot DataFlash log, of the board mounted in
    /// the vehicle by `mounting` (`AHRS_ORIENTATION`, and a custom rotation's angles, written as
    /// `PARM`s): the `IMU` messages then hold the vehicle's axes, as the firmware logs them, and
    /// the `TCLR` rows the board's.
    pub fn dataflash(
        &self,
        samples: &[Vec<ImuSample>],
        mounting: &BoardRotation,
        out: impl Write,
    ) -> std::io::Result<()> {
        const IMU: u8 = 129;
        const BARO: u8 = 130;
        const TCLR: u8 = 131;
        const PARM: u8 = 132;
        let mut w = DataFlashWriter::new(out)?;
        w.define(PARM, "PARM", "QNf", "TimeUS,Name,Value")?;
        let orientation = ("AHRS_ORIENTATION".to_owned(), f64::from(mounting.id));
        for (name, value) in std::iter::once(orientation).chain(mounting.parameters()) {
            w.write(
                PARM,
                &[Value::U64(0), Value::name(&name), Value::F32(value as f32)],
            )?;
        }
        w.define(
            IMU,
            "IMU",
            "QBffffffIIfBBHH",
            "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz",
        )?;
        w.define(BARO, "BARO", "QBfff", "TimeUS,I,Alt,Press,Temp")?;
        w.define(TCLR, "TCLR", "QBBffffI", "TimeUS,I,SType,Temp,X,Y,Z,NSamp")?;
        let mut learning: Vec<Learning> = samples
            .iter()
            .map(|own| Learning::new(own.first().map_or(0.0, |s| s.temp_c)))
            .collect();
        let n = samples.iter().map(Vec::len).min().unwrap_or(0);
        for i in 0..n {
            for (k, own) in samples.iter().enumerate() {
                let s = &own[i];
                if let Some((temp_c, count, means)) = learning[k].add(s) {
                    for (kind, xyz) in means.iter().enumerate() {
                        let mut v = vec![
                            Value::U64(s.time_us),
                            Value::U8(k as u8),
                            Value::U8(kind as u8),
                            Value::F32(temp_c as f32),
                        ];
                        v.extend(xyz.iter().map(|&x| Value::F32(x as f32)));
                        v.push(Value::U32(count));
                        w.write(TCLR, &v)?;
                    }
                }
                let mut v = vec![Value::U64(s.time_us), Value::U8(k as u8)];
                let (gyro, accel) = (mounting.turn(s.gyro), mounting.turn(s.accel));
                v.extend(gyro.iter().chain(&accel).map(|&x| Value::F32(x as f32)));
                v.extend([Value::U32(0), Value::U32(0), Value::F32(s.temp_c as f32)]);
                v.extend([
                    Value::U8(1),
                    Value::U8(1),
                    Value::U16(1000),
                    Value::U16(1000),
                ]);
                w.write(IMU, &v)?;
            }
            if let Some(s) = samples.first().map(|own| &own[i]) {
                w.write(
                    BARO,
                    &[
                        Value::U64(s.time_us),
                        Value::U8(0),
                        Value::F32(0.0),
                        Value::F32(101_325.0),
                        Value::F32(s.temp_c as f32),
                    ],
                )?;
            }
        }
        w.into_inner().flush()
    }
}

/// ArduPilot's temperature learning as it logs (`INS_TCALn_ENABLE` 2; its
/// `AP_InertialSensor_tempcal.cpp`): each sensor's samples summed until there are at least 100
/// and the temperature has risen 0.5 °C since the last row, then their mean at the mid
/// temperature, the accelerometer's less its first mean (the learning's zero). The firmware
/// low-passes the temperature first; the simulated reading is smooth already.
struct Learning {
    /// The sums of the accelerometer's and the gyro's axes (`TCLR`'s `SType` 0 and 1).
    sums: [[f64; 3]; 2],
    count: u32,
    last_temp_c: f64,
    accel_start: Option<[f64; 3]>,
}

impl Learning {
    fn new(temp_c: f64) -> Self {
        Self {
            sums: [[0.0; 3]; 2],
            count: 0,
            last_temp_c: temp_c,
            accel_start: None,
        }
    }

    /// Adds a sample; where a row is due, its temperature, sample count and the two means.
    fn add(&mut self, s: &ImuSample) -> Option<(f64, u32, [[f64; 3]; 2])> {
        for (sum, xyz) in self.sums.iter_mut().zip([s.accel, s.gyro]) {
            for (a, v) in sum.iter_mut().zip(xyz) {
                *a += v;
            }
        }
        self.count += 1;
        if self.count < 100 || s.temp_c - self.last_temp_c < 0.5 {
            return None;
        }
        let n = f64::from(self.count);
        let mut means = self.sums.map(|sum| sum.map(|v| v / n));
        let start = *self.accel_start.get_or_insert(means[0]);
        for (m, z) in means[0].iter_mut().zip(start) {
            *m -= z;
        }
        let row = (0.5 * (s.temp_c + self.last_temp_c), self.count, means);
        *self = Self {
            accel_start: Some(start),
            ..Self::new(s.temp_c)
        };
        Some(row)
    }
}

/// One IMU's sample as the board reports it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuSample {
    /// Time since boot, µs.
    pub time_us: u64,
    /// The temperature sensor's reading, °C (0.01 °C steps).
    pub temp_c: f64,
    /// Gyro x, y, z, rad/s.
    pub gyro: [f64; 3],
    /// Accelerometer x, y, z, m/s².
    pub accel: [f64; 3],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_board_warms_from_its_soak_and_imu_1s_sensor_trails_its_die() {
        let board = Board::nominal();
        let run = Run {
            duration_s: 3600.0,
            rate_hz: 1.0,
            ..Run::default()
        };
        let s = board.record(&run, 1);
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].len(), 3600);
        assert!((s[0][0].temp_c - run.soak_c).abs() < 0.1);
        assert!(s[0][3599].temp_c > 50.0);
        // IMU 1's sensor lags its die: while warming it reads colder than IMU 0's would with the
        // same self-heating.
        let t = 600;
        let die = s[0][t].temp_c - 2.0 + 5.0;
        assert!(s[1][t].temp_c < die - 0.5, "{} {die}", s[1][t].temp_c);
        // Same seed, same samples; another seed, other noise on the same curves.
        assert_eq!(board.record(&run, 1), s);
        let other = board.record(&run, 2);
        assert_ne!(other[0][10].gyro, s[0][10].gyro);
        assert_eq!(other[0][10].temp_c, s[0][10].temp_c);
    }
}
