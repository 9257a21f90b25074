//! USART1 of the STM32F405 as QEMU's netduinoplus2 models it: received bytes go from the
//! RXNE interrupt into a queue that the main loop drains; transmission is synchronous
//! (QEMU keeps TXE set).

use core::cell::RefCell;

use cortex_m::interrupt::Mutex;
use heapless::Deque;
use stm32f4::stm32f405::{interrupt, Interrupt, NVIC, RCC, USART1};

/// Bytes the interrupt can hold for the main loop. QEMU delivers one byte at a time and
/// waits for DR to be read, but the interrupt reads it at once, so a burst reaches the
/// main loop at the interrupt's pace: with 64 bytes here, a host under heavy load once
/// saw 24 bytes of an oversized frame's burst lost and two pings unanswered. 1 KiB holds
/// the longest burst the test sends (an oversized frame of up to `MAX_FRAME_LEN` + 99
/// bytes, then a request frame of at most `MAX_FRAME_LEN`); bytes that still find it full
/// are counted and reported.
const RX_QUEUE_LEN: usize = 1024;

struct Rx {
    queue: Deque<u8, RX_QUEUE_LEN>,
    lost: u32,
}

static RX: Mutex<RefCell<Rx>> = Mutex::new(RefCell::new(Rx {
    queue: Deque::new(),
    lost: 0,
}));

/// The USART, enabled.
pub struct Serial {
    usart: USART1,
}

impl Serial {
    /// Clocks and enables USART1 (transmit, receive, RXNE interrupt) and unmasks its
    /// interrupt. QEMU ignores the baud rate; 115 200 Bd at 16 MHz is set for form.
    pub fn new(usart: USART1, rcc: &RCC) -> Self {
        rcc.apb2enr().modify(|_, w| w.usart1en().set_bit());
        // 16 MHz / 115 200 = 138.9: mantissa 8, fraction 11 (oversampling by 16).
        usart.brr().write(|w| unsafe { w.bits((8 << 4) | 11) });
        usart.cr1().write(|w| {
            w.ue()
                .set_bit()
                .te()
                .set_bit()
                .re()
                .set_bit()
                .rxneie()
                .set_bit()
        });
        // SAFETY: the handler below only touches RX through a critical section.
        unsafe { NVIC::unmask(Interrupt::USART1) };
        Self { usart }
    }

    /// Sends `bytes`, waiting for TXE before each.
    pub fn write(&mut self, bytes: &[u8]) {
        for &byte in bytes {
            while self.usart.sr().read().txe().bit_is_clear() {}
            self.usart
                .dr()
                .write(|w| unsafe { w.dr().bits(u16::from(byte)) });
        }
    }

    /// The next received byte, if any.
    pub fn read(&mut self) -> Option<u8> {
        cortex_m::interrupt::free(|cs| RX.borrow(cs).borrow_mut().queue.pop_front())
    }

    /// Sleeps until an interrupt when no byte is waiting (checked with interrupts off,
    /// so a byte arriving in between still wakes the core).
    pub fn wait(&self) {
        cortex_m::interrupt::free(|cs| {
            if RX.borrow(cs).borrow().queue.is_empty() {
                cortex_m::asm::wfi();
            }
        });
    }

    /// Bytes dropped because the queue was full.
    pub fn lost(&self) -> u32 {
        cortex_m::interrupt::free(|cs| RX.borrow(cs).borrow().lost)
    }
}

#[interrupt]
fn USART1() {
    // SAFETY: reading SR then DR is the RXNE acknowledge sequence; the main loop only
    // writes DR and reads SR.TXE, which this does not disturb.
    let usart = unsafe { &*USART1::ptr() };
    while usart.sr().read().rxne().bit_is_set() {
        let byte = usart.dr().read().dr().bits() as u8;
        cortex_m::interrupt::free(|cs| {
            let mut rx = RX.borrow(cs).borrow_mut();
            if rx.queue.push_back(byte).is_err() {
                rx.lost = rx.lost.wrapping_add(1);
            }
        });
    }
}
