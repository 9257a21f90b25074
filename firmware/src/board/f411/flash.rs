//! The parameter storage: flash sectors 6 and 7 ([`STORAGE`]), erased and programmed
//! through the flash interface (RM0383 §3.5, the same on the STM32F446, RM0390 §3.6).
//!
//! Registers and sequence:
//!
//! 1. **Unlock** FLASH_CR: write the keys 0x4567_0123 then 0xCDEF_89AB to FLASH_KEYR
//!    (a wrong sequence locks FLASH_CR until the next reset).
//! 2. **Wait** for FLASH_SR.BSY = 0 (no operation in progress; FLASH_CR may not be
//!    written while BSY is set) and clear the sticky error flags (FLASH_SR.PGSERR,
//!    PGPERR, PGAERR, WRPERR, OPERR: rc_w1).
//! 3. **Erase** the sector: FLASH_CR.PSIZE = 10 (x32 parallelism: allowed at V_DD
//!    2.7–3.6 V; both boards run at 3.3 V, and the link service asks for a write only
//!    while the brown-out reset at level 3 holds V_DD above 2.7 V), SER = 1, SNB = the sector; then STRT = 1;
//!    wait for BSY = 0. Every fetch from flash stalls meanwhile (single bank): 1–2 s for
//!    a 128 KiB sector (`robot_app::stm32f4::flash`), which is why the caller has lengthened
//!    the watchdog to [`WATCHDOG_PERSIST`] first.
//! 4. **Program** word by word: SER = 0, PG = 1, each 32-bit word written to its
//!    address (a word access, as PSIZE = x32 requires), wait for BSY = 0 after each
//!    (16–100 µs); then PG = 0.
//! 5. **Lock** FLASH_CR again (LOCK = 1) and check the error flags.
//! 6. **Reset the data cache** (FLASH_ACR: DCEN = 0, DCRST = 1, DCRST = 0, DCEN = 1;
//!    RM0383 allows DCRST only while the cache is off): a line holding the sector's old
//!    contents would otherwise be what the read-back sees.

use robot_app::persist::{Slot, MAX_RECORD_LEN};
use robot_app::stm32f4::flash::{persist_watchdog_timeout_us, StorageSectors, STORAGE_F411};
use robot_app::stm32f4::watchdog::IwdgConfig;
use stm32f4xx_hal::pac;

use super::CHIP;

/// The sectors of the two record pages: 6 and 7 on the F411 and F446.
pub const STORAGE: StorageSectors = STORAGE_F411;

/// FLASH_KEYR's unlock sequence.
const KEYS: [u32; 2] = [0x4567_0123, 0xCDEF_89AB];

/// The independent watchdog while a record is written: it outlasts the longest erase of
/// a storage sector and the programming of the largest record even at the fastest LSI
/// (47 kHz): ÷32, reload 3025, 2.06 s there, 3.0 s at the typical 32 kHz, 5.7 s at
/// 17 kHz (`robot_app::stm32f4::flash::persist_watchdog_timeout_us`).
pub const WATCHDOG_PERSIST: IwdgConfig = {
    let needed = match persist_watchdog_timeout_us(&STORAGE.a, MAX_RECORD_LEN) {
        Some(us) => us,
        None => panic!("no erase time for the storage sector"),
    };
    match IwdgConfig::at_least_us(needed, CHIP.lsi_hz().2) {
        Ok(config) => config,
        Err(_) => panic!("the persistence watchdog is out of range"),
    }
};

/// A flash operation that reported an error (the FLASH_SR bits), or a flash that stayed
/// locked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum FlashError {
    /// FLASH_CR.LOCK stayed set after the key sequence.
    Locked,
    /// FLASH_SR after the operation, with an error flag set.
    Status(u32),
}

/// FLASH_SR error flags: OPERR, WRPERR, PGAERR, PGPERR, PGSERR (bits 1, 4–7).
pub(super) const SR_ERRORS: u32 = 0b1111_0010;

/// The flash interface, owned for the storage's erase and program operations.
pub struct Storage {
    flash: pac::FLASH,
}

impl Storage {
    /// The storage on this chip: sectors 6 and 7 of the F411 and F446; none on the
    /// F401 (see `robot_app::stm32f4::flash`).
    pub fn new(flash: pac::FLASH) -> Option<Self> {
        if cfg!(feature = "stm32f401") {
            return None;
        }
        Some(Self { flash })
    }

    /// The first [`MAX_RECORD_LEN`] bytes of `slot`'s sector, as the flash holds them.
    pub fn page(&self, slot: Slot) -> &'static [u8] {
        let start = STORAGE.sector(slot).address as usize as *const u8;
        // SAFETY: the sector lies inside the chip's flash (sectors 6 and 7 of a 512 KiB
        // part, `robot_app::stm32f4::flash` checks the map), which is always readable and
        // outside every section of this program (`memory.x` ends FLASH below it); it
        // only changes under `erase_and_program`, which takes `&mut self`, so no such
        // slice is read while it runs (the caller holds none across it).
        unsafe { core::slice::from_raw_parts(start, MAX_RECORD_LEN) }
    }

    /// Erases `slot`'s sector and programs `record` at its start (the last word padded
    /// with 0xFF), with the sequence of the module doc. Stalls the CPU for up to ~2 s.
    pub fn erase_and_program(&mut self, slot: Slot, record: &[u8]) -> Result<(), FlashError> {
        let sector = STORAGE.sector(slot);
        self.unlock()?;
        let result = self.erase(sector.number).and_then(|()| {
            let mut address = sector.address;
            for chunk in record.chunks(4) {
                let mut word = [0xFF; 4];
                word.iter_mut().zip(chunk).for_each(|(w, b)| *w = *b);
                self.program(address, u32::from_le_bytes(word))?;
                address += 4;
            }
            Ok(())
        });
        self.flash
            .cr()
            .modify(|_, w| w.pg().clear_bit().ser().clear_bit().lock().set_bit());
        self.reset_data_cache();
        result
    }

    fn unlock(&mut self) -> Result<(), FlashError> {
        if self.flash.cr().read().lock().bit_is_set() {
            for key in KEYS {
                self.flash.keyr().write(|w| w.key().set(key));
            }
        }
        if self.flash.cr().read().lock().bit_is_set() {
            return Err(FlashError::Locked);
        }
        Ok(())
    }

    /// Waits for BSY = 0; the status's error flags (cleared) as an error.
    fn wait_idle(&mut self) -> Result<(), FlashError> {
        while self.flash.sr().read().bsy().bit_is_set() {}
        let status = self.flash.sr().read().bits();
        if status & SR_ERRORS != 0 {
            // SAFETY: writing 1 clears these rc_w1 flags; the other bits ignore writes.
            self.flash
                .sr()
                .write(|w| unsafe { w.bits(status & SR_ERRORS) });
            return Err(FlashError::Status(status));
        }
        Ok(())
    }

    fn erase(&mut self, sector: u8) -> Result<(), FlashError> {
        // Errors left over from before are not this erase's: clear them.
        let _ = self.wait_idle();
        // SAFETY: SNB is a 4-bit field and `sector` is a sector number of this chip
        // (6 or 7, from `robot_app::stm32f4::flash`).
        self.flash.cr().modify(|_, w| unsafe {
            w.pg()
                .clear_bit()
                .psize()
                .psize32()
                .ser()
                .set_bit()
                .snb()
                .bits(sector)
        });
        self.flash.cr().modify(|_, w| w.strt().set_bit());
        let result = self.wait_idle();
        self.flash.cr().modify(|_, w| w.ser().clear_bit());
        result
    }

    fn program(&mut self, address: u32, word: u32) -> Result<(), FlashError> {
        self.flash
            .cr()
            .modify(|_, w| w.ser().clear_bit().psize().psize32().pg().set_bit());
        // SAFETY: `address` is word-aligned inside an erased storage sector (the caller
        // walks the sector from its start), which no part of the program occupies; a
        // word write with PG set programs it.
        unsafe { (address as usize as *mut u32).write_volatile(word) };
        self.wait_idle()
    }

    fn reset_data_cache(&mut self) {
        self.flash.acr().modify(|_, w| w.dcen().clear_bit());
        self.flash.acr().modify(|_, w| w.dcrst().set_bit());
        self.flash.acr().modify(|_, w| w.dcrst().clear_bit());
        self.flash.acr().modify(|_, w| w.dcen().set_bit());
    }
}
