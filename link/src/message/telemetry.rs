//! What the robot streams: telemetry samples, the simulator's ground truth, statistics.

use controller_core::controller::MotorCommand;
use controller_core::gyro::GyroHealth;
use controller_core::kinematics::{BodyVelocity, Pose, TrackingError, WheelSpeeds};
use controller_core::supervisor::{Faults, RunMode, State};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

use crate::decoder::RxCounters;

/// One telemetry sample, taken at the end of control step `step`. About 130 bytes of
/// postcard (see the crate doc for the measured size).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub struct TelemetryFrame {
    /// Control step of the sample (since boot).
    pub step: u32,
    /// Supervisor state.
    pub state: State,
    /// Mode used when armed.
    pub run_mode: RunMode,
    /// Latched faults.
    pub faults: Faults,
    /// Odometry pose, world frame (m, rad).
    pub pose: Pose,
    /// Tracking error at the last steering update, robot frame (m, rad).
    pub tracking_error: TrackingError,
    /// The steering law's Lyapunov function V (dimensionless mix of m² and rad²).
    pub lyapunov: f32,
    /// Its rate V̇ predicted by the law, per s (≤ 0 when the proof holds).
    pub lyapunov_rate: f32,
    /// Wheel-speed set-points, rad/s.
    pub wheel_setpoint: WheelSpeeds,
    /// Measured wheel speeds, rad/s.
    pub wheel_speed: WheelSpeeds,
    /// Motor duties applied, each in [−1, 1].
    pub duty: MotorCommand,
    /// The left wheel PID's output, by part, V.
    pub pid_left: PidParts,
    /// The right wheel PID's output, by part, V.
    pub pid_right: PidParts,
    /// Measured supply (battery) voltage, V.
    pub supply_v: f32,
    /// Control ticks missed since boot (the loop was late).
    pub missed_ticks: u32,
    /// The gyro's yaw rate, robot frame, counter-clockwise positive, bias removed, rad/s
    /// (0 without a gyro).
    pub gyro_yaw_rate_radps: f32,
    /// The gyro's bias estimate, robot frame, rad/s.
    pub gyro_bias_radps: f32,
    /// The fused heading, world frame, wrapped to (−π, π], rad (odometry's without a
    /// gyro).
    pub fused_heading_rad: f32,
    /// The heading from the encoders alone, world frame, wrapped to (−π, π], rad.
    pub odometry_heading_rad: f32,
    /// The gyro's state (none, reading, failed and why).
    pub gyro_health: GyroHealth,
    /// The board's encoder counts since boot, before the robot's wiring corrections,
    /// armed or not (what a bring-up reads while a wheel is turned by hand or pulsed).
    pub raw_counts: RawCounts,
}

/// The board's two encoder inputs as positions since boot, counts (wrapping `i32`), before
/// the wiring corrections: `left` is the input the board labels left, whichever wheel is
/// on it, counting up when that encoder turns the way the board calls forward.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub struct RawCounts {
    /// The board's left encoder input, counts.
    pub left: i32,
    /// The board's right encoder input, counts.
    pub right: i32,
}

/// One wheel PID's output split into its parts, V. Their sum is the voltage asked of the
/// motor before saturation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
pub struct PidParts {
    /// Proportional part, V.
    pub p_v: f32,
    /// Integral part, V.
    pub i_v: f32,
    /// Derivative part, V.
    pub d_v: f32,
    /// Feed-forward part, V.
    pub ff_v: f32,
}

/// The simulated robot's true state at a step (the virtual robot only).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
pub struct GroundTruth {
    /// Control step of the sample.
    pub step: u32,
    /// True pose, world frame (m, rad).
    pub pose: Pose,
    /// True body velocity, robot frame (m/s, rad/s).
    pub velocity: BodyVelocity,
    /// True wheel speeds, rad/s.
    pub wheel_speed: WheelSpeeds,
}

/// Timing and link statistics since boot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub struct Stats {
    /// Longest control step, CPU cycles.
    pub max_step_cycles: u32,
    /// Control ticks missed (the loop was late).
    pub missed_ticks: u32,
    /// Control steps that overran their period.
    pub overruns: u32,
    /// Most stack ever used, bytes.
    pub stack_high_water_bytes: u32,
    /// The link's counters.
    pub link: LinkStats,
}

/// The robot's side of the link.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub struct LinkStats {
    /// What the robot's [`Decoder`](crate::Decoder) received and dropped.
    pub received: RxCounters,
    /// Frames the robot sent.
    pub frames_sent: u32,
    /// Telemetry frames not sent because the link had no room for them.
    pub telemetry_dropped: u32,
}
