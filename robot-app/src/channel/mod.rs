//! What passes between the control side and the link side, and how, without either
//! side ever waiting for the other.
//!
//! | path | carries | capacity | when full |
//! |---|---|---|---|
//! | commands, link → control | a request's `seq` and what to do ([`ToControl`]) | [`COMMAND_CAPACITY`] | the link side refuses with `Busy` (one place is kept for `EmergencyStop`) |
//! | uplink, control → link | replies to commands and supervisor events ([`ToLink`]) | [`UPLINK_CAPACITY`] | the control side takes no command (so replies always have room); an event is dropped and counted |
//! | telemetry, control → link | the latest [`TelemetryFrame`] | [`TELEMETRY_CAPACITY`] | the sample is dropped and counted |
//! | run reports, control → link | a path-following run's [`RunReport`], once when it ends | [`REPORT_CAPACITY`] | the report is dropped (the link side still has the previous one) |
//! | staging, link → control → link | a new configuration or path ([`Staged`]) | one | the link side refuses with `Busy` |
//! | status, control → link | state, step, missed ticks, overruns, drop counters | atomics | overwritten every step |
//! | telemetry rate, link → control | Hz | an atomic | overwritten |
//!
//! Commands, uplink and telemetry are lock-free single-producer single-consumer rings
//! ([`ring`]); the staging area is a one-item mailbox ([`mailbox`]) that the control side
//! reads in place and hands back, so the link side can read what was applied, and that
//! the link side assembles path uploads in while it is empty; the rest are atomics. The control side copies bulk data only when a command tells it to
//! install what is staged, and only while disarmed.
//!
//! [`Channels`] holds all of it; [`Channels::split`] gives the [`LinkEnd`] (for the
//! [`LinkService`](crate::LinkService)) and the [`ControlEnd`] (for the
//! [`ControlSide`](crate::ControlSide)). In RTIC, put the `Channels` in a `static` (e.g.
//! `#[init(local = [channels: Channels = Channels::new()])]`), split it in `init`, and
//! move each end into its task's local resources: no lock is needed, because each ring
//! has one producer and one consumer and the atomics need none.

#[cfg(test)]
mod interleavings;
pub mod mailbox;
pub mod ring;

use core::sync::atomic::{AtomicU32, AtomicU8, Ordering};

use controller_core::kinematics::{Pose, WheelSpeeds};
use controller_core::law::LawKind;
use controller_core::params::Params;
use controller_core::reference::Reference;
use controller_core::supervisor::{Command, Event, State, SupervisorConfig};
use link::{CommitSummary, RunReport, TelemetryFrame, TuneReport, UploadSegments};

use self::mailbox::{Mailbox, Receiver, Sender};
use self::ring::{Consumer, Producer, Ring};
use crate::outer::OuterLoopSlot;

/// Commands the link side may queue for the control side, which takes at most one per
/// control step.
pub const COMMAND_CAPACITY: usize = 4;
/// Replies and events the control side may queue for the link side.
pub const UPLINK_CAPACITY: usize = 8;
/// Telemetry samples the control side may queue: one; the link side sends the latest.
pub const TELEMETRY_CAPACITY: usize = 1;
/// Run and tune reports the control side may queue: one (a run or a tune ends at most
/// once per step, and the link side takes it at its next poll).
pub const REPORT_CAPACITY: usize = 1;

/// What ended: a path-following run or a wheel-loop tune.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Report {
    /// A path-following run's metrics.
    Run(RunReport),
    /// A tune's model and gains, or why it stopped.
    Tune(TuneReport),
}

/// A request the link side forwards to the control side: the `seq` to answer and what to
/// do. Each gets exactly one [`ToLink::Reply`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToControl {
    /// The request's [`Downlink::seq`](link::Downlink), echoed in the reply.
    pub seq: u16,
    /// What to do.
    pub op: Op,
}

/// What the control side is asked to do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Op {
    /// Hand this command to the supervisor in the next step.
    Command(Command),
    /// Enter the supervisor's Persisting state (the start of a `PersistParams`).
    BeginPersist,
    /// Leave Persisting (the board finished its flash work).
    EndPersist,
    /// Install what is staged (a configuration or a path), if disarmed.
    Install,
}

impl Op {
    /// The kind of operation, echoed in its reply.
    pub const fn kind(&self) -> OpKind {
        match self {
            Op::Command(_) => OpKind::Command,
            Op::BeginPersist => OpKind::BeginPersist,
            Op::EndPersist => OpKind::EndPersist,
            Op::Install => OpKind::Install,
        }
    }
}

/// Which kind of [`Op`] a reply answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OpKind {
    /// [`Op::Command`].
    Command,
    /// [`Op::BeginPersist`].
    BeginPersist,
    /// [`Op::EndPersist`].
    EndPersist,
    /// [`Op::Install`].
    Install,
}

/// Why the control side did not do what it was asked (the link side turns it into a
/// [`link::Refusal`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ControlRefusal {
    /// The robot is armed.
    Armed,
    /// Faults are latched.
    Faulted,
    /// Not now (persisting, or nothing staged); retry.
    Busy,
    /// The button is held: the local stop wins.
    ButtonHeld,
    /// The staged supervisor settings were rejected (the link side validates them first,
    /// so this means the two disagree).
    Invalid,
    /// Arming from rest while a wheel still turns (the supervisor's
    /// [`CommandRefusal::WheelsTurning`](controller_core::supervisor::CommandRefusal)).
    WheelsTurning,
    /// A velocity command while not armed in the velocity mode.
    NotInVelocityMode,
}

impl core::fmt::Display for ControlRefusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ControlRefusal::Armed => "the robot is armed",
            ControlRefusal::Faulted => "faults are latched",
            ControlRefusal::Busy => "not now (persisting, or nothing staged): retry",
            ControlRefusal::ButtonHeld => "the robot's button is held (local stop)",
            ControlRefusal::Invalid => "the staged settings were rejected",
            ControlRefusal::WheelsTurning => "the wheels are still turning",
            ControlRefusal::NotInVelocityMode => "not armed in the velocity mode",
        })
    }
}

impl core::error::Error for ControlRefusal {}

/// What the control side sends the link side besides telemetry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToLink {
    /// The outcome of a [`ToControl`].
    Reply {
        /// The request's `seq`.
        seq: u16,
        /// What it was.
        op: OpKind,
        /// Done, or why not.
        result: Result<(), ControlRefusal>,
    },
    /// A supervisor state change.
    Event {
        /// Control step at which it happened (since start).
        step: u32,
        /// What happened.
        event: Event,
    },
}

/// Bulk data handed from the link side to the control side through the staging area, to
/// be installed atomically at a commit; between commits, the slot a path upload is
/// assembled in.
// A path is about 1 KiB; the staging area holds one item and there is no heap to box it.
#[allow(clippy::large_enum_variant)]
// An explicit tag, `Assembling` first (tag 0): the initial item, empty segments, is then
// all zero bytes, and the `Channels` static stays in `.bss` instead of costing its 1.6 KB
// of initial value in flash (`cargo xtask size` would show it in `.data`).
#[repr(u8)]
#[derive(Clone, Debug)]
pub enum Staged {
    /// The segments of the path upload being received (never published): a path is
    /// assembled in the slot it is then staged in, so the link side needs no storage of
    /// its own for it. Staging a configuration over it discards the open upload.
    Assembling(UploadSegments),
    /// A new configuration, already validated.
    Params {
        /// The robot's parameters.
        params: Params,
        /// The supervisor's settings (validated against `params`).
        supervisor: SupervisorConfig,
    },
    /// A new path with how to follow it.
    Path(StagedPath),
}

impl Staged {
    /// An empty upload slot (a constant: written from flash, not built on the stack).
    pub const ASSEMBLING: Staged = Staged::Assembling(UploadSegments::new());
    /// Space for a committed path to be built into ([`StagedPath::PLACEHOLDER`]), whole
    /// for the same reason.
    pub const PATH_PLACEHOLDER: Staged = Staged::Path(StagedPath::PLACEHOLDER);
}

/// A committed path upload, ready to install.
#[derive(Clone, Debug)]
pub struct StagedPath {
    /// The path, its reference speed and mode.
    pub reference: Reference,
    /// The steering law to follow it with.
    pub law: LawKind,
    /// The supervisor's settings with the upload's start pose (world frame, m and rad)
    /// and, where enabled, the divergence check and geofence derived for this path.
    pub supervisor: SupervisorConfig,
    /// What the commit reports.
    pub summary: CommitSummary,
}

impl StagedPath {
    /// Space for a path to be built into in place ([`Reference::PLACEHOLDER`], the
    /// tracking law, the supervisor's defaults at 1 kHz, an empty summary): a constant,
    /// written from flash.
    pub const PLACEHOLDER: StagedPath = StagedPath {
        reference: Reference::PLACEHOLDER,
        law: LawKind::Tracking,
        supervisor: SupervisorConfig::at_rate(
            1000,
            Pose {
                x_m: 0.0,
                y_m: 0.0,
                theta_rad: 0.0,
            },
            WheelSpeeds::new(0.0, 0.0),
        ),
        summary: CommitSummary {
            upload_id: 0,
            segment_count: 0,
            checksum: 0,
            length_m: 0.0,
            closed: false,
        },
    };
}

/// What the control side publishes every step, and the telemetry rate the link side sets.
/// Every field is an atomic written by one side only.
#[derive(Debug)]
pub(crate) struct Status {
    state: AtomicU8,
    step: AtomicU32,
    missed_ticks: AtomicU32,
    overruns: AtomicU32,
    telemetry_dropped: AtomicU32,
    events_dropped: AtomicU32,
    /// Telemetry rate, Hz (0: off); written by the link side.
    telemetry_hz: AtomicU8,
}

/// The control side's counters as the link side sees them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ControlStatus {
    /// Supervisor state after the last step.
    pub state: Option<State>,
    /// Control steps since start.
    pub step: u32,
    /// Missed control ticks since start (saturating).
    pub missed_ticks: u32,
    /// Overrun steps since start (saturating).
    pub overruns: u32,
    /// Telemetry samples dropped because the link side had not taken the previous one.
    pub telemetry_dropped: u32,
    /// Events dropped because the uplink ring was full.
    pub events_dropped: u32,
}

const fn state_code(state: State) -> u8 {
    match state {
        State::Disarmed => 1,
        State::Armed => 2,
        State::Faulted => 3,
        State::Persisting => 4,
    }
}

const fn state_from_code(code: u8) -> Option<State> {
    match code {
        1 => Some(State::Disarmed),
        2 => Some(State::Armed),
        3 => Some(State::Faulted),
        4 => Some(State::Persisting),
        _ => None,
    }
}

impl Status {
    const fn new() -> Self {
        Self {
            state: AtomicU8::new(0),
            step: AtomicU32::new(0),
            missed_ticks: AtomicU32::new(0),
            overruns: AtomicU32::new(0),
            telemetry_dropped: AtomicU32::new(0),
            events_dropped: AtomicU32::new(0),
            telemetry_hz: AtomicU8::new(0),
        }
    }

    fn read(&self) -> ControlStatus {
        ControlStatus {
            state: state_from_code(self.state.load(Ordering::Relaxed)),
            step: self.step.load(Ordering::Relaxed),
            missed_ticks: self.missed_ticks.load(Ordering::Relaxed),
            overruns: self.overruns.load(Ordering::Relaxed),
            telemetry_dropped: self.telemetry_dropped.load(Ordering::Relaxed),
            events_dropped: self.events_dropped.load(Ordering::Relaxed),
        }
    }
}

/// Everything shared by the two sides (see the module doc), and the control side's outer
/// loop, which it may lend to a third context (`crate::outer`). About 3 KiB, most of it
/// the staging area's slot for a path (where uploads are assembled too) and the outer
/// loop's reference; `const`-constructible for a `static`.
pub struct Channels {
    commands: Ring<ToControl, COMMAND_CAPACITY>,
    uplink: Ring<ToLink, UPLINK_CAPACITY>,
    telemetry: Ring<TelemetryFrame, TELEMETRY_CAPACITY>,
    reports: Ring<Report, REPORT_CAPACITY>,
    staging: Mailbox<Staged>,
    status: Status,
    outer_loop: Mailbox<OuterLoopSlot>,
}

impl Default for Channels {
    fn default() -> Self {
        Self::new()
    }
}

impl Channels {
    /// Empty channels.
    pub const fn new() -> Self {
        Self {
            commands: Ring::new(),
            uplink: Ring::new(),
            telemetry: Ring::new(),
            reports: Ring::new(),
            staging: Mailbox::new(Staged::Assembling(UploadSegments::new())),
            status: Status::new(),
            outer_loop: Mailbox::new(OuterLoopSlot::Empty),
        }
    }

    /// The link side's end and the control side's end.
    pub fn split(&mut self) -> (LinkEnd<'_>, ControlEnd<'_>) {
        let (link, control, _) = self.split_all();
        (link, control)
    }

    /// The link side's end, the control side's end, and the two ends of the outer loop's
    /// mailbox.
    pub(crate) fn split_all(
        &mut self,
    ) -> (
        LinkEnd<'_>,
        ControlEnd<'_>,
        (Sender<'_, OuterLoopSlot>, Receiver<'_, OuterLoopSlot>),
    ) {
        let Channels {
            commands,
            uplink,
            telemetry,
            reports,
            staging,
            status,
            outer_loop,
        } = self;
        let (command_tx, command_rx) = commands.split();
        let (uplink_tx, uplink_rx) = uplink.split();
        let (telemetry_tx, telemetry_rx) = telemetry.split();
        let (report_tx, report_rx) = reports.split();
        let (staging_tx, staging_rx) = staging.split();
        let status: &Status = status;
        (
            LinkEnd {
                commands: command_tx,
                uplink: uplink_rx,
                telemetry: telemetry_rx,
                reports: report_rx,
                staging: staging_tx,
                status,
            },
            ControlEnd {
                commands: command_rx,
                uplink: uplink_tx,
                telemetry: telemetry_tx,
                reports: report_tx,
                staging: staging_rx,
                status,
            },
            outer_loop.split(),
        )
    }
}

/// The link side's end of the [`Channels`]: give it to
/// [`LinkService`](crate::LinkService).
pub struct LinkEnd<'a> {
    pub(crate) commands: Producer<'a, ToControl, COMMAND_CAPACITY>,
    pub(crate) uplink: Consumer<'a, ToLink, UPLINK_CAPACITY>,
    pub(crate) telemetry: Consumer<'a, TelemetryFrame, TELEMETRY_CAPACITY>,
    pub(crate) reports: Consumer<'a, Report, REPORT_CAPACITY>,
    pub(crate) staging: Sender<'a, Staged>,
    status: &'a Status,
}

impl LinkEnd<'_> {
    /// The control side's state and counters as last published.
    pub fn control_status(&self) -> ControlStatus {
        self.status.read()
    }

    /// Sets the telemetry rate the control side samples at, Hz (0: off).
    pub(crate) fn set_telemetry_hz(&self, hz: u8) {
        self.status.telemetry_hz.store(hz, Ordering::Relaxed);
    }
}

/// The control side's end of the [`Channels`]: give it to
/// [`ControlSide`](crate::ControlSide).
pub struct ControlEnd<'a> {
    pub(crate) commands: Consumer<'a, ToControl, COMMAND_CAPACITY>,
    pub(crate) uplink: Producer<'a, ToLink, UPLINK_CAPACITY>,
    pub(crate) telemetry: Producer<'a, TelemetryFrame, TELEMETRY_CAPACITY>,
    pub(crate) reports: Producer<'a, Report, REPORT_CAPACITY>,
    pub(crate) staging: Receiver<'a, Staged>,
    status: &'a Status,
}

/// What the control side publishes after a step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Published {
    pub state: State,
    pub step: u32,
    pub missed_ticks: u32,
    pub overruns: u32,
}

impl ControlEnd<'_> {
    /// Publishes the step's state and counters (four relaxed stores).
    pub(crate) fn publish(&self, p: Published) {
        let s = self.status;
        s.state.store(state_code(p.state), Ordering::Relaxed);
        s.step.store(p.step, Ordering::Relaxed);
        s.missed_ticks.store(p.missed_ticks, Ordering::Relaxed);
        s.overruns.store(p.overruns, Ordering::Relaxed);
    }

    /// Counts a telemetry sample dropped at the source.
    pub(crate) fn count_telemetry_drop(&self) {
        let c = &self.status.telemetry_dropped;
        c.store(c.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
    }

    /// Counts an event dropped at the source.
    pub(crate) fn count_event_drop(&self) {
        let c = &self.status.events_dropped;
        c.store(c.load(Ordering::Relaxed).wrapping_add(1), Ordering::Relaxed);
    }

    /// The telemetry rate the link side asked for, Hz (0: off).
    pub(crate) fn telemetry_hz(&self) -> u8 {
        self.status.telemetry_hz.load(Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_control_refusal_says_its_own_reason() {
        let all = [
            ControlRefusal::Armed,
            ControlRefusal::Faulted,
            ControlRefusal::Busy,
            ControlRefusal::ButtonHeld,
            ControlRefusal::Invalid,
            ControlRefusal::WheelsTurning,
        ];
        let texts: std::vec::Vec<std::string::String> =
            all.iter().map(std::string::ToString::to_string).collect();
        assert!(texts[0].contains("armed") && texts[3].contains("button"));
        for (i, a) in texts.iter().enumerate() {
            assert!(texts[i + 1..].iter().all(|b| a != b), "{a} repeated");
        }
        let _: &dyn core::error::Error = &ControlRefusal::Busy;
    }

    #[test]
    fn every_state_survives_its_code() {
        for state in [
            State::Disarmed,
            State::Armed,
            State::Faulted,
            State::Persisting,
        ] {
            assert_eq!(state_from_code(state_code(state)), Some(state));
        }
        assert_eq!(state_from_code(0), None, "before the first step");
    }

    #[test]
    fn the_two_ends_share_the_status() {
        let mut channels = Channels::new();
        let (link, control) = channels.split();
        assert_eq!(link.control_status().state, None);
        control.publish(Published {
            state: State::Armed,
            step: 7,
            missed_ticks: 2,
            overruns: 1,
        });
        control.count_telemetry_drop();
        control.count_event_drop();
        control.count_event_drop();
        let s = link.control_status();
        assert_eq!(s.state, Some(State::Armed));
        assert_eq!((s.step, s.missed_ticks, s.overruns), (7, 2, 1));
        assert_eq!((s.telemetry_dropped, s.events_dropped), (1, 2));
        link.set_telemetry_hz(25);
        assert_eq!(control.telemetry_hz(), 25);
    }
}
