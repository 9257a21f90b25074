//! SVG figures of a run in the style of the paper's Figs. 5–7, and the comparison of
//! several laws' runs, drawn from [`TraceRow`]s (world frame, m and rad; time in s from
//! the start of the trace):
//!
//! - [`fig5_path`]: the robot's true path against the reference path, with the robot and
//!   its reference point joined every 2 s (the paper's law shows its lag there);
//! - [`fig6_errors`]: x_e, y_e, θ_e of eq. (9) against time, for the true pose;
//! - [`fig7_inputs`]: v and ω (commanded and true), wheel speeds (set-point and true) and
//!   duties against time;
//! - [`compare`]: every law's path over the reference, and their position errors;
//! - [`write_run_figures`]: Figs. 5–7 of one run into a directory.
//!
//! [`chart`] has the pieces they are drawn with, for other figures of the same look.

pub mod chart;
mod paths;

use std::path::{Path as FsPath, PathBuf};

use controller_core::path::Path;
use plotters::drawing::DrawingAreaErrorKind;

use crate::metrics::Summary;
use crate::scenario::Scenario;
use crate::trace::TraceRow;
use chart::{
    darker, draw_panel, present, run_style, svg_canvas, LineStyle, Series, BLUE, GREEN, ORANGE, RED,
};
use paths::{draw_paths, legend_entries, path_bbox, path_canvas_height};

/// Why a figure could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum FigureError {
    /// Plotters could not draw it.
    #[error("drawing a figure: {0}")]
    Draw(#[from] DrawingAreaErrorKind<std::io::Error>),
    /// The SVG file could not be written.
    #[error("writing {}: {source}", file.display())]
    Write {
        /// The figure's file.
        file: PathBuf,
        /// What went wrong.
        source: DrawingAreaErrorKind<std::io::Error>,
    },
}

/// Writes Figs. 5–7 of a run of `scenario` whose `summary` and `trace` they show into
/// `dir` (which must exist) as `fig5_path.svg`, `fig6_errors.svg` and `fig7_inputs.svg`,
/// titled with the scenario's name and the law, the settle time of the summary's headline
/// errors marked. Returns the files written.
pub fn write_run_figures(
    dir: &FsPath,
    scenario: &Scenario,
    summary: &Summary,
    trace: &[TraceRow],
) -> Result<Vec<PathBuf>, FigureError> {
    let title = format!("{}, {} law", scenario.name, summary.law);
    let settle = summary.headline_error().settle_time_s;
    let fig5 = dir.join("fig5_path.svg");
    fig5_path(&fig5, &title, &scenario.path, trace)?;
    let fig6 = dir.join("fig6_errors.svg");
    fig6_errors(&fig6, &title, trace, settle)?;
    let fig7 = dir.join("fig7_inputs.svg");
    fig7_inputs(&fig7, &title, trace, settle)?;
    Ok(vec![fig5, fig6, fig7])
}

/// Fig. 5: the true path of the robot against the reference path. `title` names the run.
pub fn fig5_path(
    file: &FsPath,
    title: &str,
    path: &Path,
    trace: &[TraceRow],
) -> Result<(), FigureError> {
    let robot = [("robot (true)", LineStyle::solid(BLUE, 2), trace)];
    let height = path_canvas_height(path_bbox(path, &robot), 760, legend_entries(1, true));
    let root = svg_canvas(file, (760, height))?;
    draw_paths(
        &root,
        &format!("Fig. 5 — path, {title}"),
        path,
        &robot,
        true,
    )?;
    present(&root, file)
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
) -> Result<(), FigureError> {
    let root = svg_canvas(file, (900, 800))?;
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
        &[("x_e (along track)", LineStyle::solid(BLUE, 2), col(0))],
        marker,
    )?;
    draw_panel(
        &panels[1],
        "",
        "y_e (m)",
        &t,
        &[("y_e (cross track)", LineStyle::solid(GREEN, 2), col(1))],
        unlabelled,
    )?;
    draw_panel(
        &panels[2],
        "",
        "θ_e (rad)",
        &t,
        &[("θ_e = θ_r − θ", LineStyle::solid(RED, 2), col(2))],
        unlabelled,
    )?;
    present(&root, file)
}

/// Fig. 7: v (m/s), ω (rad/s), wheel speeds (rad/s) and duties against time, with the
/// settle time `settle_s` (s) marked.
pub fn fig7_inputs(
    file: &FsPath,
    title: &str,
    trace: &[TraceRow],
    settle_s: Option<f64>,
) -> Result<(), FigureError> {
    let root = svg_canvas(file, (900, 1000))?;
    let panels = root.split_evenly((4, 1));
    let (trace, note) = time_window(trace, settle_s);
    let marker = settle_marker(settle_s);
    let marker = marker.as_ref().map(|(t, l)| (*t, l.as_str()));
    let unlabelled = marker.map(|(t, _)| (t, ""));
    let t: Vec<f64> = trace.iter().map(|r| r.t_s).collect();
    let get = |f: &dyn Fn(&TraceRow) -> f64| trace.iter().map(f).collect::<Vec<_>>();
    // The truth solid in the series' colour, the command dashed in its darker shade and
    // drawn over it, so both show where they coincide.
    let truth = |colour| LineStyle::solid(colour, 2);
    let command = |colour| LineStyle::dashed(darker(colour), 2);
    draw_panel(
        &panels[0],
        &format!("Fig. 7 — inputs, {title}{note}"),
        "v (m/s)",
        &t,
        &[
            ("v true", truth(BLUE), get(&|r| r.true_velocity.0)),
            (
                "v commanded",
                command(BLUE),
                get(&|r| f64::from(r.command.v_m_s)),
            ),
        ],
        marker,
    )?;
    draw_panel(
        &panels[1],
        "",
        "ω (rad/s)",
        &t,
        &[
            ("ω true", truth(RED), get(&|r| r.true_velocity.1)),
            (
                "ω commanded",
                command(RED),
                get(&|r| f64::from(r.command.omega_rad_s)),
            ),
        ],
        unlabelled,
    )?;
    draw_panel(
        &panels[2],
        "",
        "ω_wheel (rad/s)",
        &t,
        &[
            ("left true", truth(GREEN), get(&|r| r.true_wheel[0])),
            ("right true", truth(ORANGE), get(&|r| r.true_wheel[1])),
            (
                "left set-point",
                command(GREEN),
                get(&|r| f64::from(r.setpoint.left_rad_s)),
            ),
            (
                "right set-point",
                command(ORANGE),
                get(&|r| f64::from(r.setpoint.right_rad_s)),
            ),
        ],
        unlabelled,
    )?;
    draw_panel(
        &panels[3],
        "",
        "duty (−1…1)",
        &t,
        &[
            ("left", truth(GREEN), get(&|r| f64::from(r.duty.left))),
            ("right", truth(ORANGE), get(&|r| f64::from(r.duty.right))),
        ],
        unlabelled,
    )?;
    present(&root, file)
}

/// The comparison: every law's true path over the reference (top), with each robot and
/// its reference point joined every 2 s (the paper's law trails its reference along the
/// path, where its line alone would lie on the others'), and each law's position error
/// against time (bottom). `runs` = (law name, trace); the `i`-th is drawn in
/// [`chart::run_style`]`(i)`, each narrower than the one before and over it.
pub fn compare(
    file: &FsPath,
    title: &str,
    path: &Path,
    runs: &[(&str, &[TraceRow])],
) -> Result<(), FigureError> {
    let styled: Vec<(&str, LineStyle, &[TraceRow])> = runs
        .iter()
        .enumerate()
        .map(|(i, (name, trace))| (*name, run_style(i), *trace))
        .collect();
    let entries = legend_entries(styled.len(), true);
    let top_height = path_canvas_height(path_bbox(path, &styled), 800, entries);
    let root = svg_canvas(file, (800, top_height + 370))?;
    let (top, bottom) = root.split_vertically(top_height);
    draw_paths(
        &top,
        &format!("{title}: every law on the same plant"),
        path,
        &styled,
        true,
    )?;
    let t: Vec<f64> = runs
        .first()
        .map(|(_, trace)| trace.iter().map(|r| r.t_s).collect())
        .unwrap_or_default();
    let series: Vec<Series<'_>> = styled
        .iter()
        .map(|(name, style, trace)| {
            (
                *name,
                *style,
                trace.iter().map(|r| r.true_error.0).collect(),
            )
        })
        .collect();
    draw_panel(&bottom, "", "position error (m)", &t, &series, None)?;
    present(&root, file)
}
