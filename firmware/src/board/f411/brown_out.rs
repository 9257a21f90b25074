//! The brown-out reset level, set in the option bytes the first time the firmware starts
//! on a chip, before anything can be persisted (`robot_app::stm32f4::option_bytes` says
//! why level 3, and computes the one value written).
//!
//! At every start [`ensure_level`] reads FLASH_OPTCR.BOR_LEV. On a chip that already has
//! [`BorLevel::REQUIRED`] it writes nothing. Otherwise (a new chip: the factory leaves it
//! off) it programs the option bytes, still on the 16 MHz HSI and before the clock is
//! raised to 3 wait states:
//!
//! 1. the watchdog is lengthened to `WATCHDOG_PERSIST` (2.06 s at the fastest LSI): the
//!    option-byte write stalls flash fetches like an erase;
//! 2. FLASH_OPTKEYR gets the two keys (OPTLOCK clears), FLASH_SR.BSY is waited for;
//! 3. FLASH_OPTCR = the value read with only BOR_LEV replaced (RDP, nWRP and the other
//!    options unchanged), then the same with OPTSTRT, then BSY is waited for at most
//!    `OPTION_WRITE_TIMEOUT_US` (1 s, timed by the cycle counter);
//! 4. the error flags are checked, OPTLOCK set again, the watchdog set back to
//!    `WATCHDOG_INIT`, and BOR_LEV read back.
//!
//! Whatever happens, the level read back is what the robot reports in `Info`, and the
//! link service refuses `PersistParams` unless it is level 3, so a chip whose option
//! bytes could not be written keeps running (the log says why) but never writes its
//! parameter flash.

use core::fmt;

use robot_app::stm32f4::chip::HSI_HZ;
use robot_app::stm32f4::option_bytes::{
    optcr_with_bor_level, BorLevel, OPTION_KEYS, OPTION_WRITE_TIMEOUT_US, OPTSTRT,
};
use robot_app::stm32f4::oscillator::cycles_in_us;
use stm32f4xx_hal::pac;

use super::flash::SR_ERRORS;
use super::wait::within_cycles;
use super::watchdog::Watchdog;
use super::{WATCHDOG_INIT, WATCHDOG_PERSIST};

/// The bound of each wait for FLASH_SR.BSY, in cycles of the HSI the core runs on here.
const BUSY_CYCLES: u32 = cycles_in_us(OPTION_WRITE_TIMEOUT_US, HSI_HZ);

/// Why the option bytes were not written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum OptionWriteError {
    /// The watchdog did not take the long timeout: nothing was written.
    Watchdog,
    /// FLASH_OPTCR.OPTLOCK stayed set after the key sequence.
    Locked,
    /// FLASH_SR.BSY stayed set past the bound (before or after OPTSTRT).
    Busy,
    /// FLASH_SR after the write, with an error flag set.
    Status(u32),
}

impl fmt::Display for OptionWriteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self, f)
    }
}

/// Sets the brown-out reset to [`BorLevel::REQUIRED`] unless it is already there (module
/// doc); the level in force afterwards, as read back.
pub fn ensure_level(flash: &pac::FLASH, watchdog: &mut Watchdog) -> BorLevel {
    let found = BorLevel::from_optcr(flash.optcr().read().bits());
    if found == BorLevel::REQUIRED {
        return found;
    }
    let threshold = BorLevel::REQUIRED.falling_threshold_mv();
    defmt::warn!(
        "brown-out reset: {=str} in the option bytes; setting {=str} (resets below {=u16}-{=u16} mV)",
        found.name(),
        BorLevel::REQUIRED.name(),
        threshold.map_or(0, |t| t.min),
        threshold.map_or(0, |t| t.max),
    );
    if watchdog.set_timeout(WATCHDOG_PERSIST).is_err() {
        report(Err(OptionWriteError::Watchdog), found);
        return found;
    }
    let written = write_level(flash, BorLevel::REQUIRED);
    // Locked again whatever happened; the key sequence is needed for any later write.
    flash.optcr().modify(|_, w| w.optlock().set_bit());
    if watchdog.set_timeout(WATCHDOG_INIT).is_err() {
        defmt::warn!("brown-out reset: the watchdog did not take the init timeout back");
    }
    let now = BorLevel::from_optcr(flash.optcr().read().bits());
    report(written, now);
    now
}

/// Steps 2 and 3 of the module doc, and the error flags.
fn write_level(flash: &pac::FLASH, level: BorLevel) -> Result<(), OptionWriteError> {
    if flash.optcr().read().optlock().bit_is_set() {
        for key in OPTION_KEYS {
            flash.optkeyr().write(|w| w.optkeyr().set(key));
        }
    }
    if flash.optcr().read().optlock().bit_is_set() {
        return Err(OptionWriteError::Locked);
    }
    let idle = || flash.sr().read().bsy().bit_is_clear();
    if !within_cycles(BUSY_CYCLES, idle) {
        return Err(OptionWriteError::Busy);
    }
    let value = optcr_with_bor_level(flash.optcr().read().bits(), level);
    // SAFETY: `value` is FLASH_OPTCR as read with only BOR_LEV changed (to an encoding
    // RM0383 defines) and OPTSTRT/OPTLOCK clear: the read protection and every other
    // option keep their programmed values (`optcr_with_bor_level`'s host tests).
    flash.optcr().write(|w| unsafe { w.bits(value) });
    // SAFETY: the same value, with OPTSTRT: programs it.
    flash.optcr().write(|w| unsafe { w.bits(value | OPTSTRT) });
    if !within_cycles(BUSY_CYCLES, idle) {
        return Err(OptionWriteError::Busy);
    }
    let status = flash.sr().read().bits();
    if status & SR_ERRORS != 0 {
        // SAFETY: writing 1 clears these rc_w1 flags; the other bits ignore writes.
        flash.sr().write(|w| unsafe { w.bits(status & SR_ERRORS) });
        return Err(OptionWriteError::Status(status));
    }
    Ok(())
}

fn report(written: Result<(), OptionWriteError>, now: BorLevel) {
    match written {
        Ok(()) if now == BorLevel::REQUIRED => {
            defmt::info!("brown-out reset: {=str} written to the option bytes", now.name());
        }
        Ok(()) => defmt::error!(
            "brown-out reset: the option bytes read back {=str}; parameters will not be persisted",
            now.name()
        ),
        Err(e) => defmt::error!(
            "brown-out reset: option bytes not written ({}), {=str} in force; parameters will not be persisted",
            e,
            now.name()
        ),
    }
}
