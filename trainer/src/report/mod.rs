//! `trainer report`: one self-contained HTML page (inline SVG, no network) with the figures a
//! calibration engineer reads first — the rate table, the paper's Fig. 2, 4 and 5–6, the replay of
//! a held-out stream with the firmware's ±2σ band, static against extended, and the diagnosis —
//! plus each figure as its own SVG file. The numbers come from the same library calls as
//! `reproduce` and `investigate`; this module only runs them in order and draws.

pub mod plots;

use firmware_core::units::{DPH_PER_DPS, SECONDS_PER_HOUR};
use fog_data::cause::Cause;
use fog_data::channels::Datasheet;
use fog_data::replay::{self, Compensated};
use fog_data::stats::Line;
use fog_data::stream::Stream;
use fog_terminal::io::write_atomically;
use std::path::{Path, PathBuf};

use crate::plot::{AllanSeries, BLUE, GREY, ORANGE};
use crate::progress::Progress;
use anyhow::Context;
use fog_data::allan::Analysis as Allan;
use plots::{DiagnosisSeries, ReliabilitySeries, ReplaySeries};

use crate::analysis::diagnose::Residual;
use crate::analysis::evaluate::EvalConfig;
use crate::analysis::investigate::{self, Rebuild};
use crate::analysis::reproduce::Reproduction;
use crate::data::points::Points;
use crate::data::summary::Summary;
use crate::models::gp::GpConfig;

mod contents;
mod html;
pub mod unit;

pub use contents::{FIGURES, Figures, HeldOut, HeldOutFigures, Report, ReportKind};
pub use html::html;

/// The Allan deviation of a held-out stream's error, less its reference rate.
fn allan_of(what: &str, valid: &Stream, rate_dps: impl Iterator<Item = f64>) -> Allan {
    let error: Vec<f64> = rate_dps.zip(&valid.rate_dps).map(|(w, r)| w - r).collect();
    Allan::of(what, &valid.time_s, &error)
}

/// The paper's evaluations of a rate table; `bar` counts their fits.
fn reproduce(points: &Points, cfg: &GpConfig, bar: &dyn Progress) -> anyhow::Result<Reproduction> {
    let eval = EvalConfig {
        gp: cfg.clone(),
        ..EvalConfig::default()
    };
    Ok(crate::analysis::reproduce::reproduce(points, &eval, bar)?)
}

/// The investigation on `train`, scored on `valid` (the calibration's own power-on where
/// `calibration_run`: [`investigate::investigate`]), its blobs' σ stating what `sheet` states
/// (a channels file's `[[channel]]`), with what the figures need.
fn held_out(
    points: &Points,
    train: &Stream,
    (valid, calibration_run): (Stream, bool),
    split: String,
    (cfg, rebuild, sheet): (&GpConfig, &Rebuild<'_>, &Datasheet),
    bar: &dyn Progress,
) -> anyhow::Result<HeldOut> {
    let told = investigate::Told {
        asked: None,
        sheet: *sheet,
    };
    let (investigation, blobs) = investigate::investigate(
        points,
        train,
        (&valid, calibration_run),
        cfg,
        told,
        rebuild,
        bar,
    )?;
    let fw_static = fog_data::replay::decode(&blobs.static_blob)?;
    let fw_ext = fog_data::replay::decode(&blobs.extended_blob)?;
    let replays = [
        replay::replay_run(&fw_static, &valid, calibration_run),
        replay::replay_run(&fw_ext, &valid, calibration_run),
    ];
    let res = Residual::from_replay(
        &fw_static,
        &valid,
        (&replays[0].rate_dps, &replays[0].status),
    );
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
        Line::fit(pts).map_or(1.0, |l| l.slope)
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
    bar: &dyn Progress,
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
        kind: ReportKind::Table,
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

/// A report on a rate table and streams: `train` fits the extension, `valid` is held out;
/// `rebuild` makes the static points from part of `train`, as `points` were made from all of it
/// (the forward check fits on the earlier part alone).
#[allow(clippy::too_many_arguments)]
pub fn with_streams(
    source: &Path,
    kind: ReportKind,
    summaries: Vec<Summary>,
    points: Points,
    train: &Stream,
    valid: Stream,
    split: String,
    fitting: (&GpConfig, &Rebuild<'_>, &Datasheet),
    bar: &dyn Progress,
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
            for block in s.half_filled_blocks(&s.referenced()) {
                let n = block.len() as f64;
                t.push(block.iter().map(|&i| s.temp_c[i]).sum::<f64>() / n);
                b.push(
                    block
                        .iter()
                        .map(|&i| (s.voltage_v[i] / k - s.rate_dps[i]) * DPH_PER_DPS)
                        .sum::<f64>()
                        / n,
                );
            }
        }
        (t, b)
    });
    // A held-out log of its own is another power-on; the training log's later part is its own.
    let own_run = kind != ReportKind::Full;
    let held = held_out(
        &points,
        train,
        (valid, own_run),
        split.clone(),
        fitting,
        bar,
    )?;
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
        ReportKind::TableAndStream | ReportKind::Log => could_not.push(
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
pub(crate) fn replay_blocks(
    valid: &Stream,
    comp: &Compensated,
) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
    let scored: Vec<usize> = (0..valid.len())
        .filter(|&i| valid.rate_dps[i].is_finite() && comp.rate_dps[i].is_finite())
        .collect();
    let blocks = valid.half_filled_blocks(&scored);
    let mean = |b: &[usize], f: &dyn Fn(usize) -> f64| {
        b.iter().map(|&i| f(i)).sum::<f64>() / b.len() as f64
    };
    let t0 = valid.time_s.first().copied().unwrap_or(0.0);
    let time_h = blocks
        .iter()
        .map(|b| (mean(b, &|i| valid.time_s[i]) - t0) / SECONDS_PER_HOUR)
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
        out.extend(held_out_figures(h)?);
    }
    Ok(out)
}

/// The held-out stream's figures: the replay of both models with their bands, the diagnosis, the
/// reliability diagram and the Allan deviations of the error.
fn held_out_figures(h: &HeldOut) -> anyhow::Result<Vec<(&'static str, String)>> {
    let mut out: Vec<(&'static str, String)> = Vec::new();
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
        crate::plot::allan("Held-out stream: Allan deviation of the error", &series)?,
    ));
    Ok(out)
}

/// Writes one channel's page, `report.html`, and its figure files into `dir` (created if
/// missing); returns the paths. The figures as data are the unit's ([`unit::write`]).
fn write_page(dir: &Path, r: &Report) -> anyhow::Result<Vec<PathBuf>> {
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
