//! SysTick as an instruction counter, under QEMU's `-icount shift=0`.
//!
//! With `-icount shift=0` QEMU advances its virtual clock by 1 ns per executed
//! instruction, and SysTick, clocked from the processor clock (168 MHz on this
//! machine), then counts 0.168 ticks per instruction, whatever the host does. The
//! counter runs freely (SYST_RVR = 0xFF_FFFF, SYST_CSR = CLKSOURCE | ENABLE, no
//! interrupt: nothing else uses SysTick, and an interrupt would perturb what it
//! measures). A task's duration is the 24-bit difference of two readings; the longest
//! task is far below the 2²⁴ ticks (100 million instructions) of one wrap.
//!
//! The ratio is calibrated at start, not taken from a constant: two loops of known
//! length (10 instructions per iteration) are timed, and the fixed cost of reading the
//! counter cancels in their difference.

use core::arch::asm;
use core::hint::black_box;
use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;

/// The counter's reload value: a full 24-bit count.
const RELOAD: u32 = 0x00FF_FFFF;
/// Instructions in one iteration of [`spin`].
const SPIN_INSTRUCTIONS: u32 = 10;
/// Iterations of the short and the long calibration loop.
const SPINS: (u32, u32) = (100_000, 1_000_000);

/// SysTick ticks per 10⁶ instructions, measured by [`start`] (168 000 on
/// netduinoplus2).
static TICKS_PER_MILLION: AtomicU32 = AtomicU32::new(0);

/// What [`work_counter`] differences convert to.
pub const WORK_UNIT: &str = "instructions";

/// Starts SysTick as a free-running counter of the processor clock and calibrates it.
pub fn start(mut syst: SYST) {
    syst.disable_interrupt();
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_counter();
    let time = |n: u32| {
        let t0 = work_counter();
        spin(black_box(n));
        work_since(t0)
    };
    let ticks = time(SPINS.1).saturating_sub(time(SPINS.0));
    let instructions = u64::from(SPINS.1 - SPINS.0) * u64::from(SPIN_INSTRUCTIONS);
    let per_million = u64::from(ticks) * 1_000_000 / instructions;
    TICKS_PER_MILLION.store(per_million.max(1) as u32, Ordering::Relaxed);
}

/// SysTick ticks per 10⁶ instructions, as calibrated.
pub fn ticks_per_million() -> u32 {
    TICKS_PER_MILLION.load(Ordering::Relaxed)
}

/// SysTick's count, counting up (24 bits).
#[inline(always)]
pub fn work_counter() -> u32 {
    RELOAD - SYST::get_current()
}

/// Ticks [`work_counter`] advanced since it read `started`: the 24-bit difference, so a
/// run during which the counter wrapped is measured right (a plain `u32` difference would
/// be about 2³² − 2²⁴ ticks, longer than any real run).
#[inline(always)]
pub fn work_since(started: u32) -> u32 {
    work_counter().wrapping_sub(started) & RELOAD
}

/// A [`work_since`] difference in instructions.
#[inline(always)]
pub fn work_units(delta: u32) -> u32 {
    let ticks = u64::from(delta);
    let per_million = u64::from(ticks_per_million().max(1));
    ((ticks * 1_000_000 + per_million / 2) / per_million) as u32
}

/// Runs a loop of exactly [`SPIN_INSTRUCTIONS`] instructions `iterations` times
/// (`iterations` ≥ 1).
#[inline(never)]
fn spin(iterations: u32) {
    // SAFETY: touches only the register it is given and the flags.
    unsafe {
        asm!(
            "2:",
            "nop", "nop", "nop", "nop", "nop", "nop", "nop", "nop",
            "subs {n}, {n}, #1",
            "bne 2b",
            n = inout(reg) iterations => _,
            options(nomem, nostack),
        );
    }
}
