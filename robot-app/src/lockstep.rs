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
//!  plant ─► PlantStep  ('S' + 17 bytes)   ┐ one control step
//!  board ─► BoardStep  ('A' + 48 bytes)   ┘
//!  …
//!  plant ─► FINISH ('F')
//!  board ─► BoardReport ('F' + 16 bytes), then the emulator exits
//! ```
//!
//! Every message is a tag byte and a fixed number of little-endian bytes (`f32` as their
//! IEEE bits, so values cross exactly). The transport (a TCP socket behind the emulated
//! USART) neither loses nor corrupts bytes, so there is no checksum; a byte that is no
//! known tag, or a step whose period count is 0, is dropped and counted
//! ([`StepDecoder::errors`]), and the plant then times out waiting for the answer.

use core::num::NonZeroU32;

use controller_core::controller::{FaultFlags, MotorCommand, TickDeltas};
use controller_core::kinematics::{Pose, TrackingError};
use controller_core::supervisor::{Bridge, DisarmReason, Event, Faults, RunMode, State};

/// The board's first byte on the port: both USARTs are enabled, send.
pub const READY: u8 = b'R';
/// Tag of a [`PlantStep`].
pub const STEP_TAG: u8 = b'S';
/// Tag of a [`BoardStep`].
pub const BOARD_STEP_TAG: u8 = b'A';
/// The plant's last message, and the tag of the board's [`BoardReport`] that answers it.
pub const FINISH: u8 = b'F';

/// Bytes of a [`PlantStep`] on the wire, tag included.
pub const PLANT_STEP_LEN: usize = 18;
/// Bytes of a [`BoardStep`] on the wire, tag included.
pub const BOARD_STEP_LEN: usize = 49;
/// Bytes of a [`BoardReport`] on the wire, tag included.
pub const BOARD_REPORT_LEN: usize = 17;

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
    /// The steering law ran in this step.
    pub steering_updated: bool,
}

/// The board's figures at the end of a run (answer to [`FINISH`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BoardReport {
    /// The longest control interrupt, instructions (counted with SysTick under QEMU's
    /// `-icount`).
    pub control_max_instructions: u32,
    /// The longest run of the link task, instructions.
    pub link_max_instructions: u32,
    /// The stack's high-water mark, bytes.
    pub stack_high_water_bytes: u32,
    /// Control steps run.
    pub control_steps: u32,
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

/// Little-endian writer into a fixed buffer.
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
}

/// Little-endian reader of a fixed message (missing bytes read as 0; the decoders only
/// hand over whole messages).
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn array<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        if let Some(bytes) = self.bytes.get(self.at..self.at + N) {
            out.copy_from_slice(bytes);
        }
        self.at += N;
        out
    }
    fn u8(&mut self) -> u8 {
        self.array::<1>()[0]
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.array())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.array())
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.array())
    }
    fn f32(&mut self) -> f32 {
        f32::from_bits(self.u32())
    }
}

impl PlantStep {
    /// The message's bytes.
    pub fn encode(&self) -> [u8; PLANT_STEP_LEN] {
        let mut out = [0u8; PLANT_STEP_LEN];
        let mut w = Writer {
            out: &mut out,
            at: 0,
        };
        w.u8(STEP_TAG);
        w.bytes(&self.ticks.left.to_le_bytes());
        w.bytes(&self.ticks.right.to_le_bytes());
        w.u32(self.periods.get());
        w.f32(self.supply_v);
        w.u8(u8::from(self.button_pressed));
        out
    }

    /// The step in `bytes` (tag included), or `None` if its period count is 0.
    fn decode(bytes: &[u8]) -> Option<Self> {
        let mut r = Reader { bytes, at: 1 };
        let left = r.i32();
        let right = r.i32();
        let periods = NonZeroU32::new(r.u32())?;
        let supply_v = r.f32();
        let button_pressed = r.u8() & 1 != 0;
        Some(Self {
            ticks: TickDeltas { left, right },
            periods,
            supply_v,
            button_pressed,
        })
    }
}

impl BoardStep {
    /// The message's bytes.
    pub fn encode(&self) -> [u8; BOARD_STEP_LEN] {
        let mut out = [0u8; BOARD_STEP_LEN];
        let mut w = Writer {
            out: &mut out,
            at: 0,
        };
        w.u8(BOARD_STEP_TAG);
        w.f32(self.duty.left);
        w.f32(self.duty.right);
        w.u8(bridge_code(self.bridge));
        w.u8(state_code(self.state));
        w.u8(run_mode_code(self.run_mode));
        w.u8(u8::from(self.battery_low) | u8::from(self.steering_updated) << 1);
        w.u16(fault_bits(&self.faults));
        let [kind, arg] = event_code(self.event);
        w.u8(kind);
        w.u8(arg);
        w.u32(self.missed_ticks_total);
        w.u32(self.overruns_total);
        for v in [self.pose.x_m, self.pose.y_m, self.pose.theta_rad] {
            w.f32(v);
        }
        for v in [self.error.x_e_m, self.error.y_e_m, self.error.theta_e_rad] {
            w.f32(v);
        }
        out
    }

    /// The step in `bytes` (tag included), or `None` when a code is out of range.
    fn decode(bytes: &[u8]) -> Option<Self> {
        let mut r = Reader { bytes, at: 1 };
        let duty = MotorCommand {
            left: r.f32(),
            right: r.f32(),
        };
        let bridge = bridge_from(r.u8())?;
        let state = state_from(r.u8())?;
        let run_mode = run_mode_from(r.u8())?;
        let flags = r.u8();
        let faults = faults_from(r.u16());
        let event = event_from([r.u8(), r.u8()])?;
        let missed_ticks_total = r.u32();
        let overruns_total = r.u32();
        let pose = Pose {
            x_m: r.f32(),
            y_m: r.f32(),
            theta_rad: r.f32(),
        };
        let error = TrackingError {
            x_e_m: r.f32(),
            y_e_m: r.f32(),
            theta_e_rad: r.f32(),
        };
        Some(Self {
            duty,
            bridge,
            state,
            run_mode,
            faults,
            battery_low: flags & 1 != 0,
            event,
            missed_ticks_total,
            overruns_total,
            pose,
            error,
            steering_updated: flags & 2 != 0,
        })
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
        w.u32(self.control_max_instructions);
        w.u32(self.link_max_instructions);
        w.u32(self.stack_high_water_bytes);
        w.u32(self.control_steps);
        out
    }

    fn decode(bytes: &[u8]) -> Self {
        let mut r = Reader { bytes, at: 1 };
        Self {
            control_max_instructions: r.u32(),
            link_max_instructions: r.u32(),
            stack_high_water_bytes: r.u32(),
            control_steps: r.u32(),
        }
    }
}

/// Reassembles fixed-length tagged messages from bytes.
#[derive(Clone, Debug)]
struct Assembler<const N: usize> {
    buf: [u8; N],
    len: usize,
    /// Bytes the message being assembled has in all (0: waiting for a tag).
    want: usize,
    errors: u32,
}

impl<const N: usize> Assembler<N> {
    const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            want: 0,
            errors: 0,
        }
    }

    /// Takes `byte`; the whole message once its last byte arrived. `length_of` gives a
    /// tag's message length (`None`: not a tag, counted as an error and dropped).
    fn push(&mut self, byte: u8, length_of: impl Fn(u8) -> Option<usize>) -> Option<&[u8]> {
        if self.want == 0 {
            match length_of(byte) {
                Some(want) if want <= N => {
                    self.want = want;
                    self.len = 0;
                }
                _ => {
                    self.errors = self.errors.wrapping_add(1);
                    return None;
                }
            }
        }
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = byte;
        }
        self.len += 1;
        if self.len < self.want {
            return None;
        }
        let whole = self.want;
        self.want = 0;
        self.buf.get(..whole)
    }
}

/// The board's decoder of what the plant sends.
#[derive(Clone, Debug)]
pub struct StepDecoder(Assembler<PLANT_STEP_LEN>);

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
        let message = self.0.push(byte, |tag| match tag {
            STEP_TAG => Some(PLANT_STEP_LEN),
            FINISH => Some(1),
            _ => None,
        })?;
        match message.first() {
            Some(&FINISH) => Some(ToBoard::Finish),
            _ => match PlantStep::decode(message) {
                Some(step) => Some(ToBoard::Step(step)),
                None => {
                    self.0.errors = self.0.errors.wrapping_add(1);
                    None
                }
            },
        }
    }

    /// Bytes and messages dropped: unknown tags, steps of 0 periods.
    pub const fn errors(&self) -> u32 {
        self.0.errors
    }
}

/// The plant's decoder of what the board sends (after [`READY`]).
#[derive(Clone, Debug)]
pub struct BoardDecoder(Assembler<BOARD_STEP_LEN>);

impl Default for BoardDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl BoardDecoder {
    /// A decoder waiting for a tag.
    pub const fn new() -> Self {
        Self(Assembler::new())
    }

    /// Takes one received byte; the message it completes, if any.
    pub fn push(&mut self, byte: u8) -> Option<FromBoard> {
        let message = self.0.push(byte, |tag| match tag {
            BOARD_STEP_TAG => Some(BOARD_STEP_LEN),
            FINISH => Some(BOARD_REPORT_LEN),
            _ => None,
        })?;
        match message.first() {
            Some(&FINISH) => Some(FromBoard::Report(BoardReport::decode(message))),
            _ => match BoardStep::decode(message) {
                Some(step) => Some(FromBoard::Step(step)),
                None => {
                    self.0.errors = self.0.errors.wrapping_add(1);
                    None
                }
            },
        }
    }

    /// Bytes and messages dropped: unknown tags, codes out of range.
    pub const fn errors(&self) -> u32 {
        self.0.errors
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
    }
}

const fn run_mode_from(code: u8) -> Option<RunMode> {
    match code {
        0 => Some(RunMode::FollowPath),
        1 => Some(RunMode::HoldWheelSpeeds),
        _ => None,
    }
}

const fn disarm_code(reason: DisarmReason) -> u8 {
    match reason {
        DisarmReason::Button => 0,
        DisarmReason::Link => 1,
        DisarmReason::Timeout => 2,
        DisarmReason::LinkLost => 3,
    }
}

const fn disarm_from(code: u8) -> Option<DisarmReason> {
    match code {
        0 => Some(DisarmReason::Button),
        1 => Some(DisarmReason::Link),
        2 => Some(DisarmReason::Timeout),
        3 => Some(DisarmReason::LinkLost),
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

/// The fault flags as bits, in the order of [`Faults`]' fields.
const fn fault_bits(f: &Faults) -> u16 {
    let flags = [
        f.core.encoder_jump,
        f.core.non_finite,
        f.overrun,
        f.missed_ticks,
        f.stall_left,
        f.stall_right,
        f.saturated,
        f.divergence,
        f.geofence,
        f.supply_low,
        f.supply_high,
        f.emergency_stop,
    ];
    let mut bits = 0u16;
    let mut i = 0;
    while i < flags.len() {
        if flags[i] {
            bits |= 1 << i;
        }
        i += 1;
    }
    bits
}

fn faults_from(bits: u16) -> Faults {
    let bit = |i: u32| bits & (1 << i) != 0;
    Faults {
        core: FaultFlags {
            encoder_jump: bit(0),
            non_finite: bit(1),
        },
        overrun: bit(2),
        missed_ticks: bit(3),
        stall_left: bit(4),
        stall_right: bit(5),
        saturated: bit(6),
        divergence: bit(7),
        geofence: bit(8),
        supply_low: bit(9),
        supply_high: bit(10),
        emergency_stop: bit(11),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step() -> PlantStep {
        PlantStep {
            ticks: TickDeltas {
                left: -7,
                right: 1_000_000,
            },
            periods: NonZeroU32::new(3).unwrap(),
            supply_v: 5.987_654,
            button_pressed: true,
        }
    }

    fn board_step(event: Option<Event>) -> BoardStep {
        BoardStep {
            duty: MotorCommand {
                left: -0.25,
                right: f32::from_bits(0x3f12_3457),
            },
            bridge: Bridge::Brake,
            state: State::Faulted,
            run_mode: RunMode::HoldWheelSpeeds,
            faults: Faults {
                stall_left: true,
                emergency_stop: true,
                core: FaultFlags {
                    encoder_jump: false,
                    non_finite: true,
                },
                ..Faults::default()
            },
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
            steering_updated: false,
        }
    }

    fn board_messages(bytes: &[u8]) -> (std::vec::Vec<FromBoard>, u32) {
        let mut d = BoardDecoder::new();
        let out = bytes.iter().filter_map(|&b| d.push(b)).collect();
        (out, d.errors())
    }

    #[test]
    fn a_plant_step_crosses_bit_for_bit() {
        let s = step();
        let bytes = s.encode();
        assert_eq!(bytes[0], STEP_TAG);
        let mut d = StepDecoder::new();
        let got: std::vec::Vec<_> = bytes.iter().filter_map(|&b| d.push(b)).collect();
        assert_eq!(got, [ToBoard::Step(s)]);
        assert_eq!(d.push(FINISH), Some(ToBoard::Finish));
        assert_eq!(d.errors(), 0);
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
            Some(Event::Faulted),
            Some(Event::FaultsCleared),
            Some(Event::ModeSelected(RunMode::FollowPath)),
            Some(Event::BatteryLow),
            Some(Event::PersistStarted),
            Some(Event::PersistEnded),
        ];
        let mut bytes = std::vec::Vec::new();
        for e in events {
            bytes.extend_from_slice(&board_step(e).encode());
        }
        let (got, errors) = board_messages(&bytes);
        assert_eq!(errors, 0);
        let expected: std::vec::Vec<_> = events
            .iter()
            .map(|&e| FromBoard::Step(board_step(e)))
            .collect();
        assert_eq!(got, expected);
        // Each fault flag has its own bit.
        for i in 0..12 {
            let f = faults_from(1 << i);
            assert_eq!(fault_bits(&f), 1 << i);
            assert!(f.any());
        }
        assert!(!faults_from(0).any());
    }

    #[test]
    fn a_report_answers_finish() {
        let r = BoardReport {
            control_max_instructions: 1234,
            link_max_instructions: 98_765,
            stack_high_water_bytes: 2048,
            control_steps: 30_001,
        };
        let (got, errors) = board_messages(&r.encode());
        assert_eq!((got, errors), (std::vec![FromBoard::Report(r)], 0));
    }

    #[test]
    fn stray_bytes_and_impossible_steps_are_counted_not_acted_on() {
        let mut d = StepDecoder::new();
        assert_eq!(d.push(0x00), None);
        assert_eq!(d.push(b'x'), None);
        assert_eq!(d.errors(), 2);
        let mut bytes = step().encode();
        bytes[9..13].copy_from_slice(&0u32.to_le_bytes());
        assert!(bytes.iter().all(|&b| d.push(b).is_none()));
        assert_eq!(d.errors(), 3);
        // It resynchronises on the next tag.
        let good = step().encode();
        assert_eq!(
            good.iter().filter_map(|&b| d.push(b)).last(),
            Some(ToBoard::Step(step()))
        );
        // An out-of-range bridge code on the board's side.
        let mut bad = board_step(None).encode();
        bad[9] = 7;
        let (got, errors) = board_messages(&bad);
        assert!(got.is_empty());
        assert_eq!(errors, 1);
    }
}
