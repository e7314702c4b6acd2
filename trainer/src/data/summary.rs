//! A look at a data file as the loader sees it, before anything is fitted: rows, ranges, plateaus,
//! sampling and gaps, rows left out and why, whether the reference seems to carry the earth rate,
//! and where each column came from. A wrong `--map` or unit shows here (a temperature of 300 °C,
//! a scale factor a thousand times the gyro's), not after a fit that made sense of it.

use serde::Serialize;

use firmware_core::Quantity;
use fog_data::autopilot::Sensor;
use fog_data::columns::ColumnMap;
use fog_data::stats::Line;
use fog_data::stream::Stream;

use super::points::{Implausible, Points, PointsError, Screen, plateaus};

/// The vertical earth rate at the poles, °/s (15.041 °/h): the most a reference can be off by it.
const EARTH_DPS: f64 = 15.041 / firmware_core::units::DPH_PER_DPS;

/// The summary of a points table read from `path`, with the rows the implausible-row screen
/// would refuse listed as left out (`trainer summarize --points`).
pub fn of_points_file(
    path: &std::path::Path,
    maps: &[ColumnMap],
    scale_factor: Option<f64>,
) -> Result<Summary, PointsError> {
    let (points, left_out) =
        Points::load_screened(path, maps, None, scale_factor, Screen::Exclude)?;
    Ok(of_points(
        &path.display().to_string(),
        &points,
        maps,
        &left_out,
    ))
}

/// The summary of a stream read from `path` (`trainer summarize --stream`).
pub fn of_stream_file(
    path: &std::path::Path,
    maps: &[ColumnMap],
) -> Result<Summary, fog_data::columns::DataError> {
    let stream = Stream::load(path, maps)?;
    Ok(of_stream(&path.display().to_string(), &stream, maps))
}

/// What a file holds, as loaded.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Summary {
    /// The file.
    pub file: String,
    /// `points` or `stream`.
    pub kind: &'static str,
    /// Rows used.
    pub rows: usize,
    /// Each canonical column and where it came from.
    pub columns: Vec<(String, String)>,
    /// Temperature, °C: lowest and highest.
    pub temp_c: [f64; 2],
    /// Reference rate, °/s.
    pub rate_dps: [f64; 2],
    /// Gyro output, in its units.
    pub output: [f64; 2],
    /// Temperature plateaus of a table (readings more than 1 °C apart), or soaks of a stream
    /// (10 minutes within 0.5 °C).
    pub plateaus: usize,
    /// Distinct reference rates (to 0.01 °/s).
    pub rates: usize,
    /// A stream's typical sample interval, s.
    pub sample_interval_s: Option<f64>,
    /// A stream's gaps and other time problems, as text.
    pub time_issues: Vec<String>,
    /// Rows left out, and why.
    pub excluded: Vec<String>,
    /// The same in one line for the terminal, where windows were left out of a log.
    #[serde(skip)]
    pub excluded_line: Option<String>,
    /// A stream's output step, where every value is a whole multiple of one (a decimated log:
    /// [`fog_data::stats::quantization_step`]).
    pub output_step: Option<f64>,
    /// Output per °/s of a straight line through the non-zero rates: the scale factor the data
    /// show (a wrong unit shows here).
    pub scale_factor_estimate: Option<f64>,
    /// Whether the earth rate seems to be in the reference, and why.
    pub earth_rate: String,
}

fn range(v: &[f64]) -> [f64; 2] {
    v.iter()
        .filter(|x| x.is_finite())
        .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], &x| {
            [lo.min(x), hi.max(x)]
        })
}

fn distinct(v: &[f64], step: f64) -> usize {
    let mut k: Vec<i64> = v
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| (x / step).round() as i64)
        .collect();
    k.sort_unstable();
    k.dedup();
    k.len()
}

/// Where each canonical column came from: its `--map`, or the column of that name.
fn columns(names: &[&str], maps: &[ColumnMap]) -> Vec<(String, String)> {
    names
        .iter()
        .map(|&name| {
            let from = match maps.iter().find(|m| m.name == name) {
                Some(m) => m.source.to_string(),
                None => format!("column {name}"),
            };
            (name.to_owned(), from)
        })
        .collect()
}

/// A straight line's slope through the rows with a non-zero rate: output per °/s. None where
/// fewer than two rates differ (a constant reference, such as gravity on a resting
/// accelerometer, shows no scale factor).
fn slope(rate: &[f64], output: &[f64]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = rate
        .iter()
        .zip(output)
        .filter(|(w, v)| w.is_finite() && v.is_finite() && w.abs() > 0.5)
        .map(|(w, v)| (*w, *v))
        .collect();
    let xs: Vec<f64> = pts.iter().map(|p| p.0).collect();
    if pts.len() < 3 || distinct(&xs, 0.01) < 2 {
        return None;
    }
    Line::fit(pts).map(|l| l.slope)
}

/// The earth rate in the reference, judged from how far the non-zero rates sit from round
/// numbers: a table commanded at round rates whose reference adds the earth rate sits a few
/// thousandths of a °/s off them, all by the same amount.
fn earth_rate(rate: &[f64]) -> String {
    let mut offsets: Vec<f64> = rate
        .iter()
        .filter(|w| w.is_finite() && w.abs() > 0.5)
        .map(|w| w - (w * 10.0).round() / 10.0)
        .collect();
    if offsets.len() < 3 {
        return "cannot tell: the reference is zero (a static log); the bias then includes the \
                earth rate (up to 15 °/h)"
            .to_owned();
    }
    offsets.sort_by(f64::total_cmp);
    let median = offsets[offsets.len() / 2];
    let spread = offsets[offsets.len() * 9 / 10] - offsets[offsets.len() / 10];
    if spread > 1e-3 {
        "cannot tell: the rates are not round numbers (a rig's own steps), so an earth-rate \
         offset does not show"
            .to_owned()
    } else if median.abs() < 1e-4 {
        "seems left out: the rates are round numbers, so the model will learn the earth rate \
         (up to 15 °/h) as bias; add it to rate_dps where the bias matters"
            .to_owned()
    } else if median.abs() <= EARTH_DPS * 1.02 {
        format!(
            "seems included: every rate sits {median:+.2e} °/s off a round number, the earth \
             rate at {:.0}° latitude with the axis vertical",
            (median.abs() / EARTH_DPS).asin().to_degrees()
        )
    } else {
        format!(
            "not the earth rate: the rates sit {median:+.2e} °/s off round numbers, more than \
             the earth rate can be (a reference offset?)"
        )
    }
}

/// A table's summary; `excluded` are the rows the loader's screen left out.
pub fn of_points(
    file: &str,
    points: &Points,
    maps: &[ColumnMap],
    excluded: &[Implausible],
) -> Summary {
    let mut names = vec!["temp_c", "voltage_v", "rate_dps"];
    if points.time_s.is_some() {
        names.push("time_s");
    }
    let plateau_count = plateaus(&points.temp_c).iter().max().map_or(0, |m| m + 1);
    Summary {
        file: file.to_owned(),
        kind: "points",
        rows: points.len(),
        columns: columns(&names, maps),
        temp_c: range(&points.temp_c),
        rate_dps: range(&points.rate_dps),
        output: range(&points.voltage_v),
        plateaus: plateau_count,
        rates: distinct(&points.rate_dps, 0.01),
        sample_interval_s: None,
        time_issues: Vec::new(),
        excluded: excluded.iter().map(ToString::to_string).collect(),
        excluded_line: None,
        output_step: None,
        scale_factor_estimate: slope(&points.rate_dps, &points.voltage_v),
        earth_rate: earth_rate(&points.rate_dps),
    }
}

/// A stream's summary.
pub fn of_stream(file: &str, stream: &Stream, maps: &[ColumnMap]) -> Summary {
    // Soaks: 10-minute windows whose temperature stays within 0.5 °C, counted once per run.
    let window = (600.0 / stream.step_s.max(1e-9)).round().max(2.0) as usize;
    let mut soaks = 0;
    let mut in_soak = false;
    let mut i = 0;
    while i + window <= stream.len() {
        let [lo, hi] = range(&stream.temp_c[i..i + window]);
        let flat = hi - lo <= 0.5;
        if flat && !in_soak {
            soaks += 1;
        }
        in_soak = flat;
        i += window / 2;
    }
    let unreferenced = stream.rate_dps.iter().filter(|r| !r.is_finite()).count();
    let mut excluded: Vec<String> = stream.handled.iter().map(ToString::to_string).collect();
    if unreferenced > 0 {
        excluded.push(format!(
            "{unreferenced} samples without a reference rate: replayed, not scored or fitted"
        ));
    }
    Summary {
        file: file.to_owned(),
        kind: "stream",
        rows: stream.len(),
        columns: columns(&["time_s", "temp_c", "voltage_v", "rate_dps"], maps),
        temp_c: range(&stream.temp_c),
        rate_dps: range(&stream.rate_dps),
        output: range(&stream.voltage_v),
        plateaus: soaks,
        rates: distinct(&stream.rate_dps, 0.01),
        sample_interval_s: Some(stream.step_s),
        time_issues: stream.time_issues.iter().map(ToString::to_string).collect(),
        excluded_line: fog_data::stream::left_out_summary(&stream.handled).map(|l| {
            if unreferenced > stream.handled.iter().map(|h| h.n).sum::<usize>() {
                format!("{l}; and samples without a reference rate: replayed, not scored or fitted")
            } else {
                l
            }
        }),
        excluded,
        output_step: fog_data::stats::quantization_step(&stream.voltage_v),
        scale_factor_estimate: slope(&stream.rate_dps, &stream.voltage_v),
        earth_rate: earth_rate(&stream.rate_dps),
    }
}

impl Summary {
    /// The axis of a flight controller's `sensor` whose values are the column `axis` read as this
    /// file's stream: where its time, temperature and output come from named as the log's fields
    /// (`sensor_gyro[0].x`), not as the columns the project reads them into.
    pub fn recorded_from(mut self, sensor: &Sensor, axis: &str) -> Self {
        for (name, from) in &mut self.columns {
            let field = match name.as_str() {
                "time_s" => Some(format!("{} (µs)", sensor.field_source(sensor.time_field))),
                "temp_c" if !sensor.temp_c.is_empty() => {
                    Some(format!("{} (°C)", sensor.field_source(sensor.temp_field)))
                }
                // Both formats log rad/s and m/s²; the project reads rates in °/s.
                "voltage_v" => {
                    sensor
                        .axes
                        .iter()
                        .find(|a| a.name == axis)
                        .map(|a| match a.quantity {
                            Quantity::AngularRate => {
                                format!("{} × 180/π", sensor.field_source(a.field))
                            }
                            Quantity::SpecificForce => sensor.field_source(a.field),
                        })
                }
                _ => None,
            };
            if let Some(field) = field {
                *from = field;
            }
        }
        self
    }

    /// What a unit's channels share in this file, as text: the file and its rows (`what`: the
    /// unit), the columns other than a channel's output and reference, the temperature, the
    /// sampling or plateaus, time problems and what was left out.
    pub fn shared_text(&self, what: &str) -> String {
        let mut s = format!(
            "{} ({}, {} rows; {what})\n",
            self.file, self.kind, self.rows
        );
        for (name, from) in &self.columns {
            if name != "voltage_v" && name != "rate_dps" {
                s.push_str(&format!("  {name:<10} ← {from}\n"));
            }
        }
        s.push_str(&format!(
            "  temperature {:.2} … {:.2} °C; {}\n",
            self.temp_c[0],
            self.temp_c[1],
            match self.kind {
                "points" => format!(
                    "{} temperature plateaus (groups of readings more than 1 °C from the next)",
                    self.plateaus
                ),
                _ => format!(
                    "sampled every {:.3} s; {} soaks (10 min within 0.5 °C)",
                    self.sample_interval_s.unwrap_or(0.0),
                    self.plateaus
                ),
            }
        ));
        for issue in &self.time_issues {
            s.push_str(&format!("  time: {issue}\n"));
        }
        match &self.excluded_line {
            Some(line) => s.push_str(&format!("  left out: {line}\n")),
            None => {
                for row in &self.excluded {
                    s.push_str(&format!("  left out: {row}\n"));
                }
            }
        }
        s
    }

    /// One channel of a unit in this file, as text: where its output (in `unit`) and reference
    /// come from, their ranges in the unit of `quantity`, and what its data show of the scale
    /// factor, and of the earth rate for a gyro.
    pub fn channel_text(&self, name: &str, unit: &str, quantity: Quantity) -> String {
        let from = |col: &str| {
            self.columns
                .iter()
                .find(|(n, _)| n == col)
                .map_or(String::new(), |(_, f)| f.clone())
        };
        let q = quantity.unit();
        let mut s = format!(
            "  {name}: output ← {} ({unit}), {:.6e} … {:.6e}{}; reference ← {}, {:.4} … {:.4} {q} \
             ({} distinct)\n",
            from("voltage_v"),
            self.output[0],
            self.output[1],
            if unit == q {
                String::new()
            } else {
                format!(" {q}")
            },
            from("rate_dps"),
            self.rate_dps[0],
            self.rate_dps[1],
            self.rates
        );
        if let Some(step) = self.output_step {
            s.push_str(&format!("    output quantized in steps of {step:e}\n"));
        }
        s.push_str(&match self.scale_factor_estimate {
            Some(k) => format!("    scale factor the data show: {k:.6e} output units per {q}\n"),
            None => "    scale factor: not shown (no non-zero references): a bias model against \
                     temperature\n"
                .to_owned(),
        });
        if quantity == Quantity::AngularRate {
            s.push_str(&format!(
                "    earth rate in the reference: {}\n",
                self.earth_rate
            ));
        }
        s
    }

    /// As text, a line per fact.
    pub fn text(&self) -> String {
        let mut s = format!("{} ({}, {} rows)\n", self.file, self.kind, self.rows);
        for (name, from) in &self.columns {
            s.push_str(&format!("  {name:<10} ← {from}\n"));
        }
        s.push_str(&format!(
            "  temperature {:.2} … {:.2} °C; reference rate {:.4} … {:.4} °/s ({} distinct); \
             output {:.6e} … {:.6e}\n",
            self.temp_c[0],
            self.temp_c[1],
            self.rate_dps[0],
            self.rate_dps[1],
            self.rates,
            self.output[0],
            self.output[1]
        ));
        s.push_str(&match self.kind {
            "points" => format!(
                "  {} temperature plateaus (groups of readings more than 1 °C from the next)\n",
                self.plateaus
            ),
            _ => format!(
                "  sampled every {:.3} s; {} soaks (10 min within 0.5 °C)\n",
                self.sample_interval_s.unwrap_or(0.0),
                self.plateaus
            ),
        });
        for issue in &self.time_issues {
            s.push_str(&format!("  time: {issue}\n"));
        }
        match &self.excluded_line {
            Some(line) => s.push_str(&format!("  left out: {line}\n")),
            None => {
                for row in &self.excluded {
                    s.push_str(&format!("  left out: {row}\n"));
                }
            }
        }
        if let Some(step) = self.output_step {
            s.push_str(&format!(
                "  output quantized in steps of {step:e}: a logger that keeps raw samples rather \
                 than averaging them; the steps add step/√12 of white noise per sample to the \
                 angle random walk (trainer allan says how much)\n"
            ));
        }
        s.push_str(&match self.scale_factor_estimate {
            Some(k) => format!(
                "  scale factor the data show: {k:.6e} output units per °/s (a straight line \
                 through the non-zero rates)\n"
            ),
            None => "  scale factor: not shown (no non-zero rates)\n".to_owned(),
        });
        s.push_str(&format!(
            "  earth rate in the reference: {}\n",
            self.earth_rate
        ));
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_earth_rate_is_judged_by_how_far_the_rates_sit_from_round_numbers() {
        let round = [-80.0, -10.0, 1.0, 5.0, 40.0, 80.0];
        assert!(earth_rate(&round).starts_with("seems left out"));
        let with: Vec<f64> = round.iter().map(|w| w + 2.954e-3).collect();
        let text = earth_rate(&with);
        assert!(
            text.starts_with("seems included") && text.contains("45°"),
            "{text}"
        );
        let rig: Vec<f64> = (1..40).map(|k| f64::from(k) * 3.7713).collect();
        assert!(earth_rate(&rig).starts_with("cannot tell"));
        assert!(earth_rate(&[0.0; 20]).contains("static log"));
        let off: Vec<f64> = round.iter().map(|w| w + 0.03).collect();
        assert!(earth_rate(&off).starts_with("not the earth rate"));
    }

    #[test]
    fn a_wrong_unit_shows_in_the_scale_factor_and_the_ranges() {
        // Output logged in mV where the table expects V: a thousand times the scale factor.
        let rate = [-80.0, -40.0, -10.0, 10.0, 40.0, 80.0];
        let mv: Vec<f64> = rate.iter().map(|w| 38.0 * w).collect();
        assert!((slope(&rate, &mv).unwrap() - 38.0).abs() < 1e-9);
        // Gravity alone on a resting accelerometer shows none.
        assert_eq!(slope(&[-9.8; 10], &[-9.6; 10]), None);
        assert_eq!(range(&[3.0, f64::NAN, -1.0]), [-1.0, 3.0]);
        assert_eq!(distinct(&rate, 0.01), 6);
    }
}
