//! The figures of the noise analysis (an Allan deviation, one gyro's or a unit's), on the canvas
//! both programs share ([`fog_terminal::plot`]); the report's own figures are in
//! `report::plots`. Each function draws one figure from plain series, so the figures can be
//! checked without a fit.

use firmware_core::Quantity;
use firmware_core::units::DPH_PER_DPS;
use plotters::prelude::*;

pub use fog_terminal::plot::{
    BLUE, BROWN, CHANNEL_COLOURS, Chart, Draw, DrawResult, FONT, GREEN, GREY, LABEL, ORANGE,
    PURPLE, PlotError, RED, TICK, TITLE, axes, legend, span, svg,
};

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
    pub curve: &'a fog_data::allan::Curve,
    /// The terms read from it, drawn as the slope lines they come from.
    pub terms: fog_data::allan::Terms,
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
                .map(|b| (b * fog_data::allan::FLICKER_FLOOR * from_dph, 0.0)),
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
