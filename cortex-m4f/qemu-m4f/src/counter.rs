//! A 64-bit count of SysTick ticks.
//!
//! QEMU's DWT cycle counter reads 0, so SysTick is the only clock. It runs from the
//! processor clock, reloads at 2²⁴ and interrupts on each wrap; the handler counts the
//! wraps. Under `qemu-system-arm -icount shift=0` one instruction is 1 ns of virtual
//! time, so this counts instructions times a constant (calibrated in `timing`).

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{SCB, SYST};
use cortex_m_rt::exception;

/// The counter's reload value: it counts 0xFF_FFFF down to 0, 2²⁴ ticks per wrap.
const RELOAD: u32 = 0x00FF_FFFF;

/// Wraps counted by the SysTick handler.
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// Starts SysTick: processor clock, full 24-bit reload, interrupt on wrap.
pub fn start(mut syst: SYST) {
    syst.disable_counter();
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

/// SysTick ticks since [`start`].
///
/// Read with interrupts off; a wrap that the handler has not counted yet shows as a
/// pending SysTick, and then the current value is read again (after the wrap).
pub fn now() -> u64 {
    cortex_m::interrupt::free(|_| {
        let mut wraps = WRAPS.load(Ordering::Relaxed);
        let mut current = SYST::get_current();
        if SCB::is_pendst_pending() {
            wraps = wraps.wrapping_add(1);
            current = SYST::get_current();
        }
        (u64::from(wraps) << 24) | u64::from(RELOAD - current)
    })
}
