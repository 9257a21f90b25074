//! Path figures: the reference path and the robots' true paths (world frame, m), with
//! room for the legend. x and y are at equal scale while that leaves the data at least a
//! third of each axis; a flatter or taller picture (a line with a small manoeuvre on it)
//! has each axis fitted to the data, and the stretched axis' title says by how much.

use std::ops::Range;

use controller_core::path::Path;
use plotters::prelude::*;

use super::chart::{Axis, AxisCoord, Canvas, LineStyle, GREY};
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

/// Pixels kept free above a path plot's data for a legend of `entries` lines.
pub(super) const fn legend_px(entries: usize) -> u32 {
    25 + 15 * entries as u32
}

/// The legend's lines on a path plot of `runs` runs, `links` drawn or not: the
/// reference path, each run, and the robot dots and reference crosses.
pub(super) const fn legend_entries(runs: usize, links: bool) -> usize {
    1 + runs + if links { 2 } else { 0 }
}

/// Canvas height (px) for a path plot `width` px wide showing `b` at equal scale, with
/// a legend of `entries` lines.
pub(super) fn path_canvas_height(b: (f64, f64, f64, f64), width: u32, entries: usize) -> u32 {
    let (dx, dy) = ((b.1 - b.0).max(0.1), (b.3 - b.2).max(0.1));
    let plot_w = f64::from(width - PATH_DECOR_PX.0);
    let plot_h = (plot_w * dy / dx).clamp(0.3 * plot_w, 1.2 * plot_w);
    plot_h as u32 + PATH_DECOR_PX.1 + legend_px(entries)
}

/// Most a path figure stretches one axis against the other before it gives up equal
/// scale: equal scale must leave each extent at least a third of its axis.
const MAX_EQUAL_SCALE_WASTE: f64 = 3.0;

/// The ranges a path plot shows `b` with on a drawing area of `pixels` (width, height),
/// `legend_px` free above the data, 10 % of margin on the extent that fills its axis;
/// and the y scale over the x scale (px per metre): 1 at equal scale.
fn path_ranges(
    b: (f64, f64, f64, f64),
    pixels: (u32, u32),
    legend_px: u32,
) -> (Range<f64>, Range<f64>, f64) {
    let plot_w = f64::from(pixels.0.saturating_sub(PATH_DECOR_PX.0).max(1));
    let plot_h = f64::from(pixels.1.saturating_sub(PATH_DECOR_PX.1).max(2));
    let data_h = (plot_h - f64::from(legend_px)).max(0.5 * plot_h);
    let (cx, cy) = (0.5 * (b.0 + b.1), 0.5 * (b.2 + b.3));
    // Metres per pixel each extent needs, with 10 % of margin.
    let x_scale = (b.1 - b.0).max(0.1) / plot_w * 1.1;
    let y_scale = (b.3 - b.2).max(0.1) / data_h * 1.1;
    let equal = x_scale.max(y_scale);
    let (x_scale, y_scale) = if equal <= MAX_EQUAL_SCALE_WASTE * x_scale.min(y_scale) {
        (equal, equal)
    } else {
        (x_scale, y_scale)
    };
    let hw = 0.5 * x_scale * plot_w;
    let bottom = cy - 0.5 * y_scale * data_h;
    (
        cx - hw..cx + hw,
        bottom..bottom + y_scale * plot_h,
        x_scale / y_scale,
    )
}

/// The title of an axis of `name` (m) drawn `stretch` times the other's scale (px per
/// metre), which it states when it is not 1.
fn axis_title(name: &str, stretch: f64) -> String {
    if stretch > 1.0 + 1e-9 {
        format!("{name} (m, scale ×{stretch:.1})")
    } else {
        format!("{name} (m)")
    }
}

/// Bounding box of the reference path and every robot path, m.
pub(super) fn path_bbox(path: &Path, runs: &[PathRun<'_>]) -> (f64, f64, f64, f64) {
    bbox(
        path_points(path).into_iter().chain(
            runs.iter()
                .flat_map(|(_, _, t)| t.iter().map(|r| (r.true_pose.x_m, r.true_pose.y_m))),
        ),
    )
}

/// One robot's path on a path figure: (legend label, line style, trace).
pub(super) type PathRun<'a> = (&'a str, LineStyle, &'a [TraceRow]);

/// Most robot-to-reference links drawn on a path figure.
const MAX_LINKS: usize = 60;

/// Draws the reference path and one robot path per `runs` entry on `area`; with `links`,
/// every run's robot and its reference point at the same instant, joined, every 2 s
/// (which is where a law that trails its reference shows it, even when its path lies on
/// the reference path).
pub(super) fn draw_paths(
    area: &Canvas<'_>,
    caption: &str,
    path: &Path,
    runs: &[PathRun<'_>],
    links: bool,
) -> Result<(), FigureError> {
    let reference = path_points(path);
    let legend = legend_px(legend_entries(runs.len(), links));
    let (xr, yr, y_over_x) = path_ranges(path_bbox(path, runs), area.dim_in_pixel(), legend);
    let (x_axis, y_axis) = (Axis::within(xr), Axis::within(yr));
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(AxisCoord::from(x_axis), AxisCoord::from(y_axis))?;
    chart
        .configure_mesh()
        .x_desc(axis_title("x", 1.0 / y_over_x))
        .y_desc(axis_title("y", y_over_x))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    let reference_style = LineStyle::dashed(GREY, 2);
    chart
        .draw_series(DashedLineSeries::new(reference, 6, 4, GREY.stroke_width(2)))?
        .label("reference path")
        .legend(move |at| reference_style.legend_sample(at));
    for (label, style, trace) in runs {
        let style = *style;
        let points = trace.iter().map(|r| (r.true_pose.x_m, r.true_pose.y_m));
        let anno = match style.dash {
            Some((dash, gap)) => {
                chart.draw_series(DashedLineSeries::new(points, dash, gap, style.stroke()))?
            }
            None => chart.draw_series(LineSeries::new(points, style.stroke()))?,
        };
        anno.label(*label).legend(move |at| style.legend_sample(at));
        if let Some(first) = trace.first() {
            chart.draw_series(std::iter::once(Circle::new(
                (first.true_pose.x_m, first.true_pose.y_m),
                5,
                style.colour.filled(),
            )))?;
        }
    }
    if links {
        draw_links(&mut chart, runs)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// A path plot's chart.
type PathChart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<AxisCoord, AxisCoord>>;

/// Every run's robot (a dot in its colour) and its reference point at the same instant (a
/// cross), joined, every 2 s, or at most [`MAX_LINKS`] of them over a long run (a 24 h
/// soak would draw 43 200); the legend names them once.
fn draw_links(chart: &mut PathChart<'_, '_>, runs: &[PathRun<'_>]) -> Result<(), FigureError> {
    let Some((_, first_style, first)) = runs.first() else {
        return Ok(());
    };
    let row_s = first
        .windows(2)
        .next()
        .map(|w| w[1].t_s - w[0].t_s)
        .filter(|dt| *dt > 0.0)
        .unwrap_or(1.0);
    let every = ((2.0 / row_s).round() as usize)
        .max(first.len().div_ceil(MAX_LINKS))
        .max(1);
    let interval_s = every as f64 * row_s;
    for (_, _, trace) in runs {
        chart.draw_series(trace.iter().step_by(every).map(|r| {
            PathElement::new(
                vec![
                    (r.true_pose.x_m, r.true_pose.y_m),
                    (f64::from(r.reference.x_m), f64::from(r.reference.y_m)),
                ],
                BLACK.stroke_width(1),
            )
        }))?;
    }
    // One legend entry for the dots: in the first run's colour for one run, grey (each
    // run's dots are in its own colour) for several.
    let (dots_label, dots_colour) = if runs.len() == 1 {
        (
            format!("robot every {interval_s:.0} s from t = 0"),
            first_style.colour,
        )
    } else {
        (
            format!("each robot every {interval_s:.0} s from t = 0"),
            GREY,
        )
    };
    for (i, (_, style, trace)) in runs.iter().enumerate() {
        let colour = style.colour;
        // Outlined, so a dot shows on its own run's line.
        chart.draw_series(
            trace
                .iter()
                .step_by(every)
                .map(|r| Circle::new((r.true_pose.x_m, r.true_pose.y_m), 4, BLACK.filled())),
        )?;
        let dots = chart.draw_series(
            trace
                .iter()
                .step_by(every)
                .map(|r| Circle::new((r.true_pose.x_m, r.true_pose.y_m), 3, colour.filled())),
        )?;
        if i == 0 {
            dots.label(dots_label.clone())
                .legend(move |(x, y)| Circle::new((x + 12, y), 3, dots_colour.filled()));
        }
    }
    // Each run's own reference point: the same for every run in time-indexed mode, the
    // run's closest point of the path in path-following mode.
    for (i, (_, _, trace)) in runs.iter().enumerate() {
        let crosses = chart.draw_series(trace.iter().step_by(every).map(|r| {
            Cross::new(
                (f64::from(r.reference.x_m), f64::from(r.reference.y_m)),
                4,
                BLACK.stroke_width(1),
            )
        }))?;
        if i == 0 {
            crosses
                .label("reference point at the same t")
                .legend(|(x, y)| Cross::new((x + 12, y), 4, BLACK.stroke_width(1)));
        }
    }
    Ok(())
}
