//! The link side: the robot's end of the runtime link, run by a low-priority task (or the
//! simulator's loop).
//!
//! [`LinkService`] decodes the host's requests from received bytes, answers what it can
//! answer itself (`Info`, `Ping`, `GetParams`, path chunks, `SetTelemetryRate`,
//! `GetStats`, `GetRunReport`, `GetTuneReport`, `GetPanicRecord`, `ClearPanicRecord`),
//! validates configurations and paths and stages them for the control side,
//! forwards the rest (arming, heartbeats, persistence) as [`ToControl`] requests, and
//! turns the control side's replies, events and telemetry into frames in a bounded
//! transmit buffer ([`TX_CAPACITY`] bytes).
//!
//! # Nothing but telemetry is ever dropped
//!
//! - Before taking another received byte, the service checks that the transmit buffer
//!   has room for the largest frame ([`REPLY_RESERVE`]) plus [`CONTROL_REPLY_MAX`] for
//!   every request still with the control side ([`LinkService::ready_for_input`]); if not,
//!   the bytes wait (in the board's receive ring) until the board has sent some. So every
//!   reply, heartbeat replies and path-chunk acknowledgements included, has room.
//! - Events wait in the uplink ring when the buffer is short of room (they may not take
//!   the room owed to replies); the control side counts the ones the ring could not take.
//! - A run's report (sent when a path-following run ends) waits in the service until
//!   the buffer has room beyond that reserve; a host may also ask for it again.
//! - A telemetry sample is sent only if the buffer keeps that reserve afterwards; else it
//!   is dropped and counted ([`LinkStats::telemetry_dropped`]).
//! - A request the control side cannot take now (its queue is full, a staged install is
//!   in flight, a flash write is in progress) is refused with [`Refusal::Busy`]; one queue
//!   place is kept for `EmergencyStop`.

mod config;
mod persisting;
mod tx;

use controller_core::kinematics::{BodyVelocity, Pose};
use controller_core::path::{Segment, MAX_SEGMENTS};
use controller_core::supervisor::{
    ArmRequest, Command, MotorTestRequest, ResetCause, RunMode, State, Wheel, MOTOR_TEST_MAX_MS,
    MOTOR_TEST_MAX_VOLTS,
};
use link::{
    bounded, check_telemetry_rate, params_hash, ArmMode, BrownOutReset, ClockSource, Commit,
    CommitSummary, CommittedPath, Decoder, Downlink, FieldProblem, LinkStats, NotPermitted,
    ParamSet, ProtocolId, Received, Refusal, Reply, Request, RobotInfo, RunReport, Stats,
    TuneReport, Uplink, UploadSegments, UploadState, MAX_FRAME_LEN,
};

use crate::channel::mailbox::Sender;
use crate::channel::{
    ControlRefusal, LinkEnd, Op, OpKind, Report, Staged, ToControl, ToLink, COMMAND_CAPACITY,
};
use crate::panic_record::{PanicRecord, PanicRecordStore};
use crate::stm32f4::bridge::BridgeChip;

pub use self::config::{bridge_rating_problem, supervisor_problem, within_bridge_rating};
pub use self::persisting::PersistJob;
use self::persisting::{PersistPhase, Persisted};
use self::tx::TxBuffer;
pub use self::tx::TX_CAPACITY;

/// Transmit-buffer room kept for the reply to the request being decoded: the largest
/// frame.
pub const REPLY_RESERVE: usize = MAX_FRAME_LEN;

/// Largest frame the link side sends in answer to a request it forwarded to the control
/// side (`Ack`, `ParamsApplied`, `PathCommitted`, or a short refusal), bytes on the wire;
/// a test checks every one.
pub const CONTROL_REPLY_MAX: usize = 48;

const _: () = assert!(REPLY_RESERVE + COMMAND_CAPACITY * CONTROL_REPLY_MAX <= TX_CAPACITY);

/// Bytes on the wire of the largest telemetry frame (`link::bandwidth::telemetry_wire_len`,
/// checked by a test; a constant here so the target needs no size-counting serializer).
pub const TELEMETRY_WIRE_LEN: usize = 157;

/// Who the robot is and what its board found when it started, as [`Request::Info`]
/// reports it. Strings longer than the link's capacities are cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Identity {
    /// Firmware version, e.g. `0.1.0`.
    pub firmware_version: &'static str,
    /// Git commit of the build, e.g. `e39f8b3c41aa-dirty`.
    pub git_hash: &'static str,
    /// Chip, e.g. `STM32F411CEU6`, or the simulator's name.
    pub chip: &'static str,
    /// The robot's name.
    pub robot_name: &'static str,
    /// What the system clock runs from (the fallback when the external oscillator did not
    /// start).
    pub clock: ClockSource,
    /// The brown-out reset level in force: `PersistParams` is refused unless it guards
    /// flash writes ([`BrownOutReset::guards_flash_writes`]).
    pub brown_out_reset: BrownOutReset,
}

/// How the board's link is set up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkOptions {
    /// UART baud rate (8N1); caps the telemetry rate.
    pub baud: u32,
    /// Telemetry rate at start, Hz (0: off until the host sets one); capped like a
    /// `SetTelemetryRate`.
    pub telemetry_hz: u8,
    /// The board can persist parameters (see [`LinkService::persist_job`]).
    pub storage: bool,
}

/// Figures only the board knows, for [`Request::GetStats`].
pub trait BoardStats {
    /// Longest control step since start, CPU cycles (0 if not measured).
    fn max_step_cycles(&self) -> u32;
    /// Most stack used since start, bytes (0 if not measured).
    fn stack_high_water_bytes(&self) -> u32;
}

/// A board that measures neither and keeps no panic record (e.g. the simulator).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoBoardStats;

impl BoardStats for NoBoardStats {
    fn max_step_cycles(&self) -> u32 {
        0
    }
    fn stack_high_water_bytes(&self) -> u32 {
        0
    }
}

impl PanicRecordStore for NoBoardStats {
    fn panic_record(&self) -> Option<PanicRecord> {
        None
    }
    fn clear_panic_record(&self) {}
}

/// What the board knows that the link service reports: its figures for `GetStats` and
/// its panic record for `GetPanicRecord`.
pub trait Board: BoardStats + PanicRecordStore {}

impl<B: BoardStats + PanicRecordStore + ?Sized> Board for B {}

/// What the link side counted (its decoder's counters are in [`LinkService::stats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ServiceCounters {
    /// Frames put in the transmit buffer.
    pub frames_sent: u32,
    /// Telemetry samples dropped because the transmit buffer had no room.
    pub telemetry_dropped: u32,
    /// Requests refused with `Busy` because the control side could not take them yet.
    pub busy: u32,
    /// Replies that found no room in the transmit buffer (the reserve makes this 0).
    pub replies_dropped: u32,
}

/// The link side (see the module doc). Owned by the link task.
pub struct LinkService<'a> {
    end: LinkEnd<'a>,
    decoder: Decoder,
    /// The open path upload; its segments are in the staging area (`Staged::Assembling`).
    uploads: UploadState,
    tx: TxBuffer,
    identity: Identity,
    /// Why the chip last reset, for `Info`.
    reset_cause: ResetCause,
    /// The configuration in force (the control side confirmed it).
    active: ParamSet,
    active_hash: u32,
    /// The path installed by the last confirmed commit (None: the board's own).
    active_path: Option<CommitSummary>,
    max_telemetry_hz: u8,
    storage: bool,
    /// The board's motor bridge, whose rating bounds `robot.drive.max_supply_v`.
    bridge: BridgeChip,
    /// Requests forwarded to the control side and not answered yet.
    in_flight: usize,
    persist: PersistPhase,
    /// The outcome of the last `PersistParams` that wrote flash, for a repeat of it.
    persisted: Option<Persisted>,
    counters: ServiceCounters,
    /// The last run's report from the control side, and whether it still has to be sent.
    last_report: RunReport,
    /// The last tune's outcome, and whether it still has to be sent.
    last_tune: TuneReport,
    tune_unsent: bool,
    report_unsent: bool,
}

impl<'a> LinkService<'a> {
    /// The link side talking to the control side through `end`, with `active` the
    /// configuration the control side was built with, on a board with `bridge` that last
    /// reset for `reset_cause`.
    /// [`crate::start`] builds both sides from one configuration.
    pub fn new(
        end: LinkEnd<'a>,
        identity: Identity,
        reset_cause: ResetCause,
        active: ParamSet,
        options: LinkOptions,
        bridge: BridgeChip,
    ) -> Self {
        let max_telemetry_hz = max_telemetry_rate_hz(options.baud);
        end.set_telemetry_hz(options.telemetry_hz.min(max_telemetry_hz));
        Self {
            end,
            decoder: Decoder::new(),
            uploads: UploadState::new(),
            tx: TxBuffer::new(),
            identity,
            reset_cause,
            active,
            active_hash: params_hash(&active),
            active_path: None,
            max_telemetry_hz,
            storage: options.storage,
            bridge,
            in_flight: 0,
            persist: PersistPhase::Idle,
            persisted: None,
            counters: ServiceCounters::default(),
            last_report: RunReport::default(),
            last_tune: TuneReport::NONE,
            tune_unsent: false,
            report_unsent: false,
        }
    }

    /// The configuration in force.
    pub const fn active_params(&self) -> &ParamSet {
        &self.active
    }

    /// The fastest telemetry rate accepted at this baud rate, Hz.
    pub const fn max_telemetry_hz(&self) -> u8 {
        self.max_telemetry_hz
    }

    /// What the link side counted.
    pub const fn counters(&self) -> ServiceCounters {
        self.counters
    }

    /// The statistics `GetStats` reports, with the board's figures from `board`. Not
    /// inlined, like the other replies' payloads, so that the link task's request
    /// handling does not hold their room on its stack.
    #[inline(never)]
    pub fn stats<B: Board + ?Sized>(&self, board: &B) -> Stats {
        let control = self.end.control_status();
        Stats {
            max_step_cycles: board.max_step_cycles(),
            missed_ticks: control.missed_ticks,
            overruns: control.overruns,
            stack_high_water_bytes: board.stack_high_water_bytes(),
            link: LinkStats {
                received: self.decoder.counters(),
                frames_sent: self.counters.frames_sent,
                telemetry_dropped: self
                    .counters
                    .telemetry_dropped
                    .wrapping_add(control.telemetry_dropped),
            },
        }
    }

    /// True when the transmit buffer has room for the replies owed and the reply to one
    /// more request: only then take another received byte.
    pub fn ready_for_input(&self) -> bool {
        self.tx.free() >= self.reply_room_owed()
    }

    /// Takes one received byte; a byte that completes a request is acted on at once.
    /// Call only while [`LinkService::ready_for_input`] (a byte taken anyway is decoded,
    /// and a reply that then finds no room is counted in
    /// [`ServiceCounters::replies_dropped`]).
    pub fn receive_byte<B: Board + ?Sized>(&mut self, byte: u8, board: &B) {
        // The request is borrowed where the decoder left it, not moved: it can be a few
        // hundred bytes, and each copy is stack.
        match self.decoder.push::<Downlink>(byte) {
            Some(Ok(Received::Message(ref message))) => {
                self.handle(message.seq, &message.request, board);
            }
            Some(Ok(Received::Mismatch(id))) => self.refuse_version(id),
            // Dropped frames are counted by the decoder.
            Some(Err(_)) | None => {}
        }
    }

    /// Takes received bytes from the front of `bytes` while
    /// [`LinkService::ready_for_input`]; returns how many it took (keep the rest for
    /// later).
    pub fn receive<B: Board + ?Sized>(&mut self, bytes: &[u8], board: &B) -> usize {
        let mut taken = 0;
        for &byte in bytes {
            if !self.ready_for_input() {
                break;
            }
            self.receive_byte(byte, board);
            taken += 1;
        }
        taken
    }

    /// Turns what the control side queued (replies, events, telemetry) into frames, and
    /// resumes a persistence that waits for room in the command queue. Call it whenever
    /// the control side reports [`Actuation::link_has_work`](crate::Actuation), and after
    /// sending frees room.
    pub fn poll(&mut self) {
        while let Some(&item) = self.end.uplink.peek() {
            if let ToLink::Event { step, event } = item {
                let message = Uplink::Event { step, event };
                if !self.tx.append(&message, self.reply_room_owed_by_control()) {
                    break; // waits in the ring until frames have gone out
                }
                self.counters.frames_sent = self.counters.frames_sent.wrapping_add(1);
            }
            let _ = self.end.uplink.pop();
            if let ToLink::Reply { seq, op, result } = item {
                self.in_flight = self.in_flight.saturating_sub(1);
                self.complete(seq, op, result);
            }
        }
        self.resume_persist();
        match self.end.reports.pop() {
            Some(Report::Run(report)) => {
                self.last_report = report;
                self.report_unsent = true;
            }
            Some(Report::Tune(report)) => {
                self.last_tune = report;
                self.tune_unsent = true;
            }
            None => {}
        }
        // Sent like telemetry, without the room owed to replies, but never dropped: it
        // waits here for room (and a host may ask for it with `GetRunReport`).
        if self.report_unsent
            && self
                .tx
                .append(&Uplink::RunReport(self.last_report), self.reply_room_owed())
        {
            self.report_unsent = false;
            self.counters.frames_sent = self.counters.frames_sent.wrapping_add(1);
        }
        // The same for a tune's outcome.
        if self.tune_unsent
            && self
                .tx
                .append(&Uplink::TuneReport(self.last_tune), self.reply_room_owed())
        {
            self.tune_unsent = false;
            self.counters.frames_sent = self.counters.frames_sent.wrapping_add(1);
        }
        if let Some(sample) = self.end.telemetry.pop() {
            if self
                .tx
                .append(&Uplink::Telemetry(sample), self.reply_room_owed())
            {
                self.counters.frames_sent = self.counters.frames_sent.wrapping_add(1);
            } else {
                self.counters.telemetry_dropped = self.counters.telemetry_dropped.wrapping_add(1);
            }
        }
    }

    /// The bytes to send, oldest first. They stay in place until
    /// [`LinkService::consume`], so a DMA transfer may read them meanwhile.
    pub fn outgoing(&self) -> &[u8] {
        self.tx.pending()
    }

    /// The board has sent the first `sent` bytes of [`LinkService::outgoing`].
    pub fn consume(&mut self, sent: usize) {
        self.tx.consume(sent);
    }

    /// Transmit-buffer room owed to replies: one more request's, and the control side's
    /// for every request it still has.
    fn reply_room_owed(&self) -> usize {
        REPLY_RESERVE.saturating_add(self.reply_room_owed_by_control())
    }

    fn reply_room_owed_by_control(&self) -> usize {
        self.in_flight.saturating_mul(CONTROL_REPLY_MAX)
    }

    /// Answers a frame of another protocol version. Not inlined: its message is as large
    /// as any, and inlined its room was on the stack under every request's handling.
    #[inline(never)]
    fn refuse_version(&mut self, received: ProtocolId) {
        self.send_reply(&Uplink::VersionMismatch { received });
    }

    /// Acts on one request; every request gets exactly one reply, now or when the control
    /// side has answered.
    ///
    /// Not inlined, and `request` by reference: the decoded request and the reply are
    /// each a few hundred bytes, and inlined into the caller their copies added up on
    /// the link task's stack. For the same reason the replies' payloads and refusals
    /// with texts are built by functions of their own, out of line: LLVM gave each
    /// inlined one room of its own in this frame, which a path commit's staging then sat
    /// on.
    #[inline(never)]
    fn handle<B: Board + ?Sized>(&mut self, seq: u16, request: &Request, board: &B) {
        // The kept outcome answers only a repeat that comes next: any other request
        // (another station's first `Info`, a new `SetParams`) means the next
        // `PersistParams` is a new one, even if its `seq` happens to be the same.
        if !matches!(request, Request::PersistParams) {
            self.persisted = None;
        }
        let now = match request {
            Request::Info => Some(Ok(Reply::Info(self.info()))),
            &Request::Ping { nonce } => Some(Ok(Reply::Pong { nonce })),
            Request::GetParams => Some(Ok(Reply::Params(self.active))),
            Request::SetParams(set) => self.set_params(seq, set),
            Request::PersistParams => self.persist_params(seq),
            Request::PathBegin(begin) => Some(self.path_begin(begin)),
            Request::PathChunk(chunk) => Some(self.path_chunk(chunk)),
            Request::PathCommit(commit) => self.path_commit(seq, commit),
            &Request::Arm {
                mode,
                initial_motion,
                run_time_limit_steps,
            } => {
                let arm = arm_request(mode, initial_motion, run_time_limit_steps);
                self.forward(seq, Op::Command(Command::Arm(arm)))
            }
            Request::Disarm => self.forward(seq, Op::Command(Command::Disarm)),
            Request::EmergencyStop => self.forward(seq, Op::Command(Command::EmergencyStop)),
            Request::ClearFaults => self.forward(seq, Op::Command(Command::ClearFaults)),
            Request::Heartbeat => self.forward(seq, Op::Command(Command::Heartbeat)),
            &Request::SetTelemetryRate { hz } => Some(self.set_telemetry_rate(hz)),
            Request::GetStats => Some(Ok(Reply::Stats(self.stats(board)))),
            Request::GetRunReport => Some(Ok(Reply::RunReport(self.last_report))),
            Request::GetTuneReport => Some(Ok(Reply::TuneReport(self.last_tune))),
            &Request::SetPose {
                x_m,
                y_m,
                theta_rad,
            } => match finite_pose(x_m, y_m, theta_rad) {
                Ok(pose) => self.forward(seq, Op::Command(Command::SetPose(pose))),
                Err(refused) => Some(Err(refused)),
            },
            Request::GetPanicRecord => Some(Ok(panic_record_reply(board))),
            Request::ClearPanicRecord => {
                board.clear_panic_record();
                Some(Ok(Reply::Ack))
            }
            &Request::Velocity { v_m_s, omega_rad_s } => {
                match finite_velocity(v_m_s, omega_rad_s) {
                    Ok(body) => self.forward(seq, Op::Command(Command::Velocity(body))),
                    Err(refused) => Some(Err(refused)),
                }
            }
            &Request::MotorTest {
                wheel,
                volts,
                duration_ms,
                confirm,
            } => match motor_test(
                wheel,
                volts,
                duration_ms,
                confirm,
                self.active.robot.control_rate_hz,
            ) {
                Ok(test) => self.forward(seq, Op::Command(Command::MotorTest(test))),
                Err(refused) => Some(Err(refused)),
            },
        };
        if let Some(result) = now {
            self.reply(seq, result);
        }
    }

    /// What `Info` reports. Not inlined: see [`LinkService::handle`].
    #[inline(never)]
    fn info(&self) -> RobotInfo {
        let id = &self.identity;
        RobotInfo {
            protocol: ProtocolId::OURS,
            firmware_version: bounded(id.firmware_version),
            git_hash: bounded(id.git_hash),
            chip: bounded(id.chip),
            robot_name: bounded(id.robot_name),
            params_hash: self.active_hash,
            bridge: self.bridge,
            clock: id.clock,
            brown_out_reset: id.brown_out_reset,
            reset_cause: self.reset_cause,
        }
    }

    /// `SetTelemetryRate`. Not inlined, nor [`LinkService::path_begin`]: a refusal's
    /// bounded texts are built on the stack, and inlined in [`LinkService::handle`] they
    /// were room of their own under every request.
    #[inline(never)]
    fn set_telemetry_rate(&mut self, hz: u8) -> Result<Reply, Refusal> {
        let hz = check_telemetry_rate(hz)?;
        if hz > self.max_telemetry_hz {
            return Err(Refusal::InvalidArgument(FieldProblem::new(
                "hz",
                "is more than this baud rate carries",
            )));
        }
        self.end.set_telemetry_hz(hz);
        Ok(Reply::Ack)
    }

    /// `PathBegin`: a new upload, unless the robot is armed.
    #[inline(never)]
    fn path_begin(&mut self, begin: &link::PathBegin) -> Result<Reply, Refusal> {
        self.refuse_if_armed()
            .and_then(|()| self.uploads.begin(begin))
    }

    /// The last state the control side published.
    fn state(&self) -> Option<State> {
        self.end.control_status().state
    }

    /// `Armed` while the robot is armed (as last published; the control side checks
    /// again when it acts).
    fn refuse_if_armed(&self) -> Result<(), Refusal> {
        if self.state() == Some(State::Armed) {
            Err(Refusal::Armed)
        } else {
            Ok(())
        }
    }

    /// Queue places a request needs: all but the last, which is kept for
    /// `EmergencyStop`.
    fn queue_has_room(&self, op: &Op) -> bool {
        let needed = match op {
            Op::Command(Command::EmergencyStop) => 1,
            _ => 2,
        };
        self.end.commands.free() >= needed
    }

    /// Hands `op` to the control side (its reply comes through [`LinkService::poll`]), or
    /// refuses with `Busy` when the queue is full.
    fn forward(&mut self, seq: u16, op: Op) -> Option<Result<Reply, Refusal>> {
        if !self.queue_has_room(&op) || self.end.commands.push(ToControl { seq, op }).is_err() {
            return Some(Err(self.busy()));
        }
        self.in_flight = self.in_flight.saturating_add(1);
        None
    }

    fn busy(&mut self) -> Refusal {
        self.counters.busy = self.counters.busy.wrapping_add(1);
        Refusal::Busy
    }

    /// Checks that an install can be staged and forwarded now.
    fn ready_to_install(&mut self) -> Result<(), Refusal> {
        self.refuse_if_armed()?;
        if !self.end.staging.is_empty() || !self.queue_has_room(&Op::Install) {
            return Err(self.busy());
        }
        Ok(())
    }

    /// Stores a chunk of the open upload in the staging area, which holds the upload's
    /// segments while it is empty (`Staged::Assembling`; busy while a staged item waits
    /// for the control side, which a host that waits for each reply never meets).
    fn path_chunk(&mut self, chunk: &link::PathChunk) -> Result<Reply, Refusal> {
        match upload_room(&mut self.end.staging) {
            Some(segments) => self.uploads.chunk(chunk, segments),
            None => Err(self.busy()),
        }
    }

    /// Stages `staged` and asks the control side to install it. Called only after
    /// [`LinkService::ready_to_install`]: the mailbox is empty and the queue has room,
    /// and only this side fills either, so neither step can fail here (a staged item
    /// without its `Install` would block the mailbox).
    fn install(&mut self, seq: u16, staged: Staged) -> Option<Result<Reply, Refusal>> {
        if self.end.staging.stage(staged).is_err() {
            return Some(Err(self.busy()));
        }
        self.forward(seq, Op::Install)
    }

    /// Publishes what was built in the staging area and asks the control side to
    /// install it (see [`LinkService::install`]).
    fn forward_staged(&mut self, seq: u16) -> Option<Result<Reply, Refusal>> {
        if !self.end.staging.publish() {
            return Some(Err(self.busy()));
        }
        self.forward(seq, Op::Install)
    }

    // Cold: kept out of the link task's frame, which a control step preempting it adds to.
    #[inline(never)]
    fn path_commit(
        &mut self,
        seq: u16,
        commit: &link::PathCommit,
    ) -> Option<Result<Reply, Refusal>> {
        // Before the assembler closes the upload: a refusal here leaves it open.
        if let Err(refusal) = self.ready_to_install() {
            return Some(Err(refusal));
        }
        // `ready_to_install` found the staging area empty, so the room is there.
        let Some(segments) = upload_room(&mut self.end.staging) else {
            return Some(Err(self.busy()));
        };
        let committed = match self.uploads.commit(commit, segments) {
            Ok(Commit::New(committed)) => committed,
            Ok(Commit::Repeated(summary)) if self.active_path == Some(summary) => {
                return Some(Ok(Reply::PathCommitted(summary)));
            }
            // A repeat of a commit that never became active (the control side refused
            // it): its segments are gone, the host must upload again.
            Ok(Commit::Repeated(summary)) => {
                return Some(Err(Refusal::UnknownUpload {
                    upload_id: summary.upload_id,
                }));
            }
            Err(refusal) => return Some(Err(refusal)),
        };
        match stage_path_in_place(&mut self.end.staging, &committed, &self.active) {
            Ok(()) => self.forward_staged(seq),
            Err(refusal) => Some(Err(refusal)),
        }
    }

    // Cold and large (a path or a configuration by value): kept out of the link task's
    // frame, which a control step preempting it adds to.
    #[inline(never)]
    fn set_params(&mut self, seq: u16, set: &ParamSet) -> Option<Result<Reply, Refusal>> {
        if let Err(refusal) = self.ready_to_install() {
            return Some(Err(refusal));
        }
        match config::check(set, self.active.robot.control_rate_hz, self.bridge) {
            Ok(params) => {
                // The configuration takes the room the open upload's segments are in:
                // the upload is over (the host begins it again).
                self.uploads.abort();
                self.install(
                    seq,
                    Staged::Params {
                        params,
                        supervisor: set.supervisor,
                    },
                )
            }
            Err(refusal) => Some(Err(refusal)),
        }
    }

    /// The control side answered the request `seq`.
    fn complete(&mut self, seq: u16, op: OpKind, result: Result<(), ControlRefusal>) {
        let reply = match op {
            OpKind::Command => Some(result.map(|()| Reply::Ack).map_err(refusal)),
            OpKind::Install => Some(self.installed(result)),
            OpKind::BeginPersist => self.persist_started(seq, result),
            OpKind::EndPersist => self.persist_ended(seq),
        };
        if let Some(result) = reply {
            self.reply(seq, result);
        }
    }

    /// The control side installed (or refused) what was staged: update the active
    /// configuration, empty the staging area, and say what is now active.
    // Cold and large (a path or a configuration by value): kept out of the link task's
    // frame, which a control step preempting it adds to.
    #[inline(never)]
    fn installed(&mut self, result: Result<(), ControlRefusal>) -> Result<Reply, Refusal> {
        let reply = match (result, self.end.staging.done()) {
            (Err(refused), _) => Err(refusal(refused)),
            (Ok(()), None) => Err(Refusal::Busy),
            (Ok(()), Some(Staged::Params { params, supervisor })) => {
                self.active = ParamSet {
                    robot: *params.config(),
                    supervisor: *supervisor,
                };
                self.active_hash = params_hash(&self.active);
                Ok(Reply::ParamsApplied {
                    params_hash: self.active_hash,
                })
            }
            (Ok(()), Some(Staged::Path(path))) => {
                self.active.supervisor = path.supervisor;
                self.active_hash = params_hash(&self.active);
                self.active_path = Some(path.summary);
                Ok(Reply::PathCommitted(path.summary))
            }
            // Never published (the control side refuses it as not staged).
            (Ok(()), Some(Staged::Assembling(_))) => Err(Refusal::Busy),
        };
        self.end.staging.clear();
        reply
    }

    /// Answers the request `seq` with `result` ([`LinkService::send_reply`]). Not
    /// inlined: the message it builds is another copy of the reply, which need not be on
    /// the stack while the reply is worked out.
    #[inline(never)]
    fn reply(&mut self, seq: u16, result: Result<Reply, Refusal>) {
        self.send_reply(&Uplink::Reply { seq, result });
    }

    /// Appends a reply (room is reserved for it; counted if there was none).
    fn send_reply(&mut self, message: &Uplink) {
        if self.tx.append(message, 0) {
            self.counters.frames_sent = self.counters.frames_sent.wrapping_add(1);
        } else {
            self.counters.replies_dropped = self.counters.replies_dropped.wrapping_add(1);
        }
    }
}

/// The pose of a `SetPose`, or the refusal that names its first field that is not
/// finite. Not inlined: see [`LinkService::handle`].
#[inline(never)]
fn finite_pose(x_m: f32, y_m: f32, theta_rad: f32) -> Result<Pose, Refusal> {
    for (field, value) in [("x_m", x_m), ("y_m", y_m), ("theta_rad", theta_rad)] {
        if !value.is_finite() {
            return Err(Refusal::InvalidArgument(FieldProblem::new(
                field,
                "must be finite",
            )));
        }
    }
    Ok(Pose::new(x_m, y_m, theta_rad))
}

/// The body velocity of a `Velocity`, or the refusal that names its first field that is
/// not finite. Not inlined: see [`LinkService::handle`].
#[inline(never)]
fn finite_velocity(v_m_s: f32, omega_rad_s: f32) -> Result<BodyVelocity, Refusal> {
    for (field, value) in [("v_m_s", v_m_s), ("omega_rad_s", omega_rad_s)] {
        if !value.is_finite() {
            return Err(Refusal::InvalidArgument(FieldProblem::new(
                field,
                "must be finite",
            )));
        }
    }
    Ok(BodyVelocity::new(v_m_s, omega_rad_s))
}

/// The supervisor's motor pulse for the link's `MotorTest` at a control rate of
/// `rate_hz` (Hz), or the refusal that names what is wrong: the confirmation first, then
/// each field out of its bounds. Not inlined: see [`LinkService::handle`].
#[inline(never)]
fn motor_test(
    wheel: Wheel,
    volts: f32,
    duration_ms: u16,
    confirm: u32,
    rate_hz: u32,
) -> Result<MotorTestRequest, Refusal> {
    if confirm != link::MOTOR_TEST_CONFIRMATION {
        return Err(Refusal::NotPermitted(NotPermitted::MotorTestUnconfirmed));
    }
    if !(volts.is_finite() && controller_core::math::abs(volts) <= MOTOR_TEST_MAX_VOLTS) {
        return Err(Refusal::InvalidArgument(FieldProblem::new(
            "volts",
            "must be finite and at most 3 V either way",
        )));
    }
    if duration_ms == 0 || u32::from(duration_ms) > MOTOR_TEST_MAX_MS {
        return Err(Refusal::InvalidArgument(FieldProblem::new(
            "duration_ms",
            "must be in 1..=500",
        )));
    }
    let steps = (u64::from(rate_hz) * u64::from(duration_ms) / 1000).max(1) as u32;
    Ok(MotorTestRequest {
        wheel,
        volts,
        steps,
    })
}

/// The reply to `GetPanicRecord`: what `board` keeps. Not inlined: see
/// [`LinkService::handle`].
#[inline(never)]
fn panic_record_reply<B: Board + ?Sized>(board: &B) -> Reply {
    Reply::PanicRecord(board.panic_record().map(|record| record.report()))
}

/// The supervisor's arm request for the link's `Arm`.
fn arm_request(
    mode: ArmMode,
    initial_motion: Option<BodyVelocity>,
    run_time_limit_steps: Option<u32>,
) -> ArmRequest {
    let (mode, hold_speeds) = match mode {
        ArmMode::FollowPath => (RunMode::FollowPath, None),
        ArmMode::HoldWheelSpeeds(speeds) => (RunMode::HoldWheelSpeeds, Some(speeds)),
        ArmMode::Tune => (RunMode::Tune, None),
        ArmMode::FollowVelocity => (RunMode::FollowVelocity, None),
    };
    ArmRequest {
        mode,
        hold_speeds,
        initial_motion,
        max_armed_steps: run_time_limit_steps,
    }
}

/// The link's refusal for the control side's.
fn refusal(refused: ControlRefusal) -> Refusal {
    match refused {
        ControlRefusal::Armed => Refusal::Armed,
        ControlRefusal::Faulted => Refusal::Faulted,
        ControlRefusal::Busy => Refusal::Busy,
        ControlRefusal::ButtonHeld => Refusal::NotPermitted(NotPermitted::ButtonHeld),
        ControlRefusal::WheelsTurning => Refusal::NotPermitted(NotPermitted::WheelsTurning),
        ControlRefusal::NotInVelocityMode => Refusal::NotPermitted(NotPermitted::NotInVelocityMode),
        ControlRefusal::Invalid => Refusal::InvalidParams(FieldProblem {
            field: link::bounded("supervisor"),
            problem: link::bounded("is not valid"),
        }),
    }
}

/// The fastest telemetry rate a UART at `baud` (8N1) carries with the link's default
/// reserve, Hz, capped to 100 Hz: `link::max_telemetry_rate_hz` in 32-bit arithmetic
/// (the link's 64-bit division costs the target about 0.9 KiB of flash for one division;
/// a test checks both agree).
pub fn max_telemetry_rate_hz(baud: u32) -> u8 {
    const KEPT_PERCENT: u32 = 100 - link::bandwidth::DEFAULT_RESERVED_PERCENT as u32;
    let bytes_per_s = baud / link::bandwidth::BITS_PER_BYTE_8N1;
    // ⌊bytes_per_s · kept / 100⌋ exactly, without overflowing 32 bits.
    let usable = bytes_per_s / 100 * KEPT_PERCENT + bytes_per_s % 100 * KEPT_PERCENT / 100;
    let rate = usable / TELEMETRY_WIRE_LEN as u32;
    let max = *link::TELEMETRY_RATE_HZ.end();
    u8::try_from(rate).map_or(max, |r| r.min(max))
}

/// Turns the staging area's upload room into the committed path, in place: the
/// segments are copied out (the one copy on the stack, under 1 KiB), the room becomes
/// [`Staged::PATH_PLACEHOLDER`] (written from flash), and the path is built into it
/// ([`config::stage_path`]). Not published: the caller does that. Not inlined, so its
/// copy of the segments and the commit's own temporaries are never on the stack together.
#[inline(never)]
fn stage_path_in_place(
    staging: &mut Sender<'_, Staged>,
    committed: &CommittedPath,
    active: &ParamSet,
) -> Result<(), Refusal> {
    let Some(slot) = staging.item_mut() else {
        return Err(Refusal::Busy);
    };
    let Staged::Assembling(room) = slot else {
        return Err(Refusal::Busy);
    };
    let mut segments = heapless::Vec::<Segment, MAX_SEGMENTS>::new();
    // The room holds at most MAX_SEGMENTS: it fits.
    let _ = segments.extend_from_slice(room.first(committed.summary.segment_count));
    *slot = Staged::PATH_PLACEHOLDER;
    let Staged::Path(staged) = slot else {
        return Err(Refusal::Busy);
    };
    config::stage_path(staged, committed, &segments, active)
}

/// The room the open path upload is assembled in: the staging area, while it is empty
/// (what was installed last is no longer needed there, and its room becomes the
/// upload's). None while a staged item waits for the control side or for its reply.
fn upload_room<'s>(staging: &'s mut Sender<'_, Staged>) -> Option<&'s mut UploadSegments> {
    let slot = staging.item_mut()?;
    if !matches!(slot, Staged::Assembling(_)) {
        *slot = Staged::ASSEMBLING;
    }
    match slot {
        Staged::Assembling(segments) => Some(segments),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use link::{CommitSummary, RxCounters};

    fn wire_len(message: &Uplink) -> usize {
        let mut buf = [0u8; MAX_FRAME_LEN];
        link::encode(message, &mut buf).unwrap_or(usize::MAX)
    }

    #[test]
    fn the_telemetry_frame_length_is_the_links() {
        assert_eq!(TELEMETRY_WIRE_LEN, link::bandwidth::telemetry_wire_len());
        for baud in [
            0,
            1_200,
            9_600,
            57_600,
            115_200,
            230_400,
            460_800,
            921_600,
            3_000_000,
            u32::MAX,
        ]
        .into_iter()
        // And every seventh baud below the cap, where each digit of the arithmetic counts.
        .chain((0..200_000).step_by(7))
        {
            assert_eq!(
                max_telemetry_rate_hz(baud),
                link::max_telemetry_rate_hz(baud, link::bandwidth::DEFAULT_RESERVED_PERCENT),
                "{baud} baud"
            );
        }
    }

    #[test]
    fn every_reply_to_a_forwarded_request_fits_its_reserve() {
        let summary = CommitSummary {
            upload_id: u16::MAX,
            segment_count: u8::MAX,
            checksum: u32::MAX,
            length_m: f32::MAX,
            closed: true,
        };
        let mut results = vec![
            Ok(Reply::Ack),
            Ok(Reply::ParamsApplied {
                params_hash: u32::MAX,
            }),
            Ok(Reply::PathCommitted(summary)),
        ];
        for refused in [
            ControlRefusal::Armed,
            ControlRefusal::Faulted,
            ControlRefusal::Busy,
            ControlRefusal::ButtonHeld,
            ControlRefusal::Invalid,
            ControlRefusal::WheelsTurning,
        ] {
            results.push(Err(refusal(refused)));
        }
        results.push(Err(Refusal::NotPermitted(NotPermitted::StorageFailed)));
        for result in results {
            let message = Uplink::Reply {
                seq: u16::MAX,
                result,
            };
            let len = wire_len(&message);
            assert!(len <= CONTROL_REPLY_MAX, "{len} B: {message:?}");
        }
    }

    #[test]
    fn stats_fit_a_reply_frame() {
        let stats = Stats {
            max_step_cycles: u32::MAX,
            missed_ticks: u32::MAX,
            overruns: u32::MAX,
            stack_high_water_bytes: u32::MAX,
            link: LinkStats {
                received: RxCounters {
                    frames_ok: u32::MAX,
                    crc_errors: u32::MAX,
                    format_errors: u32::MAX,
                    overflows: u32::MAX,
                    mismatches: u32::MAX,
                    decode_errors: u32::MAX,
                },
                frames_sent: u32::MAX,
                telemetry_dropped: u32::MAX,
            },
        };
        let len = wire_len(&Uplink::Reply {
            seq: u16::MAX,
            result: Ok(Reply::Stats(stats)),
        });
        assert!(len <= REPLY_RESERVE, "{len}");
    }

    #[test]
    fn arm_modes_map_to_the_supervisors() {
        let speeds = controller_core::kinematics::WheelSpeeds::new(2.0, -1.0);
        let hold = arm_request(ArmMode::HoldWheelSpeeds(speeds), None, None);
        assert_eq!(
            (hold.mode, hold.hold_speeds),
            (RunMode::HoldWheelSpeeds, Some(speeds))
        );
        let follow = arm_request(ArmMode::FollowPath, None, None);
        assert_eq!(follow.mode, RunMode::FollowPath);
        let tune = arm_request(ArmMode::Tune, None, None);
        assert_eq!((tune.mode, tune.hold_speeds), (RunMode::Tune, None));
    }
}
