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
use firmware_sim::data::stream::{Stream, Window};
use firmware_sim::io::write_atomically;
use firmware_sim::plot::{AllanSeries, BLUE, GREY, ORANGE};
use firmware_sim::replay::{self, Compensated};
use indicatif::ProgressBar;
use plots::{DiagnosisSeries, ReliabilitySeries, ReplaySeries};

use crate::analysis::diagnose::Residual;
use crate::analysis::evaluate::EvalConfig;
use crate::analysis::investigate::{self, Investigation, Rebuild};
use crate::analysis::reproduce::{PAPER_LOO_GPR, PAPER_LOO_LSSVR, PAPER_LOTO, Reproduction};
use crate::data::points::Points;
use crate::data::summary::{Summary, least_squares_slope};
use crate::models::gp::GpConfig;

/// The figure files, in page order: (file name, caption).
pub const FIGURES: [(&str, &str); 9] = [
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
        "bias_vs_temperature.svg",
        "The log's bias against temperature, heating and cooling apart",
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
        "reliability.svg",
        "Reliability of the σ: the fraction of errors within the interval it claims, at every level",
    ),
    (
        "allan.svg",
        "Allan deviation of the held-out stream's error: raw, static and extended (lines: the slopes the noise terms are read from)",
    ),
];

/// What a report is made from: the data a user brings decides what it can show.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A rate table alone (the paper's protocol).
    Table,
    /// A rate table and one stream: its first two thirds train the extension, the last third is
    /// held out.
    TableAndStream,
    /// One log alone (a static log with its scale factor, or a ramp log): its first two thirds
    /// fit the model, the last third is held out.
    Log,
    /// A rate table, a training stream and a held-out stream.
    Full,
}

/// The held-out stream and what it shows.
pub struct HeldOut {
    /// How it was held out, in words.
    pub split: String,
    /// The investigation: diagnosis on the training stream, both models scored here.
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
    /// Allan analyses of the held-out stream's error: raw (output over the scale factor),
    /// static, extended.
    pub allan: [Allan; 3],
}

/// Everything the page shows.
pub struct Report {
    /// Where the data came from.
    pub source: String,
    /// What the data are.
    pub kind: Kind,
    /// Each file as the loader saw it: the page's first section.
    pub summaries: Vec<Summary>,
    /// The points the static model is fitted on (a rate table, or a log's 60 s means).
    pub points: Points,
    /// LOO evaluations and the Fig. 2 check (a rate table only).
    pub reproduction: Option<Reproduction>,
    /// The held-out stream (not for a rate table alone).
    pub held_out: Option<HeldOut>,
    /// A static log's bias against temperature: 60 s means of temperature and of output / K −
    /// reference, °/h.
    pub bias: Option<(Vec<f64>, Vec<f64>)>,
    /// What these data could show, and what they could not.
    pub could: Vec<String>,
    /// What they could not.
    pub could_not: Vec<String>,
}

/// The Allan deviation of a held-out stream's error, less its reference rate.
fn allan_of(what: &str, valid: &Stream, rate_dps: impl Iterator<Item = f64>) -> Allan {
    let error: Vec<f64> = rate_dps.zip(&valid.rate_dps).map(|(w, r)| w - r).collect();
    Allan::of(what, &valid.time_s, &error)
}

/// The paper's evaluations of a rate table; `bar` counts their fits.
fn reproduce(points: &Points, cfg: &GpConfig, bar: &ProgressBar) -> anyhow::Result<Reproduction> {
    let eval = EvalConfig {
        gp: cfg.clone(),
        ..EvalConfig::default()
    };
    Ok(crate::analysis::reproduce::reproduce(points, &eval, bar)?)
}

/// The investigation on `train`, scored on `valid`, with what the figures need.
fn held_out(
    points: &Points,
    train: &Stream,
    valid: Stream,
    split: String,
    (cfg, rebuild): (&GpConfig, &Rebuild<'_>),
    bar: &ProgressBar,
) -> anyhow::Result<HeldOut> {
    let (investigation, blobs) =
        investigate::investigate(points, train, &valid, cfg, None, rebuild, bar)?;
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
    // The raw gyro in °/s: its output over the scale factor given, or over a straight line
    // through the points (what an uncompensated gyro's datasheet scale factor does).
    let k = points.scale_factor.unwrap_or_else(|| {
        let pts: Vec<(f64, f64)> = points
            .rate_dps
            .iter()
            .copied()
            .zip(points.voltage_v.iter().copied())
            .collect();
        least_squares_slope(&pts).unwrap_or(1.0)
    });
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
    Ok(HeldOut {
        split,
        investigation,
        valid,
        replays,
        residual,
        regressor,
        block_temp_c,
        allan,
    })
}

/// A report on a rate table alone.
pub fn table(
    source: &Path,
    summaries: Vec<Summary>,
    points: Points,
    cfg: &GpConfig,
    bar: &ProgressBar,
) -> anyhow::Result<Report> {
    let reproduction = reproduce(&points, cfg, bar)?;
    let skipped: Vec<String> = reproduction
        .gpr
        .skipped
        .iter()
        .map(|s| format!("part of leave-one-group-out: {s}"))
        .chain(reproduction.skipped.iter().map(|s| format!("the {s}")))
        .collect();
    let could = vec![
        "the static map ω = f(T, output) and how well it holds on points it did not see: \
         leave-one-out and leave-one-temperature-out errors, and the error over (T, rate)"
            .to_owned(),
        format!(
            "the trained range, {:.1} … {:.1} °C and {:.1} … {:.1} °/s: outside it the firmware \
             flags every output Extrapolating",
            min(&points.temp_c),
            max(&points.temp_c),
            min(&points.rate_dps),
            max(&points.rate_dps)
        ),
    ];
    let could_not = vec![
        "transients (a lagging sensor, a thermal-rate bias, warm-up, hysteresis): soaked points \
         hold none, and this report does not look for them in a table; a table recorded in time \
         order is diagnosed by `trainer fit --map time_s=… --features auto`, a ramp run is added \
         with --stream"
            .to_owned(),
        "the noise (Allan deviation): 2-minute means average it away; log the gyro at rest"
            .to_owned(),
        "how the firmware does on a stream in time: there is none to replay".to_owned(),
    ]
    .into_iter()
    .chain(skipped)
    .collect();
    Ok(Report {
        source: source.display().to_string(),
        kind: Kind::Table,
        summaries,
        points,
        reproduction: Some(reproduction),
        held_out: None,
        bias: None,
        could,
        could_not,
    })
}

fn min(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

/// The parts of `stream` before and from `from_s` (s from its first sample; default two thirds of
/// its time), and where it was cut.
pub fn split(stream: &Stream, from_s: Option<f64>) -> anyhow::Result<(Stream, Stream, f64)> {
    let t0 = stream.time_s.first().copied().unwrap_or(0.0);
    let t1 = stream.time_s.last().copied().unwrap_or(t0);
    let split = from_s.unwrap_or((t1 - t0) * 2.0 / 3.0);
    anyhow::ensure!(
        split > 0.0 && split < t1 - t0,
        "--hold-out-from {split} s: the stream runs from 0 to {:.0} s, so nothing would be left \
         to fit on or to hold out",
        t1 - t0
    );
    let before = stream.window(Window {
        start_s: None,
        end_s: Some(split),
    });
    let after = stream.window(Window {
        start_s: Some(split),
        end_s: None,
    });
    Ok((before, after, split))
}

/// A report on a rate table and streams: `train` fits the extension, `valid` is held out;
/// `rebuild` makes the static points from part of `train`, as `points` were made from all of it
/// (the forward check fits on the earlier part alone).
#[allow(clippy::too_many_arguments)]
pub fn with_streams(
    source: &Path,
    kind: Kind,
    summaries: Vec<Summary>,
    points: Points,
    train: &Stream,
    valid: Stream,
    split: String,
    fitting: (&GpConfig, &Rebuild<'_>),
    bar: &ProgressBar,
) -> anyhow::Result<Report> {
    let on_table = points.soaked;
    let reproduction = if on_table {
        Some(reproduce(&points, fitting.0, bar)?)
    } else {
        None
    };
    let static_log = points.scale_factor.is_some();
    let bias = static_log.then(|| {
        // Both parts, in time order: the whole log's 60 s means.
        let k = points.scale_factor.unwrap_or(1.0);
        let mut t = Vec::new();
        let mut b = Vec::new();
        for s in [train, &valid] {
            for block in replay::blocks(s, &s.referenced()) {
                let n = block.len() as f64;
                t.push(block.iter().map(|&i| s.temp_c[i]).sum::<f64>() / n);
                b.push(
                    block
                        .iter()
                        .map(|&i| (s.voltage_v[i] / k - s.rate_dps[i]) * 3600.0)
                        .sum::<f64>()
                        / n,
                );
            }
        }
        (t, b)
    });
    let held = held_out(&points, train, valid, split.clone(), fitting, bar)?;
    let mut could = Vec::new();
    let mut could_not = Vec::new();
    if on_table {
        could.push(
            "the static map from the rate table, with the paper's leave-one-out tables and figures"
                .to_owned(),
        );
    } else if static_log {
        could.push(format!(
            "the bias against temperature (output / {} − reference), heating and cooling apart",
            points.scale_factor.unwrap_or(1.0)
        ));
        could_not.push(
            "the scale factor and its temperature dependence: the reference never moves (the \
             scale factor given is taken as it is), nor any error that grows with rate"
                .to_owned(),
        );
    } else {
        could.push("the static map from the log's 60 s means (no rate table)".to_owned());
        could_not.push(
            "the paper's leave-one-out tables: they need soaked rate-table points".to_owned(),
        );
    }
    could.push(format!(
        "what the static model misses on a stream, its cause and an extension, fitted on the \
         training part and scored once on the held-out part ({split})"
    ));
    could.push(
        "the noise of the held-out error (Allan deviation): raw, static and extended".to_owned(),
    );
    match kind {
        Kind::TableAndStream | Kind::Log => could_not.push(
            "a second, independent run: the held-out part is the same run's later hours (same \
             power-on, same history); another run tells whether the model carries"
                .to_owned(),
        ),
        _ => {}
    }
    Ok(Report {
        source: source.display().to_string(),
        kind,
        summaries,
        points,
        reproduction,
        held_out: Some(held),
        bias,
        could,
        could_not,
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

/// 60 s block means of the replay error and the σ of each mean (the firmware's bias variance
/// and the noise of a mean that long), with block mid-times in hours.
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
        .map(|b| comp.mean_std_dps(b, b.len() as f64 * valid.step_s))
        .collect();
    (time_h, temp, err, std)
}

/// Every scored sample's error and σ of a replay.
fn sample_errors(valid: &Stream, comp: &Compensated) -> (Vec<f64>, Vec<f64>) {
    (0..valid.len())
        .filter(|&i| {
            valid.rate_dps[i].is_finite() && comp.status[i] != firmware_core::Status::Fault
        })
        .map(|i| {
            (
                f64::from(comp.rate_dps[i]) - valid.rate_dps[i],
                comp.std_dps(i),
            )
        })
        .unzip()
}

/// Draws the figures the report's data support: (file name, SVG text), in [`FIGURES`] order.
pub fn figures(r: &Report) -> anyhow::Result<Vec<(&'static str, String)>> {
    let p = &r.points;
    let mut out: Vec<(&'static str, String)> = Vec::new();
    if let Some(rep) = &r.reproduction {
        out.push((
            "rate_table.svg",
            plots::rate_table(&p.temp_c, &p.rate_dps, &p.voltage_v)?,
        ));
        out.push((
            "output_vs_temperature.svg",
            plots::output_vs_temperature(&p.temp_c, &p.rate_dps, &p.voltage_v)?,
        ));
        let methods: Vec<(&str, &crate::analysis::evaluate::Evaluation)> =
            std::iter::once(("GPR", &rep.gpr))
                .chain(rep.lssvr.as_ref().map(|e| ("LS-SVR", e)))
                .collect();
        let qq: Vec<(&str, &[f64], f64)> = methods
            .iter()
            .map(|(n, e)| (*n, e.loo_errors_dps.as_slice(), e.qq_correlation))
            .collect();
        out.push(("qq.svg", plots::qq(&qq)?));
        let maps: Vec<(&str, &[f64])> = methods
            .iter()
            .map(|(n, e)| (*n, e.loo_errors_dps.as_slice()))
            .collect();
        out.push((
            "loo_error.svg",
            plots::loo_map(&p.temp_c, &p.rate_dps, &maps)?,
        ));
    }
    if let Some(rep) = &r.reproduction
        && r.held_out.is_none()
        && !rep.gpr.group_errors.is_empty()
    {
        let (errors, sigmas): (Vec<f64>, Vec<f64>) = rep.gpr.group_errors.iter().copied().unzip();
        out.push((
            "reliability.svg",
            plots::reliability(&[ReliabilitySeries {
                name: "GPR, groups left out (each fold's σ)".to_owned(),
                errors: &errors,
                sigmas: &sigmas,
            }])?,
        ));
    }
    if let Some((t, b)) = &r.bias {
        out.push(("bias_vs_temperature.svg", plots::bias_vs_temperature(t, b)?));
    }
    if let Some(h) = &r.held_out {
        let (time_h, temp, err_s, std_s) = replay_blocks(&h.valid, &h.replays[0]);
        let (_, _, err_e, std_e) = replay_blocks(&h.valid, &h.replays[1]);
        let extended = if h.investigation.added_inputs.is_empty() {
            "extended (nothing added)".to_owned()
        } else {
            format!("extended (+ {})", h.investigation.added_inputs.join(", "))
        };
        let cause = h.investigation.cause();
        let line = h
            .investigation
            .diagnosis
            .candidates
            .iter()
            .find(|c| c.id == cause)
            .map_or((0.0, 0.0), |c| (c.intercept_dps, c.slope));
        out.push((
            "replay.svg",
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
        ));
        out.push((
            "diagnosis.svg",
            plots::diagnosis(&DiagnosisSeries {
                cause: cause.id(),
                regressor_label: regressor_label(cause),
                regressor: &h.regressor,
                line,
                residual_dps: &h.residual,
                temp_c: &h.block_temp_c,
            })?,
        ));
        let (samples_e, samples_s) = sample_errors(&h.valid, &h.replays[1]);
        out.push((
            "reliability.svg",
            plots::reliability(&[
                ReliabilitySeries {
                    name: "static, 60 s means".to_owned(),
                    errors: &err_s,
                    sigmas: &std_s,
                },
                ReliabilitySeries {
                    name: format!("{extended}, 60 s means"),
                    errors: &err_e,
                    sigmas: &std_e,
                },
                ReliabilitySeries {
                    name: format!("{extended}, samples"),
                    errors: &samples_e,
                    sigmas: &samples_s,
                },
            ])?,
        ));
        let curves: Vec<_> = h.allan.iter().map(Allan::curve).collect();
        let series: Vec<AllanSeries<'_>> = h
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
        out.push((
            "allan.svg",
            firmware_sim::plot::allan("Held-out stream: Allan deviation of the error", &series)?,
        ));
    }
    Ok(out)
}

/// What the Allan table shows at the longest τ the raw and the shipped curves share, in words that
/// follow its figures: compensation should lower the long-τ part (the temperature's slow drift),
/// and where it does not, the page says so.
fn allan_sentence(allan: &[Allan; 3]) -> String {
    let (raw, shipped) = (&allan[0], &allan[2]);
    let longest = raw
        .tau_s
        .iter()
        .zip(&raw.adev_dps)
        .rev()
        .find_map(|(t, r)| {
            let k = shipped
                .tau_s
                .iter()
                .position(|s| (s - t).abs() <= 1e-9 * t)?;
            Some((*t, *r, shipped.adev_dps[k]))
        });
    let long = match longest {
        Some((tau, r, e)) if e < r => format!(
            "Compensation lowers the long-τ part, the temperature's slow drift: at τ = {tau:.0} s \
             the Allan deviation falls from {:.3} to {:.3} °/h.",
            r * 3600.0,
            e * 3600.0
        ),
        Some((tau, r, e)) => format!(
            "Compensation does not lower the long-τ part here: at τ = {tau:.0} s the Allan \
             deviation goes from {:.3} to {:.3} °/h, so what drifts slowly in this stream is not \
             the static temperature curve the model removes.",
            r * 3600.0,
            e * 3600.0
        ),
        None => "The curves share no τ to compare.".to_owned(),
    };
    format!(
        "<p>{long} The short-τ part is the gyro's own white noise, which no model removes. A term \
         \"not shown\" is one whose slope the curve never reaches (a log too short, or a residual \
         still drifting).</p>\n"
    )
}

/// The σ each model states on the held-out stream, scored: coverage at 1, 2 and 3σ of samples and
/// of 60 s means, and the median σ over the RMS error; then how the shipped σ was calibrated.
fn sigma_table(inv: &Investigation) -> String {
    let mut s = String::from(
        "<h3>The firmware's σ on the held-out stream</h3>\n<table><tr><th>model</th><th>of</th>\
         <th>RMS error (°/h)</th><th>median σ (°/h)</th><th>within 1σ</th><th>2σ</th><th>3σ</th>\
         <th>median σ / RMS</th></tr>\n",
    );
    for (name, score) in [
        ("static", &inv.static_score),
        ("shipped", &inv.extended_score),
    ] {
        for (of, c) in [
            ("samples", &score.sigma_samples),
            ("60 s means", &score.sigma_60s),
        ] {
            let _ = writeln!(
                s,
                "<tr><td>{name}</td><td>{of}</td><td>{:.2}</td><td>{:.2}</td><td>{:.0}%</td>\
                 <td>{:.0}%</td><td>{:.0}%</td><td>{:.2}</td></tr>",
                c.rmse * 3600.0,
                c.median_sigma * 3600.0,
                100.0 * c.within_1sigma,
                100.0 * c.within_2sigma,
                100.0 * c.within_3sigma,
                c.sharpness
            );
        }
    }
    let _ = writeln!(
        s,
        "</table>\n<p>A Gaussian σ covers 68/95/99.7% at 1/2/3σ, with a median σ about the RMS \
         error. The shipped model's {}.</p>",
        escape(&inv.calibration.describe("°/s"))
    );
    s
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
         <p>Data: <code>{}</code> ({}). Figures are also written as SVG files beside this \
         page.</p>\n",
        escape(&r.source),
        match r.kind {
            Kind::Table => "a rate table alone",
            Kind::TableAndStream => "a rate table and one stream",
            Kind::Log => "one log alone",
            Kind::Full => "a rate table, a training stream and a held-out stream",
        }
    );
    s.push_str("<h2>The data, as loaded</h2>\n");
    for summary in &r.summaries {
        let _ = writeln!(s, "<pre>{}</pre>", escape(summary.text().trim_end()));
    }
    s.push_str("<h3>What these data could show</h3>\n<ul>\n");
    for c in &r.could {
        let _ = writeln!(s, "<li>{}</li>", escape(c));
    }
    s.push_str("</ul>\n<h3>What they could not</h3>\n<ul>\n");
    for c in &r.could_not {
        let _ = writeln!(s, "<li>{}</li>", escape(c));
    }
    s.push_str("</ul>\n");
    if let Some(rep) = &r.reproduction {
        s.push_str("<h2>How the model does on the rate table</h2>\n<table><tr><th>method</th><th>LOO RMSE (°/s)</th><th>LOO RMSE (°/h)</th><th>paper (°/s)</th><th>leave-one-temperature-out (°/s)</th><th>Q-Q r</th></tr>\n");
        for (name, e, paper) in [
            ("GPR", Some(&rep.gpr), Some(PAPER_LOO_GPR)),
            ("LS-SVR", rep.lssvr.as_ref(), Some(PAPER_LOO_LSSVR)),
            ("two-step", rep.two_step.as_ref(), None),
        ] {
            let Some(e) = e else {
                let _ = writeln!(
                    s,
                    "<tr><td>{name}</td><td colspan=\"5\">could not be fitted on these points</td></tr>"
                );
                continue;
            };
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
                .iter()
                .flat_map(|e| e.per_temperature.iter())
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
        s.push_str("</table>\n");
    }
    if let Some(h) = &r.held_out {
        let inv = &h.investigation;
        let _ = write!(
            s,
            "<h2>Diagnosis of the training stream, gain on the held-out stream</h2>\n<p>Held out: {}.</p>\n<p>Named causes: <b>{}</b> — {}</p>\n\
         <p>Shipped: <b>{:?}</b> — {}</p>\n\
         <table><tr><th>model</th><th>inputs added</th><th>rmse_60s (°/s)</th><th>rmse_60s (°/h)</th><th>gain</th></tr>\n\
         <tr><td>static</td><td>—</td><td>{}</td><td>{:.2}</td><td>1.00×</td></tr>\n\
         <tr><td>shipped</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{:.2}×</td></tr></table>\n\
         <table><tr><th>candidate cause</th><th>score (interleaved)</th><th>score (forward)</th><th>parameter</th><th>correlation</th><th>amplitude (°/h)</th></tr>\n",
            escape(&h.split),
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
        s.push_str("</table>\n");
        s.push_str(&sigma_table(inv));
        s.push_str("<h3>Noise of the held-out stream's error (Allan deviation, IEEE 952)</h3>\n<table><tr><th>output</th><th>ARW (°/√h)</th><th>bias instability (°/h)</th><th>at τ (s)</th><th>rate random walk ((°/h)/√h)</th></tr>\n");
        let cell = |v: Option<f64>| v.map_or("not shown".to_owned(), |v| format!("{v:.4}"));
        for a in &h.allan {
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
        s.push_str("</table>\n");
        s.push_str(&allan_sentence(&h.allan));
    }
    s.push_str("<h2>Figures</h2>\n");
    for (name, svg) in figures {
        let caption = FIGURES.iter().find(|f| f.0 == *name).map_or("", |f| f.1);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_allan_sentence_follows_the_curves_it_describes() {
        let time: Vec<f64> = (0..4000).map(f64::from).collect();
        let white: Vec<f64> = (0..4000)
            .map(|i| 1e-3 * ((f64::from(i) * 7.77).sin() + (f64::from(i) * 3.1).cos()))
            .collect();
        let drifting: Vec<f64> = white
            .iter()
            .enumerate()
            .map(|(i, w)| w + 1e-6 * i as f64)
            .collect();
        let of = |r: &[f64]| Allan::of("x", &time, r);
        let lowered = allan_sentence(&[of(&drifting), of(&white), of(&white)]);
        assert!(lowered.contains("lowers the long-τ part"), "{lowered}");
        let raised = allan_sentence(&[of(&white), of(&white), of(&drifting)]);
        assert!(raised.contains("does not lower"), "{raised}");
    }
}
