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
//! stalls the CPU, so the firmware lengthens the watchdog first), using the pure
//! functions of [`crate::persist`]. The host re-sends the request if its bytes or the
//! reply were lost during the erase (a repeat after the end writes again, which is
//! harmless).

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

    /// `PersistParams`: starts the sequence, or refuses.
    pub(super) fn persist_params(&mut self, seq: u16) -> Option<Result<Reply, Refusal>> {
        if !self.storage {
            return Some(Err(Refusal::NotPermitted(NotPermitted::NoStorage)));
        }
        if self.persist != PersistPhase::Idle {
            return Some(Err(self.busy()));
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
    pub(super) fn persist_ended(&mut self) -> Option<Result<Reply, Refusal>> {
        let ok = match self.persist {
            PersistPhase::Ending { ok, .. } => ok,
            _ => false,
        };
        self.persist = PersistPhase::Idle;
        Some(if ok {
            Ok(Reply::Ack)
        } else {
            Err(Refusal::NotPermitted(NotPermitted::StorageFailed))
        })
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
