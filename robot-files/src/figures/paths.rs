//! Path figures: the reference path and the robots' true paths at equal scale on x and
//! y (world frame, m), with room for the legend.

use std::ops::Range;

use controller_core::path::Path;
use plotters::prelude::*;

use super::chart::{Canvas, GREY};
use super::FigureError;
use crate::trace::TraceRow;

/// Points of `path` every ~1 cm (at most 5000), world frame, m.
fn path_points(path: &Path) -> Vec<(f64, f64)> {
    let length = f64::from(path.length_m());
    let n = ((length / 0.01).ceil() as usize).clamp(2, 5000);
    (0..=n)
        .map(|i| {
            let p = path.sample((length * i as f64 / n as f64) as f32).point;
            (f64::from(p.x_m), f64::from(p.y_m))
        })
        .collect()
}

/// Bounding box (x0, x1, y0, y1) of the finite `points`, m; a 2 m box at the origin if
/// there are none.
fn bbox(points: impl Iterator<Item = (f64, f64)>) -> (f64, f64, f64, f64) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in points.filter(|(x, y)| x.is_finite() && y.is_finite()) {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        (-1.0, 1.0, -1.0, 1.0)
    } else {
        (x0, x1, y0, y1)
    }
}

/// Pixels the chart decorations take from a path plot: (horizontal, vertical).
const PATH_DECOR_PX: (u32, u32) = (55 + 2 * 12, 40 + 2 * 12 + 30);

/// Pixels kept free above a path plot's data for the legend.
const LEGEND_PX: u32 = 95;

/// Canvas height (px) for a path plot `width` px wide showing `b` at equal scale.
pub(super) fn path_canvas_height(b: (f64, f64, f64, f64), width: u32) -> u32 {
    let (dx, dy) = ((b.1 - b.0).max(0.1), (b.3 - b.2).max(0.1));
    let plot_w = f64::from(width - PATH_DECOR_PX.0);
    let plot_h = (plot_w * dy / dx).clamp(0.3 * plot_w, 1.2 * plot_w);
    plot_h as u32 + PATH_DECOR_PX.1 + LEGEND_PX
}

/// Ranges around `b` at equal scale on a drawing area of `pixels` (width, height), with
/// [`LEGEND_PX`] free above the data for the legend.
fn equal_scale_ranges(b: (f64, f64, f64, f64), pixels: (u32, u32)) -> (Range<f64>, Range<f64>) {
    let plot_w = f64::from(pixels.0.saturating_sub(PATH_DECOR_PX.0).max(1));
    let plot_h = f64::from(pixels.1.saturating_sub(PATH_DECOR_PX.1).max(2));
    let data_h = (plot_h - f64::from(LEGEND_PX)).max(0.5 * plot_h);
    let (cx, cy) = (0.5 * (b.0 + b.1), 0.5 * (b.2 + b.3));
    // Metres per pixel: enough for both extents, plus 10 % of margin.
    let scale = ((b.1 - b.0).max(0.1) / plot_w).max((b.3 - b.2).max(0.1) / data_h) * 1.1;
    let hw = 0.5 * scale * plot_w;
    let bottom = cy - 0.5 * scale * data_h;
    (cx - hw..cx + hw, bottom..bottom + scale * plot_h)
}

/// Bounding box of the reference path and every robot path, m.
pub(super) fn path_bbox(
    path: &Path,
    runs: &[(&str, RGBColor, &[TraceRow])],
) -> (f64, f64, f64, f64) {
    bbox(
        path_points(path).into_iter().chain(
            runs.iter()
                .flat_map(|(_, _, t)| t.iter().map(|r| (r.true_pose.x_m, r.true_pose.y_m))),
        ),
    )
}

/// Most robot-to-reference links drawn on a path figure.
const MAX_LINKS: usize = 60;

/// Draws the reference path and one robot path per `(label, colour, trace)` on `area`.
pub(super) fn draw_paths(
    area: &Canvas<'_>,
    caption: &str,
    path: &Path,
    runs: &[(&str, RGBColor, &[TraceRow])],
    links: bool,
) -> Result<(), FigureError> {
    let reference = path_points(path);
    let (xr, yr) = equal_scale_ranges(path_bbox(path, runs), area.dim_in_pixel());
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(xr, yr)?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    chart
        .draw_series(DashedLineSeries::new(reference, 6, 4, GREY.stroke_width(2)))?
        .label("reference path")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GREY.stroke_width(2)));
    for (label, colour, trace) in runs {
        let colour = *colour;
        chart
            .draw_series(LineSeries::new(
                trace.iter().map(|r| (r.true_pose.x_m, r.true_pose.y_m)),
                colour.stroke_width(2),
            ))?
            .label(*label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        if let Some(first) = trace.first() {
            chart.draw_series(std::iter::once(Circle::new(
                (first.true_pose.x_m, first.true_pose.y_m),
                5,
                colour.filled(),
            )))?;
        }
    }
    if links {
        // Robot and reference point at the same instant, every 2 s, or at most
        // MAX_LINKS of them over a long run (a 24 h soak would draw 43 200).
        if let Some((_, colour, trace)) = runs.first() {
            let row_s = trace
                .windows(2)
                .next()
                .map(|w| w[1].t_s - w[0].t_s)
                .filter(|dt| *dt > 0.0)
                .unwrap_or(1.0);
            let every = ((2.0 / row_s).round() as usize)
                .max(trace.len().div_ceil(MAX_LINKS))
                .max(1);
            let interval_s = every as f64 * row_s;
            let colour = *colour;
            chart.draw_series(trace.iter().step_by(every).map(|r| {
                PathElement::new(
                    vec![
                        (r.true_pose.x_m, r.true_pose.y_m),
                        (f64::from(r.reference.x_m), f64::from(r.reference.y_m)),
                    ],
                    BLACK.stroke_width(1),
                )
            }))?;
            chart
                .draw_series(
                    trace.iter().step_by(every).map(|r| {
                        Circle::new((r.true_pose.x_m, r.true_pose.y_m), 3, colour.filled())
                    }),
                )?
                .label(format!("robot every {interval_s:.0} s from t = 0"))
                .legend(move |(x, y)| Circle::new((x + 10, y), 3, colour.filled()));
            chart
                .draw_series(trace.iter().step_by(every).map(|r| {
                    Cross::new(
                        (f64::from(r.reference.x_m), f64::from(r.reference.y_m)),
                        4,
                        BLACK.stroke_width(1),
                    )
                }))?
                .label("reference point at the same t")
                .legend(|(x, y)| Cross::new((x + 10, y), 4, BLACK.stroke_width(1)));
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}
