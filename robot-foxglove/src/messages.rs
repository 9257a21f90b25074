//! The robot's own message types, `derive(foxglove::Encode)` structs of numbers that
//! Foxglove's Plot panel plots by message path (e.g. `/wheels.left.measured_rad_s`). The
//! SDK encodes them as protobuf, its schema written into the file, so any MCAP reader
//! with protobuf support decodes them. World frame for poses, robot frame for the
//! tracking errors (eq. 9).
//!
//! The derived schema follows the field order: a field is added at the end of its
//! struct, never moved or removed, so recorded files keep decoding.

use controller_core::pid::PidParts;
use controller_core::supervisor::{Fault, Faults, State};
use foxglove::Encode;

/// The tracking error (9) of one pose against the reference, robot frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Encode)]
pub struct TrackingErrorMessage {
    /// Along the robot's heading, m.
    pub x_e_m: f64,
    /// To the robot's left, m.
    pub y_e_m: f64,
    /// θ_r − θ, rad, wrapped to (−π, π].
    pub theta_e_rad: f64,
}

/// `/errors`: how far the robot is from its reference, and the law's Lyapunov function.
#[derive(Clone, Copy, Debug, Default, PartialEq, Encode)]
pub struct ErrorsMessage {
    /// The controller's error of its estimate at its last steering update.
    pub estimated: TrackingErrorMessage,
    /// The true pose's error against the independent reference (NaN without truth).
    pub truth: TrackingErrorMessage,
    /// Distance from the true pose to the reference, m (NaN without truth).
    pub true_position_m: f64,
    /// The true heading error θ_r − θ, rad (NaN without truth).
    pub true_heading_rad: f64,
    /// The steering law's Lyapunov function V.
    pub lyapunov_v: f64,
    /// Its rate V̇ predicted by the law, per s (≤ 0 when the proof holds).
    pub lyapunov_rate_per_s: f64,
}

/// A body velocity, robot frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Encode)]
pub struct BodyVelocityMessage {
    /// Forward speed, m/s.
    pub v_m_s: f64,
    /// Yaw rate, rad/s (+ counter-clockwise).
    pub omega_rad_s: f64,
}

/// `/body`: the commanded body velocity and the true one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Encode)]
pub struct BodyMessage {
    /// The command after the acceleration limit and the rim-speed cap.
    pub command: BodyVelocityMessage,
    /// The true body velocity (NaN without truth).
    pub truth: BodyVelocityMessage,
}

/// A wheel PID's output split into its parts, V; they add up to the voltage asked of
/// the motor before saturation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Encode)]
pub struct PidMessage {
    /// Proportional part, V.
    pub p_v: f64,
    /// Integral part, V.
    pub i_v: f64,
    /// Derivative part, V.
    pub d_v: f64,
    /// Feed-forward part, V.
    pub ff_v: f64,
}

impl From<PidParts> for PidMessage {
    fn from(parts: PidParts) -> Self {
        Self {
            p_v: f64::from(parts.p),
            i_v: f64::from(parts.i),
            d_v: f64::from(parts.d),
            ff_v: f64::from(parts.ff),
        }
    }
}

/// One wheel's loop.
#[derive(Clone, Copy, Debug, Default, PartialEq, Encode)]
pub struct WheelMessage {
    /// The wheel-speed set-point, rad/s.
    pub setpoint_rad_s: f64,
    /// The controller's speed estimate, rad/s.
    pub measured_rad_s: f64,
    /// The true wheel speed, rad/s (NaN without truth).
    pub true_rad_s: f64,
    /// The armature voltage the loop commanded, V.
    pub volts_v: f64,
    /// The duty sent to the bridge, −1…1.
    pub duty: f64,
    /// The PID's parts, V.
    pub pid: PidMessage,
}

/// `/wheels`: both wheel loops.
#[derive(Clone, Copy, Debug, Default, PartialEq, Encode)]
pub struct WheelsMessage {
    /// The left wheel.
    pub left: WheelMessage,
    /// The right wheel.
    pub right: WheelMessage,
}

/// The supervisor's state, as the core names it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Encode)]
pub enum SupervisorState {
    /// Motors off; waiting for a press, the link or auto-arm.
    #[default]
    Disarmed,
    /// The controller drives the motors.
    Armed,
    /// Motors off; faults latched until acknowledged.
    Faulted,
    /// Motors off while the firmware writes flash.
    Persisting,
}

impl From<State> for SupervisorState {
    fn from(state: State) -> Self {
        match state {
            State::Disarmed => Self::Disarmed,
            State::Armed => Self::Armed,
            State::Faulted => Self::Faulted,
            State::Persisting => Self::Persisting,
        }
    }
}

/// The latched faults, one flag each (the core's [`Fault`] names).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Encode)]
pub struct FaultsMessage {
    /// A tick delta implied an implausible wheel speed.
    pub encoder_jump: bool,
    /// A pose, command or duty became NaN or infinite.
    pub non_finite: bool,
    /// The control loop overran its period too often.
    pub overrun: bool,
    /// The control loop missed too many ticks.
    pub missed_ticks: bool,
    /// The left wheel did not follow its drive.
    pub stall_left: bool,
    /// The right wheel did not follow its drive.
    pub stall_right: bool,
    /// A wheel loop kept hitting its limits.
    pub saturated: bool,
    /// The tracking error stayed above its bound.
    pub divergence: bool,
    /// The estimated pose left the geofence.
    pub geofence: bool,
    /// The supply was below the battery's fault threshold.
    pub supply_low: bool,
    /// The supply was above what the bridge tolerates.
    pub supply_high: bool,
    /// An emergency stop was commanded.
    pub emergency_stop: bool,
    /// The gyro and odometry disagreed, configured to stop.
    pub heading_disagreement: bool,
}

impl From<Faults> for FaultsMessage {
    fn from(f: Faults) -> Self {
        Self {
            encoder_jump: f.has(Fault::EncoderJump),
            non_finite: f.has(Fault::NonFinite),
            overrun: f.has(Fault::Overrun),
            missed_ticks: f.has(Fault::MissedTicks),
            stall_left: f.has(Fault::StallLeft),
            stall_right: f.has(Fault::StallRight),
            saturated: f.has(Fault::Saturated),
            divergence: f.has(Fault::Divergence),
            geofence: f.has(Fault::Geofence),
            supply_low: f.has(Fault::SupplyLow),
            supply_high: f.has(Fault::SupplyHigh),
            emergency_stop: f.has(Fault::EmergencyStop),
            heading_disagreement: f.has(Fault::HeadingDisagreement),
        }
    }
}

/// `/supervisor`: the state, the supply and the latched faults.
#[derive(Clone, Copy, Debug, Default, PartialEq, Encode)]
pub struct SupervisorMessage {
    /// The supervisor's state.
    pub state: SupervisorState,
    /// The filtered supply the controller used, V.
    pub supply_v: f64,
    /// The latched faults.
    pub faults: FaultsMessage,
    /// True when any fault is latched.
    pub any_fault: bool,
}
