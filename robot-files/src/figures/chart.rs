//! The drawing pieces every figure is made of: a white SVG canvas, time panels with a
//! legend, the colours. Plotters' SVG backend writes text as SVG `<text>` and needs no
//! font files.

use std::ops::Range;
use std::path::Path as FsPath;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::FigureError;

/// A drawing area of an SVG figure.
pub type Canvas<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// Blue (the robot in Figs. 5–7; x_e, v).
pub const BLUE: RGBColor = RGBColor(31, 119, 180);
/// Orange (the right wheel).
pub const ORANGE: RGBColor = RGBColor(255, 127, 14);
/// Green (the left wheel; y_e).
pub const GREEN: RGBColor = RGBColor(44, 160, 44);
/// Red (θ_e, ω).
pub const RED: RGBColor = RGBColor(214, 39, 40);
/// Grey (the reference, set-points).
pub const GREY: RGBColor = RGBColor(120, 120, 120);
/// Colours of successive series (laws in a comparison, runs in a step comparison).
pub const PALETTE: [RGBColor; 4] = [RED, BLUE, GREEN, ORANGE];

/// A white SVG canvas of `size` (width, height) px that will be written to `file` by
/// [`present`].
pub fn svg_canvas(file: &FsPath, size: (u32, u32)) -> Result<Canvas<'_>, FigureError> {
    let root = SVGBackend::new(file, size).into_drawing_area();
    root.fill(&WHITE)?;
    Ok(root)
}

/// Writes `root`, made by [`svg_canvas`] for `file`, to its file.
pub fn present(root: &Canvas<'_>, file: &FsPath) -> Result<(), FigureError> {
    root.present().map_err(|source| FigureError::Write {
        file: file.to_path_buf(),
        source,
    })
}

/// A range around `values` with 5 % margin (never empty).
fn range_of(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return -1.0..1.0;
    }
    let span = (hi - lo).max(1e-3);
    lo - 0.05 * span..hi + 0.05 * span
}

/// One series of a time panel: (label, colour, dashed, one value per time sample, in the
/// panel's unit).
pub type Series<'a> = (&'a str, RGBColor, bool, Vec<f64>);

/// Draws one time panel on `area`: `series` against `t` (s), the y axis titled `y_desc`
/// (with its unit), a vertical dashed `marker` at (t s, legend label; an empty label
/// draws no legend entry), and the legend where the data are not.
pub fn draw_panel(
    area: &Canvas<'_>,
    caption: &str,
    y_desc: &str,
    t: &[f64],
    series: &[Series<'_>],
    marker: Option<(f64, &str)>,
) -> Result<(), FigureError> {
    let t_range = range_of(t.iter().copied());
    let t_range = t.first().copied().unwrap_or(0.0)..t_range.end;
    let y_range = range_of(series.iter().flat_map(|s| s.3.iter().copied()));
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(32)
        .y_label_area_size(60)
        .build_cartesian_2d(t_range, y_range)?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .y_desc(y_desc)
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (label, colour, dashed, values) in series {
        let colour = *colour;
        let points: Vec<(f64, f64)> = t.iter().copied().zip(values.iter().copied()).collect();
        let anno = if *dashed {
            chart.draw_series(DashedLineSeries::new(points, 5, 3, colour.stroke_width(1)))?
        } else {
            chart.draw_series(LineSeries::new(points, colour.stroke_width(2)))?
        };
        let width = if *dashed { 1 } else { 2 };
        anno.label(*label).legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(width))
        });
    }
    if let Some((at, label)) = marker {
        let y = chart.y_range();
        let line = chart.draw_series(DashedLineSeries::new(
            vec![(at, y.start), (at, y.end)],
            4,
            4,
            BLACK.stroke_width(1),
        ))?;
        if !label.is_empty() {
            line.label(label).legend(|(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(1))
            });
        }
    }
    // Legend where the data are not: data late in the run high up → legend low.
    let late = t.len() * 13 / 20;
    let (mut sum, mut n) = (0.0, 0usize);
    for (_, _, _, values) in series {
        for v in values.iter().skip(late).filter(|v| v.is_finite()) {
            sum += v;
            n += 1;
        }
    }
    let y = chart.y_range();
    let high = n > 0 && sum / n as f64 > 0.5 * (y.start + y.end);
    chart
        .configure_series_labels()
        .position(if high {
            SeriesLabelPosition::LowerRight
        } else {
            SeriesLabelPosition::UpperRight
        })
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}
