//! Files and text a run leaves behind: `trace.csv`, `summary.json`, the figures, and a
//! short human summary.

use std::fs;
use std::path::{Path as FsPath, PathBuf};

use anyhow::{Context, Result};

use crate::metrics::{SETTLE_HEADING_RAD, SETTLE_POSITION_M};
use crate::plot;
use crate::run::{RunResult, TraceRow};
use crate::scenario::Scenario;

/// The trace as CSV text: a header (units in the column names) and one line per row.
pub fn trace_csv(trace: &[TraceRow]) -> String {
    let mut out = String::with_capacity(64 + trace.len() * 300);
    out.push_str(TraceRow::CSV_HEADER);
    out.push('\n');
    for row in trace {
        row.write_csv(&mut out);
        out.push('\n');
    }
    out
}

/// Writes `trace.csv`, `summary.json`, `fig5_path.svg`, `fig6_errors.svg` and
/// `fig7_inputs.svg` into `dir` (created if needed). Returns the files written.
pub fn write_run(dir: &FsPath, scenario: &Scenario, result: &RunResult) -> Result<Vec<PathBuf>> {
    fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut written = Vec::new();
    let trace = dir.join("trace.csv");
    fs::write(&trace, trace_csv(&result.trace))
        .with_context(|| format!("writing {}", trace.display()))?;
    written.push(trace);
    let summary = dir.join("summary.json");
    let json = serde_json::to_string_pretty(&result.summary).context("serialising the summary")?;
    fs::write(&summary, json + "\n").with_context(|| format!("writing {}", summary.display()))?;
    written.push(summary);
    let title = format!("{}, {} law", scenario.name, result.summary.law);
    let settle = result.summary.headline_error().settle_time_s;
    let fig5 = dir.join("fig5_path.svg");
    plot::fig5_path(&fig5, &title, &scenario.path, &result.trace)?;
    written.push(fig5);
    let fig6 = dir.join("fig6_errors.svg");
    plot::fig6_errors(&fig6, &title, &result.trace, settle)?;
    written.push(fig6);
    let fig7 = dir.join("fig7_inputs.svg");
    plot::fig7_inputs(&fig7, &title, &result.trace, settle)?;
    written.push(fig7);
    Ok(written)
}

/// `Some(x)` as "x.xx s", `None` as "not settled".
pub fn settle_text(settle: Option<f64>) -> String {
    match settle {
        Some(t) => format!("{t:.2} s"),
        None => "not settled".to_string(),
    }
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
