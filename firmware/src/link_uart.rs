//! The link's USART (USART2 on both boards), interrupt-driven both ways, with no DMA
//! (QEMU's USART has none, nor idle-line detection, so this is the same code on silicon
//! and in emulation).
//!
//! The interrupt (priority 4, above every task: USART2 holds one character, 43.4 µs at
//! 230 400 Bd, so nothing may hold it off for longer):
//!
//! - **receive**: when USART_SR.RXNE (or ORE) is set, reads USART_DR (the SR-then-DR
//!   read also clears ORE, NF and FE, RM0383 §19.6.1) and pushes the byte into the
//!   receive ring, whose consumer is the link task; a full ring drops the byte (the
//!   frame then fails its CRC and is counted by the decoder; the host re-sends). An
//!   overrun (a byte lost because the previous one was not read within one character,
//!   43 µs at 230 400 Bd) shows up the same way.
//! - **transmit**: while USART_SR.TXE is set and the transmit ring holds bytes, writes
//!   the next one to USART_DR; USART_CR1.TXEIE is on exactly while bytes wait. Only this
//!   interrupt writes CR1 after `init` (the link task starts a transmission by pending
//!   the interrupt), so there is no read-modify-write race on it.
//! - **wakes the link task** (returns `true`) when a byte arrived or the transmit ring
//!   ran empty (room for the next frames).

use robot_app::channel::ring::{Consumer, Producer};
use stm32f4xx_hal::pac;

/// Bytes the receive ring holds: a whole frame of the largest size (`link::MAX_FRAME_LEN`,
/// 400) does not need to fit, only what arrives while the link task cannot take it
/// (its transmit buffer full); 256 B is 11 ms at 230 400 Bd.
pub const RX_RING: usize = 256;
/// Bytes the transmit ring holds: a staging area between the link service's buffer and
/// the interrupt (2.8 ms of transmission at 230 400 Bd); the link task refills it.
pub const TX_RING: usize = 64;

/// USART2 and its interrupt's ends of the two rings.
pub struct LinkUart {
    usart: pac::USART2,
    rx: Producer<'static, u8, RX_RING>,
    tx: Consumer<'static, u8, TX_RING>,
}

impl LinkUart {
    /// The driver of an enabled `usart` (receive interrupt on).
    pub fn new(
        usart: pac::USART2,
        rx: Producer<'static, u8, RX_RING>,
        tx: Consumer<'static, u8, TX_RING>,
    ) -> Self {
        Self { usart, rx, tx }
    }

    /// The interrupt's work (module doc); true when the link task should run.
    pub fn on_interrupt(&mut self) -> bool {
        let mut wake = false;
        let sr = self.usart.sr().read();
        if sr.rxne().bit_is_set() || sr.ore().bit_is_set() {
            let byte = self.usart.dr().read().dr().bits() as u8;
            // A full ring drops the byte (module doc).
            let _ = self.rx.push(byte);
            wake = true;
        }
        let had_bytes = !self.tx.is_empty();
        while self.usart.sr().read().txe().bit_is_set() {
            let Some(byte) = self.tx.pop() else {
                break;
            };
            self.usart.dr().write(|w| w.dr().set(u16::from(byte)));
        }
        let waiting = !self.tx.is_empty();
        if had_bytes && !waiting {
            wake = true;
        }
        if self.usart.cr1().read().txeie().bit() != waiting {
            self.usart.cr1().modify(|_, w| w.txeie().bit(waiting));
        }
        wake
    }
}
