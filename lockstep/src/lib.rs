//! The lockstep port between an emulated board and a simulated plant: the firmware's
//! `qemu` board and `host-sim pil`, over one emulated USART.
//!
//! The plant owns time. Each [`PlantStep`] it sends carries what the board's sensors
//! read for one control step (encoder ticks, the periods since the previous step, the
//! supply measurement, the button) and triggers exactly one control step; the board
//! answers with one [`BoardStep`] (the duties, the bridge, the supervisor's decision and
//! the controller's estimate), and the plant advances only after it has that answer. So
//! the closed loop computes the same numbers however fast or slow either side runs, and
//! however the host's bytes fall against the emulator's virtual time.
//!
//! ```text
//!  board ─► READY ('R', once, after both USARTs are enabled)
//!  plant ─► PlantStep   ('S', or 'P' with the button pressed; 8 bytes typically)  ┐ one
//!  board ─► BoardStep   ('A' 10 bytes, or 'D' 40 bytes or more with the details)    ┘ step
//!  …
//!  plant ─► FINISH ('F')
//!  board ─► BoardReport ('F' + 68 bytes), then the emulator exits
//! ```
//!
//! Messages are short because the emulated USART is slow: QEMU hands the guest one byte
//! per main-loop turn (about 0.1 ms each, measured), so bytes per step set the run's
//! speed. Integers are LEB128 varints (zig-zag for signed), `f32` their four IEEE bytes,
//! little-endian, so values cross exactly. A [`BoardStep`] carries its details (faults,
//! event, counters, the controller's pose and error) only when the steering law ran or
//! one of them changed; the [`BoardDecoder`] keeps the last ones, so every decoded step
//! is whole.
//!
//! The transport (a TCP socket behind the emulated USART) neither loses nor corrupts
//! bytes, so there is no checksum; a byte that is no known tag, or a step whose period
//! count is 0, is dropped and counted ([`StepDecoder::errors`]), and the plant then times
//! out waiting for the answer.

#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

use core::num::NonZeroU32;

use controller_core::controller::{MotorCommand, TickDeltas};
use controller_core::kinematics::{Pose, TrackingError};
use controller_core::supervisor::{Bridge, DisarmReason, Event, Faults, RunMode, State};

/// The board's first byte on the port: both USARTs are enabled, send.
pub const READY: u8 = b'R';
/// Tag of a [`PlantStep`] with the button released.
pub const STEP_TAG: u8 = b'S';
/// Tag of a [`PlantStep`] with the button pressed.
pub const STEP_PRESSED_TAG: u8 = b'P';
/// Tag of a [`BoardStep`] without its details (the decoder repeats the last ones).
pub const BOARD_STEP_TAG: u8 = b'A';
/// Tag of a [`BoardStep`] with its details.
pub const BOARD_DETAIL_TAG: u8 = b'D';
/// The plant's last message, and the tag of the board's [`BoardReport`] that answers it.
pub const FINISH: u8 = b'F';

/// Most bytes of a [`PlantStep`] on the wire: tag, three varints of up to 5 bytes, an
/// `f32`.
pub const PLANT_STEP_MAX_LEN: usize = 1 + 3 * 5 + 4;
/// Most bytes of a [`BoardStep`] on the wire: tag, two `f32`, the status byte, and the
/// details (faults, event, two varint counters, six `f32`).
pub const BOARD_STEP_MAX_LEN: usize = 1 + 8 + 1 + 2 + 2 + 2 * 5 + 24;
/// Most bytes of any message the board sends: a [`BoardStep`] or a [`BoardReport`].
const BOARD_MESSAGE_MAX_LEN: usize = if BOARD_STEP_MAX_LEN > BOARD_REPORT_LEN {
    BOARD_STEP_MAX_LEN
} else {
    BOARD_REPORT_LEN
};
/// Bytes of a [`BoardReport`] on the wire, tag included.
pub const BOARD_REPORT_LEN: usize = 1 + 5 * 3 * 4 + 2 * 4;

/// What the board's sensors read for one control step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantStep {
    /// Encoder ticks since the previous step, forward positive.
    pub ticks: TickDeltas,
    /// Control periods since the previous step (1 on time, never 0).
    pub periods: NonZeroU32,
    /// The supply measurement, V.
    pub supply_v: f32,
    /// The arm button's raw level, true while pressed.
    pub button_pressed: bool,
}

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

/// The board's figures at the end of a run (answer to [`FINISH`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BoardReport {
    /// The control interrupt's runs, every step, in any state.
    pub control: TaskFigures,
    /// The control interrupt's runs in the armed steady state: the steps that end armed
    /// and report no event.
    pub control_armed: TaskFigures,
    /// The control interrupt's runs in the steps that arm (in motion or not).
    pub control_arming: TaskFigures,
    /// The steering task's runs (the outer loop lent by the control interrupt).
    pub steering: TaskFigures,
    /// The link task's runs.
    pub link: TaskFigures,
    /// The stack's high-water mark while the application ran (after start-up), bytes.
    pub stack_high_water_bytes: u32,
    /// The stack start-up (`init`) used, bytes.
    pub start_stack_bytes: u32,
}

/// One task's runs, in instructions (counted with SysTick under QEMU's `-icount`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TaskFigures {
    /// Runs recorded.
    pub runs: u32,
    /// The longest run, instructions.
    pub max_instructions: u32,
    /// All runs together, instructions (saturating at `u32::MAX`).
    pub total_instructions: u32,
}

impl TaskFigures {
    /// The mean run, instructions (0 without a run).
    pub fn mean_instructions(&self) -> f64 {
        if self.runs == 0 {
            0.0
        } else {
            f64::from(self.total_instructions) / f64::from(self.runs)
        }
    }
}

/// What the plant sends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToBoard {
    /// One control step.
    Step(PlantStep),
    /// The run is over: report and stop.
    Finish,
}

/// What the board sends (after [`READY`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FromBoard {
    /// The answer to a [`PlantStep`].
    Step(BoardStep),
    /// The answer to [`FINISH`].
    Report(BoardReport),
}

/// Writer into a fixed buffer (bytes past its end are dropped; the buffers are sized
/// for the longest message).
struct Writer<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn bytes(&mut self, bytes: &[u8]) {
        if let Some(slot) = self.out.get_mut(self.at..self.at + bytes.len()) {
            slot.copy_from_slice(bytes);
        }
        self.at += bytes.len();
    }
    fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }
    fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }
    /// LEB128: seven bits a byte, the high bit set on all but the last.
    fn varint(&mut self, mut v: u32) {
        while v >= 0x80 {
            self.u8(v as u8 | 0x80);
            v >>= 7;
        }
        self.u8(v as u8);
    }
    /// Zig-zag, then LEB128: small magnitudes of either sign take one byte.
    fn signed(&mut self, v: i32) {
        self.varint(((v << 1) ^ (v >> 31)) as u32);
    }
}

/// Reader of a message that may not have arrived whole: every read is `None` past the
/// bytes there are.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        let bytes = self.bytes.get(self.at..self.at + N)?;
        self.at += N;
        bytes.try_into().ok()
    }
    fn u8(&mut self) -> Option<u8> {
        self.array::<1>().map(|[b]| b)
    }
    fn u16(&mut self) -> Option<u16> {
        self.array().map(u16::from_le_bytes)
    }
    fn u32(&mut self) -> Option<u32> {
        self.array().map(u32::from_le_bytes)
    }
    fn f32(&mut self) -> Option<f32> {
        self.u32().map(f32::from_bits)
    }
    /// A LEB128 varint of up to five bytes (longer ones read as their first five).
    fn varint(&mut self) -> Option<u32> {
        let mut value = 0u32;
        for shift in [0, 7, 14, 21, 28] {
            let byte = self.u8()?;
            value |= u32::from(byte & 0x7F) << shift;
            if byte & 0x80 == 0 {
                break;
            }
        }
        Some(value)
    }
    fn signed(&mut self) -> Option<i32> {
        self.varint().map(|z| ((z >> 1) as i32) ^ -((z & 1) as i32))
    }
}

/// What the bytes assembled so far hold.
enum Parse<T> {
    /// A whole message.
    Whole(T),
    /// Not yet: more bytes to come.
    Partial,
    /// Not a valid message.
    Invalid,
}

impl<T> Parse<T> {
    /// `Whole` for a message read, `Partial` when the reader ran out of bytes.
    fn read(value: Option<T>) -> Self {
        value.map_or(Parse::Partial, Parse::Whole)
    }
}

impl PlantStep {
    /// Writes the message into `out`; its length.
    pub fn encode(&self, out: &mut [u8; PLANT_STEP_MAX_LEN]) -> usize {
        let mut w = Writer { out, at: 0 };
        w.u8(if self.button_pressed {
            STEP_PRESSED_TAG
        } else {
            STEP_TAG
        });
        w.signed(self.ticks.left);
        w.signed(self.ticks.right);
        w.varint(self.periods.get());
        w.f32(self.supply_v);
        w.at
    }

    /// The step in `bytes` (tag included).
    fn parse(bytes: &[u8]) -> Parse<Self> {
        let mut r = Reader { bytes, at: 0 };
        let read = |r: &mut Reader<'_>| {
            let tag = r.u8()?;
            Some((tag, r.signed()?, r.signed()?, r.varint()?, r.f32()?))
        };
        match read(&mut r) {
            None => Parse::Partial,
            Some((tag, left, right, periods, supply_v)) => match NonZeroU32::new(periods) {
                Some(periods) => Parse::Whole(Self {
                    ticks: TickDeltas { left, right },
                    periods,
                    supply_v,
                    button_pressed: tag == STEP_PRESSED_TAG,
                }),
                None => Parse::Invalid,
            },
        }
    }
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

impl BoardReport {
    /// The message's bytes.
    pub fn encode(&self) -> [u8; BOARD_REPORT_LEN] {
        let mut out = [0u8; BOARD_REPORT_LEN];
        let mut w = Writer {
            out: &mut out,
            at: 0,
        };
        w.u8(FINISH);
        for task in [
            &self.control,
            &self.control_armed,
            &self.control_arming,
            &self.steering,
            &self.link,
        ] {
            w.u32(task.runs);
            w.u32(task.max_instructions);
            w.u32(task.total_instructions);
        }
        w.u32(self.stack_high_water_bytes);
        w.u32(self.start_stack_bytes);
        out
    }

    fn parse(bytes: &[u8]) -> Parse<Self> {
        let mut r = Reader { bytes, at: 1 };
        Parse::read((|| {
            let mut task = || {
                Some(TaskFigures {
                    runs: r.u32()?,
                    max_instructions: r.u32()?,
                    total_instructions: r.u32()?,
                })
            };
            let (control, control_armed, control_arming, steering, link) =
                (task()?, task()?, task()?, task()?, task()?);
            Some(Self {
                control,
                control_armed,
                control_arming,
                steering,
                link,
                stack_high_water_bytes: r.u32()?,
                start_stack_bytes: r.u32()?,
            })
        })())
    }
}

/// Collects a message's bytes until they parse.
#[derive(Clone, Debug)]
struct Assembler<const N: usize> {
    buf: [u8; N],
    len: usize,
    errors: u32,
}

impl<const N: usize> Assembler<N> {
    const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            errors: 0,
        }
    }

    /// Takes `byte`. A first byte that `is_tag` refuses is dropped and counted; then the
    /// bytes so far go to `parse` until it has a whole message (or an invalid one,
    /// dropped and counted, as is one longer than `N` bytes).
    fn push<T>(
        &mut self,
        byte: u8,
        is_tag: impl Fn(u8) -> bool,
        parse: impl Fn(&[u8]) -> Parse<T>,
    ) -> Option<T> {
        if self.len == 0 && !is_tag(byte) {
            self.errors = self.errors.wrapping_add(1);
            return None;
        }
        let Some(slot) = self.buf.get_mut(self.len) else {
            self.len = 0;
            self.errors = self.errors.wrapping_add(1);
            return None;
        };
        *slot = byte;
        self.len += 1;
        match parse(self.buf.get(..self.len).unwrap_or_default()) {
            Parse::Partial => None,
            Parse::Whole(message) => {
                self.len = 0;
                Some(message)
            }
            Parse::Invalid => {
                self.len = 0;
                self.errors = self.errors.wrapping_add(1);
                None
            }
        }
    }
}

/// The board's decoder of what the plant sends.
#[derive(Clone, Debug)]
pub struct StepDecoder(Assembler<PLANT_STEP_MAX_LEN>);

impl Default for StepDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl StepDecoder {
    /// A decoder waiting for a tag.
    pub const fn new() -> Self {
        Self(Assembler::new())
    }

    /// Takes one received byte; the message it completes, if any.
    pub fn push(&mut self, byte: u8) -> Option<ToBoard> {
        self.0.push(
            byte,
            |tag| matches!(tag, STEP_TAG | STEP_PRESSED_TAG | FINISH),
            |bytes| match bytes.first() {
                Some(&FINISH) => Parse::Whole(ToBoard::Finish),
                _ => match PlantStep::parse(bytes) {
                    Parse::Whole(step) => Parse::Whole(ToBoard::Step(step)),
                    Parse::Partial => Parse::Partial,
                    Parse::Invalid => Parse::Invalid,
                },
            },
        )
    }

    /// Bytes and messages dropped: unknown tags, steps of 0 periods.
    pub const fn errors(&self) -> u32 {
        self.0.errors
    }
}

/// The plant's decoder of what the board sends (after [`READY`]); it keeps the last
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
    }
}

const fn run_mode_from(code: u8) -> Option<RunMode> {
    match code {
        0 => Some(RunMode::FollowPath),
        1 => Some(RunMode::HoldWheelSpeeds),
        2 => Some(RunMode::Tune),
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
        _ => return None,
    };
    Some(Some(event))
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::supervisor::Fault;
    use std::vec::Vec;

    fn step(left: i32, right: i32, periods: u32, button_pressed: bool) -> PlantStep {
        PlantStep {
            ticks: TickDeltas { left, right },
            periods: NonZeroU32::new(periods).unwrap(),
            supply_v: 5.987_654,
            button_pressed,
        }
    }

    fn plant_bytes(s: &PlantStep) -> Vec<u8> {
        let mut out = [0u8; PLANT_STEP_MAX_LEN];
        let len = s.encode(&mut out);
        out[..len].to_vec()
    }

    fn board_step(event: Option<Event>, steering_updated: bool) -> BoardStep {
        BoardStep {
            duty: MotorCommand {
                left: -0.25,
                right: f32::from_bits(0x3f12_3457),
            },
            bridge: Bridge::Brake,
            state: State::Faulted,
            run_mode: RunMode::HoldWheelSpeeds,
            faults: Faults::NONE
                .with(Fault::StallLeft)
                .with(Fault::EmergencyStop)
                .with(Fault::NonFinite),
            battery_low: true,
            event,
            missed_ticks_total: 12,
            overruns_total: u32::MAX,
            pose: Pose::new(-1.0, 2.5, 3.1),
            error: TrackingError {
                x_e_m: 0.01,
                y_e_m: -0.02,
                theta_e_rad: 1e-7,
            },
            steering_updated,
        }
    }

    fn board_messages(bytes: &[u8]) -> (Vec<FromBoard>, u32) {
        let mut d = BoardDecoder::new();
        let out = bytes.iter().filter_map(|&b| d.push(b)).collect();
        (out, d.errors())
    }

    #[test]
    fn plant_steps_cross_bit_for_bit_in_few_bytes() {
        let steps = [
            step(-7, 3, 1, false),
            step(i32::MIN, i32::MAX, u32::MAX, true),
            step(0, -1, 12, false),
        ];
        let mut d = StepDecoder::new();
        let mut got = Vec::new();
        for s in &steps {
            got.extend(plant_bytes(s).iter().filter_map(|&b| d.push(b)));
        }
        assert_eq!(got, steps.map(ToBoard::Step));
        // A step of a moving robot: tag, one byte per count, the supply.
        assert_eq!(plant_bytes(&steps[0]).len(), 8);
        assert_eq!(plant_bytes(&steps[0])[0], STEP_TAG);
        assert_eq!(plant_bytes(&steps[1])[0], STEP_PRESSED_TAG);
        assert_eq!(plant_bytes(&steps[1]).len(), PLANT_STEP_MAX_LEN);
        assert_eq!(d.push(FINISH), Some(ToBoard::Finish));
        assert_eq!(d.errors(), 0);
    }

    #[test]
    fn the_details_go_along_only_when_needed_and_the_decoder_keeps_them() {
        let mut encoder = BoardEncoder::new();
        let mut out = [0u8; BOARD_STEP_MAX_LEN];
        let mut bytes = Vec::new();
        let mut send = |s: &BoardStep| {
            let len = encoder.encode(s, &mut out);
            bytes.extend_from_slice(&out[..len]);
            len
        };
        let first = board_step(None, false);
        // The first answer carries the details (the overrun count at its longest).
        assert_eq!(send(&first), 44);
        // Nothing changed, no steering, no event: duties and status only.
        let mut quiet = first;
        quiet.duty.left = 0.5;
        assert_eq!(send(&quiet), 10);
        // The steering law ran: details (the new pose) again.
        let mut steering = quiet;
        steering.steering_updated = true;
        steering.pose.x_m = 7.0;
        assert!(send(&steering) > 10);
        // An event.
        let armed = board_step(Some(Event::Armed(RunMode::FollowPath)), false);
        assert!(send(&armed) > 10);
        // The step after the event: compact again, and the event is not repeated.
        let after_event = board_step(None, false);
        assert_eq!(send(&after_event), 10);
        // A counter changed.
        let mut late = board_step(None, false);
        late.missed_ticks_total += 3;
        assert!(send(&late) > 10);
        let (got, errors) = board_messages(&bytes);
        assert_eq!(errors, 0);
        // Every step comes out whole, the quiet one with the last details.
        assert_eq!(
            got,
            [first, quiet, steering, armed, after_event, late].map(FromBoard::Step)
        );
    }

    #[test]
    fn every_event_and_fault_crosses() {
        let events = [
            None,
            Some(Event::Armed(RunMode::FollowPath)),
            Some(Event::Armed(RunMode::HoldWheelSpeeds)),
            Some(Event::Disarmed(DisarmReason::Button)),
            Some(Event::Disarmed(DisarmReason::Link)),
            Some(Event::Disarmed(DisarmReason::Timeout)),
            Some(Event::Disarmed(DisarmReason::LinkLost)),
            Some(Event::Disarmed(DisarmReason::TuneFinished)),
            Some(Event::Armed(RunMode::Tune)),
            Some(Event::Faulted),
            Some(Event::FaultsCleared),
            Some(Event::ModeSelected(RunMode::FollowPath)),
            Some(Event::BatteryLow),
            Some(Event::PersistStarted),
            Some(Event::PersistEnded),
        ];
        let mut encoder = BoardEncoder::new();
        let mut out = [0u8; BOARD_STEP_MAX_LEN];
        let mut bytes = Vec::new();
        for e in events {
            let len = encoder.encode(&board_step(e, true), &mut out);
            bytes.extend_from_slice(&out[..len]);
        }
        let (got, errors) = board_messages(&bytes);
        assert_eq!(errors, 0);
        let expected: Vec<_> = events
            .iter()
            .map(|&e| FromBoard::Step(board_step(e, true)))
            .collect();
        assert_eq!(got, expected);
        // Each fault alone crosses as itself.
        bytes.clear();
        let steps: Vec<_> = Fault::ALL
            .iter()
            .map(|&f| BoardStep {
                faults: Faults::NONE.with(f),
                ..board_step(None, true)
            })
            .collect();
        for s in &steps {
            let len = encoder.encode(s, &mut out);
            bytes.extend_from_slice(&out[..len]);
        }
        let (got, errors) = board_messages(&bytes);
        assert_eq!(errors, 0);
        let expected: Vec<_> = steps.into_iter().map(FromBoard::Step).collect();
        assert_eq!(got, expected);
    }

    #[test]
    fn a_report_answers_finish() {
        let task = |k: u32| TaskFigures {
            runs: 30_001 + k,
            max_instructions: 11_234 * k,
            total_instructions: 4_000_000_000 - k,
        };
        let r = BoardReport {
            control: task(1),
            control_armed: task(2),
            control_arming: task(3),
            steering: task(4),
            link: task(5),
            stack_high_water_bytes: 2048,
            start_stack_bytes: 9000,
        };
        let (got, errors) = board_messages(&r.encode());
        assert_eq!((got, errors), (std::vec![FromBoard::Report(r)], 0));
        assert_eq!(task(0).mean_instructions(), 4e9 / 30_001.0);
        assert_eq!(TaskFigures::default().mean_instructions(), 0.0);
    }

    #[test]
    fn stray_bytes_and_impossible_steps_are_counted_not_acted_on() {
        let mut d = StepDecoder::new();
        assert_eq!(d.push(0x00), None);
        assert_eq!(d.push(b'x'), None);
        assert_eq!(d.errors(), 2);
        // Zero periods: tag, two one-byte counts, a zero, the supply.
        let mut zero = plant_bytes(&step(1, 1, 1, false));
        zero[3] = 0;
        assert!(zero.iter().all(|&b| d.push(b).is_none()));
        assert_eq!(d.errors(), 3);
        // It resynchronises on the next tag.
        let good = step(5, 5, 1, false);
        assert_eq!(
            plant_bytes(&good).iter().filter_map(|&b| d.push(b)).last(),
            Some(ToBoard::Step(good))
        );
        // An out-of-range bridge code on the board's side.
        let mut out = [0u8; BOARD_STEP_MAX_LEN];
        let len = BoardEncoder::new().encode(&board_step(None, false), &mut out);
        out[9] |= 0b11;
        let (got, errors) = board_messages(&out[..len]);
        assert!(got.is_empty());
        // The message and the bytes after it (read as tags) are dropped.
        assert!(errors >= 1);
    }
}
