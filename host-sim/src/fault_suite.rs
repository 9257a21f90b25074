//! `host-sim faults`: every kind of fault, one at a time, on a built-in scenario, with
//! what the supervisor did about it and how fast, against the limit its detector implies.
//!
//! Each case runs the scenario (the paper's circle by default) in a configuration
//! ([`crate::fault_matrix`]: its own, or the nearest where the case applies), injects one
//! fault [`INJECT_AT_S`] after arming (after the divergence check's settling window) and
//! runs on for [`RUN_AFTER_S`]. A case is one of:
//!
//! - **detectable**: the firmware's own signals can see it; it must stop the robot within
//!   `limit_s`, which follows from the detector's settings (stated per case);
//! - **harmless**: it must trip nothing (a short slip patch, one late step);
//! - **warn**: a gyro's own failure: the supervisor must warn within `limit_s` and the
//!   robot drive on, its heading back on odometry;
//! - **undetectable**: odometry stays self-consistent (and, on a robot with a gyro, the
//!   yaw rates disagree too little), so nothing the robot has can see it; reported with
//!   `detected: false`, no limit, and the sensor that would;
//! - **re-arm**: the button pressed twice while following: the first press must stop the
//!   robot within `limit_s`; the second re-arms it only once the wheels are at rest, from
//!   the pose odometry kept, so it ends on the path ([`REARM_FINAL_ERROR_M`]). These cases
//!   follow the path by projection (the true error is the distance to the path, whatever
//!   the reference's clock).
//!
//! The rows "with a gyro" run on a robot with the ICM-42688-P model steering by the fused
//! heading, its disagreement check set to stop it. The detectors run on the robot's
//! signals only (ticks, applied voltages, the step count, the supply measurement, the
//! gyro's readings); the simulator's truth only measures what the fault did.

use controller_core::law::LawKind;
use robot_files::faults::{Fault, FaultKind, Wheel};
use robot_files::metrics::FaultReport;
use robot_files::scenario::Scenario;
use serde::Serialize;

use std::path::Path;

use crate::fault_matrix::{Configuration, Heading, Mode};
use crate::run::{run_scenario_with, RunError, RunOptions};

/// When each case's fault is injected, s after arming (after the paper's circle's 5.5 s
/// divergence settling window).
pub const INJECT_AT_S: f64 = 10.0;
/// How long each case runs after the injection, s.
pub const RUN_AFTER_S: f64 = 10.0;

/// A re-armed robot ends at most this far from the path (true position error at the
/// end), m: it resumed from where it really was.
pub const REARM_FINAL_ERROR_M: f64 = 0.05;

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
    /// Seen by the gyro, which warns within `limit_s`; the robot drives on (a failed gyro
    /// gives the heading back to odometry).
    Warn {
        /// The limit, s.
        limit_s: f64,
        /// Why that limit: the gyro check and its setting.
        because: &'static str,
    },
    /// Not visible to the firmware; this sensor would see it.
    Undetectable {
        /// The sensor that would see it.
        sensor: &'static str,
    },
    /// Pressed twice: stopped within `limit_s` by the first press; the second re-arms
    /// (`armed_again`) or is refused because the wheels still turn.
    Rearm {
        /// The first press's limit, s.
        limit_s: f64,
        /// Whether the second press re-arms.
        armed_again: bool,
        /// Why.
        because: &'static str,
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
    /// The same fault again, this long after the first began, s (`None`: once).
    pub again_after_s: Option<f64>,
    /// What it should do.
    pub expect: Expectation,
    /// The heading source the row is stated for (`None`: either): the rows whose
    /// expectation depends on it come once for each.
    pub heading: Option<Heading>,
}

impl Case {
    /// `kind` to the end of the run, once, on a robot without a gyro, expected to `expect`.
    const fn new(name: &'static str, kind: FaultKind, expect: Expectation) -> Self {
        Self {
            name,
            kind,
            duration_s: None,
            again_after_s: None,
            expect,
            heading: None,
        }
    }

    /// The fault lasts `s` seconds.
    const fn lasting(mut self, s: f64) -> Self {
        self.duration_s = Some(s);
        self
    }

    /// The same fault again, `s` seconds after the first began.
    const fn again_after(mut self, s: f64) -> Self {
        self.again_after_s = Some(s);
        self
    }

    /// Stated for a robot steering by the fused heading ([`Heading::Fused`]).
    const fn with_gyro(mut self) -> Self {
        self.heading = Some(Heading::Fused);
        self
    }

    /// Stated for a robot steering by odometry alone ([`Heading::Odometry`]).
    const fn without_gyro(mut self) -> Self {
        self.heading = Some(Heading::Odometry);
        self
    }

    /// The configuration nearest `own` in which the row applies: `own` with the row's
    /// heading source, and a path-indexed reference for a re-arm row.
    pub fn configuration_near(&self, own: Configuration) -> Configuration {
        Configuration {
            heading: self.heading.unwrap_or(own.heading),
            mode: match self.expect {
                Expectation::Rearm { .. } => Mode::PathIndexed,
                _ => own.mode,
            },
            start: own.start,
        }
    }

    /// Whether the row is a cell of `configuration`: its heading source is the one the
    /// row is stated for, and a re-arm row (it resumes along the path) needs a
    /// path-indexed reference.
    pub fn applies_in(&self, configuration: &Configuration) -> bool {
        let heading = self.heading.is_none_or(|h| h == configuration.heading);
        let mode = match self.expect {
            Expectation::Rearm { .. } => configuration.mode == Mode::PathIndexed,
            _ => true,
        };
        heading && mode
    }
}

/// The cases `host-sim faults` runs (module doc).
pub fn cases() -> Vec<Case> {
    use Expectation::*;
    use FaultKind::*;
    let stall = Detect {
        limit_s: 0.6,
        because: "stall check: 0.4 s driven at ≥ 1 V below 1 rad/s, net of the steps between",
    };
    vec![
        Case::new(
            "encoder disconnected",
            EncoderDisconnect(Wheel::Left),
            stall,
        ),
        Case::new(
            "encoder glitch",
            EncoderGlitch(Wheel::Left, 1000),
            Detect {
                limit_s: 0.001,
                because: "encoder-jump check: one step",
            },
        ),
        Case::new(
            "encoder cables swapped",
            EncodersSwapped,
            Detect {
                limit_s: 1.5,
                because: "divergence check: 0.5 m for 1 s (or the stall check first)",
            },
        ),
        Case::new(
            "motor disconnected",
            MotorDisconnect(Wheel::Left),
            Detect {
                limit_s: 1.5,
                because: "stall check, or divergence if the chassis drags the wheel",
            },
        ),
        Case::new("wheel blocked", WheelBlocked(Wheel::Right), stall),
        Case::new(
            "slip patch (0.2 s at 30 %)",
            SlipPatch(Wheel::Left, 0.3),
            Harmless,
        )
        .lasting(0.2),
        Case::new(
            "supply sag to 4.0 V",
            SupplySag(4.0),
            Detect {
                limit_s: 0.3,
                because: "battery check: below 4.6 V for 0.2 s (20 ms supply filter)",
            },
        )
        .lasting(2.0),
        Case::new("supply dip to 4.8 V", SupplySag(4.8), Harmless).lasting(2.0),
        Case::new(
            "one step 3 periods late",
            LateSteps {
                count: 1,
                periods: 3,
            },
            Harmless,
        ),
        Case::new(
            "control loop blind 12 ms",
            LateSteps {
                count: 1,
                periods: 12,
            },
            Detect {
                limit_s: 0.012,
                because: "missed-tick check: a gap of 10 periods",
            },
        ),
        Case::new(
            "button pressed",
            ButtonPress,
            Detect {
                limit_s: 0.021,
                because: "button: disarm on the debounced press (20 ms)",
            },
        )
        .lasting(0.1),
        Case::new(
            "button pressed twice 60 ms apart",
            ButtonPress,
            Rearm {
                limit_s: 0.021,
                armed_again: false,
                because: "re-arming needs both wheels below 0.5 rad/s for 0.1 s",
            },
        )
        .lasting(0.03)
        .again_after(0.06),
        Case::new(
            "button pressed twice 1 s apart",
            ButtonPress,
            Rearm {
                limit_s: 0.021,
                armed_again: true,
                because: "at rest: re-armed where it stopped, back on the path",
            },
        )
        .lasting(0.03)
        .again_after(1.0),
        Case::new(
            "track width 5 % off",
            TrackWidthError(5.0),
            Undetectable {
                sensor: "a gyro (its yaw rate against odometry's) or an absolute position fix",
            },
        )
        .without_gyro(),
        Case::new(
            "left motor and encoder both inverted",
            BothInverted(Wheel::Left),
            Undetectable {
                sensor: "a gyro (its yaw rate against odometry's) or an absolute position fix",
            },
        )
        .without_gyro(),
        Case::new(
            "left encoder loses 1 tick in 10",
            TicksLost(Wheel::Left, 0.1),
            Undetectable {
                sensor: "a gyro (its yaw rate against odometry's) or an absolute position fix",
            },
        )
        .without_gyro(),
        Case::new(
            "left wheel slips 2 %, steadily",
            SlipPatch(Wheel::Left, 0.02),
            Undetectable {
                sensor: "a gyro (its yaw rate against odometry's) or an absolute position fix",
            },
        )
        .without_gyro(),
        Case::new(
            "track width 5 % off, with a gyro",
            TrackWidthError(5.0),
            Undetectable {
                sensor: "an absolute position fix (the yaw-rate error, 5 % of 0.2 rad/s, is \
                         below the gyro check's 0.03 rad/s)",
            },
        )
        .with_gyro(),
        Case::new(
            "left motor and encoder inverted, with a gyro",
            BothInverted(Wheel::Left),
            disagreement(GYRO_INVERTED_LIMIT_S),
        )
        .with_gyro(),
        Case::new(
            "left encoder loses 1 tick in 10, with a gyro",
            TicksLost(Wheel::Left, 0.1),
            disagreement(GYRO_TICKS_LOST_LIMIT_S),
        )
        .with_gyro(),
        Case::new(
            "left wheel slips 2 %, with a gyro",
            SlipPatch(Wheel::Left, 0.02),
            Undetectable {
                sensor: "an absolute position fix (the yaw-rate error, 0.032 rad/s, passes \
                         the gyro check's 0.03 rad/s only after 27 s)",
            },
        )
        .with_gyro(),
        Case::new(
            "gyro stuck",
            GyroStuck,
            Warn {
                limit_s: 0.201,
                because: "stuck check: 200 identical readings while odometry turns 0.01 rad",
            },
        )
        .with_gyro(),
        Case::new(
            "gyro absent",
            GyroAbsent,
            Warn {
                limit_s: 0.021,
                because: "absent check: 20 steps without a reading",
            },
        )
        .with_gyro(),
        Case::new(
            "gyro saturated",
            GyroSaturated,
            Warn {
                limit_s: 0.001,
                because: "saturation check: one reading at full scale",
            },
        )
        .with_gyro(),
    ]
}

/// A disagreement the gyro configured to stop must stop the robot within `limit_s`.
const fn disagreement(limit_s: f64) -> Expectation {
    Expectation::Detect {
        limit_s,
        because: "disagreement check: the 10 s running mean of gyro minus odometry yaw rate beyond ±0.03 rad/s",
    }
}

/// The disagreement rows' limits, s. The running mean of a constant disagreement e passes
/// the threshold c after −τ ln(1 − c/e) (τ = 10 s, c = 0.03 rad/s); e is what the fault
/// does to odometry's yaw rate on the paper's circle (v = 0.25 m/s, ω = 0.2 rad/s,
/// L = 0.15 m, the left wheel at v_l = v − ωL/2 = 0.235 m/s).
///
/// A left wheel turning backwards while its encoder counts forwards: the robot spins,
/// e ≈ 2 v_l / L ≈ 3 rad/s, 0.1 s; with the reversal of the wheel, 0.2 s.
const GYRO_INVERTED_LIMIT_S: f64 = 0.2;
/// A tenth of the left wheel's ticks lost: e = 0.1 · v_l / L = 0.157 rad/s, 2.1 s, with
/// a margin of 0.4 s for the wheel speeds the controller settles at meanwhile.
const GYRO_TICKS_LOST_LIMIT_S: f64 = 2.5;

/// One row of the table and of `faults.json`.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    /// The case.
    pub case: &'static str,
    /// The fault's kind.
    pub fault: String,
    /// Whether the supervisor stopped the robot (for a warn case: whether it warned).
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
    /// The supervisor's state at the end of the run (`Armed` for a re-armed robot).
    pub final_state: String,
    /// The true position error at the end of the run, m.
    pub final_true_error_m: Option<f64>,
    /// With a gyro, the largest running mean of |gyro − odometry| yaw rate while armed,
    /// rad/s (`null` without one).
    pub max_gyro_disagreement_radps: Option<f64>,
}

/// Runs every case on `scenario` with `law`, each in the configuration nearest the
/// scenario's own where it applies ([`Case::configuration_near`]); with `mcap_dir`, each
/// case's run is also written there as an MCAP file named after the case
/// ([`crate::mcap::file_stem`]).
pub fn run_suite(
    scenario: &Scenario,
    law: LawKind,
    mcap_dir: Option<&Path>,
) -> Result<Vec<CaseResult>, RunError> {
    let own = Configuration::of(scenario);
    cases()
        .into_iter()
        .map(|case| {
            let file =
                mcap_dir.map(|d| d.join(format!("{}.mcap", crate::mcap::file_stem(case.name))));
            let configured = case.configuration_near(own).apply(scenario);
            run_case(&configured, law, case, file.as_deref())
        })
        .collect()
}

/// Runs `case` on `scenario` (already in the configuration the case is run in: see
/// [`Configuration::apply`]) with `law`, the fault injected [`INJECT_AT_S`] after
/// arming; with `mcap`, the run (traced at the steering rate) is also written to that
/// file.
pub fn run_case(
    scenario: &Scenario,
    law: LawKind,
    case: Case,
    mcap: Option<&Path>,
) -> Result<CaseResult, RunError> {
    let rate = f64::from(scenario.robot.control_rate_hz);
    {
        let mut s = scenario.clone();
        // A robot with a gyro may stand still first, to learn its bias: the run arms then.
        let armed_s = s.gyro.map_or(0.0, |g| g.rest_before_arming_s);
        s.duration_s = armed_s + INJECT_AT_S + RUN_AFTER_S;
        let fault = Fault {
            kind: case.kind,
            at_step: ((armed_s + INJECT_AT_S) * rate).round() as u64,
            duration_steps: case.duration_s.map(|d| ((d * rate).round() as u64).max(1)),
        };
        s.faults = vec![fault];
        if let Some(after) = case.again_after_s {
            s.faults.push(Fault {
                at_step: fault.at_step + (after * rate).round() as u64,
                ..fault
            });
        }
        if let FaultKind::TrackWidthError(_) = case.kind {
            // The mismatch exists from the start: odometry is wrong all run long.
            s.faults[0].at_step = 0;
        }
        let trace_every_steps = if mcap.is_some() {
            s.robot.steering_divider
        } else {
            0
        };
        let run = run_scenario_with(&s, law, RunOptions::traced_every(trace_every_steps))?;
        if let Some(file) = mcap {
            crate::mcap::write_run_mcap(file, &s, &run)?;
        }
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
            Expectation::Warn { limit_s, .. } => (
                Some(limit_s),
                !report.detected
                    && report
                        .warning_latency_s
                        .is_some_and(|l| l <= limit_s + 1e-9),
            ),
            Expectation::Harmless | Expectation::Undetectable { .. } => (None, !report.detected),
            Expectation::Rearm {
                limit_s,
                armed_again,
                ..
            } => {
                let stopped = report
                    .latency_s
                    .is_some_and(|l| report.detected && l <= limit_s + 1e-9);
                let armed_at_end = run.summary.supervisor.final_state == "Armed";
                let on_path = final_true_error_m(&run).is_some_and(|e| e <= REARM_FINAL_ERROR_M);
                (
                    Some(limit_s),
                    stopped && armed_at_end == armed_again && (!armed_again || on_path),
                )
            }
        };
        // A case the robot drives on through is detected by its warning.
        let (detected, latency_s) = match case.expect {
            Expectation::Warn { .. } => (report.warning.is_some(), report.warning_latency_s),
            _ => (report.detected, report.latency_s),
        };
        Ok(CaseResult {
            case: case.name,
            fault: report.fault.clone(),
            detected,
            latency_s,
            limit_s,
            expect: case.expect,
            passed,
            report,
            final_state: run.summary.supervisor.final_state.clone(),
            final_true_error_m: final_true_error_m(&run),
            max_gyro_disagreement_radps: s.gyro.map(|_| run.max_gyro_disagreement_radps),
        })
    }
}

/// The true position error at the end of `run`, m.
fn final_true_error_m(run: &crate::run::RunResult) -> Option<f64> {
    run.summary
        .true_error
        .as_ref()
        .map(|e| e.final_position_error_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `case` on `scenario` in the configuration nearest the scenario's own, as
    /// `host-sim faults` runs it.
    fn run_near(scenario: &Scenario, case: Case) -> CaseResult {
        let configured = case
            .configuration_near(Configuration::of(scenario))
            .apply(scenario);
        run_case(&configured, LawKind::Tracking, case, None).unwrap()
    }

    /// The hole the fused heading opened: steering by the gyro, the outer loop turns a
    /// wheel whose encoder is silent down again and again, so its drive dips below the
    /// stall check's voltage; the check still stops it within the row's limit, from what
    /// the wheel does, with the gyro's disagreement only a warning (the default).
    #[test]
    fn a_silent_encoder_stops_a_robot_steering_by_the_fused_heading_by_the_stall_check() {
        let mut scenario = Scenario::load("paper-circle-gyro").unwrap();
        scenario.robot.gyro.disagreement_stops = false;
        let case = cases()
            .into_iter()
            .find(|c| c.kind == FaultKind::EncoderDisconnect(Wheel::Left))
            .unwrap();
        let r = run_case(&scenario, LawKind::Tracking, case, None).unwrap();
        assert_eq!(r.report.detected_by, ["stall_left"], "{r:?}");
        assert!(r.passed, "{r:?}");
        // The gyro's 5 s rest comes first: the fault is injected 10 s after arming.
        assert!((r.report.injected_s - 15.0).abs() < 1e-9, "{r:?}");
    }

    /// Every configuration reads back from the scenario it makes, every configuration has
    /// cells and every row is a cell somewhere.
    #[test]
    fn every_configuration_is_what_it_makes_and_every_row_is_in_the_matrix() {
        let base = Scenario::load("paper-circle").unwrap();
        let all = Configuration::all();
        assert_eq!(all.len(), 12);
        for c in &all {
            assert_eq!(Configuration::of(&c.apply(&base)), *c);
            assert!(cases().iter().any(|case| case.applies_in(c)), "{c}");
        }
        for case in cases() {
            assert!(all.iter().any(|c| case.applies_in(c)), "{}", case.name);
            assert!(case.applies_in(&case.configuration_near(Configuration::of(&base))));
        }
    }

    /// The re-arm rows: a second press 60 ms after the first is refused (the wheels still
    /// turn); one a second later re-arms the robot where it stopped, and it ends on the
    /// path.
    #[test]
    fn a_second_press_re_arms_only_at_rest_and_resumes_from_the_real_pose() {
        let scenario = Scenario::load("paper-circle").unwrap();
        for case in cases().into_iter().filter(|c| c.again_after_s.is_some()) {
            let r = run_near(&scenario, case);
            let Expectation::Rearm { armed_again, .. } = case.expect else {
                panic!("{}: a repeated press is a re-arm case", case.name);
            };
            assert!(r.passed, "{r:?}");
            assert_eq!(r.final_state == "Armed", armed_again, "{r:?}");
            if armed_again {
                assert!(r.report.distance_after_m > 1.0, "it drove on: {r:?}");
            }
            assert!(
                r.final_true_error_m.unwrap() <= REARM_FINAL_ERROR_M,
                "{r:?}"
            );
        }
    }

    /// The rows with a gyro: a failed gyro warns within its limit and the robot drives
    /// on; a wheel inverted with its encoder and lost ticks stop it by the disagreement;
    /// the same faults without a gyro go unseen.
    #[test]
    fn a_gyro_sees_what_odometry_cannot_and_its_own_failure_never_stops_the_robot() {
        let scenario = Scenario::load("paper-circle").unwrap();
        for case in cases().into_iter().filter(|c| {
            matches!(
                c.kind,
                FaultKind::TicksLost(..) | FaultKind::BothInverted(_)
            ) || c.heading == Some(Heading::Fused)
        }) {
            let r = run_near(&scenario, case);
            assert!(r.passed, "{r:?}");
            match case.expect {
                Expectation::Warn { .. } => {
                    // Drove on, back on odometry's heading, still on the path.
                    assert_eq!(r.final_state, "Armed", "{r:?}");
                    assert!(r.report.distance_after_m > 2.0, "{r:?}");
                    assert!(r.final_true_error_m.is_some_and(|e| e < 0.01), "{r:?}");
                }
                Expectation::Detect { .. } => {
                    assert_eq!(r.report.detected_by, ["heading_disagreement"], "{r:?}");
                }
                _ => assert!(!r.report.detected, "{r:?}"),
            }
        }
    }
}
