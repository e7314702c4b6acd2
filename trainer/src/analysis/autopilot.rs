//! What the autopilots' cubic costs, held out: a channel's cubic in temperature (as the firmware
//! of PX4 and ArduPilot applies it, [`crate::firmware::autopilot`]) fitted on the training part
//! and scored on the held-out part as every model here is, on 60 s means; beside it the cubics
//! the autopilots' own scripts would fit on the same samples, and the noise of a 60 s mean the
//! verdict is judged against.
//!
//! The scripts, as they fit (their sources, read for this): PX4's `process_sensor_caldata.py`
//! median-filters each axis over 31 samples and averages it in 2,000 temperature bins before its
//! least-squares cubic; ArduPilot's `tempcal_IMU.py` takes a 2 s moving average of the axis and
//! of the temperature and fits every remaining sample alike. Every cubic is scored with its
//! constant as fitted (ArduPilot's firmware takes its constant from the boot-time calibration
//! instead; a held-out log of another power-on is where that difference shows).

use fog_data::stream::Stream;
use serde::Serialize;

use crate::firmware::autopilot::{Cubic, CubicError};

/// A cubic's held-out figures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct CubicScore {
    /// RMS of the held-out 60 s means' error, in the channel's units.
    pub rmse_60s: f64,
    /// The same over the 60 s means inside the calibrated range (no sample clipped).
    pub rmse_60s_in_range: f64,
    /// RMS over the held-out part's 1 °C temperature bins of each bin's mean error: every degree
    /// counts once, however long the board stayed there (the weighting the cubic is fitted with).
    pub rmse_per_degree: f64,
    /// The σ it would carry: the RMS of its 60 s residuals on the training part.
    pub sigma: f64,
    /// Share of the held-out 60 s means within ±2σ.
    pub within_2sigma: f64,
    /// σ over the held-out RMS (1 is honest; below, too sure).
    pub sharpness: f64,
}

/// A channel's cubics, held out.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct CubicFigures {
    /// The project's cubic (temperature-binned, the training window and handling).
    pub project: CubicScore,
    /// The cubic PX4's script would fit on the same samples.
    pub px4_script: Option<CubicScore>,
    /// The cubic ArduPilot's script would fit on the same samples.
    pub ardupilot_script: Option<CubicScore>,
    /// The white noise of one 60 s mean of the held-out part, in the channel's units.
    pub noise_60s: f64,
}

/// The training part's samples with a reference: temperature and output less reference.
fn offsets(s: &Stream) -> (Vec<f64>, Vec<f64>) {
    s.referenced()
        .into_iter()
        .map(|i| (s.temp_c[i], s.voltage_v[i] - s.rate_dps[i]))
        .unzip()
}

/// The 60 s means of `s`'s error under `cubic` (its output less reference less the cubic at its
/// temperature), each with whether all its samples are inside the calibrated range.
fn block_errors(s: &Stream, cubic: &Cubic) -> Vec<(f64, bool)> {
    s.half_filled_blocks(&s.referenced())
        .iter()
        .map(|b| {
            let e = b
                .iter()
                .map(|&i| s.voltage_v[i] - s.rate_dps[i] - cubic.at(s.temp_c[i]))
                .sum::<f64>()
                / b.len() as f64;
            let inside = b
                .iter()
                .all(|&i| (cubic.tmin_c..=cubic.tmax_c).contains(&s.temp_c[i]));
            (e, inside)
        })
        .collect()
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// RMS over `s`'s 1 °C temperature bins of the mean error under `cubic` in each.
fn per_degree(s: &Stream, cubic: &Cubic) -> f64 {
    let mut bins = std::collections::BTreeMap::<i64, (f64, usize)>::new();
    for i in s.referenced() {
        let bin = bins.entry(s.temp_c[i].floor() as i64).or_default();
        bin.0 += s.voltage_v[i] - s.rate_dps[i] - cubic.at(s.temp_c[i]);
        bin.1 += 1;
    }
    let means: Vec<f64> = bins.values().map(|&(e, n)| e / n as f64).collect();
    rms(&means)
}

/// `cubic` scored: its σ from `train`'s 60 s residuals, its error on `valid`'s.
fn score(cubic: &Cubic, train: &Stream, valid: &Stream) -> CubicScore {
    let errors = |s: &Stream| -> Vec<f64> { block_errors(s, cubic).iter().map(|b| b.0).collect() };
    let sigma = rms(&errors(train));
    let blocks = block_errors(valid, cubic);
    let held = errors(valid);
    let inside: Vec<f64> = blocks.iter().filter(|b| b.1).map(|b| b.0).collect();
    let rmse_60s = rms(&held);
    CubicScore {
        rmse_60s,
        rmse_60s_in_range: rms(&inside),
        rmse_per_degree: per_degree(valid, cubic),
        sigma,
        within_2sigma: held.iter().filter(|e| e.abs() <= 2.0 * sigma).count() as f64
            / held.len().max(1) as f64,
        sharpness: if rmse_60s > 0.0 {
            sigma / rmse_60s
        } else {
            1.0
        },
    }
}

/// A running median over `width` samples (the window shrinking at the ends).
fn median_filter(v: &[f64], width: usize) -> Vec<f64> {
    let half = width / 2;
    (0..v.len())
        .map(|i| {
            let mut w: Vec<f64> = v[i.saturating_sub(half)..(i + half + 1).min(v.len())].to_vec();
            w.sort_by(f64::total_cmp);
            w[w.len() / 2]
        })
        .collect()
}

/// A moving average over `width` samples, only where the window is whole (numpy's `valid`).
fn moving_average(v: &[f64], width: usize) -> Vec<f64> {
    let width = width.clamp(1, v.len().max(1));
    v.windows(width)
        .map(|w| w.iter().sum::<f64>() / width as f64)
        .collect()
}

/// The white noise of one 60 s mean of `s`: the samples' scatter from one to the next (what a
/// slow drift leaves alone) over √(samples a block).
fn noise_60s(s: &Stream) -> f64 {
    let y: Vec<f64> = s
        .referenced()
        .into_iter()
        .map(|i| s.voltage_v[i] - s.rate_dps[i])
        .collect();
    let diffs: Vec<f64> = y.windows(2).map(|w| w[1] - w[0]).collect();
    let per_block = (fog_data::blocks::BLOCK_S / s.step_s).max(1.0);
    rms(&diffs) / std::f64::consts::SQRT_2 / per_block.sqrt()
}

/// The cubics of a channel fitted on `train` and scored on `valid`.
pub fn held_out(train: &Stream, valid: &Stream) -> Result<CubicFigures, CubicError> {
    let (temp, y) = offsets(train);
    let project = Cubic::fit(&temp, &y)?;
    let px4 = Cubic::binned(&temp, &median_filter(&y, 31), 2000).ok();
    let window = (2.0 / train.step_s).round().max(1.0) as usize;
    let ardupilot =
        Cubic::unweighted(&moving_average(&temp, window), &moving_average(&y, window)).ok();
    Ok(CubicFigures {
        project: score(&project, train, valid),
        px4_script: px4.map(|c| score(&c, train, valid)),
        ardupilot_script: ardupilot.map(|c| score(&c, train, valid)),
        noise_60s: noise_60s(valid),
    })
}

impl CubicFigures {
    /// The verdict on the cubic for a channel whose GP (`gp_rmse_60s`, with `causes` named or
    /// empty) scored this on the same held-out part: within the sensor's noise or not, and why.
    pub fn verdict(&self, gp_rmse_60s: f64, causes: &str) -> String {
        let cubic = self.project.rmse_60s;
        let noise = self.noise_60s;
        if cubic <= 2.0 * noise {
            return format!(
                "the cubic is enough: within the sensor's noise ({:.1}× that of a 60 s mean)",
                cubic / noise
            );
        }
        let misses = format!(
            "the cubic misses: {:.1}× the noise of a 60 s mean",
            cubic / noise
        );
        if gp_rmse_60s < 0.95 * cubic {
            let with = if causes.is_empty() {
                "a curve a cubic cannot bend to".to_owned()
            } else {
                format!("the curve and {causes}")
            };
            format!(
                "{misses}; the GP follows {with} ({:.2}× the cubic's error)",
                gp_rmse_60s / cubic
            )
        } else {
            format!(
                "{misses}, and so does the GP: what is left does not follow the temperature \
                 (a warm-up, another power-on)"
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_filters_keep_what_the_scripts_keep() {
        let v = [1.0, 9.0, 2.0, 3.0, 4.0];
        assert_eq!(median_filter(&v, 3), [9.0, 2.0, 3.0, 3.0, 4.0]);
        assert_eq!(moving_average(&v, 2), [5.0, 5.5, 2.5, 3.5]);
        assert_eq!(moving_average(&v, 9), [3.8]);
    }
}
