//! A simulated unit of several gyro axes (a FOG triad, or more): each axis its own gyro (scale
//! factor, bias, noise) and its own hidden effects, all in one housing with one temperature
//! sensor, in one chamber, on a rate table that turns every axis (a three-axis table: each axis
//! through its own rate program in a stream; the paper's rates together at each soak), or, in a
//! static log (the `room` stream), all of them at rest.
//!
//! Each axis runs the single gyro's simulation ([`paper::run`], [`stream::run`]) with its own
//! noise seed (the first axis the unit's seed, so a unit of one axis is the single gyro, byte for
//! byte); the housing's thermal behaviour is the first axis's (its self-heating and sensor noise
//! are the unit's), so every axis sees the same housing temperature, and the unit's temperature
//! column is the first axis's sensor reading. Every axis's effects act on its own coil.
//!
//! The files name each axis's columns `NAME.voltage_v` and `NAME.rate_dps` (and `NAME.coil_c` and
//! `NAME.table_rate_dps`, the truth); [`Axes::channels_toml`] writes the channels file that names them
//! for the trainer.

use serde::{Deserialize, Serialize};

use crate::gyro::effects::{Effect, Hidden};
use crate::gyro::paper::{self, Point};
use crate::gyro::plant::GyroParams;
use crate::gyro::stream::{self, Row, StreamConfig};

/// Most axes a simulated unit has (a unit blob's channels on the firmware's six).
pub const MAX_AXES: usize = 6;

/// One axis: its name, its gyro and its hidden effects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Axis {
    /// Its name (`gyro.x`).
    pub name: String,
    /// Its gyro.
    pub params: GyroParams,
    /// Effects acting on it.
    pub effects: Vec<Effect>,
}

/// The axes of a unit, the first setting the housing's thermal behaviour (module doc).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Axes {
    /// The axes, in order.
    pub axes: Vec<Axis>,
}

/// The name of axis `k` of `n`: `gyro.x`, `gyro.y`, `gyro.z`, then `gyro.4` … for more.
pub fn axis_name(k: usize) -> String {
    match k {
        0 => "gyro.x".to_owned(),
        1 => "gyro.y".to_owned(),
        2 => "gyro.z".to_owned(),
        _ => format!("gyro.{}", k + 1),
    }
}

/// The noise seed of axis `k` of a unit simulated with `seed`.
fn axis_seed(seed: u64, k: usize) -> u64 {
    seed.wrapping_add(0x9E37_79B9 * k as u64)
}

impl Axes {
    /// `params` and `effects` per axis, named in order, the first axis's housing the unit's.
    pub fn new(parts: Vec<(GyroParams, Hidden)>) -> Self {
        let housing = parts.first().map(|(p, _)| p.clone());
        Self {
            axes: parts
                .into_iter()
                .enumerate()
                .map(|(k, (mut params, effects))| {
                    if let Some(h) = &housing {
                        params.self_heating_c = h.self_heating_c;
                        params.temp_noise_c = h.temp_noise_c;
                    }
                    Axis {
                        name: axis_name(k),
                        params,
                        effects: effects.0,
                    }
                })
                .collect(),
        }
    }

    /// The paper's protocol on every axis: one list of points per axis, row for row at the same
    /// soaks and table rates.
    pub fn paper(&self, seed: u64, position_tests: bool) -> Vec<Vec<Point>> {
        self.axes
            .iter()
            .enumerate()
            .map(|(k, a)| {
                paper::run(
                    &a.params,
                    Hidden(a.effects.clone()),
                    axis_seed(seed, k),
                    position_tests,
                )
            })
            .collect()
    }

    /// A stream of the chamber program `cfg` on every axis: one list of rows per axis, at the same
    /// times (every axis's own rate program).
    pub fn stream(&self, cfg: &StreamConfig, seed: u64) -> Vec<Vec<Row>> {
        self.axes
            .iter()
            .enumerate()
            .map(|(k, a)| {
                stream::run(
                    &a.params,
                    cfg,
                    Hidden(a.effects.clone()),
                    axis_seed(seed, k),
                )
            })
            .collect()
    }

    /// The points of every axis as one CSV: the unit's temperature and setpoint, then each axis's
    /// output and reference (`NAME.voltage_v`, `NAME.rate_dps`) and its commanded rate.
    pub fn points_csv(&self, points: &[Vec<Point>]) -> String {
        let mut s = String::from("temp_c,setpoint_c");
        for a in &self.axes {
            let n = &a.name;
            s.push_str(&format!(",{n}.voltage_v,{n}.rate_dps,{n}.table_rate_dps"));
        }
        s.push('\n');
        let rows = points.first().map_or(0, Vec::len);
        for i in 0..rows {
            let first = &points[0][i];
            s.push_str(&format!("{:.5},{}", first.temp_c, first.setpoint_c));
            for p in points {
                let p = &p[i];
                s.push_str(&format!(
                    ",{:.9},{:.9},{}",
                    p.voltage_v, p.rate_dps, p.table_rate_dps
                ));
            }
            s.push('\n');
        }
        s
    }

    /// The stream of every axis as one CSV: time, the unit's temperature and the chamber air, then
    /// each axis's output and reference, and the truth behind them (coil temperature, commanded
    /// rate).
    pub fn stream_csv(&self, rows: &[Vec<Row>]) -> String {
        let mut s = String::from("time_s,temp_c,air_c");
        for a in &self.axes {
            let n = &a.name;
            s.push_str(&format!(
                ",{n}.voltage_v,{n}.rate_dps,{n}.coil_c,{n}.table_rate_dps"
            ));
        }
        s.push('\n');
        let n = rows.first().map_or(0, Vec::len);
        for i in 0..n {
            let first = &rows[0][i];
            s.push_str(&format!(
                "{},{:.4},{:.4}",
                first.time_s, first.temp_c, first.air_c
            ));
            for r in rows {
                let r = &r[i];
                s.push_str(&format!(
                    ",{:.9},{:.9},{:.4},{}",
                    r.voltage_v, r.rate_dps, r.coil_c, r.table_rate_dps
                ));
            }
            s.push('\n');
        }
        s
    }

    /// The channels file that names the axes' columns of [`Self::points_csv`] and
    /// [`Self::stream_csv`] for every command that reads them (`--channels`).
    pub fn channels_toml(&self, sensor_id: &str) -> String {
        let mut s = format!(
            "# A simulated unit of {} gyro axes (firmware-sim generate --axes).\n\
             sensor_id = \"{sensor_id}\"\n",
            self.axes.len()
        );
        for a in &self.axes {
            let n = &a.name;
            s.push_str(&format!(
                "\n[[channel]]\nname = \"{n}\"\noutput = \"{n}.voltage_v\"\nunit = \"V\"\n\
                 reference = \"{n}.rate_dps\"\n"
            ));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fog_data::cause::Cause;
    use fog_data::channels::Channels;
    use fog_data::stream::Stream;

    fn triad() -> Axes {
        let hidden = |c: Cause| Hidden::new(&[c], &[]).unwrap();
        Axes::new(vec![
            (GyroParams::nominal(), hidden(Cause::ThermalRate)),
            (GyroParams::random_unit(5), hidden(Cause::None)),
            (GyroParams::random_unit(6), hidden(Cause::Hysteresis)),
        ])
    }

    #[test]
    fn a_unit_of_one_axis_is_the_single_gyro_and_every_axis_shares_the_housing() {
        let one = Axes::new(vec![(GyroParams::nominal(), Hidden::default())]);
        let cfg = StreamConfig::short();
        assert_eq!(
            one.stream(&cfg, 7)[0],
            stream::run(&GyroParams::nominal(), &cfg, Effect::None, 7)
        );
        assert_eq!(
            one.paper(7, false)[0],
            paper::run(&GyroParams::nominal(), Effect::None, 7, false)
        );
        let unit = triad();
        assert_eq!(
            unit.axes[2].params.self_heating_c,
            unit.axes[0].params.self_heating_c
        );
        let rows = unit.stream(&cfg, 7);
        // Same times; the housing (coil of an effect-free axis at rest) follows the first's.
        assert!(rows.iter().all(|r| r.len() == rows[0].len()));
        assert_eq!(rows[1][100].time_s, rows[0][100].time_s);
        // Each axis its own rate program.
        assert_ne!(
            rows[0].iter().map(|r| r.table_rate_dps).collect::<Vec<_>>(),
            rows[1].iter().map(|r| r.table_rate_dps).collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_units_files_read_back_through_its_channels_file() {
        let unit = triad();
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("s.csv");
        let rows = unit.stream(&StreamConfig::short(), 3);
        std::fs::write(&csv, unit.stream_csv(&rows)).unwrap();
        let channels =
            Channels::parse(&dir.path().join("s.toml"), &unit.channels_toml("T-1")).unwrap();
        assert_eq!(channels.sensor_id, "T-1");
        let streams = channels.load_log(&csv, &[]).unwrap();
        assert_eq!(streams.len(), 3);
        for (s, r) in streams.iter().zip(&rows) {
            assert_eq!(s.len(), r.len());
            assert!((s.voltage_v[50] - r[50].voltage_v).abs() < 1e-8);
            assert!((s.rate_dps[50] - r[50].rate_dps).abs() < 1e-8);
        }
        // One axis alone reads as the single gyro's file does.
        let single = dir.path().join("one.csv");
        std::fs::write(&single, crate::gyro::output::stream_csv(&rows[0])).unwrap();
        let alone = Stream::load(&single, &[]).unwrap();
        assert_eq!(alone.temp_c, streams[0].temp_c);
        assert_eq!(alone.voltage_v, streams[0].voltage_v);
    }
}
