//! The parameters read beside the output map: the noise terms from a static log's residual
//! Allan deviation, the temperature sensor's noise, the self-heating from soaked points; and
//! those no data here can show, nominal with the reason.

use crate::gyro::plant::GyroParams;
use firmware_core::units::SECONDS_PER_HOUR;
use fog_data::stats::rms;

use super::params::Parameter;
use super::source::Measured;
use fog_data::allan;

/// The noise parameters, from the residual's Allan deviation of a static log (`noise`), set in
/// `params`: where the reference steps, that deviation shows the map's small errors per rate (a
/// hump at the rate hold), not the noise, so those keep their nominal values.
pub(super) fn noise_parameters(
    noise: Option<allan::Terms>,
    has_stream: bool,
    params: &mut GyroParams,
) -> Vec<Parameter> {
    let nominal = GyroParams::nominal();
    let Some((t, arw)) = noise.and_then(|t| Some((t, t.arw_deg_per_sqrt_h?))) else {
        let why = if has_stream {
            "needs a static log: where the reference steps, the residual's Allan deviation shows \
             the map's errors per rate, not the noise: nominal"
        } else {
            "needs a static log (2-minute means average the noise away): nominal"
        };
        return [
            ("arw_dpsqrth", nominal.arw_dpsqrth),
            ("bias_instability_dph", nominal.bias_instability_dph),
            ("rrw_dph_per_sqrth", nominal.rrw_dph_per_sqrth),
        ]
        .into_iter()
        .map(|(name, value)| Parameter {
            name: name.to_owned(),
            value,
            std_error: None,
            determined: false,
            why: why.to_owned(),
        })
        .collect();
    };
    params.arw_dpsqrth = arw;
    let (bi, bi_why) = match t.bias_instability_deg_per_h {
        Some(b) => (
            gauss_markov_sigma(arw, b, nominal.bias_instability_tau_s),
            format!(
                "the Gauss–Markov σ (T = {:.0} s) whose Allan curve bottoms at the measured \
                 {b:.3} °/h × 0.664",
                nominal.bias_instability_tau_s
            ),
        ),
        None => (
            nominal.bias_instability_dph,
            "the Allan deviation shows no bottom (log too short): nominal".to_owned(),
        ),
    };
    params.bias_instability_dph = bi;
    let (rrw, rrw_why) = match t.rrw_deg_per_h_per_sqrt_h {
        Some(k) => (k, "slope +½ at 3 s".to_owned()),
        None => (
            nominal.rrw_dph_per_sqrth,
            "no slope +½ in the Allan deviation (log too short): nominal".to_owned(),
        ),
    };
    params.rrw_dph_per_sqrth = rrw;
    vec![
        Parameter {
            name: "arw_dpsqrth".to_owned(),
            value: arw,
            std_error: None,
            determined: true,
            why: "the stream residual's Allan deviation, slope −½ at 1 s".to_owned(),
        },
        Parameter {
            name: "bias_instability_dph".to_owned(),
            value: bi,
            std_error: None,
            determined: t.bias_instability_deg_per_h.is_some(),
            why: bi_why,
        },
        Parameter {
            name: "rrw_dph_per_sqrth".to_owned(),
            value: rrw,
            std_error: None,
            determined: t.rrw_deg_per_h_per_sqrt_h.is_some(),
            why: rrw_why,
        },
    ]
}

/// The parameters read from the data beside the map (the temperature sensor's noise from a
/// stream, the self-heating from soaked points with their setpoints) set in `params`, and those
/// no data here can show, nominal with the reason.
pub(super) fn other_parameters(
    points: Option<&Measured>,
    stream: Option<&Measured>,
    params: &mut GyroParams,
) -> Vec<Parameter> {
    let nominal = GyroParams::nominal();
    let mut out = Vec::new();
    if let Some(s) = stream {
        let t: Vec<f64> = s.records.iter().map(|r| r.temp_c).collect();
        let d: Vec<f64> = t.windows(3).map(|w| w[2] - 2.0 * w[1] + w[0]).collect();
        // The second difference removes a ramp; white sensor noise σ gives √6 σ.
        let sigma = rms(&d) / 6f64.sqrt();
        params.temp_noise_c = sigma;
        out.push(Parameter {
            name: "temp_noise_c".to_owned(),
            value: sigma,
            std_error: None,
            determined: true,
            why: "the stream's temperature, second differences".to_owned(),
        });
    }
    // Soaked table points read the chamber's setpoint plus the electronics' self-heating.
    let soaked = points.and_then(|p| {
        let set = p.setpoint_c.as_ref()?;
        let n = set.len().max(1) as f64;
        Some(
            p.records
                .iter()
                .zip(set)
                .map(|(r, s)| r.temp_c - s)
                .sum::<f64>()
                / n,
        )
    });
    if let Some(heat) = soaked {
        params.self_heating_c = heat;
        out.push(Parameter {
            name: "self_heating_c".to_owned(),
            value: heat,
            std_error: None,
            determined: true,
            why: "the soaked points' readings above the chamber's setpoint".to_owned(),
        });
    }
    let nominals = [
        (
            "self_heating_c",
            nominal.self_heating_c,
            "needs the chamber's setpoint beside the sensor reading (a setpoint_c column): nominal",
        ),
        (
            "latitude_deg",
            nominal.latitude_deg,
            "the earth rate is inside the fitted bias where the reference lacks it: nominal",
        ),
        (
            "bias_instability_tau_s",
            nominal.bias_instability_tau_s,
            "the Gauss–Markov correlation time is not read from the curve: nominal",
        ),
        (
            "adc_bits",
            f64::from(nominal.adc_bits),
            "a logger's resolution is not in its means: nominal",
        ),
    ];
    for (name, value, why) in nominals {
        if name == "self_heating_c" && soaked.is_some() {
            continue;
        }
        out.push(Parameter {
            name: name.to_owned(),
            value,
            std_error: None,
            determined: false,
            why: why.to_owned(),
        });
    }
    out
}

/// The noise terms of a stream's residual (°/s), over its longest run without a gap.
pub(super) fn noise_terms(stream: &Measured, residual_dps: &[f64]) -> allan::Terms {
    let t: Vec<f64> = stream
        .records
        .iter()
        .map(|r| r.time_s.unwrap_or(0.0))
        .collect();
    allan::Analysis::of("the twin's residual", &t, residual_dps).terms
}

/// The Gauss–Markov σ (°/h, correlation time `corr_s`) whose Allan curve, with white noise of
/// ARW `arw` (°/√h), bottoms at `b` × 0.664 (°/h): the simulator's bias instability from a
/// measured one (bisection; the bottom grows with σ).
fn gauss_markov_sigma(arw: f64, b: f64, corr_s: f64) -> f64 {
    let bottom = |sigma: f64| {
        let curve = |tau: f64| {
            (allan::white_avar(arw / 60.0, tau)
                + allan::gauss_markov_avar(sigma / SECONDS_PER_HOUR, corr_s, tau))
            .sqrt()
        };
        let grid: Vec<f64> = (0..5000)
            .map(|i| 10f64.powf(f64::from(i) / 1000.0))
            .collect();
        grid.windows(2)
            .find(|w| curve(w[1]) >= curve(w[0]))
            .map_or_else(|| curve(1e5), |w| curve(w[0]))
            / allan::FLICKER_FLOOR
            * SECONDS_PER_HOUR
    };
    let (mut lo, mut hi) = (0.0, 100.0 * b.max(1e-6));
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if bottom(mid) < b {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}
