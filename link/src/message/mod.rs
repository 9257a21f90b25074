//! The messages: what the host asks ([`Downlink`] = `seq` + [`Request`]) and what the
//! robot sends back ([`Uplink`]: replies, telemetry, events, statistics).
//!
//! Every request gets exactly one [`Uplink::Reply`] carrying the request's `seq` and
//! either a [`Reply`] or a [`Refusal`]:
//!
//! | request | reply when accepted |
//! |---|---|
//! | [`Request::Info`] | [`Reply::Info`] |
//! | [`Request::Ping`] | [`Reply::Pong`] with the same nonce |
//! | [`Request::GetParams`] | [`Reply::Params`] |
//! | [`Request::SetParams`] | [`Reply::ParamsApplied`] with the new [`params_hash`](crate::params_hash) |
//! | [`Request::PathChunk`] | [`Reply::PathChunkStored`] |
//! | [`Request::PathCommit`] | [`Reply::PathCommitted`] |
//! | [`Request::GetStats`] | [`Reply::Stats`] |
//! | [`Request::GetRunReport`] | [`Reply::RunReport`] |
//! | [`Request::GetTuneReport`] | [`Reply::TuneReport`] |
//! | [`Request::Arm`] | [`Reply::Ack`]; refused while a wheel still turns unless it asserts the motion ([`NotPermitted::WheelsTurning`]) |
//! | [`Request::SetPose`] | [`Reply::Ack`]; only while disarmed, every field finite |
//! | [`Request::GetPanicRecord`] | [`Reply::PanicRecord`] |
//! | every other request | [`Reply::Ack`] |
//!
//! The other [`Uplink`] messages are sent by the robot on its own: [`Uplink::Telemetry`]
//! at the rate set by [`Request::SetTelemetryRate`], [`Uplink::Event`] on each supervisor
//! state change, [`Uplink::GroundTruth`] from the simulator only, [`Uplink::Stats`]
//! whenever the robot chooses, [`Uplink::VersionMismatch`] in answer to a frame whose
//! header names another protocol, [`Uplink::RunReport`] when a path-following run ends
//! (its metrics computed on the robot at the control rate, see [`RunReport`]) and, from
//! the simulator only, [`Uplink::GroundTruthRun`] with the true metrics of that run, and
//! [`Uplink::TuneReport`] when a wheel-loop tune ([`ArmMode::Tune`]) ends.
//!
//! **Compatibility:** the wire encoding of an enum is its variant's index. New variants
//! and fields go at the end; any change of shape changes
//! [`SCHEMA_HASH`](crate::SCHEMA_HASH), and peers with different hashes refuse each
//! other's frames (see [`protocol`](crate::protocol)).

mod board;
mod path;
mod refusal;
mod run;
mod telemetry;

use controller_core::kinematics::{BodyVelocity, WheelSpeeds};
use controller_core::params::RobotConfig;
use controller_core::supervisor::{Event, SupervisorConfig};
pub use controller_core::supervisor::{ResetCause, Wheel, MOTOR_TEST_MAX_MS, MOTOR_TEST_MAX_VOLTS};
use heapless::String;
use postcard_schema::Schema;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

pub use self::board::{
    BridgeChip, BrownOutReset, ClockSource, FailureKind, PanicReport, LI_ION_CELL_FULL_V,
    PANIC_FILE_CAP, PANIC_MESSAGE_CAP,
};
pub use self::path::{CommitSummary, PathBegin, PathChunk, PathCommit, SEGMENTS_PER_CHUNK};
pub use self::refusal::{FieldProblem, NotPermitted, PathProblem, Refusal, FIELD_CAP, PROBLEM_CAP};
pub use self::run::{ErrorSummary, RunReport, TrueRunReport, TuneReport};
pub use self::telemetry::{GroundTruth, LinkStats, PidParts, RawCounts, Stats, TelemetryFrame};
use crate::protocol::ProtocolId;

/// Capacity of [`RobotInfo::firmware_version`], bytes of UTF-8.
pub const VERSION_CAP: usize = 16;
/// Capacity of [`RobotInfo::git_hash`], bytes of UTF-8 (a 12-digit hash plus `-dirty`).
pub const GIT_HASH_CAP: usize = 20;
/// Capacity of [`RobotInfo::chip`] and [`RobotInfo::robot_name`], bytes of UTF-8.
pub const NAME_CAP: usize = 24;

/// How long a host waits for the reply to [`Request::PersistParams`], ms. The robot
/// replies once the sector is erased and the record programmed and read back: 2 s at most
/// for the erase of a 128 KiB STM32F4 sector, a few ms for the rest (robot-app's tests
/// check this against its flash figures).
pub const PERSIST_REPLY_TIMEOUT_MS: u32 = 3_000;

/// A top-level message type of the link: [`Downlink`] or [`Uplink`]. Sealed: the schema
/// hash covers exactly these two.
pub trait Message: Serialize + DeserializeOwned + Schema + sealed::Sealed {}

mod sealed {
    pub trait Sealed {}
    impl Sealed for super::Downlink {}
    impl Sealed for super::Uplink {}
}

impl Message for Downlink {}
impl Message for Uplink {}

/// Host → robot: one request and the sequence number its reply echoes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub struct Downlink {
    /// Chosen by the host (typically incremented per request, wrapping); echoed in
    /// [`Uplink::Reply::seq`].
    pub seq: u16,
    /// What is asked.
    pub request: Request,
}

/// What the host asks the robot. See the module doc for the reply each one gets.
// The configuration makes one variant large; there is no heap to box it on the robot,
// which decodes a request out of line and handles it by reference.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub enum Request {
    /// Who are you: protocol, firmware, chip, robot and active parameters.
    Info,
    /// Echo `nonce` back ([`Reply::Pong`]).
    Ping {
        /// Any value; the reply carries it back.
        nonce: u32,
    },
    /// The whole active configuration ([`Reply::Params`]).
    GetParams,
    /// Replace the configuration. The robot validates it with the core's `Params::new`
    /// and `SupervisorConfig::validate` ([`Refusal::InvalidParams`]) and refuses while
    /// armed ([`Refusal::Armed`]). Not persisted until [`Request::PersistParams`].
    SetParams(ParamSet),
    /// Save the active configuration to flash; only while disarmed, and only on a robot
    /// whose brown-out reset guards its flash writes ([`RobotInfo::brown_out_reset`];
    /// otherwise [`NotPermitted::BrownOutResetOff`]). The reply comes once the flash is
    /// written and read back, within [`PERSIST_REPLY_TIMEOUT_MS`] (the erase stalls the
    /// robot's CPU, so bytes sent meanwhile may be lost): send it once and wait that long. A repeat of the same `seq` is answered with the reply the robot
    /// kept, never with a second write.
    PersistParams,
    /// Start a path upload (see [`PathAssembler`](crate::PathAssembler)); only while
    /// disarmed.
    PathBegin(PathBegin),
    /// Some segments of the upload begun with the same `upload_id`.
    PathChunk(PathChunk),
    /// Check and activate the upload atomically; only while disarmed.
    PathCommit(PathCommit),
    /// Arm the motors.
    Arm {
        /// What to do while armed.
        mode: ArmMode,
        /// "Arm in motion": the operator asserts the robot is already moving at this body
        /// velocity (robot frame, m/s and rad/s), so the controller and its limiter start
        /// from it instead of from rest (simulations that start in motion). `None`: at
        /// rest, and the wheels must be at rest (refused with
        /// [`NotPermitted::WheelsTurning`] while either still turns).
        initial_motion: Option<BodyVelocity>,
        /// This run's time limit, control steps armed (the step that arms among them):
        /// it overrides the supervisor's stored `max_armed_steps` for this run only, so
        /// a host that sets a run's length changes no setting. `None`: the stored one.
        run_time_limit_steps: Option<u32>,
    },
    /// Disarm (motors off, driver disabled).
    Disarm,
    /// Stop now, whatever the state: disarm and zero the motors. Always accepted.
    EmergencyStop,
    /// Acknowledge latched faults (the robot is then disarmed).
    ClearFaults,
    /// Keep-alive. The robot disarms when heartbeats stop for its configured timeout
    /// (counted in control steps); the reply lets the host measure the round trip.
    Heartbeat,
    /// Telemetry frames per second, 1…100 ([`TELEMETRY_RATE_HZ`](crate::TELEMETRY_RATE_HZ);
    /// refused otherwise with [`Refusal::InvalidArgument`]).
    SetTelemetryRate {
        /// Rate, Hz.
        hz: u8,
    },
    /// Timing and link statistics ([`Reply::Stats`]).
    GetStats,
    /// The report of the last path-following run ([`Reply::RunReport`]); the robot also
    /// sends it unasked when a run ends ([`Uplink::RunReport`]).
    GetRunReport,
    /// The outcome of the last wheel-loop tune ([`Reply::TuneReport`]); the robot also
    /// sends it unasked when a tune ends ([`Uplink::TuneReport`]).
    GetTuneReport,
    /// The pose command: the robot is at this pose now (world frame, the path's; m, m,
    /// rad). Only while disarmed ([`Refusal::Armed`], [`Refusal::Faulted`]); a field that
    /// is not finite is refused by name ([`Refusal::InvalidArgument`]). It sets the
    /// odometry's pose, its fixed-point heading with it; a heading fused from a gyro is
    /// set by this same command (the gyro's bias is not: it belongs to the sensor). The
    /// pose is never set otherwise: arming keeps it, and the next path-following run
    /// starts its reference afresh from it.
    SetPose {
        /// x, m.
        x_m: f32,
        /// y, m.
        y_m: f32,
        /// Heading θ, rad, counter-clockwise from +x.
        theta_rad: f32,
    },
    /// The record of the panic or hard fault that ended a previous run
    /// ([`Reply::PanicRecord`]; `None` when there is none). Reading does not clear it: the
    /// robot keeps it, across resets too, until [`Request::ClearPanicRecord`].
    GetPanicRecord,
    /// Forget the panic record (once a host has shown it). Always accepted.
    ClearPanicRecord,
    /// A body-velocity command for the velocity mode ([`ArmMode::FollowVelocity`]), the
    /// `cmd_vel` of ROS 2's `diff_drive_controller`: forward speed `v_m_s` (m/s) and yaw
    /// rate `omega_rad_s` (rad/s, counter-clockwise positive), robot frame.
    ///
    /// **Streamed, not transacted.** The host sends one about every 50 ms while it wants
    /// the robot to move, and never repeats one: each replaces the last, so a lost or late
    /// one costs nothing but its 50 ms. The reply ([`Reply::Ack`], or why not) is there
    /// for a host that wants to see refusals; nothing waits for it, and its `seq` matters
    /// to no one. The robot takes each at the next control step and the limited command
    /// starts moving towards it in that step.
    ///
    /// **Timeout.** A command holds for the robot's `cmd_vel_timeout`
    /// (`RobotConfig::velocity.cmd_vel_timeout_steps`, 0.5 s by default) after it arrived;
    /// then the robot ramps to a stop within its acceleration and jerk limits and stays
    /// armed. The limits are `RobotConfig::velocity`'s `linear_x` and `angular_z`
    /// (`diff_drive_controller`'s `linear.x.*`, `angular.z.*`: velocity, acceleration,
    /// jerk), then the rim-speed cap, which keeps ω/v.
    ///
    /// **Not a heartbeat.** A host that armed the robot keeps sending
    /// [`Request::Heartbeat`] as in every mode; a host that stops both sees the robot stop
    /// by the timeout and then disarm when the heartbeat timeout runs out.
    ///
    /// Refused ([`NotPermitted::NotInVelocityMode`]) unless the robot is armed in the
    /// velocity mode; a field that is not finite is refused by name
    /// ([`Refusal::InvalidArgument`]).
    Velocity {
        /// Forward speed v, robot frame, m/s.
        v_m_s: f32,
        /// Yaw rate ω, rad/s, counter-clockwise positive.
        omega_rad_s: f32,
    },
    /// One motor pulse of a bring-up, the wheels lifted: `volts` on `wheel`'s motor (0 V
    /// on the other) for `duration_ms`, run as a short armed mode (the core's
    /// `RunMode::MotorTest`: every fault check applies, the button stops it), then
    /// disarmed ([`Uplink::Event`] `Armed(MotorTest)`, then `Disarmed(Timeout)`). The
    /// encoders' answer is in the telemetry ([`TelemetryFrame::raw_counts`]). Only from
    /// Disarmed ([`Refusal::Armed`], [`Refusal::Faulted`], [`Refusal::Busy`]) with the
    /// wheels at rest ([`NotPermitted::WheelsTurning`]); `confirm` must be
    /// [`MOTOR_TEST_CONFIRMATION`] ([`NotPermitted::MotorTestUnconfirmed`]); |`volts`| ≤
    /// [`MOTOR_TEST_MAX_VOLTS`] and 1 ≤ `duration_ms` ≤ [`MOTOR_TEST_MAX_MS`], each
    /// refused by name otherwise ([`Refusal::InvalidArgument`]).
    MotorTest {
        /// The wheel whose motor is pulsed (through the robot's wiring corrections).
        wheel: Wheel,
        /// Armature voltage, V, forward positive.
        volts: f32,
        /// Length of the pulse, ms.
        duration_ms: u16,
        /// [`MOTOR_TEST_CONFIRMATION`]: the host says the wheels are off the ground.
        confirm: u32,
    },
}

/// The value of [`Request::MotorTest`]'s `confirm`: the bytes `LIFT`, little-endian.
pub const MOTOR_TEST_CONFIRMATION: u32 = u32::from_le_bytes(*b"LIFT");

impl Request {
    /// The request's name, for logs (`"SetParams"`, …).
    pub const fn name(&self) -> &'static str {
        match self {
            Request::Info => "Info",
            Request::Ping { .. } => "Ping",
            Request::GetParams => "GetParams",
            Request::SetParams(_) => "SetParams",
            Request::PersistParams => "PersistParams",
            Request::PathBegin(_) => "PathBegin",
            Request::PathChunk(_) => "PathChunk",
            Request::PathCommit(_) => "PathCommit",
            Request::Arm { .. } => "Arm",
            Request::Disarm => "Disarm",
            Request::EmergencyStop => "EmergencyStop",
            Request::ClearFaults => "ClearFaults",
            Request::Heartbeat => "Heartbeat",
            Request::SetTelemetryRate { .. } => "SetTelemetryRate",
            Request::GetStats => "GetStats",
            Request::GetRunReport => "GetRunReport",
            Request::GetTuneReport => "GetTuneReport",
            Request::SetPose { .. } => "SetPose",
            Request::GetPanicRecord => "GetPanicRecord",
            Request::ClearPanicRecord => "ClearPanicRecord",
            Request::Velocity { .. } => "Velocity",
            Request::MotorTest { .. } => "MotorTest",
        }
    }
}

/// What the robot does once armed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub enum ArmMode {
    /// Follow the committed path from where the robot is: resumed where the last run
    /// stopped (a time-indexed reference's clock paused while disarmed), or afresh after
    /// a new path or a [`Request::SetPose`].
    FollowPath,
    /// Hold these wheel speeds (rad/s) with the wheel PIDs only (bring-up).
    HoldWheelSpeeds(WheelSpeeds),
    /// Tune the wheel loops (the core's `tune`: open-loop voltage experiments on both
    /// wheels, the robot driving about a metre straight forward and back); the robot
    /// disarms by itself when done and sends [`Uplink::TuneReport`].
    Tune,
    /// The velocity mode: follow [`Request::Velocity`] commands, with
    /// `diff_drive_controller`'s semantics (a command timeout after which the robot ramps
    /// to a stop and stays armed; velocity, acceleration and jerk limits per axis; the
    /// rim-speed cap that keeps ω/v). Every fault check is in force and the robot's button
    /// stops it. Armed only by this request: it is not in the button's mode-select cycle.
    /// Until the first command arrives the robot holds still.
    FollowVelocity,
}

/// The robot's whole configuration: what [`Request::SetParams`] sends and
/// [`Reply::Params`] returns.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub struct ParamSet {
    /// Geometry, encoder, rates, limits and gains (SI units; see the core).
    pub robot: RobotConfig,
    /// Supervisor settings (times in control steps).
    pub supervisor: SupervisorConfig,
}

/// Robot → host.
// The configuration in a reply makes one variant large; there is no heap to box it on
// the robot, which wraps a reply into its message out of line.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub enum Uplink {
    /// The answer to the request that carried `seq`.
    Reply {
        /// [`Downlink::seq`] of the request answered.
        seq: u16,
        /// What was done, or why not.
        result: Result<Reply, Refusal>,
    },
    /// One telemetry sample.
    Telemetry(TelemetryFrame),
    /// A supervisor state change.
    Event {
        /// Control step at which it happened.
        step: u32,
        /// What happened.
        event: Event,
    },
    /// The simulated robot's true state (the virtual robot only; never from hardware).
    GroundTruth(GroundTruth),
    /// Statistics sent unasked.
    Stats(Stats),
    /// A frame arrived whose header names `received`, not this robot's protocol; it was
    /// not decoded. The header of this message names the robot's own protocol, so a host
    /// of another version can still print both (see [`Mismatch`](crate::Mismatch)).
    VersionMismatch {
        /// What the refused frame's header said.
        received: ProtocolId,
    },
    /// A path-following run ended (disarm, fault or run timeout): its metrics, computed
    /// on the robot at the control rate (see [`RunReport`]).
    RunReport(RunReport),
    /// The simulated robot's true metrics of the run that just ended (the virtual robot
    /// only; never from hardware).
    GroundTruthRun(TrueRunReport),
    /// A wheel-loop tune ended: the identified model and gains, or why it stopped.
    TuneReport(TuneReport),
}

/// The payload of an accepted request's reply.
// The configuration makes one variant large; there is no heap to box it on the robot,
// which builds a reply in place where it is sent.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub enum Reply {
    /// Done; nothing to report.
    Ack,
    /// Answer to [`Request::Info`].
    Info(RobotInfo),
    /// Answer to [`Request::Ping`].
    Pong {
        /// The ping's nonce.
        nonce: u32,
    },
    /// Answer to [`Request::GetParams`]: the active configuration.
    Params(ParamSet),
    /// Answer to [`Request::SetParams`]: the configuration is active.
    ParamsApplied {
        /// [`params_hash`](crate::params_hash) of the configuration now active.
        params_hash: u32,
    },
    /// Answer to [`Request::PathChunk`]: the chunk is stored.
    PathChunkStored {
        /// The upload.
        upload_id: u16,
        /// Distinct segments received so far.
        received: u8,
        /// Segments announced by [`PathBegin::segment_count`].
        expected: u8,
    },
    /// Answer to [`Request::PathCommit`]: the path is active.
    PathCommitted(CommitSummary),
    /// Answer to [`Request::GetStats`].
    Stats(Stats),
    /// Answer to [`Request::GetRunReport`]: the last run's metrics.
    RunReport(RunReport),
    /// Answer to [`Request::GetTuneReport`]: the last tune's outcome.
    TuneReport(TuneReport),
    /// Answer to [`Request::GetPanicRecord`]: the failure that ended a previous run, if
    /// the robot has a record of one.
    PanicRecord(Option<PanicReport>),
}

/// Who the robot is: answer to [`Request::Info`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub struct RobotInfo {
    /// The protocol the robot speaks (the same as its frame headers).
    pub protocol: ProtocolId,
    /// Firmware version, e.g. `0.1.0`.
    pub firmware_version: String<VERSION_CAP>,
    /// Git commit of the firmware build, e.g. `e39f8b3c41aa` or `e39f8b3c41aa-dirty`.
    pub git_hash: String<GIT_HASH_CAP>,
    /// Chip, e.g. `STM32F411CEU6`, or the simulator's name.
    pub chip: String<NAME_CAP>,
    /// The robot's name.
    pub robot_name: String<NAME_CAP>,
    /// [`params_hash`](crate::params_hash) of the active configuration.
    pub params_hash: u32,
    /// The board's motor bridge (on the virtual robot, the simulated plant's), which
    /// bounds the battery it may be connected to.
    pub bridge: BridgeChip,
    /// What the robot's clock runs from (an internal fallback when the external
    /// oscillator did not start).
    pub clock: ClockSource,
    /// The robot's brown-out reset level.
    pub brown_out_reset: BrownOutReset,
    /// Why the chip last reset, as its reset flags said at boot (a watchdog or brown-out
    /// reset means the previous run ended badly; the panic record may say how).
    pub reset_cause: ResetCause,
}

/// `text` as a bounded string, cut at a character boundary when longer than `N` bytes.
pub fn bounded<const N: usize>(text: &str) -> String<N> {
    let mut out = String::new();
    // Whole: cannot fail (at most N bytes).
    let _ = out.push_str(prefix_within(text, N));
    out
}

/// The longest prefix of `text` of at most `cap` bytes that ends on a character
/// boundary. Not generic, so the firmware holds one copy for every capacity.
fn prefix_within(text: &str, cap: usize) -> &str {
    let mut end = cap.min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    text.get(..end).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_cuts_at_a_character_boundary() {
        assert_eq!(bounded::<8>("abc").as_str(), "abc");
        assert_eq!(bounded::<4>("abcdef").as_str(), "abcd");
        // "é" is 2 bytes: 3 bytes of room hold "aé", not half of the next "é".
        assert_eq!(bounded::<4>("aéé").as_str(), "aé");
        assert_eq!(bounded::<0>("abc").as_str(), "");
    }

    #[test]
    fn every_request_has_a_distinct_name() {
        let names = [
            Request::Info.name(),
            Request::Ping { nonce: 0 }.name(),
            Request::GetParams.name(),
            Request::PersistParams.name(),
            Request::Disarm.name(),
            Request::EmergencyStop.name(),
            Request::ClearFaults.name(),
            Request::Heartbeat.name(),
            Request::SetTelemetryRate { hz: 1 }.name(),
            Request::GetStats.name(),
            Request::GetRunReport.name(),
            Request::GetTuneReport.name(),
            Request::SetPose {
                x_m: 0.0,
                y_m: 0.0,
                theta_rad: 0.0,
            }
            .name(),
            Request::GetPanicRecord.name(),
            Request::ClearPanicRecord.name(),
            Request::MotorTest {
                wheel: Wheel::Left,
                volts: 1.0,
                duration_ms: 100,
                confirm: MOTOR_TEST_CONFIRMATION,
            }
            .name(),
        ];
        for (i, a) in names.iter().enumerate() {
            for b in &names[i + 1..] {
                assert_ne!(a, b);
            }
        }
    }
}
