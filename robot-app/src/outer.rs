//! The control side's outer loop (the steering law of `controller_core::steering`) and
//! how it is lent to a lower-priority task.
//!
//! The outer loop lives in a mailbox of the [`Channels`](crate::Channels), with space for
//! its job and its outcome ([`OuterLoopWithJob`]). The control side's controller holds the
//! mailbox's sending end as its holder ([`OuterLoopMailbox`]):
//!
//! - By default the controller runs each job itself, at the start of the next step,
//!   straight into its telemetry (the virtual robot does this).
//! - After [`ControlSide::lend_outer_loop`](crate::ControlSide::lend_outer_loop) (the
//!   firmware does this), a step that hands over a job writes it into the mailbox and
//!   publishes it; the [`OuterLoopWorker`], in a lower-priority task, runs it in place and
//!   hands the mailbox back; the next step takes it back and applies the outcome it
//!   keeps.
//!
//! Both give the same result (the hand-over is one period either way), and nothing is
//! copied but the 44-byte job in and, once, the 100-byte outcome from the outer loop into
//! the controller's telemetry: the outer loop itself, path and all, stays where it is.

use controller_core::outer_loop::{OuterLoop, OuterLoopHolder, OuterLoopJob};

use crate::channel::mailbox::{Receiver, Sender};

/// The outer loop (which keeps its outcome) with its job.
pub struct OuterLoopWithJob {
    steering: OuterLoop,
    job: OuterLoopJob,
}

/// The outer loop's slot in the [`Channels`](crate::Channels): empty until
/// [`start`](crate::start) builds the outer loop in it. An explicit tag with `Empty`
/// first (tag 0): the `Channels` static then starts as all zero bytes and stays in
/// `.bss` instead of costing its initial value in flash.
#[repr(u8)]
// The slot is the outer loop's only place; there is no heap to box it.
#[allow(clippy::large_enum_variant)]
pub enum OuterLoopSlot {
    /// Nothing built yet (the holder behaves as if the outer loop were away).
    Empty,
    /// The outer loop.
    Built(OuterLoopWithJob),
}

impl OuterLoopSlot {
    /// The outer loop `steering` in the slot, with nothing handed over yet.
    pub(crate) fn built(steering: OuterLoop) -> Self {
        Self::Built(OuterLoopWithJob {
            steering,
            job: OuterLoopJob::default(),
        })
    }

    fn outer(&self) -> Option<&OuterLoopWithJob> {
        match self {
            Self::Built(outer) => Some(outer),
            Self::Empty => None,
        }
    }

    fn outer_mut(&mut self) -> Option<&mut OuterLoopWithJob> {
        match self {
            Self::Built(outer) => Some(outer),
            Self::Empty => None,
        }
    }
}

/// The control side's controller's holder for the outer loop: the mailbox's sending end.
/// Held while the mailbox is empty; lent while it is published or not yet collected.
pub struct OuterLoopMailbox<'a> {
    sender: Sender<'a, OuterLoopSlot>,
    /// Jobs are lent to the [`OuterLoopWorker`] rather than run by the controller.
    lends: bool,
}

impl<'a> OuterLoopMailbox<'a> {
    pub(crate) fn new(sender: Sender<'a, OuterLoopSlot>) -> Self {
        Self {
            sender,
            lends: false,
        }
    }

    /// The slot, while the outer loop is held (or not built yet).
    pub(crate) fn slot_mut(&mut self) -> Option<&mut OuterLoopSlot> {
        self.sender.item_mut()
    }

    pub(crate) fn lend_from_now_on(&mut self) {
        self.lends = true;
    }
}

impl OuterLoopHolder for OuterLoopMailbox<'_> {
    fn held(&self) -> Option<&OuterLoop> {
        self.sender
            .item()
            .and_then(OuterLoopSlot::outer)
            .map(|o| &o.steering)
    }

    fn held_mut(&mut self) -> Option<&mut OuterLoop> {
        self.sender
            .item_mut()
            .and_then(OuterLoopSlot::outer_mut)
            .map(|o| &mut o.steering)
    }

    fn runs_jobs(&self) -> bool {
        !self.lends
    }

    fn lend(&mut self, job: &OuterLoopJob) -> bool {
        if !self.lends {
            return false;
        }
        let Some(outer) = self.sender.item_mut().and_then(OuterLoopSlot::outer_mut) else {
            return false;
        };
        outer.job = *job;
        self.sender.publish()
    }

    fn collect(&mut self) -> bool {
        if self.sender.done().is_none() {
            return false;
        }
        self.sender.clear();
        true
    }
}

/// The outer loop's end in a lower-priority task (see the module doc).
pub struct OuterLoopWorker<'a> {
    receiver: Receiver<'a, OuterLoopSlot>,
}

impl<'a> OuterLoopWorker<'a> {
    pub(crate) fn new(receiver: Receiver<'a, OuterLoopSlot>) -> Self {
        Self { receiver }
    }

    /// Runs the job the control side lent, if one waits, and hands the outer loop back;
    /// true if it ran one. Never panics or waits.
    pub fn run(&mut self) -> bool {
        let Some(slot) = self.receiver.staged_mut() else {
            return false;
        };
        if let Some(OuterLoopWithJob { steering, job }) = slot.outer_mut() {
            steering.run(job);
        }
        self.receiver.finish();
        true
    }
}
