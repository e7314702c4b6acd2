//! The report's figures as SVG text (plotters' SVG backend: no fonts needed at build time, the
//! browser renders the text). Each function draws one figure from plain series, so the figures can
//! be checked without running a fit.

use crate::plot::{
    BLUE, Draw, DrawResult, FONT, GREEN, GREY, LABEL, ORANGE, PlotError, RED, TITLE, axes,
    cold_to_hot, legend, span, svg,
};
use firmware_core::Quantity;
use firmware_core::units::DPH_PER_DPS;
use fog_data::sigma::Coverage;
use fog_data::stats::{self, Line};
use plotters::prelude::*;

/// Distinct values of `xs`, sorted, merged when closer than `tol`.
pub fn levels(xs: &[f64], tol: f64) -> Vec<f64> {
    let mut v: Vec<f64> = xs.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| (*a - *b).abs() < tol);
    v
}

/// Fig. 1: the rate table, output against reference rate, one colour per temperature plateau.
pub fn rate_table(temp_c: &[f64], rate_dps: &[f64], output: &[f64]) -> Result<String, PlotError> {
    svg("the rate table", (900, 560), |root| {
        let (x0, x1) = span(rate_dps.iter().copied(), 0.05);
        let (y0, y1) = span(output.iter().copied(), 0.05);
        let (t0, t1) = span(temp_c.iter().copied(), 0.0);
        let mut chart = ChartBuilder::on(root)
            .caption(
                "Rate table: gyro output over (temperature, rate)",
                (FONT, TITLE),
            )
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        axes(
            &mut chart,
            "reference rate (°/s)",
            "gyro output (V or counts)",
        )?;
        let plateaus = levels(temp_c, 1.0);
        let nearest = |t: f64| {
            (0..plateaus.len())
                .min_by(|&a, &b| (plateaus[a] - t).abs().total_cmp(&(plateaus[b] - t).abs()))
        };
        for (k, &level) in plateaus.iter().enumerate() {
            let colour = cold_to_hot((level - t0) / (t1 - t0).max(1e-9));
            let pts: Vec<(f64, f64)> = (0..temp_c.len())
                .filter(|&i| nearest(temp_c[i]) == Some(k))
                .map(|i| (rate_dps[i], output[i]))
                .collect();
            let series =
                chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
            // One legend entry per plateau up to ten; beyond, the end points only.
            if plateaus.len() <= 10 || k == 0 || k + 1 == plateaus.len() {
                series
                    .label(format!("{level:.1} °C"))
                    .legend(move |(x, y)| Circle::new((x, y), 4, colour.filled()));
            }
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        Ok(())
    })
}

/// Fig. 2: per rate, the output against temperature with its first-order fit, as the deviation
/// from that rate's mean output in thousandths of the output unit (mV for an analog gyro), one
/// panel per rate so that the curvature a straight line misses is visible.
pub fn output_vs_temperature(
    temp_c: &[f64],
    rate_dps: &[f64],
    output: &[f64],
) -> Result<String, PlotError> {
    let rates = levels(rate_dps, 1e-6);
    let cols = 4usize;
    let rows = rates.len().div_ceil(cols).max(1);
    let height = 60 + 230 * u32::try_from(rows).unwrap_or(8);
    svg("output against temperature", (1100, height), |root| {
        let (title, body) = root.split_vertically(50);
        title.titled(
            "Output against temperature per rate, with first-order fits (paper Fig. 2)",
            (FONT, TITLE),
        )?;
        for (panel, &rate) in body.split_evenly((rows, cols)).iter().zip(&rates) {
            let idx: Vec<usize> = (0..rate_dps.len())
                .filter(|&i| (rate_dps[i] - rate).abs() < 1e-6)
                .collect();
            let t: Vec<f64> = idx.iter().map(|&i| temp_c[i]).collect();
            let v: Vec<f64> = idx.iter().map(|&i| output[i]).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let dev: Vec<f64> = v.iter().map(|x| 1e3 * (x - mean)).collect();
            let (a, b) = Line::fit(t.iter().copied().zip(dev.iter().copied()))
                .map_or((stats::mean(&dev), 0.0), |l| (l.intercept, l.slope));
            let (x0, x1) = span(t.iter().copied(), 0.05);
            let (y0, y1) = span(dev.iter().copied(), 0.1);
            let mut chart = ChartBuilder::on(panel)
                .caption(format!("{rate:+.1} °/s"), (FONT, LABEL))
                .margin(8)
                .x_label_area_size(38)
                .y_label_area_size(60)
                .build_cartesian_2d(x0..x1, y0..y1)?;
            chart
                .configure_mesh()
                .x_desc("T (°C)")
                .y_desc("Δoutput (×10⁻³)")
                .x_labels(5)
                .y_labels(5)
                .label_style((FONT, 12))
                .axis_desc_style((FONT, 13))
                .draw()?;
            chart.draw_series(
                t.iter()
                    .zip(&dev)
                    .map(|(&x, &y)| Circle::new((x, y), 3, BLUE.filled())),
            )?;
            chart.draw_series(LineSeries::new(
                [x0, x1].map(|x| (x, a + b * x)),
                ORANGE.stroke_width(2),
            ))?;
        }
        Ok(())
    })
}

/// Fig. 4: normal Q-Q plot of leave-one-out residuals, one series per method with its
/// correlation in the legend. `methods`: (name, residuals, correlation).
pub fn qq(methods: &[(&str, &[f64], f64)]) -> Result<String, PlotError> {
    svg("the Q-Q plot", (760, 560), |root| {
        let normal = statrs::distribution::Normal::standard();
        let series: Vec<(String, Vec<(f64, f64)>)> = methods
            .iter()
            .map(|(name, r, corr)| {
                let mut s = r.to_vec();
                s.sort_by(f64::total_cmp);
                let n = s.len() as f64;
                let pts = s
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| {
                        let p = (i as f64 + 1.0 - 0.375) / (n + 0.25);
                        (
                            statrs::distribution::ContinuousCDF::inverse_cdf(&normal, p),
                            v,
                        )
                    })
                    .collect();
                (format!("{name} (r = {corr:.4})"), pts)
            })
            .collect();
        let (x0, x1) = span(series.iter().flat_map(|s| s.1.iter().map(|p| p.0)), 0.05);
        let (y0, y1) = span(series.iter().flat_map(|s| s.1.iter().map(|p| p.1)), 0.05);
        let mut chart = ChartBuilder::on(root)
            .caption(
                "Leave-one-out residuals against normal quantiles (paper Fig. 4)",
                (FONT, 18),
            )
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(90)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        axes(&mut chart, "standard normal quantile", "LOO residual (°/s)")?;
        for ((label, pts), colour) in series.iter().zip([BLUE, ORANGE, GREEN]) {
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))?
                .label(label.as_str())
                .legend(move |(x, y)| Circle::new((x, y), 4, colour.filled()));
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        Ok(())
    })
}

/// One σ's reliability: errors and the σ stated for each.
pub struct ReliabilitySeries<'a> {
    /// Legend name.
    pub name: String,
    /// Errors, output units.
    pub errors: &'a [f64],
    /// The σ stated for each.
    pub sigmas: &'a [f64],
}

/// Nominal central coverage levels of the reliability diagram.
const LEVELS: [f64; 12] = [
    0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.683, 0.8, 0.9, 0.954, 0.99, 0.997,
];

/// The reliability diagram: for each nominal central coverage p, the fraction of errors within
/// the Gaussian interval the σ claims (±z σ, z the normal quantile of (1 + p)/2). On the diagonal
/// the σ is what it says; below it the σ is too small (the filter trusts a wrong rate), above it
/// too wide.
pub fn reliability(series: &[ReliabilitySeries<'_>]) -> Result<String, PlotError> {
    svg("the reliability diagram", (760, 620), |root| {
        let normal = statrs::distribution::Normal::standard();
        let mut chart = ChartBuilder::on(root)
            .caption(
                "Reliability of the firmware's σ: nominal against observed coverage",
                (FONT, 18),
            )
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..1.0, 0.0..1.0)?;
        axes(&mut chart, "nominal coverage (±zσ)", "observed coverage")?;
        chart
            .draw_series(LineSeries::new(
                [(0.0, 0.0), (1.0, 1.0)],
                GREY.stroke_width(1),
            ))?
            .label("as claimed")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], GREY.stroke_width(2)));
        for (m, colour) in series.iter().zip([BLUE, ORANGE, GREEN, RED]) {
            let pts: Vec<(f64, f64)> = LEVELS
                .iter()
                .map(|&p| {
                    let z =
                        statrs::distribution::ContinuousCDF::inverse_cdf(&normal, 0.5 + 0.5 * p);
                    (p, Coverage::within(m.errors, m.sigmas, z))
                })
                .collect();
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
            chart
                .draw_series(LineSeries::new(pts, colour.stroke_width(2)))?
                .label(format!("{} (n = {})", m.name, m.errors.len()))
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(3))
                });
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        Ok(())
    })
}

/// Fig. 5–6: leave-one-out error over (temperature, rate), one panel per method on a shared
/// scale: circle area ∝ |error|, red where the model reads high, blue where low.
/// `methods`: (name, error of every point, °/s).
pub fn loo_map(
    temp_c: &[f64],
    rate_dps: &[f64],
    methods: &[(&str, &[f64])],
) -> Result<String, PlotError> {
    let width = 560 * u32::try_from(methods.len()).unwrap_or(2);
    svg("the LOO error map", (width, 620), |root| {
        let largest = methods
            .iter()
            .flat_map(|m| m.1.iter().map(|e| e.abs()))
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        let (title, body) = root.split_vertically(50);
        title.titled(
            &format!(
                "Leave-one-out error over (T, rate) (paper Fig. 5–6): area ∝ |error|, largest {largest:.2e} °/s; red = reads high, blue = low"
            ),
            (FONT, 16),
        )?;
        let (x0, x1) = span(temp_c.iter().copied(), 0.06);
        let (y0, y1) = span(rate_dps.iter().copied(), 0.06);
        for (panel, (name, err)) in body.split_evenly((1, methods.len())).iter().zip(methods) {
            let rms = stats::rms(err);
            let mut chart = ChartBuilder::on(panel)
                .caption(format!("{name}: RMSE {rms:.2e} °/s"), (FONT, LABEL))
                .margin(12)
                .x_label_area_size(50)
                .y_label_area_size(65)
                .build_cartesian_2d(x0..x1, y0..y1)?;
            axes(&mut chart, "temperature (°C)", "reference rate (°/s)")?;
            chart.draw_series((0..err.len()).map(|i| {
                let r = (14.0 * (err[i].abs() / largest).sqrt()).max(1.0);
                let colour = if err[i] >= 0.0 { RED } else { BLUE };
                Circle::new(
                    (temp_c[i], rate_dps[i]),
                    r.round() as i32,
                    colour.mix(0.6).filled(),
                )
            }))?;
        }
        Ok(())
    })
}

/// Longest step between block times drawn as one line, h: a longer one is a power-off or a gap
/// in the log, and a line across it would show data that was never measured.
const MAX_STEP_H: f64 = 3.0 / 60.0;

/// Index ranges of `time_h` without a step longer than [`MAX_STEP_H`].
fn runs(time_h: &[f64]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=time_h.len() {
        if i == time_h.len() || time_h[i] - time_h[i - 1] > MAX_STEP_H {
            out.push(start..i);
            start = i;
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

/// One replayed model on the held-out stream, reduced to 60 s blocks.
pub struct ReplaySeries<'a> {
    /// Legend name.
    pub name: &'a str,
    /// Block mean of compensated − reference, °/s.
    pub error_dps: &'a [f64],
    /// The firmware's σ of each 60 s mean, °/s.
    pub std_dps: &'a [f64],
}

/// The stream replay: temperature over time, then each model's 60 s error with the ±2σ band the
/// firmware claims for it, drawn around zero: where the error line leaves its band, the firmware
/// said it was surer than it was.
pub fn replay(
    time_h: &[f64],
    temp_c: &[f64],
    models: &[ReplaySeries<'_>],
) -> Result<String, PlotError> {
    svg("the replay", (1100, 760), |root| {
        let (top, bottom) = root.split_vertically(260);
        let (x0, x1) = span(time_h.iter().copied(), 0.0);
        let (t0, t1) = span(temp_c.iter().copied(), 0.05);
        let mut chart = ChartBuilder::on(&top)
            .caption("Held-out stream: temperature", (FONT, TITLE))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, t0..t1)?;
        axes(&mut chart, "time (h)", "sensor T (°C)")?;
        let runs = runs(time_h);
        for run in &runs {
            chart.draw_series(LineSeries::new(
                run.clone().map(|i| (time_h[i], temp_c[i])),
                RED.stroke_width(2),
            ))?;
        }
        draw_errors(
            &bottom,
            "Compensated rate error, 60 s means, and the firmware's ±2σ of a mean around zero",
            time_h,
            models,
            Quantity::AngularRate,
        )
    })
}

/// One channel of a unit on its held-out log: each model's 60 s error and ±2σ band, in the bias
/// unit of `q` (°/h, mg): a small multiple of the unit's page.
pub fn channel_errors(
    title: &str,
    time_h: &[f64],
    models: &[ReplaySeries<'_>],
    q: Quantity,
) -> Result<String, PlotError> {
    svg("a channel's held-out error", (560, 360), |root| {
        draw_errors(root, title, time_h, models, q)
    })
}

/// Each model's 60 s error over time with the ±2σ band the firmware claims for it, drawn around
/// zero, in the bias unit of `q`.
fn draw_errors(
    area: &crate::plot::Draw<'_>,
    caption: &str,
    time_h: &[f64],
    models: &[ReplaySeries<'_>],
    q: Quantity,
) -> crate::plot::DrawResult {
    let (x0, x1) = span(time_h.iter().copied(), 0.0);
    let runs = runs(time_h);
    let (k, u) = (q.bias_per_unit(), q.bias_unit());
    let (e0, e1) = span(
        models.iter().flat_map(|m| {
            m.error_dps
                .iter()
                .zip(m.std_dps)
                .flat_map(|(e, s)| [e * k, -2.0 * s * k, 2.0 * s * k])
        }),
        0.05,
    );
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, TITLE))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, e0..e1)?;
    axes(&mut chart, "time (h)", &format!("error ({u})"))?;
    for (m, colour) in models.iter().zip([BLUE, ORANGE]) {
        let band_at = |i: usize, sign: f64| (time_h[i], sign * 2.0 * m.std_dps[i] * k);
        let at = |i: usize| (time_h[i], m.error_dps[i] * k);
        let rms = stats::rms(m.error_dps);
        for (j, run) in runs.iter().enumerate() {
            let band = run
                .clone()
                .map(|i| band_at(i, 1.0))
                .chain(run.clone().rev().map(|i| band_at(i, -1.0)));
            chart.draw_series(std::iter::once(Polygon::new(
                band.collect::<Vec<_>>(),
                colour.mix(0.15).filled(),
            )))?;
            let line =
                chart.draw_series(LineSeries::new(run.clone().map(at), colour.stroke_width(2)))?;
            if j == 0 {
                line.label(format!("{}: rmse_60s {:.2} {u}", m.name, rms * k))
                    .legend(move |(x, y)| {
                        PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(3))
                    });
            }
        }
    }
    legend(&mut chart, SeriesLabelPosition::LowerMiddle)?;
    Ok(())
}

/// What the diagnosis plot shows: the static model's 60 s residuals against the named cause's
/// regressor with the fitted line, and against temperature split by heating and cooling.
pub struct DiagnosisSeries<'a> {
    /// The named cause and its regressor's axis label, when it has one.
    pub cause: &'a str,
    /// Axis label of the regressor.
    pub regressor_label: &'a str,
    /// Regressor block means (empty for `none`).
    pub regressor: &'a [f64],
    /// Fitted intercept (°/s) and slope (°/s per regressor unit).
    pub line: (f64, f64),
    /// Residual block means, °/s.
    pub residual_dps: &'a [f64],
    /// Block-mean temperature, °C.
    pub temp_c: &'a [f64],
}

/// The diagnosis figure: two panels.
pub fn diagnosis(d: &DiagnosisSeries<'_>) -> Result<String, PlotError> {
    svg("the diagnosis", (1100, 520), |root| {
        let panels = root.split_evenly((1, 2));
        let to_dph = DPH_PER_DPS;
        let r: Vec<f64> = d.residual_dps.iter().map(|v| v * to_dph).collect();
        let (r0, r1) = span(r.iter().copied(), 0.08);
        if !d.regressor.is_empty() {
            let (x0, x1) = span(d.regressor.iter().copied(), 0.05);
            let mut chart = ChartBuilder::on(&panels[0])
                .caption(
                    format!("Static residual against the cause: {}", d.cause),
                    (FONT, 18),
                )
                .margin(12)
                .x_label_area_size(50)
                .y_label_area_size(80)
                .build_cartesian_2d(x0..x1, r0..r1)?;
            axes(&mut chart, d.regressor_label, "residual, 60 s means (°/h)")?;
            chart
                .draw_series(
                    d.regressor
                        .iter()
                        .zip(&r)
                        .map(|(&x, &y)| Circle::new((x, y), 2, BLUE.mix(0.6).filled())),
                )?
                .label("60 s blocks")
                .legend(|(x, y)| Circle::new((x, y), 4, BLUE.filled()));
            let (a, b) = d.line;
            chart
                .draw_series(LineSeries::new(
                    [x0, x1].map(|x| (x, (a + b * x) * to_dph)),
                    ORANGE.stroke_width(3),
                ))?
                .label("fitted term")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], ORANGE.stroke_width(3)));
            legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        } else {
            panels[0].titled("cause: none — the residual is noise", (FONT, 18))?;
        }
        by_direction(
            &panels[1],
            "Static residual against temperature",
            "residual, 60 s means (°/h)",
            d.temp_c,
            &r,
        )
    })
}

/// 60 s means (°/h) against temperature, heating, cooling and steady blocks apart (by the
/// block-to-block temperature step): where a hysteresis loop opens up.
fn by_direction(
    area: &Draw<'_>,
    title: &str,
    y_label: &str,
    t: &[f64],
    values_dph: &[f64],
) -> DrawResult {
    let (x0, x1) = span(t.iter().copied(), 0.05);
    let (y0, y1) = span(values_dph.iter().copied(), 0.08);
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 18))
        .margin(12)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    axes(&mut chart, "sensor T (°C)", y_label)?;
    let dir = |i: usize| {
        let next = t.get(i + 1).copied().unwrap_or(t[i]);
        let prev = if i > 0 { t[i - 1] } else { t[i] };
        next - prev
    };
    for (label, colour, keep) in [
        ("heating", RED, (|s: f64| s > 0.01) as fn(f64) -> bool),
        ("cooling", BLUE, |s: f64| s < -0.01),
        ("steady", GREY, |s: f64| s.abs() <= 0.01),
    ] {
        chart
            .draw_series(
                (0..t.len())
                    .filter(|&i| keep(dir(i)))
                    .map(|i| Circle::new((t[i], values_dph[i]), 2, colour.mix(0.6).filled())),
            )?
            .label(label)
            .legend(move |(x, y)| Circle::new((x, y), 4, colour.filled()));
    }
    legend(&mut chart, SeriesLabelPosition::MiddleMiddle)
}

/// A static log's bias against temperature: its 60 s means of output / K − reference, heating
/// and cooling apart.
pub fn bias_vs_temperature(temp_c: &[f64], bias_dph: &[f64]) -> Result<String, PlotError> {
    svg("the bias against temperature", (900, 560), |root| {
        by_direction(
            root,
            "Bias against temperature, heating and cooling apart",
            "bias, 60 s means (°/h)",
            temp_c,
            bias_dph,
        )
    })
}

/// One channel of a unit's static log: its bias against temperature, heating and cooling apart,
/// in the bias unit of `q` (`bias_dph`: as [`bias_vs_temperature`] takes it, °/s times 3600).
pub fn channel_bias(
    name: &str,
    temp_c: &[f64],
    bias_dph: &[f64],
    q: Quantity,
) -> Result<String, PlotError> {
    let k = q.bias_per_unit() / DPH_PER_DPS;
    let bias: Vec<f64> = bias_dph.iter().map(|b| b * k).collect();
    svg("a channel's bias against temperature", (560, 360), |root| {
        by_direction(
            root,
            &format!("{name}: bias against temperature"),
            &format!("bias, 60 s means ({})", q.bias_unit()),
            temp_c,
            &bias,
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_break_at_gaps_in_the_log() {
        let minute = 1.0 / 60.0;
        let t = [0.0, minute, 2.0 * minute, 30.0 * minute, 31.0 * minute];
        assert_eq!(runs(&t), vec![0..3, 3..5]);
        assert_eq!(runs(&t[..3]), vec![0..3]);
        assert!(runs(&[]).is_empty());
    }

    #[test]
    fn figures_carry_their_labels_and_data() {
        let t = [20.0, 20.0, 40.0, 40.0];
        let w = [-10.0, 10.0, -10.0, 10.0];
        let v = [-0.1, 0.1, -0.099, 0.101];
        let fig1 = rate_table(&t, &w, &v).unwrap();
        assert!(fig1.starts_with("<svg"), "{}", &fig1[..40]);
        for label in ["reference rate (°/s)", "20.0 °C", "40.0 °C"] {
            assert!(fig1.contains(label), "missing {label}");
        }
        let fig2 = output_vs_temperature(&t, &w, &v).unwrap();
        assert!(fig2.contains("+10.0 °/s") && fig2.contains("-10.0 °/s"));
        let e = [1e-3, -2e-3, 5e-4, 0.0];
        let map = loo_map(&t, &w, &[("GPR", &e), ("LS-SVR", &e)]).unwrap();
        assert!(map.contains("GPR: RMSE") && map.contains("LS-SVR: RMSE"));
        assert_eq!(map.matches("<circle").count(), 8);
        assert!(
            qq(&[("GPR", &e, 0.99)])
                .unwrap()
                .contains("GPR (r = 0.9900)")
        );
    }

    #[test]
    fn levels_merge_readings_of_one_plateau() {
        assert_eq!(levels(&[20.1, 39.8, 20.3, 40.2], 1.0), vec![20.1, 39.8]);
    }
}
