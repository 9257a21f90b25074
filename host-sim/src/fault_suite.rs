//! `host-sim faults`: every kind of fault, one at a time, on a built-in scenario, with
//! what the supervisor did about it and how fast, against the limit its detector implies.
//!
//! Each case runs the scenario (the paper's circle by default) armed in motion, injects
//! one fault at [`INJECT_AT_S`] (after the divergence check's settling window) and runs
//! on for [`RUN_AFTER_S`]. A case is one of:
//!
//! - **detectable**: the firmware's own signals can see it; it must stop the robot within
//!   `limit_s`, which follows from the detector's settings (stated per case);
//! - **harmless**: it must trip nothing (a short slip patch, one late step);
//! - **undetectable**: odometry stays self-consistent, so nothing the firmware has can
//!   see it; reported with `detected: false`, no limit, and the sensor that would.
//!
//! The detectors run on the robot's signals only (ticks, applied voltages, the step count,
//! the supply measurement); the simulator's truth only measures what the fault did.

use controller_core::law::LawKind;
use robot_files::faults::{Fault, FaultKind, Wheel};
use robot_files::metrics::FaultReport;
use robot_files::scenario::Scenario;
use serde::Serialize;

use crate::run::{run_scenario_with, RunError, RunOptions};

/// When each case's fault is injected, s (after the paper's circle's 5.5 s divergence
/// settling window).
pub const INJECT_AT_S: f64 = 10.0;
/// How long each case runs after the injection, s.
pub const RUN_AFTER_S: f64 = 10.0;

/// What a case is expected to do (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Expectation {
    /// Stopped within this many seconds.
    Detect {
        /// The limit, s.
        limit_s: f64,
        /// Why that limit: the detector and its setting.
        because: &'static str,
    },
    /// Trips nothing.
    Harmless,
    /// Not visible to the firmware; this sensor would see it.
    Undetectable {
        /// The sensor that would see it.
        sensor: &'static str,
    },
}

/// One case: a fault and what it should do.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    /// Short name of the case for the table.
    pub name: &'static str,
    /// The fault.
    pub kind: FaultKind,
    /// How long it lasts, s (`None`: to the end).
    pub duration_s: Option<f64>,
    /// What it should do.
    pub expect: Expectation,
}

/// The cases `host-sim faults` runs (module doc).
pub fn cases() -> Vec<Case> {
    use Expectation::*;
    use FaultKind::*;
    let stall = Detect {
        limit_s: 0.6,
        because: "stall check: 0.5 s at ≥ 3.6 V below 1 rad/s",
    };
    vec![
        Case {
            name: "encoder disconnected",
            kind: EncoderDisconnect(Wheel::Left),
            duration_s: None,
            expect: stall,
        },
        Case {
            name: "encoder glitch",
            kind: EncoderGlitch(Wheel::Left, 1000),
            duration_s: None,
            expect: Detect {
                limit_s: 0.001,
                because: "encoder-jump check: one step",
            },
        },
        Case {
            name: "encoder cables swapped",
            kind: EncodersSwapped,
            duration_s: None,
            expect: Detect {
                limit_s: 1.5,
                because: "divergence check: 0.5 m for 1 s (or the stall check first)",
            },
        },
        Case {
            name: "motor disconnected",
            kind: MotorDisconnect(Wheel::Left),
            duration_s: None,
            expect: Detect {
                limit_s: 1.5,
                because: "stall check, or divergence if the chassis drags the wheel",
            },
        },
        Case {
            name: "wheel blocked",
            kind: WheelBlocked(Wheel::Right),
            duration_s: None,
            expect: stall,
        },
        Case {
            name: "slip patch (0.2 s at 30 %)",
            kind: SlipPatch(Wheel::Left, 0.3),
            duration_s: Some(0.2),
            expect: Harmless,
        },
        Case {
            name: "supply sag to 4.0 V",
            kind: SupplySag(4.0),
            duration_s: Some(2.0),
            expect: Detect {
                limit_s: 0.3,
                because: "battery check: below 4.6 V for 0.2 s (20 ms supply filter)",
            },
        },
        Case {
            name: "supply dip to 4.8 V",
            kind: SupplySag(4.8),
            duration_s: Some(2.0),
            expect: Harmless,
        },
        Case {
            name: "one step 3 periods late",
            kind: LateSteps {
                count: 1,
                periods: 3,
            },
            duration_s: None,
            expect: Harmless,
        },
        Case {
            name: "control loop blind 12 ms",
            kind: LateSteps {
                count: 1,
                periods: 12,
            },
            duration_s: None,
            expect: Detect {
                limit_s: 0.012,
                because: "missed-tick check: a gap of 10 periods",
            },
        },
        Case {
            name: "button pressed",
            kind: ButtonPress,
            duration_s: Some(0.1),
            expect: Detect {
                limit_s: 0.021,
                because: "button: disarm on the debounced press (20 ms)",
            },
        },
        Case {
            name: "track width 5 % off",
            kind: TrackWidthError(5.0),
            duration_s: None,
            expect: Undetectable {
                sensor: "a gyro (its yaw rate against odometry's) or an absolute position fix",
            },
        },
        Case {
            name: "left motor and encoder both inverted",
            kind: BothInverted(Wheel::Left),
            duration_s: None,
            expect: Undetectable {
                sensor: "a gyro (its yaw rate against odometry's) or an absolute position fix",
            },
        },
    ]
}

/// One row of the table and of `faults.json`.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    /// The case.
    pub case: &'static str,
    /// The fault's kind.
    pub fault: String,
    /// Whether the supervisor stopped the robot.
    pub detected: bool,
    /// How long after the injection, s (`null` if not).
    pub latency_s: Option<f64>,
    /// The limit, s (`null` for harmless and undetectable cases).
    pub limit_s: Option<f64>,
    /// What the case should do.
    pub expect: Expectation,
    /// True when it did.
    pub passed: bool,
    /// What the run reported for the fault (detector, motors at 0, wheels stopped,
    /// distance after).
    pub report: FaultReport,
}

/// Runs every case on `scenario` with `law`.
pub fn run_suite(scenario: &Scenario, law: LawKind) -> Result<Vec<CaseResult>, RunError> {
    let rate = f64::from(scenario.robot.control_rate_hz);
    let mut results = Vec::new();
    for case in cases() {
        let mut s = scenario.clone();
        s.duration_s = INJECT_AT_S + RUN_AFTER_S;
        s.faults = vec![Fault {
            kind: case.kind,
            at_step: (INJECT_AT_S * rate).round() as u64,
            duration_steps: case.duration_s.map(|d| ((d * rate).round() as u64).max(1)),
        }];
        if let FaultKind::TrackWidthError(_) = case.kind {
            // The mismatch exists from the start: odometry is wrong all run long.
            s.faults[0].at_step = 0;
        }
        let run = run_scenario_with(
            &s,
            law,
            RunOptions {
                trace_every_steps: 0,
            },
        )?;
        let report = run
            .summary
            .injected_faults
            .first()
            .cloned()
            .ok_or(RunError::Argument {
                name: "fault",
                rule: "must be reported",
                value: 0.0,
            })?;
        let (limit_s, passed) = match case.expect {
            Expectation::Detect { limit_s, .. } => (
                Some(limit_s),
                report
                    .latency_s
                    .is_some_and(|l| report.detected && l <= limit_s + 1e-9),
            ),
            Expectation::Harmless | Expectation::Undetectable { .. } => (None, !report.detected),
        };
        results.push(CaseResult {
            case: case.name,
            fault: report.fault.clone(),
            detected: report.detected,
            latency_s: report.latency_s,
            limit_s,
            expect: case.expect,
            passed,
            report,
        });
    }
    Ok(results)
}
