//! SVG figures in the style of the paper's Figs. 5–7, and the comparison overlay.
//!
//! - [`fig5_path`]: the robot's true path against the reference path, with the robot and
//!   its reference point joined every 2 s (the paper's law shows its lag there);
//! - [`fig6_errors`]: x_e, y_e, θ_e of eq. (9) against time, for the true pose;
//! - [`fig7_inputs`]: v and ω (commanded and true), wheel speeds (set-point and true) and
//!   duties against time;
//! - [`compare`]: every law's path over the reference, and their position errors.
//!
//! Plotters' SVG backend writes text as SVG `<text>` and needs no font files.

use std::path::Path as FsPath;

use anyhow::{Context, Result};
use controller_core::path::Path;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::run::TraceRow;

const BLUE: RGBColor = RGBColor(31, 119, 180);
const ORANGE: RGBColor = RGBColor(255, 127, 14);
const GREEN: RGBColor = RGBColor(44, 160, 44);
const RED: RGBColor = RGBColor(214, 39, 40);
const GREY: RGBColor = RGBColor(120, 120, 120);
/// Colours of successive series (laws in [`compare`]).
const PALETTE: [RGBColor; 4] = [RED, BLUE, GREEN, ORANGE];

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
fn path_canvas_height(b: (f64, f64, f64, f64), width: u32) -> u32 {
    let (dx, dy) = ((b.1 - b.0).max(0.1), (b.3 - b.2).max(0.1));
    let plot_w = f64::from(width - PATH_DECOR_PX.0);
    let plot_h = (plot_w * dy / dx).clamp(0.3 * plot_w, 1.2 * plot_w);
    plot_h as u32 + PATH_DECOR_PX.1 + LEGEND_PX
}

/// Ranges around `b` at equal scale on a drawing area of `pixels` (width, height), with
/// [`LEGEND_PX`] free above the data for the legend.
fn equal_scale_ranges(
    b: (f64, f64, f64, f64),
    pixels: (u32, u32),
) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
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

/// A range around `values` with 5 % margin (never empty).
fn range_of(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
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

fn svg_root(file: &FsPath, size: (u32, u32)) -> Result<DrawingArea<SVGBackend<'_>, Shift>> {
    let root = SVGBackend::new(file, size).into_drawing_area();
    root.fill(&WHITE)?;
    Ok(root)
}

/// Bounding box of the reference path and every robot path, m.
fn path_bbox(path: &Path, runs: &[(&str, RGBColor, &[TraceRow])]) -> (f64, f64, f64, f64) {
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
fn draw_paths(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    caption: &str,
    path: &Path,
    runs: &[(&str, RGBColor, &[TraceRow])],
    links: bool,
) -> Result<()> {
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

/// Fig. 5: the true path of the robot against the reference path. `title` names the run.
pub fn fig5_path(file: &FsPath, title: &str, path: &Path, trace: &[TraceRow]) -> Result<()> {
    let b = path_bbox(path, &[("", BLUE, trace)]);
    let root = svg_root(file, (760, path_canvas_height(b, 760)))?;
    draw_paths(
        &root,
        &format!("Fig. 5 — path, {title}"),
        path,
        &[("robot (true)", BLUE, trace)],
        true,
    )?;
    root.present()
        .with_context(|| format!("writing {}", file.display()))?;
    Ok(())
}

/// One time-series panel: `series` = (label, colour, dashed, values per row).
type Series<'a> = (&'a str, RGBColor, bool, Vec<f64>);

fn draw_panel(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    caption: &str,
    y_desc: &str,
    t: &[f64],
    series: &[Series<'_>],
    marker: Option<(f64, &str)>,
) -> Result<()> {
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

/// The part of `trace` the time plots show: the first max(10 s, 3 × settle time) when the
/// run settled (the transient is what the paper's figures are about), else everything;
/// and the caption's note about it.
fn time_window(trace: &[TraceRow], settle_s: Option<f64>) -> (&[TraceRow], String) {
    let end = trace.last().map_or(0.0, |r| r.t_s);
    match settle_s {
        Some(t) if (3.0 * t).max(10.0) < end => {
            let until = (3.0 * t).max(10.0);
            let n = trace.partition_point(|r| r.t_s <= until);
            (&trace[..n], format!(" (first {until:.0} s of {end:.0} s)"))
        }
        _ => (trace, String::new()),
    }
}

/// The settle-time marker of the time plots.
fn settle_marker(settle_s: Option<f64>) -> Option<(f64, String)> {
    settle_s.map(|t| (t, format!("settled (1 cm, 1°) at {t:.2} s")))
}

/// Fig. 6: x_e, y_e (m, robot frame) and θ_e (rad) of the true pose against time, with
/// the settle time `settle_s` (s) marked.
pub fn fig6_errors(
    file: &FsPath,
    title: &str,
    trace: &[TraceRow],
    settle_s: Option<f64>,
) -> Result<()> {
    let root = svg_root(file, (900, 800))?;
    let panels = root.split_evenly((3, 1));
    let (trace, note) = time_window(trace, settle_s);
    let marker = settle_marker(settle_s);
    let marker = marker.as_ref().map(|(t, l)| (*t, l.as_str()));
    let unlabelled = marker.map(|(t, _)| (t, ""));
    let t: Vec<f64> = trace.iter().map(|r| r.t_s).collect();
    let col = |i: usize| trace.iter().map(|r| r.true_tracking[i]).collect::<Vec<_>>();
    draw_panel(
        &panels[0],
        &format!("Fig. 6 — tracking error (9) of the true pose, {title}{note}"),
        "x_e (m)",
        &t,
        &[("x_e (along track)", BLUE, false, col(0))],
        marker,
    )?;
    draw_panel(
        &panels[1],
        "",
        "y_e (m)",
        &t,
        &[("y_e (cross track)", GREEN, false, col(1))],
        unlabelled,
    )?;
    draw_panel(
        &panels[2],
        "",
        "θ_e (rad)",
        &t,
        &[("θ_e = θ_r − θ", RED, false, col(2))],
        unlabelled,
    )?;
    root.present()
        .with_context(|| format!("writing {}", file.display()))?;
    Ok(())
}

/// Fig. 7: v (m/s), ω (rad/s), wheel speeds (rad/s) and duties against time, with the
/// settle time `settle_s` (s) marked.
pub fn fig7_inputs(
    file: &FsPath,
    title: &str,
    trace: &[TraceRow],
    settle_s: Option<f64>,
) -> Result<()> {
    let root = svg_root(file, (900, 1000))?;
    let panels = root.split_evenly((4, 1));
    let (trace, note) = time_window(trace, settle_s);
    let marker = settle_marker(settle_s);
    let marker = marker.as_ref().map(|(t, l)| (*t, l.as_str()));
    let unlabelled = marker.map(|(t, _)| (t, ""));
    let t: Vec<f64> = trace.iter().map(|r| r.t_s).collect();
    let get = |f: &dyn Fn(&TraceRow) -> f64| trace.iter().map(f).collect::<Vec<_>>();
    draw_panel(
        &panels[0],
        &format!("Fig. 7 — inputs, {title}{note}"),
        "v (m/s)",
        &t,
        &[
            (
                "v commanded",
                BLUE,
                true,
                get(&|r| f64::from(r.command.v_m_s)),
            ),
            ("v true", BLUE, false, get(&|r| r.true_velocity.0)),
        ],
        marker,
    )?;
    draw_panel(
        &panels[1],
        "",
        "ω (rad/s)",
        &t,
        &[
            (
                "ω commanded",
                RED,
                true,
                get(&|r| f64::from(r.command.omega_rad_s)),
            ),
            ("ω true", RED, false, get(&|r| r.true_velocity.1)),
        ],
        unlabelled,
    )?;
    draw_panel(
        &panels[2],
        "",
        "ω_wheel (rad/s)",
        &t,
        &[
            (
                "left set-point",
                GREEN,
                true,
                get(&|r| f64::from(r.setpoint.left_rad_s)),
            ),
            ("left true", GREEN, false, get(&|r| r.true_wheel[0])),
            (
                "right set-point",
                ORANGE,
                true,
                get(&|r| f64::from(r.setpoint.right_rad_s)),
            ),
            ("right true", ORANGE, false, get(&|r| r.true_wheel[1])),
        ],
        unlabelled,
    )?;
    draw_panel(
        &panels[3],
        "",
        "duty (−1…1)",
        &t,
        &[
            ("left", GREEN, false, get(&|r| f64::from(r.duty.left))),
            ("right", ORANGE, false, get(&|r| f64::from(r.duty.right))),
        ],
        unlabelled,
    )?;
    root.present()
        .with_context(|| format!("writing {}", file.display()))?;
    Ok(())
}

/// The comparison: every law's true path over the reference (top) and its position
/// error against time (bottom). `runs` = (law name, trace).
pub fn compare(
    file: &FsPath,
    title: &str,
    path: &Path,
    runs: &[(&str, &[TraceRow])],
) -> Result<()> {
    let coloured: Vec<(&str, RGBColor, &[TraceRow])> = runs
        .iter()
        .zip(PALETTE.iter().cycle())
        .map(|((name, trace), colour)| (*name, *colour, *trace))
        .collect();
    let top_height = path_canvas_height(path_bbox(path, &coloured), 800);
    let root = svg_root(file, (800, top_height + 370))?;
    let (top, bottom) = root.split_vertically(top_height);
    draw_paths(
        &top,
        &format!("{title}: every law on the same plant"),
        path,
        &coloured,
        false,
    )?;
    let t: Vec<f64> = runs
        .first()
        .map(|(_, trace)| trace.iter().map(|r| r.t_s).collect())
        .unwrap_or_default();
    let series: Vec<Series<'_>> = coloured
        .iter()
        .map(|(name, colour, trace)| {
            (
                *name,
                *colour,
                false,
                trace.iter().map(|r| r.true_error.0).collect(),
            )
        })
        .collect();
    draw_panel(&bottom, "", "position error (m)", &t, &series, None)?;
    root.present()
        .with_context(|| format!("writing {}", file.display()))?;
    Ok(())
}

/// The wheel-speed step response: true and estimated speed against the set-point (top)
/// and the duty (bottom).
pub fn step_response(
    file: &FsPath,
    title: &str,
    response: &crate::run::StepResponse,
) -> Result<()> {
    let root = svg_root(file, (900, 600))?;
    let panels = root.split_evenly((2, 1));
    let s = &response.samples;
    let t: Vec<f64> = s.iter().map(|x| x.0).collect();
    draw_panel(
        &panels[0],
        &format!("wheel-speed step, {title}"),
        "ω_wheel (rad/s)",
        &t,
        &[
            (
                "set-point",
                GREY,
                true,
                vec![response.setpoint_rad_s; s.len()],
            ),
            ("true", BLUE, false, s.iter().map(|x| x.1).collect()),
            (
                "estimated (encoder window)",
                ORANGE,
                false,
                s.iter().map(|x| x.2).collect(),
            ),
        ],
        None,
    )?;
    draw_panel(
        &panels[1],
        "",
        "duty (−1…1)",
        &t,
        &[("left duty", GREEN, false, s.iter().map(|x| x.3).collect())],
        None,
    )?;
    root.present()
        .with_context(|| format!("writing {}", file.display()))?;
    Ok(())
}

/// Several wheel-speed step responses on one figure: each run's true left wheel speed
/// against the set-point (top) and its duty (bottom). `runs` = (label, response); the
/// time axis is the first run's.
pub fn step_comparison(
    file: &FsPath,
    title: &str,
    runs: &[(&str, &crate::run::StepResponse)],
) -> Result<()> {
    let root = svg_root(file, (900, 600))?;
    let panels = root.split_evenly((2, 1));
    let Some((_, first)) = runs.first() else {
        anyhow::bail!("no step response to plot");
    };
    let n = runs.iter().map(|(_, r)| r.samples.len()).min().unwrap_or(0);
    let t: Vec<f64> = first.samples.iter().take(n).map(|x| x.0).collect();
    let mut speeds: Vec<Series<'_>> =
        vec![("set-point", GREY, true, vec![first.setpoint_rad_s; n])];
    let mut duties: Vec<Series<'_>> = Vec::new();
    for ((label, r), colour) in runs.iter().zip(PALETTE.iter().cycle()) {
        speeds.push((
            label,
            *colour,
            false,
            r.samples.iter().take(n).map(|x| x.1).collect(),
        ));
        duties.push((
            label,
            *colour,
            false,
            r.samples.iter().take(n).map(|x| x.3).collect(),
        ));
    }
    draw_panel(
        &panels[0],
        &format!("wheel-speed step, {title}"),
        "true ω_wheel (rad/s)",
        &t,
        &speeds,
        None,
    )?;
    draw_panel(&panels[1], "", "left duty (−1…1)", &t, &duties, None)?;
    root.present()
        .with_context(|| format!("writing {}", file.display()))?;
    Ok(())
}
