//! `trainer report`'s page of a sensor unit. Each channel gets the whole analysis of its data
//! ([`super::table`], [`super::with_streams`]). A unit of one channel (one channel's data) shows
//! it as the page; a unit of several shows them side by side: a table of each channel's held-out figures, cause and gain, a
//! small multiple per channel (its held-out error with the firmware's ±2σ, static and shipped; a
//! rate table's leave-one-out error where there is no log), and the unit's Allan deviations of
//! the held-out error on one figure. Every figure states a channel in its own units (°/h for a
//! gyro, mg for an accelerometer).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use firmware_core::Quantity;
use fog_terminal::io::{write_atomically, write_json};
use fog_terminal::schema;
use serde::Serialize;

use super::html::escape;
use super::plots::{self, ReplaySeries};
use super::{Figures, Report, replay_blocks};
use crate::analysis::autopilot::CubicFigures;
use crate::plot::{AllanSeries, CHANNEL_COLOURS};
use fog_data::allan::Analysis as Allan;

/// One channel of the page: its name, what it measures, and its analysis.
pub struct ChannelSection<'a> {
    /// Its name.
    pub name: &'a str,
    /// What it measures.
    pub quantity: Quantity,
    /// Its analysis, as a single channel's report makes it.
    pub report: Report,
    /// The autopilots' cubic against it, held out (a channel in a physical unit, with a
    /// held-out part).
    pub cubic: Option<CubicFigures>,
}

/// A unit's page as data (`report.json` beside `report.html`): each channel's held-out
/// investigation, and the autopilots' cubics against it with the verdict.
#[derive(Debug, Serialize, schemars::JsonSchema)]
pub struct UnitFigures<'a> {
    /// Where the data came from.
    pub source: &'a str,
    /// Each channel, in the unit's order.
    pub channels: Vec<ChannelFigures<'a>>,
}

/// One channel of a unit's page, as data.
#[derive(Debug, Serialize, schemars::JsonSchema)]
pub struct ChannelFigures<'a> {
    /// Its name.
    pub name: &'a str,
    /// What it measures.
    pub quantity: Quantity,
    /// Its analysis, as a page of one channel shows it.
    #[serde(flatten)]
    pub figures: Figures<'a>,
    /// The autopilots' cubics held out.
    pub cubic: Option<&'a CubicFigures>,
    /// The verdict on the cubic, as the page words it.
    pub cubic_verdict: Option<String>,
}

/// The page's figures, as data.
pub fn figures<'a>(source: &'a str, channels: &'a [ChannelSection<'a>]) -> UnitFigures<'a> {
    UnitFigures {
        source,
        channels: channels
            .iter()
            .map(|c| {
                let held = c.report.held_out.as_ref();
                ChannelFigures {
                    name: c.name,
                    quantity: c.quantity,
                    figures: c.report.figures(),
                    cubic: c.cubic.as_ref(),
                    cubic_verdict: c.cubic.as_ref().zip(held).map(|(f, h)| {
                        let inv = &h.investigation;
                        let causes = crate::analysis::diagnose::joined(&inv.diagnosis.causes);
                        f.verdict(inv.extended_score.rmse_60s_dps, &causes)
                    }),
                }
            })
            .collect(),
    }
}

/// The file of channel `name`'s small multiple, and of its bias against temperature.
fn figure_names(name: &str) -> [String; 2] {
    [format!("channel-{name}.svg"), format!("bias-{name}.svg")]
}

/// ChannelSection `c`'s small multiple: its held-out error, static and shipped, with their bands; or,
/// from a rate table alone, its leave-one-out error over (T, rate).
fn small_multiple(c: &ChannelSection<'_>) -> anyhow::Result<String> {
    if let Some(h) = &c.report.held_out {
        let (time_h, _, err_s, std_s) = replay_blocks(&h.valid, &h.replays[0]);
        let (_, _, err_e, std_e) = replay_blocks(&h.valid, &h.replays[1]);
        let inv = &h.investigation;
        let shipped = match inv.shipped {
            crate::analysis::investigate::Shipped::Extended => {
                format!("shipped (+ {})", inv.added_inputs.join(", "))
            }
            crate::analysis::investigate::Shipped::Static => "shipped (static)".to_owned(),
        };
        return Ok(plots::channel_errors(
            &format!("{}: held out, gain {:.2}×", c.name, inv.gain),
            &time_h,
            &[
                ReplaySeries {
                    name: "static",
                    error_dps: &err_s,
                    std_dps: &std_s,
                },
                ReplaySeries {
                    name: &shipped,
                    error_dps: &err_e,
                    std_dps: &std_e,
                },
            ],
            c.quantity,
        )?);
    }
    let p = &c.report.points;
    let rep = c
        .report
        .reproduction
        .as_ref()
        .context("a channel with neither a held-out log nor a rate table")?;
    Ok(plots::loo_map(
        &p.temp_c,
        &p.rate_dps,
        &[("GPR", rep.gpr.loo_errors_dps.as_slice())],
    )?)
}

/// The unit's Allan deviations of the held-out error of each channel's shipped model, a panel
/// per quantity; `None` without a held-out log.
fn allan(channels: &[ChannelSection<'_>]) -> anyhow::Result<Option<String>> {
    let held: Vec<(&ChannelSection<'_>, &Allan)> = channels
        .iter()
        .filter_map(|c| c.report.held_out.as_ref().map(|h| (c, &h.allan[2])))
        .collect();
    if held.is_empty() {
        return Ok(None);
    }
    let curves: Vec<_> = held.iter().map(|(_, a)| a.curve()).collect();
    let mut panels: Vec<(Quantity, Vec<AllanSeries<'_>>)> = Vec::new();
    for (k, ((c, a), curve)) in held.iter().zip(&curves).enumerate() {
        let series = AllanSeries {
            label: c.name,
            colour: CHANNEL_COLOURS[k % CHANNEL_COLOURS.len()],
            curve,
            terms: a.terms,
        };
        match panels.iter_mut().find(|(q, _)| *q == c.quantity) {
            Some((_, s)) => s.push(series),
            None => panels.push((c.quantity, vec![series])),
        }
    }
    Ok(Some(crate::plot::allan_unit(
        "Held out: Allan deviation of the shipped models' error",
        &panels,
    )?))
}

/// The table of each channel's figures: held out (static, shipped, gain, causes, the σ of the
/// shipped model's 60 s means), or from a rate table alone its leave-one-out errors.
fn figures_table(channels: &[ChannelSection<'_>]) -> String {
    let mut s = String::from(
        "<table><tr><th>channel</th><th>static, held out</th><th>shipped, held out</th>\
         <th>gain</th><th>causes named</th><th>ships</th><th>60 s means within ±2σ</th>\
         <th>median σ / RMS</th><th>LOO (rate table)</th></tr>\n",
    );
    for c in channels {
        let (k, u) = (c.quantity.bias_per_unit(), c.quantity.bias_unit());
        let loo = c.report.reproduction.as_ref().map_or("—".to_owned(), |r| {
            format!("{:.3} {u}", r.gpr.rmse_dps * k)
        });
        match &c.report.held_out {
            Some(h) => {
                let inv = &h.investigation;
                let causes = if inv.diagnosis.causes.is_empty() {
                    "none".to_owned()
                } else {
                    crate::analysis::diagnose::joined(&inv.diagnosis.causes)
                };
                let _ = writeln!(
                    s,
                    "<tr><td>{}</td><td>{:.3} {u}</td><td>{:.3} {u}</td><td>{:.2}×</td>\
                     <td>{}</td><td>{}</td><td>{:.0}%</td><td>{:.2}</td><td>{loo}</td></tr>",
                    escape(c.name),
                    inv.static_score.rmse_60s_dps * k,
                    inv.extended_score.rmse_60s_dps * k,
                    inv.gain,
                    escape(&causes),
                    match inv.shipped {
                        crate::analysis::investigate::Shipped::Extended => "extended",
                        crate::analysis::investigate::Shipped::Static => "static",
                    },
                    100.0 * inv.extended_score.sigma_60s.within_2sigma,
                    inv.extended_score.sigma_60s.sharpness,
                );
            }
            None => {
                let _ = writeln!(
                    s,
                    "<tr><td>{}</td><td>—</td><td>—</td><td>—</td><td>—</td><td>static</td>\
                     <td>—</td><td>—</td><td>{loo}</td></tr>",
                    escape(c.name)
                );
            }
        }
    }
    s.push_str("</table>\n");
    s
}

/// The table of what the autopilots' cubic costs on each channel, held out: the cubic as PX4's
/// and ArduPilot's firmware apply it (the project's fit, and the autopilots' scripts' on the same
/// samples), the GP, the noise of a 60 s mean, the σ the cubic would carry and the verdict;
/// `None` where no channel has one.
fn cubic_table(channels: &[ChannelSection<'_>]) -> Option<String> {
    let mut s = String::from(
        "<table><tr><th>channel</th><th>cubic (this project)</th><th>cubic (PX4's script)</th>\
         <th>cubic (ArduPilot's script)</th><th>GP, static</th><th>GP, shipped</th>\
         <th>noise of a 60 s mean</th><th>the cubic's σ: within ±2σ, σ / RMS</th>\
         <th>verdict</th></tr>\n",
    );
    let mut any = false;
    for c in channels {
        let (Some(f), Some(h)) = (&c.cubic, &c.report.held_out) else {
            continue;
        };
        any = true;
        let (k, u) = (c.quantity.bias_per_unit(), c.quantity.bias_unit());
        let v = |x: f64| format!("{:.3} {u}", x * k);
        let both = |all: f64, inside: f64| format!("{:.3} ({:.3}) {u}", all * k, inside * k);
        let cubic = |s: &crate::analysis::autopilot::CubicScore| {
            format!(
                "{}; {:.3} every °C",
                both(s.rmse_60s, s.rmse_60s_in_range),
                s.rmse_per_degree * k
            )
        };
        let opt = |x: Option<crate::analysis::autopilot::CubicScore>| {
            x.map_or("—".to_owned(), |s| cubic(&s))
        };
        let inv = &h.investigation;
        let causes = crate::analysis::diagnose::joined(&inv.diagnosis.causes);
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{:.0}%, {:.2}</td><td style=\"text-align:left\">{}</td></tr>",
            escape(c.name),
            cubic(&f.project),
            opt(f.px4_script),
            opt(f.ardupilot_script),
            both(
                inv.static_score.rmse_60s_dps,
                inv.static_score.rmse_60s_in_range_dps
            ),
            both(
                inv.extended_score.rmse_60s_dps,
                inv.extended_score.rmse_60s_in_range_dps
            ),
            v(f.noise_60s),
            100.0 * f.project.within_2sigma,
            f.project.sharpness,
            escape(&f.verdict(inv.extended_score.rmse_60s_dps, &causes)),
        );
    }
    s.push_str("</table>\n");
    any.then_some(s)
}

/// The page: the data as loaded, the table, the small multiples and the Allan figure.
fn html(
    source: &str,
    summary: &str,
    channels: &[ChannelSection<'_>],
    figures: &[(String, String)],
    allan: Option<&str>,
) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>Sensor unit drift compensation report</title><style>\
         body{{font-family:sans-serif;max-width:1400px;margin:2em auto;color:#222}}\
         table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #bbb;padding:4px 10px;text-align:right}}\
         th{{background:#eee}}.grid{{display:grid;grid-template-columns:repeat(auto-fill,minmax(420px,1fr));gap:1em}}\
         figure{{margin:1em 0}}figcaption{{font-weight:bold;margin-bottom:.5em}}\
         svg{{max-width:100%;height:auto}}</style></head><body>\n\
         <h1>Sensor unit drift compensation report</h1>\n\
         <p>Data: <code>{}</code>, {} channels, each with its own model and diagnosis; what they \
         share (the time, the temperature, the minutes the unit was handled) is read once. \
         Figures are also written as SVG files beside this page.</p>\n\
         <h2>The data, as loaded</h2>\n<pre>{}</pre>\n\
         <h2>Each channel</h2>\n",
        escape(source),
        channels.len(),
        escape(summary.trim_end())
    );
    s.push_str(&figures_table(channels));
    s.push_str(
        "<p>Figures in each channel's own unit: °/h for a gyro, mg for an accelerometer (60 s \
         means of the error on the held-out part). The ±2σ is the firmware's σ of a 60 s mean; a \
         Gaussian has 95% within it and a median σ about the RMS error.</p>\n",
    );
    if let Some(table) = cubic_table(channels) {
        s.push_str(
            "<h2>The autopilots' cubic, held out</h2>\n<p>What PX4 and ArduPilot apply: a cubic in \
             the sensor's temperature, clipped to the calibrated range, fitted on the same \
             training samples. RMS of the held-out 60 s means' error, all of them (and those inside \
             the calibrated range, where neither the cubic is clipped nor the GP extrapolates); \
             then the RMS over 1 °C temperature bins of each bin's mean error, every degree \
             counted once however long the board stayed there (the weighting the project's cubic \
             is fitted with; the 60 s figures favour the temperatures the board lingered at); \
             the cubic's σ is the RMS of its training 60 s residuals, the only σ such a fit can \
             state.</p>\n",
        );
        s.push_str(&table);
    }
    s.push_str("<div class=\"grid\">\n");
    for (name, svg) in figures {
        let _ = writeln!(
            s,
            "<figure><figcaption>{}</figcaption>{svg}</figure>",
            escape(name)
        );
    }
    s.push_str("</div>\n");
    if let Some(svg) = allan {
        let _ = writeln!(
            s,
            "<h2>The unit's Allan deviations</h2>\n<figure><figcaption>Held out: the Allan \
             deviation of each channel's shipped model's error (lines: the slopes its noise terms \
             are read from)</figcaption>{svg}</figure>"
        );
    }
    if let Some(first) = channels.first() {
        s.push_str("<h2>What these data could show</h2>\n<ul>\n");
        for c in &first.report.could {
            let _ = writeln!(s, "<li>{}</li>", escape(c));
        }
        s.push_str("</ul>\n<h2>What they could not</h2>\n<ul>\n");
        for c in &first.report.could_not {
            let _ = writeln!(s, "<li>{}</li>", escape(c));
        }
        s.push_str("</ul>\n");
    }
    s.push_str("</body></html>\n");
    s
}

/// Writes the unit's `report.html` (one channel's whole page, or several side by side), its
/// figures, and its figures as data (`report.json`) into `dir` (created if missing); returns
/// the paths.
pub fn write(
    dir: &Path,
    source: &str,
    summary: &str,
    channels: &[ChannelSection<'_>],
) -> anyhow::Result<Vec<PathBuf>> {
    let mut written = match channels {
        [one] => super::write_page(dir, &one.report)?,
        _ => overview(dir, source, summary, channels)?,
    };
    let json = dir.join("report.json");
    write_json(&json, &[], schema::REPORT, &self::figures(source, channels))?;
    written.push(json);
    Ok(written)
}

/// The page of several channels side by side (module doc), and its figure files.
fn overview(
    dir: &Path,
    source: &str,
    summary: &str,
    channels: &[ChannelSection<'_>],
) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut written = Vec::new();
    let mut figures = Vec::new();
    let mut biases = Vec::new();
    for c in channels {
        let [own, bias] = figure_names(c.name);
        let svg = small_multiple(c)?;
        let path = dir.join(own);
        write_atomically(&path, svg.as_bytes())?;
        written.push(path);
        figures.push((c.name.to_owned(), svg));
        if let Some((t, b)) = &c.report.bias {
            let svg = plots::channel_bias(c.name, t, b, c.quantity)?;
            let path = dir.join(bias);
            write_atomically(&path, svg.as_bytes())?;
            written.push(path);
            biases.push((format!("{}: bias against temperature", c.name), svg));
        }
    }
    // A static log's loops first: what a person looks at before any model.
    biases.extend(figures);
    let figures = biases;
    let allan = allan(channels)?;
    if let Some(svg) = &allan {
        let path = dir.join("allan.svg");
        write_atomically(&path, svg.as_bytes())?;
        written.push(path);
    }
    let page = dir.join("report.html");
    write_atomically(
        &page,
        html(source, summary, channels, &figures, allan.as_deref()).as_bytes(),
    )?;
    written.push(page);
    Ok(written)
}

/// The files [`write()`] writes for channels named `names`, for the check that no output overwrites
/// an input.
pub fn files(names: &[&str]) -> Vec<String> {
    let figures: Vec<String> = match names {
        [_] => super::FIGURES.iter().map(|f| f.0.to_owned()).collect(),
        _ => names
            .iter()
            .flat_map(|n| figure_names(n))
            .chain(["allan.svg".to_owned()])
            .collect(),
    };
    figures
        .into_iter()
        .chain(["report.html", "report.json"].map(str::to_owned))
        .collect()
}
