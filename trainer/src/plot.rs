//! Figures as SVG text (plotters' SVG backend: no fonts needed at build time, the browser renders
//! the text): the canvas, axes and colours every figure shares, and the figures of the noise and
//! twin analyses (an Allan deviation, a twin against measured data); the report's own figures are
//! in `report::plots`. Each function draws one figure from plain series, so the figures can be
//! checked without a fit.

use std::error::Error;

use firmware_core::Quantity;
use firmware_core::units::DPH_PER_DPS;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// A figure that could not be drawn (plotters' error, as text).
#[derive(Debug, thiserror::Error)]
#[error("drawing {figure}: {message}")]
pub struct PlotError {
    /// The figure.
    pub figure: &'static str,
    /// What plotters said.
    pub message: String,
}

/// The canvas a figure draws on.
pub type Draw<'a> = DrawingArea<SVGBackend<'a>, Shift>;
/// What drawing returns (plotters' errors differ by backend: boxed).
pub type DrawResult = Result<(), Box<dyn Error + Send + Sync>>;

/// Font family of every text.
pub const FONT: &str = "sans-serif";
/// Title size, px.
pub const TITLE: u32 = 20;
/// Axis-title size, px.
pub const LABEL: u32 = 16;
/// Tick-label and legend size, px.
pub const TICK: u32 = 14;
/// Static model, extended model, GPR, LS-SVR: one colour each across the figures.
pub const BLUE: RGBColor = RGBColor(31, 119, 180);
/// The second series.
pub const ORANGE: RGBColor = RGBColor(230, 120, 20);
/// The third series.
pub const GREEN: RGBColor = RGBColor(44, 160, 44);
/// The fourth series; hot.
pub const RED: RGBColor = RGBColor(214, 39, 40);
/// The fifth series.
pub const PURPLE: RGBColor = RGBColor(148, 103, 189);
/// The sixth series.
pub const BROWN: RGBColor = RGBColor(140, 86, 75);
/// A series colour per channel of a unit, in channel order (repeating past six).
pub const CHANNEL_COLOURS: [RGBColor; 6] = [BLUE, ORANGE, GREEN, RED, PURPLE, BROWN];
/// References and guides.
pub const GREY: RGBColor = RGBColor(120, 120, 120);

/// Renders `draw` on a `size` canvas and returns the SVG text.
pub fn svg(
    figure: &'static str,
    size: (u32, u32),
    draw: impl FnOnce(&Draw<'_>) -> DrawResult,
) -> Result<String, PlotError> {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        let result = root
            .fill(&WHITE)
            .map_err(Into::into)
            .and_then(|()| draw(&root))
            .and_then(|()| root.present().map_err(Into::into));
        result.map_err(|e| PlotError {
            figure,
            message: e.to_string(),
        })?;
    }
    Ok(text)
}

/// The charts here: f64 on both axes, drawn to SVG.
pub type Chart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Grid, ticks and axis titles in the report's sizes.
pub fn axes<'a, 'b: 'a>(chart: &mut Chart<'a, 'b>, x: &str, y: &str) -> DrawResult {
    chart
        .configure_mesh()
        .x_desc(x)
        .y_desc(y)
        .label_style((FONT, TICK))
        .axis_desc_style((FONT, LABEL))
        .draw()?;
    Ok(())
}

/// The legend box at `position`, over a translucent white background.
pub fn legend<'a, 'b: 'a>(chart: &mut Chart<'a, 'b>, position: SeriesLabelPosition) -> DrawResult {
    chart
        .configure_series_labels()
        .position(position)
        .label_font((FONT, TICK))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// Low and high of a series, padded by `pad` of the span (and kept apart when constant).
pub fn span(values: impl IntoIterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (lo, hi) = values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let width = if hi > lo { hi - lo } else { lo.abs().max(1.0) };
    (lo - pad * width, hi + pad * width)
}

/// Blue (cold) to red (hot) for `t` in [0, 1].
pub fn cold_to_hot(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0);
    let mix = |a: u8, b: u8| (f64::from(a) + t * (f64::from(b) - f64::from(a))).round() as u8;
    RGBColor(mix(BLUE.0, RED.0), mix(BLUE.1, RED.1), mix(BLUE.2, RED.2))
}

/// One Allan deviation curve of a figure: its label, colour, curve and the terms read from it.
pub struct AllanSeries<'a> {
    /// Legend text.
    pub label: &'a str,
    /// Its colour.
    pub colour: RGBColor,
    /// The curve (°/s).
    pub curve: &'a crate::analysis::allan::Curve,
    /// The terms read from it, drawn as the slope lines they come from.
    pub terms: crate::analysis::allan::Terms,
}

/// Allan deviation on log-log axes (°/h against τ), each curve with its one-sigma band and the
/// lines its noise terms were read from: slope −½ through N at 1 s, the flat B·0.664, slope +½
/// through K at 3 s.
pub fn allan(title: &str, series: &[AllanSeries<'_>]) -> Result<String, PlotError> {
    svg("the Allan deviation", (900, 600), |root| {
        draw_allan(root, title, series, Quantity::AngularRate)
    })
}

/// A unit's Allan deviations on one figure: a panel per quantity (the gyros' in °/h, the
/// accelerometers' in mg), every channel of it a curve.
pub fn allan_unit(
    title: &str,
    panels: &[(Quantity, Vec<AllanSeries<'_>>)],
) -> Result<String, PlotError> {
    let width = 900 * u32::try_from(panels.len().max(1)).unwrap_or(1);
    svg("the unit's Allan deviations", (width, 600), |root| {
        let areas = root.split_evenly((1, panels.len().max(1)));
        for (area, (q, series)) in areas.iter().zip(panels) {
            let caption = match q {
                Quantity::AngularRate => format!("{title}: gyros"),
                Quantity::SpecificForce => format!("{title}: accelerometers"),
            };
            draw_allan(area, &caption, series, *q)?;
        }
        Ok(())
    })
}

/// One Allan panel in the bias unit of `q` (°/h, mg).
fn draw_allan(root: &Draw<'_>, title: &str, series: &[AllanSeries<'_>], q: Quantity) -> DrawResult {
    let k = q.bias_per_unit();
    let taus = series.iter().flat_map(|s| s.curve.tau_s.iter().copied());
    let (t0, t1) = taus.fold((f64::INFINITY, 0.0f64), |(a, b), t| (a.min(t), b.max(t)));
    let values = series.iter().flat_map(|s| {
        s.curve
            .adev_lo
            .iter()
            .chain(&s.curve.adev_hi)
            .map(move |v| v * k)
            .filter(|v| *v > 0.0)
    });
    let (y0, y1) = values.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if !(t0.is_finite() && y0.is_finite() && t1 > t0 && y1 > y0) {
        return Err("no curve to draw".into());
    }
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, TITLE))
        .margin(15)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d((t0..t1).log_scale(), (y0 / 1.5..y1 * 1.5).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("cluster time τ (s)")
        .y_desc(format!("Allan deviation ({})", q.bias_unit()))
        .label_style((FONT, TICK))
        .axis_desc_style((FONT, LABEL))
        .draw()?;
    // The terms are stated as a gyro's (°/h of °/s, IEEE 952): back to the rate's unit, then k.
    let from_dph = k / DPH_PER_DPS;
    for s in series {
        let c = s.curve;
        let band: Vec<(f64, f64)> = c
            .tau_s
            .iter()
            .zip(&c.adev_hi)
            .map(|(t, v)| (*t, v * k))
            .chain(
                c.tau_s
                    .iter()
                    .zip(&c.adev_lo)
                    .rev()
                    .map(|(t, v)| (*t, (v * k).max(y0 / 1.5))),
            )
            .collect();
        chart.draw_series(std::iter::once(Polygon::new(band, s.colour.mix(0.15))))?;
        chart
            .draw_series(LineSeries::new(
                c.tau_s.iter().zip(&c.adev).map(|(t, v)| (*t, v * k)),
                s.colour.stroke_width(2),
            ))?
            .label(s.label)
            .legend(move |(x, y)| {
                PathElement::new([(x, y), (x + 18, y)], s.colour.stroke_width(2))
            });
        let guide = s.colour.mix(0.6).stroke_width(1);
        let ys = (y0 / 1.5, y1 * 1.5);
        // N (°/√h) at τ = 1 s: σ = N/60 /√τ in the rate's unit, i.e. N/60·k/√τ.
        let lines = [
            s.terms.arw_deg_per_sqrt_h.map(|n| (n / 60.0 * k, -0.5)),
            s.terms
                .bias_instability_deg_per_h
                .map(|b| (b * crate::analysis::allan::FLICKER_FLOOR * from_dph, 0.0)),
            // K (°/h)/√h at τ = 3 s: σ = K·√(τ/3) /60 in °/h.
            s.terms
                .rrw_deg_per_h_per_sqrt_h
                .map(|r| (r / 60.0 / 3f64.sqrt() * from_dph, 0.5)),
        ];
        for (a, p) in lines.into_iter().flatten() {
            if let Some(ends) = power_line(a, p, (t0, t1), ys) {
                chart.draw_series(LineSeries::new(ends, guide))?;
            }
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, TICK))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// The ends of the line y = a·τ^p inside the box (τ in `t`, y in `y`), for a guide drawn at its
/// true slope: the box clips the τ range to where the line stays inside, rather than the plot
/// clamping each end onto its edge (which bends the slope). `None` where it never enters.
fn power_line(a: f64, p: f64, t: (f64, f64), y: (f64, f64)) -> Option<[(f64, f64); 2]> {
    let at = |tau: f64| a * tau.powf(p);
    let (mut lo, mut hi) = t;
    if p != 0.0 {
        // Where the line crosses the box's bottom and top.
        let cross = |v: f64| (v / a).powf(1.0 / p);
        let (c0, c1) = (cross(y.0), cross(y.1));
        let (c_lo, c_hi) = if c0 < c1 { (c0, c1) } else { (c1, c0) };
        lo = lo.max(c_lo);
        hi = hi.min(c_hi);
    }
    let inside = |v: f64| v >= y.0 && v <= y.1;
    (lo < hi && inside(at(lo)) && inside(at(hi))).then(|| [(lo, at(lo)), (hi, at(hi))])
}

/// What the simulation gets wrong: the held-out difference between the measured output and the
/// twin's (°/h) on the held-out axis (hours of a stream, or index of a table's points), before
/// and after the effects are added. Streams are drawn as one-minute means.
pub fn twin(
    title: &str,
    axis: &str,
    points: &[(f64, f64, f64)],
    after_label: &str,
) -> Result<String, PlotError> {
    svg("the twin", (900, 500), |root| {
        let (x0, x1) = span(points.iter().map(|p| p.0), 0.02);
        let (y0, y1) = span(points.iter().flat_map(|p| [p.1, p.2]), 0.05);
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, TITLE))
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        axes(&mut chart, axis, "measured − twin, rate-equivalent (°/h)")?;
        chart.draw_series(LineSeries::new([(x0, 0.0), (x1, 0.0)], BLACK.mix(0.4)))?;
        for (label, colour, pick) in [("static twin", GREY, 1usize), (after_label, BLUE, 2usize)] {
            let at = move |p: &(f64, f64, f64)| (p.0, if pick == 1 { p.1 } else { p.2 });
            chart
                .draw_series(
                    points
                        .iter()
                        .map(|p| Circle::new(at(p), 2, colour.filled())),
                )?
                .label(label)
                .legend(move |(x, y)| Circle::new((x + 8, y), 4, colour.filled()));
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight)
    })
}

#[cfg(test)]
mod tests {
    use super::power_line;

    #[test]
    fn a_guide_keeps_its_slope_inside_the_box() {
        // Slope −½ through 1000 at τ = 1 s, τ 1…10⁴ s, the box 1…100: it enters through the top
        // at τ = 100 s and keeps its slope to the end.
        let [(t0, y0), (t1, y1)] = power_line(1000.0, -0.5, (1.0, 1e4), (1.0, 100.0)).unwrap();
        assert!(((y1 / y0).ln() / (t1 / t0).ln() + 0.5).abs() < 1e-12);
        assert!((t0 - 100.0).abs() < 1e-9 && (y0 - 100.0).abs() < 1e-9);
        assert_eq!(t1, 1e4);
        // A flat line outside the box is not drawn.
        assert!(power_line(500.0, 0.0, (1.0, 10.0), (1.0, 100.0)).is_none());
    }
}
