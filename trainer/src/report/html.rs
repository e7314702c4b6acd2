//! The report's page: the figures with their captions and the tables of the held-out figures,
//! as one self-contained HTML file.

use firmware_core::units::DPH_PER_DPS;
use std::fmt::Write as _;

use fog_data::allan::Analysis as Allan;
use fog_data::replay::Score;
use fog_data::sigma::Coverage;

use crate::analysis::investigate::Investigation;
use crate::analysis::reproduce::{PAPER_LOO_GPR, PAPER_LOO_LSSVR, PAPER_LOTO};

use super::contents::{FIGURES, Report, ReportKind};

/// What the Allan table shows at the longest τ the raw and the shipped curves share, in words that
/// follow its figures: compensation should lower the long-τ part (the temperature's slow drift),
/// and where it does not, the page says so.
pub(super) fn allan_sentence(allan: &[Allan; 3]) -> String {
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
            r * DPH_PER_DPS,
            e * DPH_PER_DPS
        ),
        Some((tau, r, e)) => format!(
            "Compensation does not lower the long-τ part here: at τ = {tau:.0} s the Allan \
             deviation goes from {:.3} to {:.3} °/h, so what drifts slowly in this stream is not \
             the static temperature curve the model removes.",
            r * DPH_PER_DPS,
            e * DPH_PER_DPS
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
/// of 60 s means (all, then those inside the trained range and those beyond it apart, where both
/// hold some), and the median σ over the RMS error; then how the shipped σ was calibrated.
pub(super) fn sigma_table(inv: &Investigation) -> String {
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
        ]
        .into_iter()
        .chain(split_by_range(score))
        {
            let _ = writeln!(
                s,
                "<tr><td>{name}</td><td>{of}</td><td>{:.2}</td><td>{:.2}</td><td>{:.0}%</td>\
                 <td>{:.0}%</td><td>{:.0}%</td><td>{:.2}</td></tr>",
                c.rmse * DPH_PER_DPS,
                c.median_sigma * DPH_PER_DPS,
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
    if let Some(c) = &inv.basis_choice {
        let _ = writeln!(s, "<p>Its prior mean: {}.</p>", escape(&c.verdict));
    }
    s
}

/// The 60 s means inside the trained range and beyond it, apart, where there are both.
fn split_by_range(score: &Score) -> Vec<(&'static str, &Coverage)> {
    match (&score.sigma_60s_in_range, &score.sigma_60s_beyond) {
        (Some(inside), Some(beyond)) => vec![
            ("60 s means inside the trained range", inside),
            ("60 s means beyond it", beyond),
        ],
        _ => Vec::new(),
    }
}

pub(super) fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

pub(super) fn sci(v: f64) -> String {
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
            ReportKind::Table => "a rate table alone",
            ReportKind::TableAndStream => "a rate table and one stream",
            ReportKind::Log => "one log alone",
            ReportKind::Full => "a rate table, a training stream and a held-out stream",
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
            inv.static_score.rmse_60s_dps * DPH_PER_DPS,
            if inv.added_inputs.is_empty() {
                "nothing".into()
            } else {
                inv.added_inputs.join(", ")
            },
            sci(inv.extended_score.rmse_60s_dps),
            inv.extended_score.rmse_60s_dps * DPH_PER_DPS,
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

#[cfg(test)]
mod tests {
    use super::*;
    use fog_data::allan::Analysis as Allan;

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
