//! SVG figures of the wheel-speed loop's step response, in the look of the run figures
//! ([`robot_files::figures`], which draws Figs. 5–7 and the comparison):
//!
//! - [`step_response`]: one step, true and estimated speed against the set-point, and the
//!   duty;
//! - [`step_comparison`]: several steps on one figure.

use std::path::Path as FsPath;

use anyhow::Result;
use robot_files::figures::chart::{
    draw_panel, present, run_style, svg_canvas, LineStyle, Series, BLUE, GREEN, GREY, ORANGE,
};

use crate::run::StepResponse;

/// The wheel-speed step response: true and estimated speed against the set-point (top)
/// and the duty (bottom).
pub fn step_response(file: &FsPath, title: &str, response: &StepResponse) -> Result<()> {
    let root = svg_canvas(file, (900, 600))?;
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
                "true",
                LineStyle::solid(BLUE, 2),
                s.iter().map(|x| x.1).collect(),
            ),
            (
                "estimated (encoder window)",
                LineStyle::solid(ORANGE, 1),
                s.iter().map(|x| x.2).collect(),
            ),
            (
                "set-point",
                LineStyle::dashed(GREY, 1),
                vec![response.setpoint_rad_s; s.len()],
            ),
        ],
        None,
    )?;
    draw_panel(
        &panels[1],
        "",
        "duty (−1…1)",
        &t,
        &[(
            "left duty",
            LineStyle::solid(GREEN, 2),
            s.iter().map(|x| x.3).collect(),
        )],
        None,
    )?;
    present(&root, file)?;
    Ok(())
}

/// Several wheel-speed step responses on one figure: each run's true left wheel speed
/// against the set-point (top) and its duty (bottom). `runs` = (label, response); the
/// time axis is the first run's.
pub fn step_comparison(file: &FsPath, title: &str, runs: &[(&str, &StepResponse)]) -> Result<()> {
    let root = svg_canvas(file, (900, 600))?;
    let panels = root.split_evenly((2, 1));
    let Some((_, first)) = runs.first() else {
        anyhow::bail!("no step response to plot");
    };
    let n = runs.iter().map(|(_, r)| r.samples.len()).min().unwrap_or(0);
    let t: Vec<f64> = first.samples.iter().take(n).map(|x| x.0).collect();
    let mut speeds: Vec<Series<'_>> = Vec::new();
    let mut duties: Vec<Series<'_>> = Vec::new();
    for (i, (label, r)) in runs.iter().enumerate() {
        speeds.push((
            label,
            run_style(i),
            r.samples.iter().take(n).map(|x| x.1).collect(),
        ));
        duties.push((
            label,
            run_style(i),
            r.samples.iter().take(n).map(|x| x.3).collect(),
        ));
    }
    speeds.push((
        "set-point",
        LineStyle::dashed(GREY, 1),
        vec![first.setpoint_rad_s; n],
    ));
    draw_panel(
        &panels[0],
        &format!("wheel-speed step, {title}"),
        "true ω_wheel (rad/s)",
        &t,
        &speeds,
        None,
    )?;
    draw_panel(&panels[1], "", "left duty (−1…1)", &t, &duties, None)?;
    present(&root, file)?;
    Ok(())
}
