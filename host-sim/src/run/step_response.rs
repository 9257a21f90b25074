//! The wheel-speed loop alone: a set-point step from rest on both wheels through the
//! supervisor's hold mode, and its rise, overshoot, settling and steady-state error.
//!
//! Contract: the robot warms its supply filter up for 50 steps at rest, then arms in
//! [`RunMode::HoldWheelSpeeds`]; the response is the left wheel's true speed at every
//! control step of `duration_s`.

use controller_core::prelude::*;
use controller_core::supervisor::{ArmRequest, RunMode};
use robot_files::scenario::Scenario;

use super::{step, LocalRobot, RobotLogic, RunError};
use crate::hardware::SimHardware;

/// The wheel-speed loop's response to a set-point step, from rest (both wheels).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepResponse {
    /// Set-point, rad/s.
    pub setpoint_rad_s: f64,
    /// Samples every control step: (t s, true left wheel speed rad/s, estimated left wheel
    /// speed rad/s, left duty).
    pub samples: Vec<(f64, f64, f64, f64)>,
    /// 10 → 90 % rise time of the true speed, s (`None` if 90 % is never reached).
    pub rise_time_s: Option<f64>,
    /// Peak overshoot above the set-point, % of the set-point.
    pub overshoot_pct: f64,
    /// Time after which the true speed stays within ±5 % of the set-point, s.
    pub settling_time_s: Option<f64>,
    /// Mean true speed over the last 20 % of the run minus the set-point, rad/s.
    pub steady_state_error_rad_s: f64,
}

/// Holds both wheels at `setpoint_rad_s` (rad/s) from rest with the wheel loops only
/// (armed in hold mode through the supervisor) for `duration_s` (s), on `scenario`'s
/// robot and plant. The robot drives straight; the response is the left wheel's.
pub fn wheel_step_response(
    scenario: &Scenario,
    setpoint_rad_s: f64,
    duration_s: f64,
) -> Result<StepResponse, RunError> {
    let max_s =
        robot_files::scenario::MAX_CONTROL_STEPS / f64::from(scenario.robot.control_rate_hz);
    if !(duration_s > 0.0 && duration_s <= max_s.min(robot_files::scenario::MAX_DURATION_S)) {
        return Err(RunError::Argument {
            name: "duration_s",
            rule: "must be > 0 and within the scenario's step and time limits",
            value: duration_s,
        });
    }
    if !setpoint_rad_s.is_finite() {
        return Err(RunError::Argument {
            name: "setpoint_rad_s",
            rule: "must be finite",
            value: setpoint_rad_s,
        });
    }
    let mut robot = LocalRobot::new(scenario, LawKind::Tracking)?;
    let mut hardware = SimHardware::new(scenario, &[])?;
    let sp = setpoint_rad_s as f32;
    // Warm the supply filter up before the step, as a robot that has been on for a while.
    for _ in 0..50 {
        step(&mut robot, &mut hardware)?;
    }
    let start = hardware.period();
    let request = ArmRequest {
        mode: RunMode::HoldWheelSpeeds,
        hold_speeds: Some(WheelSpeeds::new(sp, sp)),
        initial_motion: None,
        max_armed_steps: None,
    };
    if !robot.arm_locally(request) {
        return Err(RunError::Argument {
            name: "scenario",
            rule: "must let the robot arm",
            value: 0.0,
        });
    }
    let rate = f64::from(scenario.robot.control_rate_hz);
    let steps = (duration_s * rate).round() as u64;
    let mut samples = Vec::with_capacity(steps as usize);
    while hardware.period() < start + steps {
        let k = hardware.period() - start;
        let decision = step(&mut robot, &mut hardware)?;
        let measured = decision.telemetry.map_or(0.0, |t| t.wheel_speed.left_rad_s);
        let duty = decision.out.duty.left;
        samples.push((
            k as f64 / rate,
            hardware.plant().wheel_speeds()[0],
            f64::from(measured),
            f64::from(duty),
        ));
    }
    let target = setpoint_rad_s;
    let first_at = |fraction: f64| {
        samples
            .iter()
            .find(|s| s.1 * target.signum() >= fraction * target.abs())
            .map(|s| s.0)
    };
    let rise_time_s = match (first_at(0.1), first_at(0.9)) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    let peak = samples
        .iter()
        .map(|s| s.1 * target.signum())
        .fold(0.0f64, f64::max);
    let band = 0.05 * target.abs();
    let settling_time_s = match samples.iter().rposition(|s| (s.1 - target).abs() > band) {
        None => Some(0.0),
        Some(i) => samples.get(i + 1).map(|s| s.0),
    };
    let tail = &samples[samples.len() * 4 / 5..];
    let mean = tail.iter().map(|s| s.1).sum::<f64>() / tail.len().max(1) as f64;
    Ok(StepResponse {
        setpoint_rad_s,
        rise_time_s,
        overshoot_pct: if target != 0.0 {
            ((peak - target.abs()) / target.abs() * 100.0).max(0.0)
        } else {
            0.0
        },
        settling_time_s,
        steady_state_error_rad_s: mean - target,
        samples,
    })
}
