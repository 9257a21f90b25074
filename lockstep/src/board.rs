//! What the board answers: one [`BoardStep`] per control step (its details only when
//! they change), the board's [`BoardEncoder`] and the plant's [`BoardDecoder`], and the
//! one-byte codes of the supervisor's values.

use controller_core::controller::MotorCommand;
use controller_core::gyro::GyroFailure;
use controller_core::kinematics::{Pose, TrackingError};
use controller_core::supervisor::{
    Bridge, CommandRefusal, DisarmReason, Event, Faults, RunMode, State,
};

use crate::report::BoardReport;
use crate::wire::{Assembler, Parse, Reader, Writer};
use crate::{
    FromBoard, BOARD_DETAIL_TAG, BOARD_MESSAGE_MAX_LEN, BOARD_STEP_MAX_LEN, BOARD_STEP_TAG, FINISH,
};

/// What the board decided in one control step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardStep {
    /// Duties written to the bridge, each in [−1, 1].
    pub duty: MotorCommand,
    /// What the bridge does.
    pub bridge: Bridge,
    /// The supervisor's state after the step.
    pub state: State,
    /// The mode used when armed.
    pub run_mode: RunMode,
    /// Latched faults.
    pub faults: Faults,
    /// The supply is below the battery's warning threshold.
    pub battery_low: bool,
    /// The step's state change.
    pub event: Option<Event>,
    /// Missed control ticks since boot.
    pub missed_ticks_total: u32,
    /// Overrun steps since boot.
    pub overruns_total: u32,
    /// The controller's odometry pose, world frame (m, rad).
    pub pose: Pose,
    /// The controller's tracking error at its last steering update, robot frame (m, rad).
    pub error: TrackingError,
    /// This step applied a steering outcome (the law ran on the previous step's pose).
    pub steering_updated: bool,
}

/// The parts of a [`BoardStep`] sent only when they change or the steering law ran.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Details {
    faults: Faults,
    event: Option<Event>,
    missed_ticks_total: u32,
    overruns_total: u32,
    pose: Pose,
    error: TrackingError,
}

impl Details {
    const NONE: Details = Details {
        faults: Faults::NONE,
        event: None,
        missed_ticks_total: 0,
        overruns_total: 0,
        pose: Pose {
            x_m: 0.0,
            y_m: 0.0,
            theta_rad: 0.0,
        },
        error: TrackingError {
            x_e_m: 0.0,
            y_e_m: 0.0,
            theta_e_rad: 0.0,
        },
    };

    fn of(step: &BoardStep) -> Self {
        Self {
            faults: step.faults,
            event: step.event,
            missed_ticks_total: step.missed_ticks_total,
            overruns_total: step.overruns_total,
            pose: step.pose,
            error: step.error,
        }
    }
}

/// The board's encoder of its answers: it remembers what it last sent, to leave out
/// the details that did not change.
#[derive(Clone, Debug, Default)]
pub struct BoardEncoder {
    /// Faults and counters last sent (`None` before the first answer).
    sent: Option<(u16, u32, u32)>,
}

impl BoardEncoder {
    /// An encoder that sends the details with its first answer.
    pub const fn new() -> Self {
        Self { sent: None }
    }

    /// Writes `step` into `out`; its length. The details go along when the steering law
    /// ran, an event happened, or the faults or counters changed.
    pub fn encode(&mut self, step: &BoardStep, out: &mut [u8; BOARD_STEP_MAX_LEN]) -> usize {
        let counters = (
            step.faults.bits(),
            step.missed_ticks_total,
            step.overruns_total,
        );
        let detail = step.steering_updated || step.event.is_some() || self.sent != Some(counters);
        self.sent = Some(counters);
        let mut w = Writer { out, at: 0 };
        w.u8(if detail {
            BOARD_DETAIL_TAG
        } else {
            BOARD_STEP_TAG
        });
        w.f32(step.duty.left);
        w.f32(step.duty.right);
        w.u8(bridge_code(step.bridge)
            | state_code(step.state) << 2
            | run_mode_code(step.run_mode) << 4
            | u8::from(step.battery_low) << 5
            | u8::from(step.steering_updated) << 6);
        if detail {
            w.u16(counters.0);
            let [kind, arg] = event_code(step.event);
            w.u8(kind);
            w.u8(arg);
            w.varint(step.missed_ticks_total);
            w.varint(step.overruns_total);
            for v in [step.pose.x_m, step.pose.y_m, step.pose.theta_rad] {
                w.f32(v);
            }
            for v in [step.error.x_e_m, step.error.y_e_m, step.error.theta_e_rad] {
                w.f32(v);
            }
        }
        w.at
    }
}

/// A [`BoardStep`]'s fixed part: duties and the status byte's fields.
struct Head {
    duty: MotorCommand,
    bridge: Bridge,
    state: State,
    run_mode: RunMode,
    battery_low: bool,
    steering_updated: bool,
}

/// Reads the fixed part after the tag; `None` inside when a code is out of range.
fn read_head(r: &mut Reader<'_>) -> Option<Option<Head>> {
    let duty = MotorCommand {
        left: r.f32()?,
        right: r.f32()?,
    };
    let status = r.u8()?;
    let head = match (
        bridge_from(status & 0b11),
        state_from((status >> 2) & 0b11),
        run_mode_from((status >> 4) & 1),
    ) {
        (Some(bridge), Some(state), Some(run_mode)) => Some(Head {
            duty,
            bridge,
            state,
            run_mode,
            battery_low: status & 1 << 5 != 0,
            steering_updated: status & 1 << 6 != 0,
        }),
        _ => None,
    };
    Some(head)
}

/// Reads the details; `None` inside when the event's code is out of range.
fn read_details(r: &mut Reader<'_>) -> Option<Option<Details>> {
    let faults = Faults::from_bits(r.u16()?);
    let event = event_from([r.u8()?, r.u8()?]);
    let missed_ticks_total = r.varint()?;
    let overruns_total = r.varint()?;
    let pose = Pose {
        x_m: r.f32()?,
        y_m: r.f32()?,
        theta_rad: r.f32()?,
    };
    let error = TrackingError {
        x_e_m: r.f32()?,
        y_e_m: r.f32()?,
        theta_e_rad: r.f32()?,
    };
    Some(event.map(|event| Details {
        faults,
        event,
        missed_ticks_total,
        overruns_total,
        pose,
        error,
    }))
}

impl BoardStep {
    /// The step in `bytes` (tag included), with `last`'s details when it carries none.
    fn parse(bytes: &[u8], last: &Details) -> Parse<Self> {
        let mut r = Reader { bytes, at: 0 };
        let Some(tag) = r.u8() else {
            return Parse::Partial;
        };
        let head = match read_head(&mut r) {
            None => return Parse::Partial,
            Some(None) => return Parse::Invalid,
            Some(Some(head)) => head,
        };
        let details = if tag == BOARD_DETAIL_TAG {
            match read_details(&mut r) {
                None => return Parse::Partial,
                Some(None) => return Parse::Invalid,
                Some(Some(details)) => details,
            }
        } else {
            Details {
                event: None,
                ..*last
            }
        };
        Parse::read(Some(Self {
            duty: head.duty,
            bridge: head.bridge,
            state: head.state,
            run_mode: head.run_mode,
            faults: details.faults,
            battery_low: head.battery_low,
            event: details.event,
            missed_ticks_total: details.missed_ticks_total,
            overruns_total: details.overruns_total,
            pose: details.pose,
            error: details.error,
            steering_updated: head.steering_updated,
        }))
    }
}

/// The plant's decoder of what the board sends (after [`READY`](crate::READY)); it keeps the last
/// details, so every [`BoardStep`] it gives is whole.
#[derive(Clone, Debug)]
pub struct BoardDecoder {
    assembler: Assembler<BOARD_MESSAGE_MAX_LEN>,
    last: Details,
}

impl Default for BoardDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl BoardDecoder {
    /// A decoder waiting for a tag.
    pub const fn new() -> Self {
        Self {
            assembler: Assembler::new(),
            last: Details::NONE,
        }
    }

    /// Takes one received byte; the message it completes, if any.
    pub fn push(&mut self, byte: u8) -> Option<FromBoard> {
        let last = self.last;
        let message = self.assembler.push(
            byte,
            |tag| matches!(tag, BOARD_STEP_TAG | BOARD_DETAIL_TAG | FINISH),
            |bytes| match bytes.first() {
                Some(&FINISH) => match BoardReport::parse(bytes) {
                    Parse::Whole(report) => Parse::Whole(FromBoard::Report(report)),
                    Parse::Partial => Parse::Partial,
                    Parse::Invalid => Parse::Invalid,
                },
                _ => match BoardStep::parse(bytes, &last) {
                    Parse::Whole(step) => Parse::Whole(FromBoard::Step(step)),
                    Parse::Partial => Parse::Partial,
                    Parse::Invalid => Parse::Invalid,
                },
            },
        )?;
        if let FromBoard::Step(step) = &message {
            self.last = Details::of(step);
        }
        Some(message)
    }

    /// Bytes and messages dropped: unknown tags, codes out of range.
    pub const fn errors(&self) -> u32 {
        self.assembler.errors
    }
}

const fn bridge_code(bridge: Bridge) -> u8 {
    match bridge {
        Bridge::Drive => 0,
        Bridge::Brake => 1,
        Bridge::Coast => 2,
    }
}

const fn bridge_from(code: u8) -> Option<Bridge> {
    match code {
        0 => Some(Bridge::Drive),
        1 => Some(Bridge::Brake),
        2 => Some(Bridge::Coast),
        _ => None,
    }
}

const fn state_code(state: State) -> u8 {
    match state {
        State::Disarmed => 0,
        State::Armed => 1,
        State::Faulted => 2,
        State::Persisting => 3,
    }
}

const fn state_from(code: u8) -> Option<State> {
    match code {
        0 => Some(State::Disarmed),
        1 => Some(State::Armed),
        2 => Some(State::Faulted),
        3 => Some(State::Persisting),
        _ => None,
    }
}

const fn run_mode_code(mode: RunMode) -> u8 {
    match mode {
        RunMode::FollowPath => 0,
        RunMode::HoldWheelSpeeds => 1,
        RunMode::Tune => 2,
        RunMode::FollowVelocity => 3,
        RunMode::MotorTest => 4,
    }
}

const fn run_mode_from(code: u8) -> Option<RunMode> {
    match code {
        0 => Some(RunMode::FollowPath),
        1 => Some(RunMode::HoldWheelSpeeds),
        2 => Some(RunMode::Tune),
        3 => Some(RunMode::FollowVelocity),
        4 => Some(RunMode::MotorTest),
        _ => None,
    }
}

const fn disarm_code(reason: DisarmReason) -> u8 {
    match reason {
        DisarmReason::Button => 0,
        DisarmReason::Link => 1,
        DisarmReason::Timeout => 2,
        DisarmReason::LinkLost => 3,
        DisarmReason::TuneFinished => 4,
    }
}

const fn disarm_from(code: u8) -> Option<DisarmReason> {
    match code {
        0 => Some(DisarmReason::Button),
        1 => Some(DisarmReason::Link),
        2 => Some(DisarmReason::Timeout),
        3 => Some(DisarmReason::LinkLost),
        4 => Some(DisarmReason::TuneFinished),
        _ => None,
    }
}

const fn gyro_failure_code(failure: GyroFailure) -> u8 {
    match failure {
        GyroFailure::Absent => 0,
        GyroFailure::NonFinite => 1,
        GyroFailure::Saturated => 2,
        GyroFailure::Stuck => 3,
    }
}

const fn gyro_failure_from(code: u8) -> Option<GyroFailure> {
    match code {
        0 => Some(GyroFailure::Absent),
        1 => Some(GyroFailure::NonFinite),
        2 => Some(GyroFailure::Saturated),
        3 => Some(GyroFailure::Stuck),
        _ => None,
    }
}

/// A refusal as one byte: 0–3 wrong state (its state's code), then the others; 8 on a
/// wrong mode (plus the mode's code).
const fn refusal_code(refusal: CommandRefusal) -> u8 {
    match refusal {
        CommandRefusal::WrongState(state) => state_code(state),
        CommandRefusal::ButtonHeld => 4,
        CommandRefusal::WheelsTurning => 5,
        CommandRefusal::NonFinitePose => 6,
        CommandRefusal::NonFiniteVelocity => 7,
        CommandRefusal::MotorTestOutOfBounds => 8,
        CommandRefusal::WrongMode(mode) => 9 + run_mode_code(mode),
    }
}

const fn refusal_from(code: u8) -> Option<CommandRefusal> {
    match code {
        4 => Some(CommandRefusal::ButtonHeld),
        5 => Some(CommandRefusal::WheelsTurning),
        6 => Some(CommandRefusal::NonFinitePose),
        7 => Some(CommandRefusal::NonFiniteVelocity),
        8 => Some(CommandRefusal::MotorTestOutOfBounds),
        9.. => match run_mode_from(code - 9) {
            Some(mode) => Some(CommandRefusal::WrongMode(mode)),
            None => None,
        },
        _ => match state_from(code) {
            Some(state) => Some(CommandRefusal::WrongState(state)),
            None => None,
        },
    }
}

/// An event as (kind, argument); (0, 0) for none.
const fn event_code(event: Option<Event>) -> [u8; 2] {
    match event {
        None => [0, 0],
        Some(Event::Armed(mode)) => [1, run_mode_code(mode)],
        Some(Event::Disarmed(reason)) => [2, disarm_code(reason)],
        Some(Event::Faulted) => [3, 0],
        Some(Event::FaultsCleared) => [4, 0],
        Some(Event::ModeSelected(mode)) => [5, run_mode_code(mode)],
        Some(Event::BatteryLow) => [6, 0],
        Some(Event::PersistStarted) => [7, 0],
        Some(Event::PersistEnded) => [8, 0],
        Some(Event::PoseSet) => [9, 0],
        Some(Event::ArmRefused(refusal)) => [10, refusal_code(refusal)],
        Some(Event::GyroFailed(failure)) => [11, gyro_failure_code(failure)],
        Some(Event::GyroDisagrees) => [12, 0],
    }
}

/// The event of a code; `None` (outer) for a code that is none.
const fn event_from(code: [u8; 2]) -> Option<Option<Event>> {
    let [kind, arg] = code;
    let event = match kind {
        0 => return Some(None),
        1 => match run_mode_from(arg) {
            Some(mode) => Event::Armed(mode),
            None => return None,
        },
        2 => match disarm_from(arg) {
            Some(reason) => Event::Disarmed(reason),
            None => return None,
        },
        3 => Event::Faulted,
        4 => Event::FaultsCleared,
        5 => match run_mode_from(arg) {
            Some(mode) => Event::ModeSelected(mode),
            None => return None,
        },
        6 => Event::BatteryLow,
        7 => Event::PersistStarted,
        8 => Event::PersistEnded,
        9 => Event::PoseSet,
        10 => match refusal_from(arg) {
            Some(refusal) => Event::ArmRefused(refusal),
            None => return None,
        },
        11 => match gyro_failure_from(arg) {
            Some(failure) => Event::GyroFailed(failure),
            None => return None,
        },
        12 => Event::GyroDisagrees,
        _ => return None,
    };
    Some(Some(event))
}
