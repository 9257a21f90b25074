//! What a processor-in-the-loop run is judged on, and the lines it prints.
//!
//! - **Against `host-sim run`** (same scenario, law and duration, the supervisor and
//!   controller run here): the summaries, every field but the wall-clock time and the
//!   source, and the trajectory digests. Both come from the same simulation loop, so
//!   they are equal exactly when the firmware computed the same duties and estimates at
//!   every step. A run with a link loss has no host counterpart and is not compared.
//! - **Injected faults:** the motors must reach 0 within the limit the simulator's fault
//!   suite gives for that kind ([`crate::fault_suite::cases`]).
//! - **A link loss:** the motors must reach 0 within the heartbeat timeout of the
//!   supervisor settings the station sent, counted from the cut. The station's
//!   heartbeats go in step (`super::station`): each has reached the control side before
//!   the step that takes it, and none is sent from the cut on, so none is in flight.

use serde_json::Value;

use robot_files::metrics::Summary;
use robot_files::scenario::Scenario;

use super::firmware::LinkLoss;
use super::PilOutcome;
use crate::fault_suite::{cases, Expectation};
use crate::run::RunResult;

/// One judged line.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// The line as printed.
    pub text: String,
    /// False when it reports a failure.
    pub passed: bool,
}

/// Every line of the run's verdict: the comparisons, the faults, the link loss, the
/// firmware's figures.
pub fn judge(scenario: &Scenario, outcome: &PilOutcome, host: Option<&RunResult>) -> Vec<Line> {
    let name = &scenario.name;
    let mut lines = Vec::new();
    match host {
        Some(host) => {
            let pil = &outcome.result;
            let differences = differing_fields(&pil.summary, &host.summary);
            lines.push(if differences.is_empty() {
                Line {
                    text: format!("PIL {name}: summary identical to host-sim"),
                    passed: true,
                }
            } else {
                Line {
                    text: format!(
                        "PIL {name}: summary differs from host-sim by at most {:.6} m ({})",
                        largest_position_difference_m(&pil.summary, &host.summary),
                        differences.join(", ")
                    ),
                    passed: false,
                }
            });
            let shown = |d: &Option<m4f_scenario::Digest>| {
                d.as_ref()
                    .map_or_else(|| "none".to_string(), ToString::to_string)
            };
            lines.push(if pil.digest.is_some() && pil.digest == host.digest {
                Line {
                    text: format!(
                        "PIL {name}: trajectory digest identical to host-sim ({})",
                        shown(&pil.digest)
                    ),
                    passed: true,
                }
            } else {
                Line {
                    text: format!(
                        "PIL {name}: trajectory digest differs: firmware {}, host-sim {}",
                        shown(&pil.digest),
                        shown(&host.digest)
                    ),
                    passed: false,
                }
            });
        }
        None => lines.push(Line {
            text: format!(
                "PIL {name}: not compared with host-sim (the link loss has no counterpart there)"
            ),
            passed: true,
        }),
    }
    for fault in &outcome.result.summary.injected_faults {
        let limit_s = cases().iter().find_map(|c| match c.expect {
            Expectation::Detect { limit_s, .. } if c.kind.name() == fault.fault => Some(limit_s),
            _ => None,
        });
        let after = fault.motors_zero_s.map(|t| t - fault.injected_s);
        let passed = matches!((after, limit_s), (Some(a), Some(l)) if a <= l + 1e-9);
        lines.push(Line {
            text: format!(
                "PIL {name}: {} at {:.3} s: stopped by [{}], motors at 0 after {} (limit {})",
                fault.fault,
                fault.injected_s,
                fault.detected_by.join(", "),
                seconds(after),
                seconds(limit_s)
            ),
            passed,
        });
    }
    if let Some(station) = &outcome.station {
        if let Some(first) = station.refused_in_step.first() {
            lines.push(Line {
                text: format!(
                    "PIL {name}: the robot refused {} of the requests sent in step, first {first}",
                    station.refused_in_step.len()
                ),
                passed: false,
            });
        }
    }
    if let Some(loss) = &outcome.link_loss {
        lines.push(link_loss_line(
            name,
            scenario.robot.control_rate_hz,
            scenario.supervisor.heartbeat_timeout_steps,
            loss,
        ));
    }
    let board = &outcome.board;
    for text in [
        format!(
            "control interrupt on Cortex-M4F (PIL), any state: max {} instructions over {} steps",
            board.control.max_instructions, board.control.runs
        ),
        format!(
            "control interrupt on Cortex-M4F (PIL), armed: mean {:.0}, max {} instructions \
             over {} steps (armed, no event)",
            board.control_armed.mean_instructions(),
            board.control_armed.max_instructions,
            board.control_armed.runs
        ),
        format!(
            "control interrupt on Cortex-M4F (PIL), arming: max {} instructions over {} steps",
            board.control_arming.max_instructions, board.control_arming.runs
        ),
        format!(
            "steering task on Cortex-M4F (PIL): max {} instructions, total {} over {} runs \
             (the outer loop, lent by the control interrupt and run below it between two \
             steps)",
            board.steering.max_instructions, board.steering.total_instructions, board.steering.runs
        ),
        format!(
            "link service on Cortex-M4F (PIL): max {} instructions, total {} over {} runs",
            board.link.max_instructions, board.link.total_instructions, board.link.runs
        ),
        format!(
            "link USART interrupt on Cortex-M4F (PIL): max {} instructions, total {} over {} \
             runs",
            board.link_uart.max_instructions,
            board.link_uart.total_instructions,
            board.link_uart.runs
        ),
    ] {
        lines.push(Line { text, passed: true });
    }
    lines
}

/// The verdict on a link loss: the motors must be at 0 within the heartbeat timeout
/// (`heartbeat_timeout_steps` control periods), counted from the cut; never reaching 0
/// fails.
fn link_loss_line(
    name: &str,
    control_rate_hz: u32,
    heartbeat_timeout_steps: u32,
    loss: &LinkLoss,
) -> Line {
    let rate = f64::from(control_rate_hz);
    let limit_steps = u64::from(heartbeat_timeout_steps);
    let after = loss
        .motors_zero_step
        .map(|s| s.saturating_sub(loss.at_step));
    Line {
        text: format!(
            "PIL {name}: link lost at {:.3} s: stopped by {}, motors at 0 after {} (limit {}: the heartbeat timeout)",
            loss.at_step as f64 / rate,
            loss.stopped_by.as_deref().unwrap_or("nothing"),
            seconds(after.map(|s| s as f64 / rate)),
            seconds(Some(limit_steps as f64 / rate)),
        ),
        passed: after.is_some_and(|a| a <= limit_steps),
    }
}

/// `x.xxx s`, or `never`.
fn seconds(s: Option<f64>) -> String {
    s.map_or_else(|| "never".to_string(), |s| format!("{s:.3} s"))
}

/// The summary as JSON without what differs by nature between two runs of the same
/// computation: the wall-clock time and the source.
fn comparable(summary: &Summary) -> Value {
    let mut value = serde_json::to_value(summary).unwrap_or(Value::Null);
    if let Some(map) = value.as_object_mut() {
        map.remove("wall_time_s");
        map.remove("source");
    }
    value
}

/// The dotted paths of the fields whose values differ.
pub fn differing_fields(a: &Summary, b: &Summary) -> Vec<String> {
    let mut out = Vec::new();
    diff(&comparable(a), &comparable(b), String::new(), &mut out);
    out
}

fn diff(a: &Value, b: &Value, path: String, out: &mut Vec<String>) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (key, va) in x {
                let sub = if path.is_empty() {
                    key.clone()
                } else {
                    format!("{path}.{key}")
                };
                match y.get(key) {
                    Some(vb) => diff(va, vb, sub, out),
                    None => out.push(sub),
                }
            }
            for key in y.keys().filter(|k| !x.contains_key(*k)) {
                out.push(format!("{path}.{key}"));
            }
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
            for (i, (va, vb)) in x.iter().zip(y).enumerate() {
                diff(va, vb, format!("{path}[{i}]"), out);
            }
        }
        _ if a == b => {}
        _ => out.push(path),
    }
}

/// The largest difference between the two summaries' position errors (true and
/// estimated: final, RMS and maximum), m.
fn largest_position_difference_m(a: &Summary, b: &Summary) -> f64 {
    let positions = |s: &Summary| {
        let mut v = Vec::new();
        for e in s.true_error.iter().chain([&s.estimated_error]) {
            v.extend([
                e.final_position_error_m,
                e.rms_position_error_m,
                e.max_position_error_m,
            ]);
        }
        v
    };
    positions(a)
        .iter()
        .zip(positions(b))
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use robot_files::metrics::{ErrorReport, SupervisorReport};

    fn summary() -> Summary {
        Summary {
            scenario: "s".into(),
            law: "tracking".into(),
            source: "simulator".into(),
            true_error: Some(ErrorReport {
                settle_time_s: Some(2.0),
                final_position_error_m: 0.001,
                final_heading_error_rad: 0.0,
                rms_position_error_m: 0.002,
                max_position_error_m: 0.003,
                samples: 1000,
            }),
            estimated_error: ErrorReport::default(),
            hourly_rms_true_position_error_m: Vec::new(),
            max_wheel_speed_rad_s: 10.0,
            max_duty: 0.5,
            supervisor: SupervisorReport {
                final_state: "Armed".into(),
                faults: Vec::new(),
                missed_ticks: 0,
                overruns: 0,
            },
            injected_faults: Vec::new(),
            sim_time_s: 1.0,
            wall_time_s: 0.5,
            steps: 1000,
        }
    }

    #[test]
    fn wall_time_and_source_do_not_count_everything_else_does() {
        let a = summary();
        let mut b = summary();
        b.wall_time_s = 99.0;
        b.source = "pil".into();
        assert!(differing_fields(&a, &b).is_empty());
        b.max_duty = 0.6;
        b.true_error = Some(ErrorReport {
            rms_position_error_m: 0.0025,
            ..a.true_error.unwrap()
        });
        assert_eq!(
            differing_fields(&a, &b),
            ["max_duty", "true_error.rms_position_error_m"]
        );
        let d = largest_position_difference_m(&a, &b);
        assert!((d - 0.0005).abs() < 1e-12, "{d}");
    }

    fn loss(at_step: u64, motors_zero_step: Option<u64>) -> LinkLoss {
        LinkLoss {
            at_step,
            motors_zero_step,
            stopped_by: Some("Disarmed(LinkLost)".into()),
        }
    }

    #[test]
    fn a_link_loss_passes_up_to_the_timeout() {
        // 1 kHz, 500-step timeout: the limit is 500 steps after the cut at step 1000.
        let judged = |zero| link_loss_line("s", 1000, 500, &loss(1000, zero));
        let at_limit = judged(Some(1500));
        assert!(at_limit.passed, "{}", at_limit.text);
        assert_eq!(
            at_limit.text,
            "PIL s: link lost at 1.000 s: stopped by Disarmed(LinkLost), motors at 0 after \
             0.500 s (limit 0.500 s: the heartbeat timeout)"
        );
        assert!(judged(Some(1200)).passed);
        let late = judged(Some(1501));
        assert!(!late.passed, "{}", late.text);
        let never = judged(None);
        assert!(!never.passed);
        assert!(
            never.text.contains("motors at 0 after never"),
            "{}",
            never.text
        );
    }
}
