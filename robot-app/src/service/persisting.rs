//! `PersistParams`: the supervisor enters Persisting (motors off, missed ticks expected),
//! the board writes flash, the supervisor leaves Persisting, and only then does the host
//! get its reply.
//!
//! ```text
//!  PersistParams ─► BeginPersist ─► (Persisting) ─► persist_job() ─► board erases/writes
//!        ─► persist_finished(ok) ─► EndPersist ─► (Disarmed) ─► reply Ack / StorageFailed
//! ```
//!
//! The board does the flash work in a low-priority context (on the STM32F411 an erase
//! stalls the CPU for up to 2 s, so the firmware lengthens the watchdog first), using the
//! pure functions of [`crate::persist`]. A host waits
//! [`PERSIST_REPLY_TIMEOUT_MS`](link::PERSIST_REPLY_TIMEOUT_MS) for the reply; bytes
//! sent meanwhile may be lost in the stall. One request writes flash once, however often
//! its `seq` comes again:
//!
//! - a repeat while the write is under way (starting, writing, ending) gets no reply of
//!   its own: the one reply, when the write ends, answers it;
//! - a repeat after the reply gets the same reply again ([`Persisted`]), until any other
//!   request arrives (a repeat is what comes next, or never);
//! - a `PersistParams` with another `seq` while one is under way is refused `Busy`.
//!
//! Flash is written only while the chip's brown-out reset guards the supply the write
//! needs ([`BrownOutReset::guards_flash_writes`](link::BrownOutReset::guards_flash_writes));
//! otherwise the request is refused with
//! [`NotPermitted::BrownOutResetOff`](link::NotPermitted::BrownOutResetOff).

use controller_core::supervisor::State;
use link::{NotPermitted, ParamSet, Refusal, Reply};

use super::LinkService;
use crate::channel::{ControlRefusal, Op};

/// Where a `PersistParams` is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PersistPhase {
    /// None in progress.
    Idle,
    /// `BeginPersist` sent to the control side.
    Starting { seq: u16 },
    /// Persisting: the board may write.
    Writing { seq: u16 },
    /// The board is done; `EndPersist` is to be sent (`forwarded` once it is queued).
    Ending { seq: u16, ok: bool, forwarded: bool },
}

impl PersistPhase {
    /// The `seq` of the request under way, if any.
    const fn seq(self) -> Option<u16> {
        match self {
            PersistPhase::Idle => None,
            PersistPhase::Starting { seq }
            | PersistPhase::Writing { seq }
            | PersistPhase::Ending { seq, .. } => Some(seq),
        }
    }
}

/// How the last `PersistParams` that reached the flash ended: what a repeat of its `seq`
/// is answered with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Persisted {
    /// The request's `seq`.
    seq: u16,
    /// The record was written and read back intact.
    ok: bool,
}

impl Persisted {
    /// The reply to the request, and to every repeat of it.
    fn reply(self) -> Result<Reply, Refusal> {
        if self.ok {
            Ok(Reply::Ack)
        } else {
            Err(Refusal::NotPermitted(NotPermitted::StorageFailed))
        }
    }
}

/// What the board is to write: the configuration in force, borrowed (a copy would be
/// 300 bytes of the link task's stack under the flash work).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PersistJob<'a> {
    /// The configuration to persist.
    pub params: &'a ParamSet,
}

impl LinkService<'_> {
    /// A flash write the board should do now (see the module doc), if any. It stays
    /// pending until [`LinkService::persist_finished`].
    pub fn persist_job(&self) -> Option<PersistJob<'_>> {
        match self.persist {
            PersistPhase::Writing { .. } => Some(PersistJob {
                params: &self.active,
            }),
            _ => None,
        }
    }

    /// The board finished the flash work of [`LinkService::persist_job`]: `ok` when the
    /// record was written and read back intact. Leaves Persisting (now, or at the next
    /// [`LinkService::poll`] if the command queue is full) and then replies to the host.
    pub fn persist_finished(&mut self, ok: bool) {
        if let PersistPhase::Writing { seq } = self.persist {
            self.persist = PersistPhase::Ending {
                seq,
                ok,
                forwarded: false,
            };
            self.resume_persist();
        }
    }

    /// `PersistParams`: starts the sequence, answers a repeat (module doc), or refuses.
    pub(super) fn persist_params(&mut self, seq: u16) -> Option<Result<Reply, Refusal>> {
        if !self.storage {
            return Some(Err(Refusal::NotPermitted(NotPermitted::NoStorage)));
        }
        match self.persist.seq() {
            // The reply when the write ends answers this repeat too.
            Some(under_way) if under_way == seq => return None,
            Some(_) => return Some(Err(self.busy())),
            None => {}
        }
        if let Some(done) = self.persisted.filter(|done| done.seq == seq) {
            return Some(done.reply());
        }
        if !self.identity.brown_out_reset.guards_flash_writes() {
            return Some(Err(Refusal::NotPermitted(NotPermitted::BrownOutResetOff)));
        }
        if self.state() == Some(State::Armed) {
            return Some(Err(Refusal::Armed));
        }
        let now = self.forward(seq, Op::BeginPersist);
        if now.is_none() {
            self.persist = PersistPhase::Starting { seq };
        }
        now
    }

    /// The control side answered `BeginPersist`: on success the board may write (no reply
    /// yet); otherwise the refusal is the reply.
    pub(super) fn persist_started(
        &mut self,
        seq: u16,
        result: Result<(), ControlRefusal>,
    ) -> Option<Result<Reply, Refusal>> {
        match result {
            Ok(()) => {
                self.persist = PersistPhase::Writing { seq };
                None
            }
            Err(refused) => {
                self.persist = PersistPhase::Idle;
                Some(Err(super::refusal(refused)))
            }
        }
    }

    /// The control side left Persisting: the reply to `PersistParams` says how the write
    /// went.
    pub(super) fn persist_ended(&mut self, seq: u16) -> Option<Result<Reply, Refusal>> {
        let ok = match self.persist {
            PersistPhase::Ending { ok, .. } => ok,
            _ => false,
        };
        self.persist = PersistPhase::Idle;
        let done = Persisted { seq, ok };
        self.persisted = Some(done);
        Some(done.reply())
    }

    /// Sends the pending `EndPersist` if the command queue has room (it always leaves
    /// Persisting eventually: the queue drains one command per control step).
    pub(super) fn resume_persist(&mut self) {
        if let PersistPhase::Ending {
            seq,
            ok,
            forwarded: false,
        } = self.persist
        {
            if self.queue_has_room(&Op::EndPersist) && self.forward(seq, Op::EndPersist).is_none() {
                self.persist = PersistPhase::Ending {
                    seq,
                    ok,
                    forwarded: true,
                };
            }
        }
    }
}
