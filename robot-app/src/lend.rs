//! Lending the control side to the link task for the work that costs more than a
//! control step, so that the control interrupt never does it.
//!
//! Three things are such work ([`ControlSide::work_between_steps`]):
//!
//! - installing a configuration or a path, which rebuilds the controller and the
//!   supervisor in place;
//! - the rest of arming: the start pose, a tune's start, the speed estimates of a run
//!   that starts in motion, the loops restarted in the run's mode. The step that arms
//!   drives nothing (`controller_core::supervisor`, "Arming takes two steps");
//! - the report of a path-following run that ended, whose summary goes over the final
//!   window's buckets. The step that ends the run, a fault's or a disarm's, drives
//!   nothing either.
//!
//! A step that takes an install request, arms or ends a run only notes it
//! ([`Actuation::lend_due`]);
//! the work is done between that step and the next. The firmware runs it in its link
//! task, lending it the whole control side through a one-item mailbox:
//!
//! - The control side lives in a [`ControlRoom`] (a `static`). The control interrupt
//!   steps it through the room's [`ControlSeat`]; after a step with `lend_due`, the
//!   seat publishes it to the room's [`Borrower`].
//! - The link task's [`Borrower::run`] does the work and hands it back; the next step
//!   collects it. This takes a few tens of microseconds, well inside one period, and the
//!   emulated board holds the plant's next step until it is done, so there it always is.
//! - A step that finds it still away (the link task was kept from running for a whole
//!   period) is a stopped step ([`ControlSeat::step`]): zero duties, the bridge as the
//!   last step left it (that step drove nothing: braking or coasting), nothing else. Its
//!   encoder ticks and periods are handed to the next step that runs, so odometry loses
//!   nothing and the supervisor counts the periods it did not run as missed ticks. The
//!   watchdog is fed in such steps only as long as the supervisor would feed it with a
//!   starved background task (`background_timeout_steps`), so a link task that never
//!   gives the control side back ends in a reset, with the motors stopped meanwhile.
//!
//! Nothing is copied: the control side stays where it is, and only the mailbox's state
//! byte changes hands. The virtual robot (`host-sim serve`) owns its control side and
//! calls [`ControlSide::work_between_steps`] itself after such a step, before the link's
//! poll, as the firmware's link task does.

use core::num::NonZeroU32;

use controller_core::controller::{MotorCommand, Telemetry, TickDeltas};

use crate::channel::mailbox::{Mailbox, Receiver, Sender};
use crate::control::{Actuation, ControlSide, Sensors};

/// The room a [`ControlSide`] is stepped from and lent out of. Put it in a `static`
/// (`#[init(local = [room: ControlRoom<'static> = ControlRoom::new()])]`) and seat the
/// control side with [`ControlRoom::seat`].
pub struct ControlRoom<'a> {
    mailbox: Mailbox<ControlSlot<'a>>,
}

/// What the room holds. An explicit tag with `Empty` first (tag 0), as the channels'
/// rooms: the `static` then starts as zero bytes, in `.bss`.
#[repr(u8)]
// The room is the control side's only place; there is no heap to box it.
#[allow(clippy::large_enum_variant)]
enum ControlSlot<'a> {
    /// Nothing seated yet.
    Empty,
    /// The control side.
    Seated(ControlSide<'a>),
}

impl<'a> ControlRoom<'a> {
    /// An empty room (a constant, for a `static`).
    pub const fn new() -> Self {
        Self {
            mailbox: Mailbox::new(ControlSlot::Empty),
        }
    }

    /// Moves `control` into the room; returns the end that steps it (for the control
    /// interrupt) and the end that borrows it between two steps (for the link task).
    pub fn seat(&'a mut self, control: ControlSide<'a>) -> (ControlSeat<'a>, Borrower<'a>) {
        let (mut sender, receiver) = self.mailbox.split();
        if let Some(slot) = sender.item_mut() {
            *slot = ControlSlot::Seated(control);
        }
        (ControlSeat::new(sender), Borrower { receiver })
    }
}

impl Default for ControlRoom<'_> {
    fn default() -> Self {
        Self::new()
    }
}

/// The control interrupt's end of a [`ControlRoom`] (see the module doc).
pub struct ControlSeat<'a> {
    sender: Sender<'a, ControlSlot<'a>>,
    /// The outputs of the step that lent the control side, repeated (motors stopped)
    /// while it is away.
    last: Actuation,
    /// Stopped steps since it was lent.
    stopped_steps: u32,
    /// Stopped steps that may feed the watchdog.
    feed_steps: u32,
    /// Encoder ticks of the stopped steps, for the next step that runs.
    carried_ticks: TickDeltas,
    /// Periods of the stopped steps, for the next step that runs (0: none).
    carried_periods: u32,
}

impl<'a> ControlSeat<'a> {
    fn new(sender: Sender<'a, ControlSlot<'a>>) -> Self {
        Self {
            sender,
            last: Actuation::MOTORS_OFF,
            stopped_steps: 0,
            feed_steps: 0,
            carried_ticks: TickDeltas::default(),
            carried_periods: 0,
        }
    }

    /// The control side, while it is here (not lent).
    pub fn control(&self) -> Option<&ControlSide<'a>> {
        match self.sender.item()? {
            ControlSlot::Seated(control) => Some(control),
            ControlSlot::Empty => None,
        }
    }

    /// One control period: [`ControlSide::step`] if the control side is here (never
    /// lent, or back from the link task), a stopped step (module doc) while it is away.
    /// Lends it to the [`Borrower`] after a step with [`Actuation::lend_due`].
    pub fn step(&mut self, mut sensors: Sensors) -> Actuation {
        let Some(ControlSlot::Seated(control)) = self.sender.collect_mut() else {
            return self.stopped_step(sensors.ticks, sensors.periods);
        };
        if self.carried_periods != 0 {
            sensors.ticks = add_ticks(sensors.ticks, core::mem::take(&mut self.carried_ticks));
            let periods = core::mem::take(&mut self.carried_periods);
            sensors.periods = sensors.periods.saturating_add(periods);
        }
        let out = control.step(sensors);
        if out.lend_due {
            self.feed_steps = control.supervisor().config().background_timeout_steps;
            self.lend(out);
        }
        out
    }

    /// Lends the control side to the [`Borrower`] after a step that returned `last`.
    /// Out of line: not the common step.
    #[inline(never)]
    fn lend(&mut self, last: Actuation) {
        self.last = last;
        self.stopped_steps = 0;
        self.sender.publish();
    }

    /// The controller's telemetry, while the control side is here.
    pub fn telemetry(&self) -> Option<&Telemetry> {
        self.control().map(|c| c.controller().telemetry())
    }

    /// A step while the control side is away, with the step's encoder `ticks` over
    /// `periods`: motors stopped (module doc). Out of line: not the common step.
    #[inline(never)]
    fn stopped_step(&mut self, ticks: TickDeltas, periods: NonZeroU32) -> Actuation {
        self.stopped_steps = self.stopped_steps.saturating_add(1);
        self.carried_ticks = add_ticks(self.carried_ticks, ticks);
        self.carried_periods = self.carried_periods.saturating_add(periods.get());
        let mut out = self.last;
        out.duty = MotorCommand::STOP;
        out.event = None;
        // The link task has the control side: it must run.
        out.link_has_work = true;
        out.steering_lent = false;
        out.lend_due = false;
        out.feed_watchdog = self.stopped_steps <= self.feed_steps;
        out
    }
}

/// The ticks of two spans of steps together (wrapping, as the encoder counters do).
fn add_ticks(a: TickDeltas, b: TickDeltas) -> TickDeltas {
    TickDeltas {
        left: a.left.wrapping_add(b.left),
        right: a.right.wrapping_add(b.right),
    }
}

/// The link task's end of a [`ControlRoom`] (see the module doc).
pub struct Borrower<'a> {
    receiver: Receiver<'a, ControlSlot<'a>>,
}

impl Borrower<'_> {
    /// Does the work the control side was lent for ([`ControlSide::work_between_steps`])
    /// and hands it back; true if it was lent. Never waits or panics.
    pub fn run(&mut self) -> bool {
        let Some(slot) = self.receiver.staged_mut() else {
            return false;
        };
        if let ControlSlot::Seated(control) = slot {
            control.work_between_steps();
        }
        self.receiver.finish();
        true
    }
}
