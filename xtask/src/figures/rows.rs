//! The rows of `docs/figures.md`'s tables, each from one JSON document the simulator
//! wrote, rounded to what the page shows (0.1 ms, 0.1 mm).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{bail, Context as _, Result};
use serde_json::Value;

/// Reads the JSON file at `path`.
pub fn read_json(path: &Path) -> Result<Value> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))
}

/// The number at `pointer` (a JSON pointer) in `value`.
fn number(value: &Value, pointer: &str) -> Result<f64> {
    value
        .pointer(pointer)
        .and_then(Value::as_f64)
        .with_context(|| format!("no number at `{pointer}`"))
}

/// `x` with `decimals` decimals, never `-0.00`: a value that rounds to zero is shown as
/// zero, whatever its sign.
fn fixed(x: f64, decimals: usize) -> String {
    let text = format!("{x:.decimals$}");
    if text.starts_with('-') && text[1..].chars().all(|c| c == '0' || c == '.') {
        text[1..].to_string()
    } else {
        text
    }
}

/// One row of the paper table.
pub fn paper_row(experiment: &str, law: &str, summary: &Value) -> Result<String> {
    let settle = settle(summary)?;
    Ok(format!(
        "| {experiment} | {law} | {settle} | {} mm | {}° | {} mm | {:.1} rad/s | {:.2} |\n",
        fixed(
            1e3 * number(summary, "/true_error/final_position_error_m")?,
            1
        ),
        fixed(
            number(summary, "/true_error/final_heading_error_rad")?.to_degrees(),
            2
        ),
        fixed(
            1e3 * number(summary, "/true_error/rms_position_error_m")?,
            1
        ),
        number(summary, "/max_wheel_speed_rad_s")?,
        number(summary, "/max_duty")?,
    ))
}

/// One row of the gyro sweep's table: `heading` steered by, from its `sweep.json`.
pub fn gyro_sweep_row(heading: &str, sweep: &Value) -> Result<String> {
    Ok(format!(
        "| {heading} | {} m | {} m | {}° | {} | {} rad/s |\n",
        fixed(number(sweep, "/final_true_position_error_m/p50")?, 3),
        fixed(number(sweep, "/final_true_position_error_m/p90")?, 3),
        fixed(number(sweep, "/heading/final_error_deg/p90")?, 3),
        number(sweep, "/heading/disagreeing_runs")?,
        fixed(number(sweep, "/heading/max_disagreement_radps/max")?, 4),
    ))
}

/// One row of the fault table.
pub fn fault_row(case: &Value) -> Result<String> {
    let name = case["case"]
        .as_str()
        .context("faults.json: a case without a name")?;
    let expect = &case["expect"];
    let expected = if expect.as_str() == Some("harmless") {
        "harmless".to_string()
    } else if let Some(detect) = expect.get("detect") {
        format!("detected: {}", detect["because"].as_str().unwrap_or(""))
    } else if let Some(warn) = expect.get("warn") {
        format!(
            "warned, drives on: {}",
            warn["because"].as_str().unwrap_or("")
        )
    } else if let Some(undetectable) = expect.get("undetectable") {
        format!(
            "not detectable by odometry (needs {})",
            undetectable["sensor"].as_str().unwrap_or("another sensor")
        )
    } else if let Some(rearm) = expect.get("rearm") {
        let second = if rearm["armed_again"].as_bool() == Some(true) {
            "stopped, then re-armed"
        } else {
            "stopped, re-arm refused"
        };
        format!("{second}: {}", rearm["because"].as_str().unwrap_or(""))
    } else {
        bail!("faults.json: `{name}` has an expectation this page does not know");
    };
    let report = &case["report"];
    let detected_by = report["detected_by"]
        .as_array()
        .map(|d| {
            d.iter()
                .filter_map(Value::as_str)
                .collect::<Vec<_>>()
                .join(", ")
        })
        .filter(|d| !d.is_empty())
        .or_else(|| report["warning"].as_str().map(str::to_string))
        .unwrap_or_else(|| "—".to_string());
    let seconds = |v: &Value| {
        v.as_f64()
            .map_or_else(|| "—".to_string(), |s| format!("{:.1} ms", 1e3 * s))
    };
    let travelled = report["distance_after_m"]
        .as_f64()
        .map_or_else(|| "—".to_string(), |m| format!("{:.1} mm", 1e3 * m));
    let verdict = if case["passed"].as_bool() == Some(true) {
        "as expected"
    } else {
        "NOT as expected"
    };
    let mut row = String::new();
    let _ = writeln!(
        row,
        "| {name} | {expected} | {detected_by} | {} | {} | {travelled} | {verdict} |",
        seconds(&case["latency_s"]),
        seconds(&case["limit_s"]),
    );
    Ok(row)
}

/// One row of the built-in scenarios' table, from a run's `summary.json`.
pub fn scenario_row(scenario: &str, summary: &Value) -> Result<String> {
    Ok(format!(
        "| {scenario} | {} | {} | {} mm | {} mm | {} mm |\n",
        summary["law"].as_str().unwrap_or("—"),
        settle(summary)?,
        fixed(
            1e3 * number(summary, "/true_error/final_position_error_m")?,
            1
        ),
        fixed(
            1e3 * number(summary, "/true_error/rms_position_error_m")?,
            1
        ),
        fixed(
            1e3 * number(summary, "/true_error/max_position_error_m")?,
            1
        ),
    ))
}

/// A run's settle time as the page shows it: `2.32 s`, or `not settled`.
pub fn settle(summary: &Value) -> Result<String> {
    Ok(match summary.pointer("/true_error/settle_time_s") {
        Some(Value::Null) | None => "not settled".to_string(),
        Some(v) => format!("{:.2} s", v.as_f64().context("settle time: not a number")?),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_paper_row_shows_the_true_errors_in_the_page_s_units() {
        let summary = serde_json::json!({
            "true_error": {
                "settle_time_s": 2.3299999237060547,
                "final_position_error_m": 0.000086,
                "final_heading_error_rad": -0.01,
                "rms_position_error_m": 0.25,
            },
            "max_wheel_speed_rad_s": 31.56,
            "max_duty": 1.0,
        });
        assert_eq!(
            paper_row("paper-circle", "tracking", &summary).unwrap(),
            "| paper-circle | tracking | 2.33 s | 0.1 mm | -0.57° | 250.0 mm | 31.6 rad/s | 1.00 |\n"
        );
        let mut unsettled = summary.clone();
        unsettled["true_error"]["settle_time_s"] = Value::Null;
        assert!(paper_row("x", "paper", &unsettled)
            .unwrap()
            .contains("| not settled |"));
        assert!(paper_row("x", "paper", &serde_json::json!({})).is_err());
        assert_eq!(fixed(-0.0001, 2), "0.00");
        assert_eq!(fixed(-0.006, 2), "-0.01");
        assert_eq!(fixed(2.5, 1), "2.5");
    }

    #[test]
    fn a_scenario_row_shows_its_law_settle_and_errors() {
        let summary = serde_json::json!({
            "law": "tracking",
            "true_error": {
                "settle_time_s": 36.88,
                "final_position_error_m": 0.0000685,
                "rms_position_error_m": 0.000218,
                "max_position_error_m": 0.000628,
            },
        });
        assert_eq!(
            scenario_row("square-waypoints", &summary).unwrap(),
            "| square-waypoints | tracking | 36.88 s | 0.1 mm | 0.2 mm | 0.6 mm |\n"
        );
        assert!(scenario_row("x", &serde_json::json!({})).is_err());
    }

    #[test]
    fn a_fault_row_says_what_was_expected_and_whether_it_happened() {
        let case = serde_json::json!({
            "case": "wheel blocked",
            "expect": {"detect": {"limit_s": 0.6, "because": "stall check"}},
            "latency_s": 0.514,
            "limit_s": 0.6,
            "passed": true,
            "report": {"detected_by": ["stall"], "distance_after_m": 0.0123},
        });
        assert_eq!(
            fault_row(&case).unwrap(),
            "| wheel blocked | detected: stall check | stall | 514.0 ms | 600.0 ms | 12.3 mm | as expected |\n"
        );
        let harmless = serde_json::json!({
            "case": "slip", "expect": "harmless", "latency_s": null, "limit_s": null,
            "passed": false, "report": {"detected_by": [], "distance_after_m": null},
        });
        assert_eq!(
            fault_row(&harmless).unwrap(),
            "| slip | harmless | — | — | — | — | NOT as expected |\n"
        );
        let rearm = serde_json::json!({
            "case": "twice", "expect": {"rearm": {"limit_s": 0.021, "armed_again": false, "because": "turning"}},
            "latency_s": 0.019, "limit_s": 0.021, "passed": true,
            "report": {"detected_by": ["disarmed: Button"], "distance_after_m": 0.0143},
        });
        assert_eq!(
            fault_row(&rearm).unwrap(),
            "| twice | stopped, re-arm refused: turning | disarmed: Button | 19.0 ms | 21.0 ms | 14.3 mm | as expected |\n"
        );
        let warn = serde_json::json!({
            "case": "gyro absent", "expect": {"warn": {"limit_s": 0.021, "because": "absent check"}},
            "latency_s": 0.019, "limit_s": 0.021, "passed": true,
            "report": {"detected_by": [], "warning": "gyro failed: Absent", "distance_after_m": 2.5},
        });
        assert_eq!(
            fault_row(&warn).unwrap(),
            "| gyro absent | warned, drives on: absent check | gyro failed: Absent | 19.0 ms | 21.0 ms | 2500.0 mm | as expected |\n"
        );
        let unknown = serde_json::json!({"case": "x", "expect": {"other": {}}});
        assert!(fault_row(&unknown).is_err());
    }
}
