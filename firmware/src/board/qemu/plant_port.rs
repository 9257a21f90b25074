//! The plant port: USART1, QEMU's first `-serial`, connected to `host-sim pil`, speaking
//! `lockstep`.
//!
//! Its interrupt (same priority as the control task, so neither preempts the other):
//!
//! - **receive** (RXNE): bytes into a [`StepDecoder`]; a whole step message goes into
//!   the control task's queue and pends TIM5, the control task's interrupt. That is the
//!   lockstep trigger: one message, one control step.
//! - **transmit** (TXE): the control task's answers, one message at a time; TXEIE stays
//!   on while bytes wait (QEMU keeps TXE set, so in practice a message goes out in one
//!   interrupt). An answer is not started while it is held ([`hold_answer`]: the step
//!   lent the outer loop a job, and the steering task has not run it yet).
//! - **finish**: answers with the run's figures ([`BoardReport`]) and ends the emulation
//!   (semihosting `exit(0)`).

use core::sync::atomic::{AtomicBool, Ordering};

use lockstep::{
    BoardEncoder, BoardReport, BoardStep, PlantStep, StepDecoder, ToBoard, BOARD_STEP_MAX_LEN,
    READY,
};
use robot_app::channel::ring::{Consumer, Producer};
use stm32f4xx_hal::pac;

use super::STEP_SLOTS;
use crate::stats;

/// USART1 and the plant port's state.
pub struct PlantPort {
    usart: pac::USART1,
    decoder: StepDecoder,
    encoder: BoardEncoder,
    steps: Producer<'static, PlantStep, STEP_SLOTS>,
    replies: Consumer<'static, BoardStep, STEP_SLOTS>,
    /// The message being sent, its length, and how much of it has gone.
    sending: [u8; BOARD_STEP_MAX_LEN],
    len: usize,
    sent: usize,
    /// Steps that found the queue full (the plant sent before its answer: a bug there).
    overflows: u32,
}

/// The last answer queued waits for the steering task (see the module doc).
static ANSWER_HELD: AtomicBool = AtomicBool::new(false);

/// Holds the answer queued next until [`release_answer`] (`held`), or lets it go.
#[inline(always)]
pub fn hold_answer(held: bool) {
    ANSWER_HELD.store(held, Ordering::Release);
}

/// The steering task is done: the held answer may go.
#[inline(always)]
pub fn release_answer() {
    ANSWER_HELD.store(false, Ordering::Release);
}

/// Writes the ready byte (QEMU sends it at once).
pub fn send_ready() {
    // SAFETY: a single write to USART1's data register from `init`, before the plant
    // port's interrupt is enabled; nothing else uses USART1 then.
    let usart = unsafe { &*pac::USART1::ptr() };
    usart.dr().write(|w| w.dr().set(u16::from(READY)));
}

impl PlantPort {
    /// The port on an enabled `usart`, feeding `steps` and sending `replies`.
    pub fn new(
        usart: pac::USART1,
        steps: Producer<'static, PlantStep, STEP_SLOTS>,
        replies: Consumer<'static, BoardStep, STEP_SLOTS>,
    ) -> Self {
        Self {
            usart,
            decoder: StepDecoder::new(),
            encoder: BoardEncoder::new(),
            steps,
            replies,
            sending: [0; BOARD_STEP_MAX_LEN],
            len: 0,
            sent: 0,
            overflows: 0,
        }
    }

    /// The interrupt's work (module doc).
    pub fn on_interrupt(&mut self) {
        while self.usart.sr().read().rxne().bit_is_set() {
            let byte = self.usart.dr().read().dr().bits() as u8;
            match self.decoder.push(byte) {
                Some(ToBoard::Step(step)) => {
                    if self.steps.push(step).is_ok() {
                        rtic::pend(pac::Interrupt::TIM5);
                    } else {
                        self.overflows = self.overflows.wrapping_add(1);
                    }
                }
                Some(ToBoard::Finish) => self.finish(),
                None => {}
            }
        }
        self.transmit();
    }

    /// Sends what waits while the data register takes it; TXEIE on while bytes remain.
    fn transmit(&mut self) {
        loop {
            if self.sent == self.len {
                if ANSWER_HELD.load(Ordering::Acquire) {
                    break;
                }
                let Some(step) = self.replies.pop() else {
                    break;
                };
                self.len = self.encoder.encode(&step, &mut self.sending);
                self.sent = 0;
            }
            if self.usart.sr().read().txe().bit_is_clear() {
                break;
            }
            let byte = self.sending.get(self.sent).copied().unwrap_or(0);
            self.usart.dr().write(|w| w.dr().set(u16::from(byte)));
            self.sent += 1;
        }
        let more = self.sent < self.len;
        self.usart.cr1().modify(|_, w| w.txeie().bit(more));
    }

    /// Flushes the last answer, sends the report and ends the emulation.
    fn finish(&mut self) -> ! {
        while self.sent < self.len || !self.replies.is_empty() {
            self.transmit();
        }
        let report = BoardReport {
            control: stats::CONTROL.figures(),
            control_armed: stats::CONTROL_ARMED.figures(),
            control_arming: stats::CONTROL_ARMING.figures(),
            steering: stats::STEERING.figures(),
            link: stats::LINK.figures(),
            link_uart: stats::LINK_UART.figures(),
            stack_high_water_bytes: stats::stack_high_water_bytes(),
            start_stack_bytes: stats::start_stack_bytes(),
        };
        for byte in report.encode() {
            while self.usart.sr().read().txe().bit_is_clear() {}
            self.usart.dr().write(|w| w.dr().set(u16::from(byte)));
        }
        defmt::info!(
            "plant port: finished after {=u32} steps ({=u32} step messages dropped, {=u32} bad bytes)",
            report.control.runs,
            self.overflows,
            self.decoder.errors()
        );
        cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_SUCCESS);
        loop {
            cortex_m::asm::wfi();
        }
    }
}
