//! What a simulated run leaves behind: its files (`trace.csv`, `summary.json` and Figs.
//! 5–7, written by [`robot_files::output`] and [`robot_files::figures`], as the ground
//! station writes a recorded run's) and a short human summary.

use std::path::{Path as FsPath, PathBuf};

use anyhow::Result;
use robot_files::metrics::{SETTLE_HEADING_RAD, SETTLE_POSITION_M};
use robot_files::output::settle_text;
use robot_files::scenario::Scenario;

use crate::run::RunResult;

/// Writes `trace.csv`, `summary.json`, `fig5_path.svg`, `fig6_errors.svg` and
/// `fig7_inputs.svg` of `result`, a run of `scenario`, into `dir` (created if needed).
/// Returns the files written.
pub fn write_run(dir: &FsPath, scenario: &Scenario, result: &RunResult) -> Result<Vec<PathBuf>> {
    let mut written =
        robot_files::output::write_trace_and_summary(dir, &result.summary, &result.trace)?;
    written.extend(robot_files::figures::write_run_figures(
        dir,
        scenario,
        &result.summary,
        &result.trace,
    )?);
    Ok(written)
}

/// A few lines for a person: what ran, whether and when it settled, the final errors,
/// what the supervisor did.
pub fn human_summary(scenario: &Scenario, result: &RunResult) -> String {
    let s = &result.summary;
    let mut text = format!(
        "{} with the {} law: {:.1} s simulated in {:.3} s ({:.0}× real time, {} steps)\n",
        s.scenario,
        s.law,
        s.sim_time_s,
        s.wall_time_s,
        s.sim_time_s / s.wall_time_s.max(1e-9),
        s.steps
    );
    let e = s.headline_error();
    let which = if s.true_error.is_some() {
        "true"
    } else {
        "estimated"
    };
    text += &format!(
        "  settle time ({which} |e| < {:.0} mm and |θ_e| < {:.0}° to the end): {}\n",
        f64::from(SETTLE_POSITION_M) * 1e3,
        f64::from(SETTLE_HEADING_RAD).to_degrees(),
        settle_text(e.settle_time_s)
    );
    text += &format!(
        "  final error: {:.4} m, {:+.4} rad ({:+.2}°); last 10 s: RMS {:.4} m, max {:.4} m\n",
        e.final_position_error_m,
        e.final_heading_error_rad,
        e.final_heading_error_rad.to_degrees(),
        e.rms_position_error_m,
        e.max_position_error_m
    );
    let r = f64::from(
        scenario
            .robot
            .wheel_radius_left_m
            .min(scenario.robot.wheel_radius_right_m),
    );
    text += &format!(
        "  peaks: wheel {:.1} rad/s ({:.2} m/s rim, cap {:.2} m/s), duty {:.2}, current {:.2} A\n",
        s.max_wheel_speed_rad_s,
        s.max_wheel_speed_rad_s * r,
        scenario.robot.limits.max_rim_speed_m_s,
        s.max_duty,
        result.max_current_a
    );
    if let Some(t) = &s.true_error {
        let est = &s.estimated_error;
        let settle_differs = match (est.settle_time_s, t.settle_time_s) {
            (Some(a), Some(b)) => (a - b).abs() > 0.1,
            (None, None) => false,
            _ => true,
        };
        if est.samples == 0 {
            text += "  controller's own estimate: none (no steering update ran)\n";
        } else if settle_differs
            || (est.final_position_error_m - t.final_position_error_m).abs() > 0.005
        {
            text += &format!(
                "  controller's own estimate: settle {}, final error {:.4} m (odometry ≠ truth)\n",
                settle_text(est.settle_time_s),
                est.final_position_error_m
            );
        }
    }
    for f in &s.injected_faults {
        text += &format!(
            "  fault {} at {:.2} s: {}\n",
            f.fault,
            f.injected_s,
            match (f.detected, f.latency_s) {
                (true, Some(l)) =>
                    format!("stopped after {l:.3} s by {}", f.detected_by.join(", ")),
                _ => "not detected".to_string(),
            }
        );
    }
    let expected = f64::from(scenario.reference_speed_m_s) * s.sim_time_s;
    if result.distance_travelled_m < 0.5 * expected {
        text += &format!(
            "  note: the robot drove only {:.2} m of the reference's {:.2} m\n",
            result.distance_travelled_m, expected
        );
    }
    text += &format!("  supervisor: {}", s.supervisor.final_state);
    if !s.supervisor.faults.is_empty() {
        text += &format!(
            ", faults {} (motors stopped)",
            s.supervisor.faults.join(", ")
        );
    }
    text.push('\n');
    text
}
