//! `trainer report`: one self-contained HTML page (inline SVG, no network) with the figures a
//! calibration engineer reads first — the rate table, the paper's Fig. 2, 4 and 5–6, the replay of
//! a held-out stream with the firmware's ±2σ band, static against extended, and the diagnosis —
//! plus each figure as its own SVG file. The numbers come from the same library calls as
//! `reproduce` and `investigate`; this module only runs them in order and draws.

pub mod plots;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use firmware_sim::allan::Analysis as Allan;
use firmware_sim::cause::Cause;
use firmware_sim::data::stream::Stream;
use firmware_sim::io::write_atomically;
use firmware_sim::plot::{AllanSeries, BLUE, GREY, ORANGE};
use firmware_sim::replay::{self, Compensated};
use indicatif::ProgressBar;
use plots::{DiagnosisSeries, ReplaySeries};

use crate::analysis::diagnose::Residual;
use crate::analysis::evaluate::{self, EvalConfig, Method};
use crate::analysis::investigate::{self, Investigation};
use crate::analysis::reproduce::{PAPER_LOO_GPR, PAPER_LOO_LSSVR, PAPER_LOTO, Reproduction};
use crate::data::points::Points;
use crate::models::gp::GpConfig;

/// The figure files, in page order: (file name, caption).
pub const FIGURES: [(&str, &str); 7] = [
    (
        "rate_table.svg",
        "Rate table: output over temperature and rate (paper Fig. 1)",
    ),
    (
        "output_vs_temperature.svg",
        "Output against temperature per rate, first-order fits (paper Fig. 2)",
    ),
    (
        "qq.svg",
        "Q-Q plot of leave-one-out residuals (paper Fig. 4)",
    ),
    (
        "loo_error.svg",
        "Leave-one-out error over (T, rate), GPR and LS-SVR (paper Fig. 5–6)",
    ),
    (
        "replay.svg",
        "Held-out stream replayed through the firmware: static and extended models",
    ),
    (
        "diagnosis.svg",
        "Diagnosis: the static model's residual against its cause and against temperature",
    ),
    (
        "allan.svg",
        "Allan deviation of the held-out stream's error: raw, static and extended (lines: the slopes the noise terms are read from)",
    ),
];

/// Everything the page shows.
pub struct Report {
    /// Where the rate table came from.
    pub source: String,
    /// The points (rate table).
    pub points: Points,
    /// LOO evaluations and the Fig. 2 check.
    pub reproduction: Reproduction,
    /// The investigation on the held-out stream.
    pub investigation: Investigation,
    /// The held-out stream.
    pub valid: Stream,
    /// Static and extended replays of it.
    pub replays: [Compensated; 2],
    /// The static model's 60 s residual, with the named cause's regressor and block temperature.
    pub residual: Vec<f64>,
    /// Regressor of the named cause (empty for `none`).
    pub regressor: Vec<f64>,
    /// Block-mean temperature, °C.
    pub block_temp_c: Vec<f64>,
    /// Allan analyses of the held-out stream's error: raw (output over the table's scale
    /// factor), static, extended.
    pub allan: [Allan; 3],
}

/// The Allan deviation of a held-out stream's error, less its reference rate.
fn allan_of(what: &str, valid: &Stream, rate_dps: impl Iterator<Item = f64>) -> Allan {
    let error: Vec<f64> = rate_dps.zip(&valid.rate_dps).map(|(w, r)| w - r).collect();
    Allan::of(what, &valid.time_s, &error)
}

/// Runs the evaluations and the investigation; `bar` counts their fits and steps.
pub fn build(
    source: &Path,
    points: Points,
    train: &Stream,
    valid: Stream,
    cfg: &GpConfig,
    bar: &ProgressBar,
) -> anyhow::Result<Report> {
    let eval = EvalConfig {
        gp: cfg.clone(),
        ..EvalConfig::default()
    };
    let gpr = evaluate::evaluate(&points, Method::Gpr, &eval, bar)?;
    let lssvr = evaluate::evaluate(&points, Method::Lssvr, &eval, bar)?;
    let two_step = evaluate::evaluate(&points, Method::TwoStep, &eval, bar)?;
    let reproduction = Reproduction {
        gpr,
        lssvr,
        two_step,
        fig2: evaluate::fig2(&points),
    };
    // A report's points are a rate table: the forward check never rebuilds them.
    let table = |_: &Stream| Ok(points.clone());
    let (investigation, blobs) =
        investigate::investigate(&points, train, &valid, cfg, None, &table, bar)?;
    let fw_static = firmware_sim::replay::decode(&blobs.static_blob)?;
    let fw_ext = firmware_sim::replay::decode(&blobs.extended_blob)?;
    let replays = [
        replay::replay(&fw_static, &valid),
        replay::replay(&fw_ext, &valid),
    ];
    let res = Residual::from_replay(&fw_static, &valid, &replays[0]);
    let cause = investigation.cause();
    let regressor = investigation
        .diagnosis
        .candidates
        .iter()
        .find(|c| c.id == cause)
        .and_then(|c| res.regressor(cause, c.parameter as f32))
        .unwrap_or_default();
    let (residual, block_temp_c) = (res.r.clone(), res.temperature());
    // The raw gyro in °/s: its output over the table's scale factor, a straight line through
    // the points (what an uncompensated gyro's datasheet scale factor does).
    let k = {
        let n = points.len() as f64;
        let (mw, mv) = (
            points.rate_dps.iter().sum::<f64>() / n,
            points.voltage_v.iter().sum::<f64>() / n,
        );
        let sxy: f64 = points
            .rate_dps
            .iter()
            .zip(&points.voltage_v)
            .map(|(w, v)| (w - mw) * (v - mv))
            .sum();
        let sxx: f64 = points.rate_dps.iter().map(|w| (w - mw) * (w - mw)).sum();
        if sxx > 0.0 { sxy / sxx } else { 1.0 }
    };
    let allan = [
        allan_of(
            "raw (output / K)",
            &valid,
            valid.voltage_v.iter().map(|v| v / k),
        ),
        allan_of(
            "static",
            &valid,
            replays[0].rate_dps.iter().map(|&w| f64::from(w)),
        ),
        allan_of(
            "extended",
            &valid,
            replays[1].rate_dps.iter().map(|&w| f64::from(w)),
        ),
    ];
    Ok(Report {
        source: source.display().to_string(),
        points,
        reproduction,
        investigation,
        valid,
        replays,
        residual,
        regressor,
        block_temp_c,
        allan,
    })
}

/// Axis label of a cause's regressor.
fn regressor_label(cause: Cause) -> &'static str {
    match cause {
        Cause::ThermalRate => "filtered dT/dt (°C/min)",
        Cause::SensorLag => "f(coil estimate) − f(sensor) (°/s)",
        Cause::WarmUp => "exp(−t_on/τ)",
        Cause::Hysteresis => "thermal state (−1 cooling … +1 heating)",
        Cause::TimeDrift => "time since power-on (h)",
        Cause::None => "",
    }
}

/// 60 s block means of the replay error and σ, with block mid-times in hours.
fn replay_blocks(valid: &Stream, comp: &Compensated) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let scored: Vec<usize> = (0..valid.len())
        .filter(|&i| valid.rate_dps[i].is_finite() && comp.rate_dps[i].is_finite())
        .collect();
    let blocks = replay::blocks(valid, &scored);
    let mean = |b: &[usize], f: &dyn Fn(usize) -> f64| {
        b.iter().map(|&i| f(i)).sum::<f64>() / b.len() as f64
    };
    let t0 = valid.time_s.first().copied().unwrap_or(0.0);
    let time_h = blocks
        .iter()
        .map(|b| (mean(b, &|i| valid.time_s[i]) - t0) / 3600.0)
        .collect();
    let temp = blocks
        .iter()
        .map(|b| mean(b, &|i| valid.temp_c[i]))
        .collect();
    let err = blocks
        .iter()
        .map(|b| mean(b, &|i| f64::from(comp.rate_dps[i]) - valid.rate_dps[i]))
        .collect();
    let std = blocks
        .iter()
        .map(|b| mean(b, &|i| f64::from(comp.std_dps[i])))
        .collect();
    (time_h, temp, err, std)
}

/// Draws every figure: (file name, SVG text), in [`FIGURES`] order.
pub fn figures(r: &Report) -> anyhow::Result<Vec<(&'static str, String)>> {
    let p = &r.points;
    let rep = &r.reproduction;
    let (time_h, temp, err_s, std_s) = replay_blocks(&r.valid, &r.replays[0]);
    let (_, _, err_e, std_e) = replay_blocks(&r.valid, &r.replays[1]);
    let extended = if r.investigation.added_inputs.is_empty() {
        "extended (nothing added)".to_owned()
    } else {
        format!("extended (+ {})", r.investigation.added_inputs.join(", "))
    };
    let cause = r.investigation.cause();
    let line = r
        .investigation
        .diagnosis
        .candidates
        .iter()
        .find(|c| c.id == cause)
        .map_or((0.0, 0.0), |c| (c.intercept_dps, c.slope));
    let svgs = [
        plots::rate_table(&p.temp_c, &p.rate_dps, &p.voltage_v)?,
        plots::output_vs_temperature(&p.temp_c, &p.rate_dps, &p.voltage_v)?,
        plots::qq(&[
            ("GPR", &rep.gpr.loo_errors_dps, rep.gpr.qq_correlation),
            (
                "LS-SVR",
                &rep.lssvr.loo_errors_dps,
                rep.lssvr.qq_correlation,
            ),
        ])?,
        plots::loo_map(
            &p.temp_c,
            &p.rate_dps,
            &[
                ("GPR", &rep.gpr.loo_errors_dps),
                ("LS-SVR", &rep.lssvr.loo_errors_dps),
            ],
        )?,
        plots::replay(
            &time_h,
            &temp,
            &[
                ReplaySeries {
                    name: "static",
                    error_dps: &err_s,
                    std_dps: &std_s,
                },
                ReplaySeries {
                    name: &extended,
                    error_dps: &err_e,
                    std_dps: &std_e,
                },
            ],
        )?,
        plots::diagnosis(&DiagnosisSeries {
            cause: cause.id(),
            regressor_label: regressor_label(cause),
            regressor: &r.regressor,
            line,
            residual_dps: &r.residual,
            temp_c: &r.block_temp_c,
        })?,
        {
            let curves: Vec<_> = r.allan.iter().map(Allan::curve).collect();
            let series: Vec<AllanSeries<'_>> = r
                .allan
                .iter()
                .zip(&curves)
                .zip([GREY, BLUE, ORANGE])
                .map(|((a, curve), colour)| AllanSeries {
                    label: &a.of,
                    colour,
                    curve,
                    terms: a.terms,
                })
                .collect();
            firmware_sim::plot::allan("Held-out stream: Allan deviation of the error", &series)?
        },
    ];
    Ok(FIGURES.iter().map(|f| f.0).zip(svgs).collect())
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn sci(v: f64) -> String {
    format!("{v:.2e}")
}

/// The page: summary tables beside the figures, every SVG inline.
pub fn html(r: &Report, figures: &[(&'static str, String)]) -> String {
    let rep = &r.reproduction;
    let inv = &r.investigation;
    let mut s = String::new();
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>FOG drift compensation report</title><style>\
         body{{font-family:sans-serif;max-width:1140px;margin:2em auto;color:#222}}\
         table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #bbb;padding:4px 10px;text-align:right}}\
         th{{background:#eee}}figure{{margin:2em 0}}figcaption{{font-weight:bold;margin-bottom:.5em}}\
         svg{{max-width:100%;height:auto}}</style></head><body>\n\
         <h1>FOG temperature-drift compensation report</h1>\n\
         <p>Rate table: <code>{}</code>, {} points. Held-out stream: {} samples. \
         Figures are also written as SVG files beside this page.</p>\n",
        escape(&r.source),
        r.points.len(),
        r.valid.len()
    );
    s.push_str("<h2>How the model does on the rate table</h2>\n<table><tr><th>method</th><th>LOO RMSE (°/s)</th><th>LOO RMSE (°/h)</th><th>paper (°/s)</th><th>leave-one-temperature-out (°/s)</th><th>Q-Q r</th></tr>\n");
    for (name, e, paper) in [
        ("GPR", &rep.gpr, Some(PAPER_LOO_GPR)),
        ("LS-SVR", &rep.lssvr, Some(PAPER_LOO_LSSVR)),
        ("two-step", &rep.two_step, None),
    ] {
        let _ = writeln!(
            s,
            "<tr><td>{name}</td><td>{}</td><td>{:.2}</td><td>{}</td><td>{}</td><td>{:.4}</td></tr>",
            sci(e.rmse_dps),
            e.rmse_dph,
            paper.map_or("—".into(), sci),
            sci(e.group_rmse_dps),
            e.qq_correlation
        );
    }
    s.push_str("</table>\n<h3>Leave-one-temperature-out beside the paper's Table 1 (°/s)</h3>\n<table><tr><th>T (°C)</th><th>GPR</th><th>GPR paper</th><th>LS-SVR</th><th>LS-SVR paper</th></tr>\n");
    let mut order: Vec<usize> = (0..rep.gpr.per_temperature.len()).collect();
    order.sort_by(|&a, &b| {
        rep.gpr.per_temperature[a]
            .temp_c
            .total_cmp(&rep.gpr.per_temperature[b].temp_c)
    });
    let paired = order.len() == PAPER_LOTO.len();
    for (rank, &i) in order.iter().enumerate() {
        let g = &rep.gpr.per_temperature[i];
        let lssvr = rep
            .lssvr
            .per_temperature
            .iter()
            .find(|x| x.group == g.group)
            .map_or("—".into(), |x| sci(x.rmse_dps));
        let (pg, pl) = if paired {
            (sci(PAPER_LOTO[rank].2), sci(PAPER_LOTO[rank].1))
        } else {
            ("—".into(), "—".into())
        };
        let _ = writeln!(
            s,
            "<tr><td>{:.1}</td><td>{}</td><td>{pg}</td><td>{lssvr}</td><td>{pl}</td></tr>",
            g.temp_c,
            sci(g.rmse_dps)
        );
    }
    let _ = write!(
        s,
        "</table>\n<h2>Diagnosis of the training stream, gain on the held-out stream</h2>\n<p>Named causes: <b>{}</b> — {}</p>\n\
         <p>Shipped: <b>{:?}</b> — {}</p>\n\
         <table><tr><th>model</th><th>inputs added</th><th>rmse_60s (°/s)</th><th>rmse_60s (°/h)</th><th>gain</th></tr>\n\
         <tr><td>static</td><td>—</td><td>{}</td><td>{:.2}</td><td>1.00×</td></tr>\n\
         <tr><td>shipped</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{:.2}×</td></tr></table>\n\
         <table><tr><th>candidate cause</th><th>score (interleaved)</th><th>score (forward)</th><th>parameter</th><th>correlation</th><th>amplitude (°/h)</th></tr>\n",
        if inv.diagnosis.causes.is_empty() {
            "none".to_owned()
        } else {
            inv.diagnosis
                .causes
                .iter()
                .map(|c| c.id())
                .collect::<Vec<_>>()
                .join(" + ")
        },
        escape(&inv.diagnosis.explanation),
        inv.shipped,
        escape(&inv.verdict),
        sci(inv.static_score.rmse_60s_dps),
        inv.static_score.rmse_60s_dps * 3600.0,
        if inv.added_inputs.is_empty() {
            "nothing".into()
        } else {
            inv.added_inputs.join(", ")
        },
        sci(inv.extended_score.rmse_60s_dps),
        inv.extended_score.rmse_60s_dps * 3600.0,
        inv.gain
    );
    for c in &inv.diagnosis.candidates {
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{:.1}</td><td>{:.3}</td><td>{:.2}</td></tr>",
            c.id, c.score, c.forward_score, c.parameter, c.correlation, c.amplitude_dph
        );
    }
    s.push_str("</table>\n<h3>Noise of the held-out stream's error (Allan deviation, IEEE 952)</h3>\n<table><tr><th>output</th><th>ARW (°/√h)</th><th>bias instability (°/h)</th><th>at τ (s)</th><th>rate random walk ((°/h)/√h)</th></tr>\n");
    let cell = |v: Option<f64>| v.map_or("not shown".to_owned(), |v| format!("{v:.4}"));
    for a in &r.allan {
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(&a.of),
            cell(a.terms.arw_deg_per_sqrt_h),
            cell(a.terms.bias_instability_deg_per_h),
            a.terms
                .bias_instability_tau_s
                .map_or("—".to_owned(), |t| format!("{t:.0}")),
            cell(a.terms.rrw_deg_per_h_per_sqrt_h)
        );
    }
    s.push_str("</table>\n<p>Compensation removes the temperature's slow drift, so the long-τ part falls; the short-τ part is the gyro's own white noise, which no model removes. A term \"not shown\" is one whose slope the curve never reaches (a log too short, or a residual still drifting).</p>\n<h2>Figures</h2>\n");
    for ((name, svg), (_, caption)) in figures.iter().zip(FIGURES) {
        let _ = writeln!(
            s,
            "<figure id=\"{name}\"><figcaption>{caption} — <a href=\"{name}\">{name}</a></figcaption>\n{svg}\n</figure>"
        );
    }
    s.push_str("</body></html>\n");
    s
}

/// Writes `report.html` and the figure files into `dir` (created if missing); returns the paths.
pub fn write(dir: &Path, r: &Report) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let figures = figures(r)?;
    let mut written = Vec::new();
    for (name, svg) in &figures {
        let path = dir.join(name);
        write_atomically(&path, svg.as_bytes())?;
        written.push(path);
    }
    let page = dir.join("report.html");
    write_atomically(&page, html(r, &figures).as_bytes())?;
    written.push(page);
    Ok(written)
}
