//! What each injected fault did ([`FaultReport`]): whether and when the supervisor
//! stopped the robot, and by which detector, when the duties reached 0 and the wheels
//! stopped, and how far the robot drove after the injection.
//!
//! Contract: observed at every control step of the run, from the supervisor's outcome
//! and the plant's truth only; detection is the first fault or disarm event at or after
//! the injection, and its warning the first gyro warning event at or after it.

use controller_core::prelude::*;
use controller_core::supervisor::{Bridge, Event, SupervisorOutput};
use robot_files::faults::Fault;
use robot_files::metrics::{fault_names, FaultReport};
use robot_files::truth::TruePose;

/// What happened after each injected fault (see [`FaultReport`]).
pub(super) struct FaultWatch {
    fault: Fault,
    pub(super) report: FaultReport,
    last_position: (f64, f64),
}

impl FaultWatch {
    pub(super) fn new(fault: Fault, rate_hz: f64) -> Self {
        Self {
            report: FaultReport {
                fault: fault.kind.name().to_string(),
                injected_s: fault.at_step as f64 / rate_hz,
                detected: false,
                detected_s: None,
                latency_s: None,
                detected_by: Vec::new(),
                motors_zero_s: None,
                wheels_stopped_s: None,
                distance_after_m: 0.0,
                warning: None,
                warning_latency_s: None,
            },
            fault,
            last_position: (0.0, 0.0),
        }
    }

    /// One step at period `period` (time `t_s`) whose outcome is `out`, with the true
    /// pose `pose` and wheel speeds `wheels`.
    pub(super) fn observe(
        &mut self,
        period: u64,
        t_s: f64,
        out: &SupervisorOutput,
        pose: &TruePose,
        wheels: [f64; 2],
    ) {
        if period < self.fault.at_step {
            self.last_position = (pose.x_m, pose.y_m);
            return;
        }
        let r = &mut self.report;
        r.distance_after_m +=
            (pose.x_m - self.last_position.0).hypot(pose.y_m - self.last_position.1);
        self.last_position = (pose.x_m, pose.y_m);
        if !r.detected {
            let stopped_by = match out.event {
                Some(Event::Faulted) => Some(
                    fault_names(&out.faults)
                        .iter()
                        .map(|s| (*s).to_string())
                        .collect(),
                ),
                Some(Event::Disarmed(reason)) => Some(vec![format!("disarmed: {reason:?}")]),
                _ => None,
            };
            if let Some(by) = stopped_by {
                r.detected = true;
                r.detected_s = Some(t_s);
                r.latency_s = Some(t_s - r.injected_s);
                r.detected_by = by;
            }
        }
        if r.warning.is_none() {
            let warning = match out.event {
                Some(Event::GyroFailed(failure)) => Some(format!("gyro failed: {failure:?}")),
                Some(Event::GyroDisagrees) => Some("gyro disagrees with odometry".to_string()),
                _ => None,
            };
            if let Some(w) = warning {
                r.warning = Some(w);
                r.warning_latency_s = Some(t_s - r.injected_s);
            }
        }
        if r.motors_zero_s.is_none()
            && out.duty == MotorCommand::STOP
            && out.bridge != Bridge::Drive
        {
            r.motors_zero_s = Some(t_s);
        }
        if r.motors_zero_s.is_some()
            && r.wheels_stopped_s.is_none()
            && wheels[0].abs() < 0.1
            && wheels[1].abs() < 0.1
        {
            r.wheels_stopped_s = Some(t_s);
        }
    }
}
