//! Telemetry frames for the station's unit tests.

use controller_core::kinematics::Pose;
use controller_core::supervisor::{RunMode, State};
use link::TelemetryFrame;

/// A disarmed robot at rest at the origin, at control step `step`.
pub fn still(step: u32) -> TelemetryFrame {
    TelemetryFrame {
        step,
        state: State::Disarmed,
        run_mode: RunMode::FollowPath,
        faults: Default::default(),
        pose: Pose::new(0.0, 0.0, 0.0),
        tracking_error: Default::default(),
        lyapunov: 0.0,
        lyapunov_rate: 0.0,
        wheel_setpoint: Default::default(),
        wheel_speed: Default::default(),
        duty: controller_core::controller::MotorCommand::STOP,
        pid_left: Default::default(),
        pid_right: Default::default(),
        supply_v: 6.0,
        missed_ticks: 0,
        gyro_yaw_rate_radps: 0.0,
        gyro_bias_radps: 0.0,
        fused_heading_rad: 0.0,
        odometry_heading_rad: 0.0,
        gyro_health: Default::default(),
        raw_counts: Default::default(),
    }
}
