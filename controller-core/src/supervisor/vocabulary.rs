//! The words the supervisor speaks: its states and run modes, the operator's commands
//! and their refusals, the events it reports, what it reads each step ([`Inputs`]) and
//! what it decides ([`SupervisorOutput`]).

use core::num::NonZeroU32;

use super::{Faults, SupervisorConfigError};
use crate::controller::{MotorCommand, TickDeltas};
#[cfg(doc)]
use crate::gyro::GyroConfig;
use crate::gyro::{GyroFailure, GyroSample};
use crate::kinematics::{BodyVelocity, Pose, WheelSpeeds};
use crate::tune::TuneConfigError;

#[cfg(doc)]
use super::{Supervisor, SupervisorConfig, REST_SPEED_RAD_S, REST_STEPS};
#[cfg(doc)]
use crate::controller::Controller;

/// What the robot does while armed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum RunMode {
    /// Follow the controller's reference path from where the robot is: resumed where the
    /// last run stopped, or afresh after a new path or a pose command
    /// ([`Command::SetPose`]).
    FollowPath,
    /// Hold [`SupervisorConfig::hold_speeds`] with the wheel loops only (bring-up).
    HoldWheelSpeeds,
    /// Identify both wheels and compute their loops ([`crate::tune`]); disarms by itself
    /// when done ([`DisarmReason::TuneFinished`]), the outcome in
    /// [`Supervisor::tune_outcome`].
    Tune,
    /// Follow body-velocity commands ([`Command::Velocity`]) through the velocity mode's
    /// limits and timeout ([`crate::velocity`]): after the timeout the robot ramps to a
    /// stop and stays armed. Armed by a request ([`Command::Arm`], [`Supervisor::arm_locally`])
    /// only: not in the button's mode-select cycle, and the button and auto-arm arm
    /// [`RunMode::FollowPath`] when this mode was the last one.
    FollowVelocity,
    /// One motor pulse of a bring-up ([`Command::MotorTest`]): a set voltage on one wheel,
    /// the other at 0 V, for a bounded time, then disarmed ([`DisarmReason::Timeout`]).
    /// Never selected by the button.
    MotorTest,
}

impl RunMode {
    /// The mode a press held for the mode-select time selects after this one (see
    /// [`SupervisorConfig::long_press_steps`]): follow the path, hold wheel speeds, tune,
    /// and round again.
    pub const fn next(self) -> RunMode {
        match self.in_button_cycle() {
            RunMode::HoldWheelSpeeds => RunMode::Tune,
            RunMode::Tune | RunMode::MotorTest => RunMode::FollowPath,
            RunMode::FollowPath | RunMode::FollowVelocity => RunMode::HoldWheelSpeeds,
        }
    }

    /// The mode the button and auto-arm arm when this one was the last: itself, except
    /// [`RunMode::FollowVelocity`] (armed by request only), which gives
    /// [`RunMode::FollowPath`].
    pub const fn in_button_cycle(self) -> RunMode {
        match self {
            RunMode::FollowVelocity => RunMode::FollowPath,
            mode => mode,
        }
    }
}

/// The supervisor's state (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum State {
    /// Motors off; waiting for a press, the link or auto-arm.
    Disarmed,
    /// The controller drives the motors.
    Armed,
    /// Motors off; faults latched until acknowledged.
    Faulted,
    /// Motors off while the firmware writes flash.
    Persisting,
}

/// What the motor bridge does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum Bridge {
    /// Enabled, driving [`SupervisorOutput::duty`] (slow decay: 0 is a short brake).
    Drive,
    /// Enabled with both duties 0: the motors short-brake.
    Brake,
    /// In standby (TB6612 STBY / DRV8833 nSLEEP low): outputs off, the motors coast.
    Coast,
}

impl Bridge {
    /// Level of the bridge's enable line (STBY / nSLEEP): high unless coasting.
    pub const fn enabled(self) -> bool {
        !matches!(self, Bridge::Coast)
    }
}

/// Why the chip last reset, decoded from the reset-flag register (RCC_CSR on an STM32).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum ResetCause {
    /// Power-on reset.
    PowerOn,
    /// The supply dipped below the brown-out threshold while running: the battery sagged
    /// or a connector bounced. Never auto-arms: the robot is no longer where it started.
    BrownOut,
    /// The reset pin (NRST), e.g. the board's reset button or a debug probe.
    Pin,
    /// The independent or window watchdog: the control loop stalled.
    Watchdog,
    /// A software reset (`SCB::sys_reset`), e.g. after a fault handler.
    Software,
    /// A low-power-management reset.
    LowPower,
    /// No flag set.
    Unknown,
}

impl ResetCause {
    /// True for the resets a person causes on purpose (power-on, reset pin): the only
    /// ones after which [`SupervisorConfig::auto_arm_after_steps`] may arm the motors.
    pub const fn allows_auto_arm(self) -> bool {
        matches!(self, ResetCause::PowerOn | ResetCause::Pin)
    }
}

/// Why the robot left [`State::Armed`] without a fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum DisarmReason {
    /// The button was pressed.
    Button,
    /// The link asked.
    Link,
    /// The run's time limit ran out: [`ArmRequest::max_armed_steps`], or
    /// [`SupervisorConfig::max_armed_steps`] when the request had none.
    Timeout,
    /// The link armed the robot and then fell silent for
    /// [`SupervisorConfig::heartbeat_timeout_steps`].
    LinkLost,
    /// A tune ended, with a result or the reason it stopped
    /// ([`Supervisor::tune_outcome`]).
    TuneFinished,
}

/// A state change, reported once in the step it happened (for the log).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum Event {
    /// Motors armed in this mode.
    Armed(RunMode),
    /// Motors disarmed.
    Disarmed(DisarmReason),
    /// A fault stopped the motors; the flags are in [`SupervisorOutput::faults`].
    Faulted,
    /// The faults were acknowledged; the robot is Disarmed.
    FaultsCleared,
    /// A press held for the mode-select time selected this mode for the next arming.
    ModeSelected(RunMode),
    /// The supply fell below the battery's warning threshold.
    BatteryLow,
    /// Entered [`State::Persisting`].
    PersistStarted,
    /// Left [`State::Persisting`].
    PersistEnded,
    /// The pose was set: by the link's [`Command::SetPose`], or by a long press while
    /// disarmed (to [`SupervisorConfig::start_pose`]).
    PoseSet,
    /// A short press did not arm, for this reason (the link's refusals come in its
    /// reply).
    ArmRefused(CommandRefusal),
    /// A warning: the gyro failed this way, and the heading follows odometry until the
    /// supervisor's faults are next cleared or the robot restarts.
    GyroFailed(GyroFailure),
    /// A warning: armed, the gyro's and odometry's yaw rates disagree beyond
    /// [`GyroConfig::disagreement_threshold_radps`] (the track width, a wheel radius, slip
    /// or a wheel's wiring is not what odometry assumes).
    GyroDisagrees,
}

/// How to arm.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct ArmRequest {
    /// What to do once armed.
    pub mode: RunMode,
    /// Wheel speeds to hold (rad/s) instead of [`SupervisorConfig::hold_speeds`], in
    /// [`RunMode::HoldWheelSpeeds`].
    pub hold_speeds: Option<WheelSpeeds>,
    /// The motion (v m/s, ω rad/s, robot frame) the operator asserts the robot already
    /// has, for a run that starts in motion ([`Controller::seed_motion`]). Without it the
    /// wheels must be at rest ([`CommandRefusal::WheelsTurning`]).
    pub initial_motion: Option<BodyVelocity>,
    /// This run's time limit: disarm after this many steps armed, the step that arms
    /// among them, instead of [`SupervisorConfig::max_armed_steps`], for this run only
    /// (`None`: the stored setting).
    pub max_armed_steps: Option<u32>,
}

impl ArmRequest {
    /// Arm into path following from rest.
    pub const fn follow_path() -> Self {
        Self {
            mode: RunMode::FollowPath,
            hold_speeds: None,
            initial_motion: None,
            max_armed_steps: None,
        }
    }
}

/// An operator command from the link (or a simulation's script).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum Command {
    /// Arm (from Disarmed only).
    Arm(ArmRequest),
    /// Disarm.
    Disarm,
    /// Stop now and latch a fault until acknowledged.
    EmergencyStop,
    /// Acknowledge the faults (from Faulted only).
    ClearFaults,
    /// The link is alive.
    Heartbeat,
    /// Enter [`State::Persisting`] (from Disarmed only).
    BeginPersist,
    /// Leave [`State::Persisting`].
    EndPersist,
    /// The robot is at this pose (world frame, the path's; from Disarmed only): see
    /// [`Supervisor::set_pose`].
    SetPose(Pose),
    /// A body-velocity command (v m/s, ω rad/s, robot frame), only while Armed in
    /// [`RunMode::FollowVelocity`] ([`CommandRefusal::WrongState`],
    /// [`CommandRefusal::WrongMode`] otherwise) and only finite
    /// ([`CommandRefusal::NonFiniteVelocity`]): in force from this step for the velocity
    /// mode's timeout ([`Controller::command_velocity`]). Not a heartbeat.
    Velocity(BodyVelocity),
    /// One motor pulse (from Disarmed only, the wheels at rest): armed in
    /// [`RunMode::MotorTest`], every fault check in force and the button stopping it.
    MotorTest(MotorTestRequest),
}

/// Largest |voltage| of a motor pulse, V ([`MotorTestRequest::volts`]).
pub const MOTOR_TEST_MAX_VOLTS: f32 = 3.0;
/// Longest motor pulse, ms ([`MotorTestRequest::steps`] at the control rate).
pub const MOTOR_TEST_MAX_MS: u32 = 500;

/// A wheel of the robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum Wheel {
    /// The left wheel.
    Left,
    /// The right wheel.
    Right,
}

/// One motor pulse of a bring-up: `volts` on `wheel`'s motor (through the robot's wiring
/// corrections, like every duty), 0 V on the other, for `steps` control steps.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct MotorTestRequest {
    /// The wheel whose motor is pulsed.
    pub wheel: Wheel,
    /// The armature voltage, V, forward positive: finite, |volts| ≤
    /// [`MOTOR_TEST_MAX_VOLTS`] (and the motor's rating, as every voltage the loop
    /// applies).
    pub volts: f32,
    /// How long, control steps armed (the step that arms among them): 1 … the steps of
    /// [`MOTOR_TEST_MAX_MS`].
    pub steps: u32,
}

impl MotorTestRequest {
    /// The request's fault, if any, at a control rate of `rate_hz` (Hz): the voltage or
    /// the duration out of its bounds.
    pub fn check(&self, rate_hz: u32) -> Result<(), CommandRefusal> {
        let max_steps = (u64::from(rate_hz) * u64::from(MOTOR_TEST_MAX_MS) / 1000) as u32;
        let volts_ok =
            self.volts.is_finite() && crate::math::abs(self.volts) <= MOTOR_TEST_MAX_VOLTS;
        if volts_ok && self.steps >= 1 && self.steps <= max_steps {
            Ok(())
        } else {
            Err(CommandRefusal::MotorTestOutOfBounds)
        }
    }
}

/// Why a [`Command`] was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum CommandRefusal {
    /// Not in this state (e.g. arming while Armed, Faulted or Persisting).
    WrongState(State),
    /// The button is held: the local kill wins over the link.
    ButtonHeld,
    /// Arming from rest while a wheel still turns: both measured wheel speeds must have
    /// stayed below [`REST_SPEED_RAD_S`] for [`REST_STEPS`] steps, unless the request
    /// asserts the motion ([`ArmRequest::initial_motion`]).
    WheelsTurning,
    /// A pose with a NaN or infinite field.
    NonFinitePose,
    /// Armed, but in this mode: a velocity command needs [`RunMode::FollowVelocity`].
    WrongMode(RunMode),
    /// A velocity command with a NaN or infinite field.
    NonFiniteVelocity,
    /// A motor pulse above [`MOTOR_TEST_MAX_VOLTS`] or longer than [`MOTOR_TEST_MAX_MS`]
    /// (or of no steps, or a voltage that is not finite).
    MotorTestOutOfBounds,
}

impl core::fmt::Display for CommandRefusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            CommandRefusal::WrongState(state) => write!(f, "not possible while {state:?}"),
            CommandRefusal::ButtonHeld => f.write_str("the robot's button is held (local stop)"),
            CommandRefusal::WheelsTurning => f.write_str(
                "the wheels are still turning: arming waits until both have stood still",
            ),
            CommandRefusal::NonFinitePose => f.write_str("the pose must be finite"),
            CommandRefusal::WrongMode(mode) => {
                write!(f, "armed in {mode:?}, not in the velocity mode")
            }
            CommandRefusal::NonFiniteVelocity => f.write_str("the velocity command must be finite"),
            CommandRefusal::MotorTestOutOfBounds => write!(
                f,
                "a motor pulse is at most {MOTOR_TEST_MAX_VOLTS} V and {MOTOR_TEST_MAX_MS} ms"
            ),
        }
    }
}

impl core::error::Error for CommandRefusal {}

/// What the firmware reads each step, besides the controller.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Inputs {
    /// Encoder ticks since the previous step, forward positive.
    pub ticks: TickDeltas,
    /// Control periods since the previous step (1 on time).
    pub periods: NonZeroU32,
    /// Measured supply voltage, V.
    pub supply_v: f32,
    /// Raw (undebounced) button level, true while pressed.
    pub button_pressed: bool,
    /// True when the previous step was still running when this period began.
    pub overrun: bool,
    /// A counter the background work increments (any change proves it runs).
    pub background_heartbeat: u32,
    /// A command from the link, at most one per step.
    pub command: Option<Command>,
    /// The gyro's newest reading, if one arrived since the previous step (`None`: no IMU,
    /// or no new reading).
    pub gyro: Option<GyroSample>,
}

impl Inputs {
    /// A quiet, on-time step at rest on a supply of `supply_v` (V).
    pub const fn at_supply(supply_v: f32) -> Self {
        Self {
            ticks: TickDeltas { left: 0, right: 0 },
            periods: NonZeroU32::MIN,
            supply_v,
            button_pressed: false,
            overrun: false,
            background_heartbeat: 0,
            command: None,
            gyro: None,
        }
    }
}

/// What the supervisor decided in one step.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SupervisorOutput {
    /// Duties to write now, each in [−1, 1]; exactly 0 unless Armed.
    pub duty: MotorCommand,
    /// What the bridge does (drive, brake, coast).
    pub bridge: Bridge,
    /// Feed the watchdog in this step (see the module doc for the rule).
    pub feed_watchdog: bool,
    /// State after this step.
    pub state: State,
    /// Mode used when armed.
    pub run_mode: RunMode,
    /// Latched faults.
    pub faults: Faults,
    /// The supply is below the battery's warning threshold.
    pub battery_low: bool,
    /// Overrun steps since boot (saturating).
    pub overruns_total: u32,
    /// Missed control ticks since boot (saturating).
    pub missed_ticks_total: u32,
    /// The state change of this step, if any. When two happen in one step (the button's,
    /// then the link's command), the later one: the change that led to [`Self::state`].
    pub event: Option<Event>,
    /// The outcome of this step's [`Inputs::command`], if there was one.
    pub command_result: Option<Result<(), CommandRefusal>>,
    /// The controller's duties of this step, before the supervisor zeroed anything (its
    /// telemetry is [`Controller::telemetry`]).
    pub controller_duty: MotorCommand,
}

/// Why [`Supervisor::set_config`] or [`Supervisor::set_tune_config`] refused new
/// settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SupervisorSetError {
    /// Only while Disarmed.
    NotDisarmed(State),
    /// The settings are invalid.
    Invalid(SupervisorConfigError),
    /// The tune's settings are invalid.
    InvalidTune(TuneConfigError),
}

impl core::fmt::Display for SupervisorSetError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SupervisorSetError::NotDisarmed(state) => {
                write!(
                    f,
                    "new settings are taken only while disarmed, not {state:?}"
                )
            }
            SupervisorSetError::Invalid(_) => f.write_str("the supervisor settings are invalid"),
            SupervisorSetError::InvalidTune(_) => f.write_str("the tune's settings are invalid"),
        }
    }
}

impl core::error::Error for SupervisorSetError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            SupervisorSetError::NotDisarmed(_) => None,
            SupervisorSetError::Invalid(e) => Some(e),
            SupervisorSetError::InvalidTune(e) => Some(e),
        }
    }
}
