//! The link task's work: the robot's end of the runtime link (`robot_app::LinkService`)
//! between the link USART's rings, and the flash writes it asks for.
//!
//! Each run (the task is pended by the USART interrupt, by the control task when a
//! step queued something for the link, and after sending) repeats until nothing moves:
//!
//! 1. received bytes from the receive ring into the service, while it has room for
//!    their replies (otherwise they wait in the ring);
//! 2. `poll`: the control side's replies, events and telemetry into frames;
//! 3. as many outgoing bytes as the transmit ring takes, then pend the USART interrupt
//!    to send them;
//! 4. a persistence job, if the service has one (`crate::persistence`).

use link::MAX_FRAME_LEN;
use robot_app::channel::ring::{Consumer, Producer};
use robot_app::panic_record::{PanicRecord, PanicRecordStore};
use robot_app::{BoardStats, LinkService};
use rtic::Mutex;
use stm32f4xx_hal::pac;

use crate::board::{Storage, Watchdog};
use crate::link_uart::{RX_RING, TX_RING};
use crate::{panic_record, persistence, stats};

/// Rounds of the loop in one run before it yields (each round moves at least one byte
/// or frame, so this only bounds a run while bytes keep arriving).
const MAX_ROUNDS: usize = 4 * MAX_FRAME_LEN;

/// The link task's state.
pub struct LinkWorker {
    service: LinkService<'static>,
    rx: Consumer<'static, u8, RX_RING>,
    tx: Producer<'static, u8, TX_RING>,
    storage: Option<Storage>,
}

impl LinkWorker {
    /// The worker around `service`, reading `rx`, writing `tx`, persisting to `storage`.
    pub fn new(
        service: LinkService<'static>,
        rx: Consumer<'static, u8, RX_RING>,
        tx: Producer<'static, u8, TX_RING>,
        storage: Option<Storage>,
    ) -> Self {
        Self {
            service,
            rx,
            tx,
            storage,
        }
    }

    /// One run of the task (module doc).
    ///
    /// Each kind of work is a function of its own, never inlined here: inlined, their
    /// temporaries (a decoded request, a record image, a staged path) shared this
    /// function's frame and added up on the stack, whereas of calls made one after the
    /// other only the deepest counts (`cargo xtask panic-check` prints the bound).
    pub fn run(&mut self, watchdog: &mut impl Mutex<T = Watchdog>) {
        for _ in 0..MAX_ROUNDS {
            let received = receive(&mut self.service, &mut self.rx);
            let sent = send(&mut self.service, &mut self.tx);
            let persisted = persist(&mut self.service, self.storage.as_mut(), watchdog);
            if !(received || sent || persisted) {
                return;
            }
        }
        // Still busy: run again once the higher-priority work is done.
        rtic::pend(crate::app::LINK_TASK_INTERRUPT);
    }
}

/// Step 1: received bytes into the service while it has room for their replies; true
/// if any moved.
#[inline(never)]
fn receive(service: &mut LinkService<'static>, rx: &mut Consumer<'static, u8, RX_RING>) -> bool {
    let mut moved = false;
    while service.ready_for_input() {
        let Some(byte) = rx.pop() else {
            break;
        };
        service.receive_byte(byte, &FirmwareBoard);
        moved = true;
    }
    moved
}

/// Steps 2 and 3: replies, events and telemetry into frames, and as many of their
/// bytes as the transmit ring takes; true if any were queued (the USART interrupt is
/// pended to send them).
#[inline(never)]
fn send(service: &mut LinkService<'static>, tx: &mut Producer<'static, u8, TX_RING>) -> bool {
    service.poll();
    let mut queued = 0;
    for &byte in service.outgoing() {
        if tx.push(byte).is_err() {
            break;
        }
        queued += 1;
    }
    if queued > 0 {
        service.consume(queued);
        rtic::pend(pac::Interrupt::USART2);
    }
    queued > 0
}

/// Step 4: the persistence job the service asks for, if any; true if there was one.
#[inline(never)]
fn persist(
    service: &mut LinkService<'static>,
    storage: Option<&mut Storage>,
    watchdog: &mut impl Mutex<T = Watchdog>,
) -> bool {
    let Some(job) = service.persist_job() else {
        return false;
    };
    let ok = match storage {
        Some(storage) => persistence::write(&job, storage, watchdog),
        None => false,
    };
    service.persist_finished(ok);
    true
}

/// What the link service asks of the board: the control task's longest step and the
/// stack's high-water mark for `GetStats` ([`crate::stats`]), and the panic record kept
/// across resets for `GetPanicRecord` and `ClearPanicRecord` ([`crate::panic_record`]).
struct FirmwareBoard;

impl BoardStats for FirmwareBoard {
    fn max_step_cycles(&self) -> u32 {
        stats::CONTROL.max_units()
    }

    fn stack_high_water_bytes(&self) -> u32 {
        stats::stack_high_water_bytes()
    }
}

impl PanicRecordStore for FirmwareBoard {
    fn panic_record(&self) -> Option<PanicRecord> {
        panic_record::read()
    }

    fn clear_panic_record(&self) {
        panic_record::clear();
    }
}
