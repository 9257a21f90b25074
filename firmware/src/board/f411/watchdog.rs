//! The independent watchdog, written directly (IWDG_KR, IWDG_PR, IWDG_RLR, IWDG_SR) with
//! the settings of `robot_app::stm32f4::watchdog`.
//!
//! RM0383 §17.3: writing 0xCCCC to IWDG_KR starts the watchdog and forces the LSI on; the
//! counter then starts from 0xFFF at the current prescaler (÷4 after reset: 512 ms at
//! 32 kHz, 349 ms at 47 kHz). PR and RLR are write-protected until 0x5555 is written to KR
//! (any other key, such as a feed, protects them again); a new value reaches the LSI
//! domain only after IWDG_SR.PVU / RVU have cleared (up to 5 LSI periods, ≤ 0.3 ms), and
//! RLR is loaded into the counter by the next 0xAAAA (feed). So: start, unlock, write PR
//! and RLR, wait for PVU = RVU = 0, feed.
//!
//! With a 10 ms watchdog a debugger's breakpoint resets the chip; see the
//! `halt-stops-watchdog` feature (`stop_while_halted`).

use core::fmt;

use robot_app::stm32f4::watchdog::IwdgConfig;
use stm32f4xx_hal::pac;

/// Reads of IWDG_SR before an update counts as stuck: at least 10 ms at one read per
/// cycle of 100 MHz (an update takes at most 5 LSI periods, 0.3 ms at 17 kHz).
const UPDATE_POLLS: u32 = 1_000_000;

/// The watchdog's registers did not take a new setting in time (the LSI is not running).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct UpdateStuck;

impl fmt::Display for UpdateStuck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("IWDG_SR.PVU/RVU did not clear")
    }
}

/// The running independent watchdog.
pub struct Watchdog {
    iwdg: pac::IWDG,
}

impl Watchdog {
    /// Starts the watchdog with `config` and feeds it (the order of the module doc).
    pub fn start(iwdg: pac::IWDG, config: IwdgConfig) -> Result<Self, UpdateStuck> {
        iwdg.kr().write(|w| w.key().start());
        let mut watchdog = Self { iwdg };
        watchdog.write_config(config)?;
        watchdog.feed();
        Ok(watchdog)
    }

    /// Reloads the counter: another full timeout.
    #[inline]
    pub fn feed(&mut self) {
        self.iwdg.kr().write(|w| w.key().feed());
    }

    /// Changes the timeout of the running watchdog (e.g. longer around a flash erase):
    /// waits for a previous update to finish, feeds (the old timeout starts afresh, so the
    /// change itself cannot trip it), writes the new setting, waits until the LSI domain
    /// has it, and feeds again, which loads the new reload value.
    pub fn set_timeout(&mut self, config: IwdgConfig) -> Result<(), UpdateStuck> {
        self.wait_for_update()?;
        self.feed();
        self.write_config(config)?;
        self.feed();
        Ok(())
    }

    fn write_config(&mut self, config: IwdgConfig) -> Result<(), UpdateStuck> {
        self.iwdg.kr().write(|w| w.key().unlock());
        // SAFETY: PR is a 3-bit field and `pr_bits` is 0..=6, all defined by RM0383.
        self.iwdg
            .pr()
            .write(|w| unsafe { w.pr().bits(config.prescaler.pr_bits()) });
        self.iwdg.rlr().write(|w| w.rl().set(config.reload));
        self.wait_for_update()
    }

    fn wait_for_update(&self) -> Result<(), UpdateStuck> {
        for _ in 0..UPDATE_POLLS {
            let sr = self.iwdg.sr().read();
            if sr.pvu().bit_is_clear() && sr.rvu().bit_is_clear() {
                return Ok(());
            }
        }
        Err(UpdateStuck)
    }
}

/// Debug builds with feature `halt-stops-watchdog` only: freeze the watchdog while the
/// debugger halts the core (DBGMCU_APB1_FZ.DBG_IWDG_STOP), so breakpoints do not reset
/// the chip. The PWM keeps its last duty while halted.
#[cfg(feature = "halt-stops-watchdog")]
pub fn stop_while_halted(dbgmcu: &pac::DBGMCU) {
    dbgmcu.apb1_fz().modify(|_, w| w.dbg_iwdg_stop().set_bit());
}

#[cfg(all(feature = "halt-stops-watchdog", not(debug_assertions)))]
compile_error!(
    "feature `halt-stops-watchdog` is for debug builds only: a release build must reset \
     when the core stops"
);
