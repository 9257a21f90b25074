//! The control side's outer loop (the steering law of `controller_core::steering`) and
//! how it is lent to a lower-priority task.
//!
//! The outer loop lives in a mailbox of the [`Channels`](crate::Channels), with room for
//! its job and its outcome ([`OuterLoop`]). The control side's controller holds the
//! mailbox's sending end as its seat ([`OuterLoopSeat`]):
//!
//! - By default the control side runs each job itself, at the end of the step that
//!   handed it over (the virtual robot does this).
//! - After [`ControlSide::lend_outer_loop`](crate::ControlSide::lend_outer_loop) (the
//!   firmware does this), a step that hands over a job writes it into the mailbox and
//!   publishes it; the [`SteeringWorker`], in a lower-priority task, runs it in place and
//!   hands the mailbox back; the next step collects the outcome.
//!
//! Both give the same result (the hand-over is one period either way), and nothing is
//! copied but the 44-byte job in and the 100-byte outcome out: the outer loop itself,
//! path and all, stays where it is.

use controller_core::steering::{Steering, SteeringJob, SteeringOutcome, SteeringSeat};

use crate::channel::mailbox::{Receiver, Sender};

/// The outer loop with room for its job and its outcome.
pub struct OuterLoop {
    pub(crate) steering: Steering,
    job: SteeringJob,
    outcome: SteeringOutcome,
}

impl OuterLoop {
    /// Room for the outer loop, to be built in place at start ([`Steering::PLACEHOLDER`]).
    pub(crate) const PLACEHOLDER: OuterLoop = OuterLoop {
        steering: Steering::PLACEHOLDER,
        job: SteeringJob::NONE,
        outcome: SteeringOutcome::ZERO,
    };
}

/// The control side's controller's seat for the outer loop: the mailbox's sending end.
/// Seated while the mailbox is empty; lent while it is published or not yet collected.
pub struct OuterLoopSeat<'a> {
    sender: Sender<'a, OuterLoop>,
    /// Jobs are lent to the [`SteeringWorker`] rather than run by the controller.
    lends: bool,
}

impl<'a> OuterLoopSeat<'a> {
    pub(crate) fn new(sender: Sender<'a, OuterLoop>) -> Self {
        Self {
            sender,
            lends: false,
        }
    }

    pub(crate) fn lend_from_now_on(&mut self) {
        self.lends = true;
    }
}

impl SteeringSeat for OuterLoopSeat<'_> {
    fn seated(&self) -> Option<&Steering> {
        self.sender.item().map(|o| &o.steering)
    }

    fn seated_mut(&mut self) -> Option<&mut Steering> {
        self.sender.item_mut().map(|o| &mut o.steering)
    }

    fn runs_jobs(&self) -> bool {
        !self.lends
    }

    fn lend(&mut self, job: &SteeringJob) -> bool {
        if !self.lends {
            return false;
        }
        let Some(room) = self.sender.item_mut() else {
            return false;
        };
        room.job = *job;
        self.sender.publish()
    }

    fn collect(&mut self, outcome: &mut SteeringOutcome) -> bool {
        let Some(back) = self.sender.done() else {
            return false;
        };
        *outcome = back.outcome;
        self.sender.clear();
        true
    }
}

/// The outer loop's end in a lower-priority task (see the module doc).
pub struct SteeringWorker<'a> {
    receiver: Receiver<'a, OuterLoop>,
}

impl<'a> SteeringWorker<'a> {
    pub(crate) fn new(receiver: Receiver<'a, OuterLoop>) -> Self {
        Self { receiver }
    }

    /// Runs the job the control side lent, if one waits, and hands the outer loop back;
    /// true if it ran one. Never panics or waits.
    pub fn run(&mut self) -> bool {
        let Some(lent) = self.receiver.staged_mut() else {
            return false;
        };
        let OuterLoop {
            steering,
            job,
            outcome,
        } = lent;
        steering.run(job, outcome);
        self.receiver.finish();
        true
    }
}
