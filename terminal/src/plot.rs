//! Figures as SVG text (plotters' SVG backend: no fonts needed at build time, the browser renders
//! the text): the canvas, axes, colours and sizes every figure of both programs shares, so that a
//! trainer report and a bench figure look alike.

use std::error::Error;

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
