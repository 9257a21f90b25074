//! The on-chip flash as parameter storage: which sectors hold the two record pages, how
//! long erasing and programming them may stall the CPU, and the watchdog timeout that
//! outlasts it.
//!
//! # Sectors
//!
//! The STM32F411xE and STM32F446xE have the same 512 KiB single-bank layout (RM0383 and
//! RM0390, "Flash module organization"): sectors 0–3 of 16 KiB from 0x0800_0000, sector 4
//! of 64 KiB at 0x0801_0000, sectors 5–7 of 128 KiB from 0x0802_0000. The records
//! ([`crate::persist`], two pages used in turn) go to the last two sectors, 6 and 7
//! ([`STORAGE_F411`]), so the code may use sectors 0–5: the firmware's `memory.x`
//! gives it [`code_flash_len`]`(&STORAGE_F411)` = 256 KiB (`cargo test -p xtask` checks
//! `memory/stm32f411.x` against it). The firmware build is held to sectors 0–4,
//! [`FIRMWARE_FLASH_BUDGET`] = 128 KiB (`cargo xtask size` reads that constant), so a
//! debug build, much larger, still links.
//!
//! The STM32F401 port example has no storage: the F401CC of the WeAct board has only
//! sectors 0–5 (256 KiB), all of which a debug build may need.
//!
//! # Erase and program times
//!
//! The flash is a single bank: while it erases or programs, every fetch from it (code,
//! literal pools, the vector table) waits, so the CPU and every interrupt stall. The
//! firmware erases only in the supervisor's Persisting state (motors off), after
//! lengthening the independent watchdog to [`persist_watchdog_timeout_us`].
//!
//! Times for x32 parallelism (FLASH_CR.PSIZE = 10, allowed at V_DD 2.7–3.6 V; both
//! boards run at 3.3 V), from the datasheets' "Flash memory programming" tables
//! (DS10314 for the F411, DS10693 for the F446; the figures are the same):
//!
//! | operation | typical | maximum |
//! |---|---|---|
//! | word program (32 bits) | 16 µs | 100 µs |
//! | 16 KiB sector erase | 250 ms | 500 ms |
//! | 64 KiB sector erase | 550 ms | 1 100 ms |
//! | 128 KiB sector erase | 1 s | 2 s |

/// Where the flash starts in the memory map.
pub const FLASH_BASE: u32 = 0x0800_0000;

/// One flash sector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sector {
    /// Its number, the value of FLASH_CR.SNB that erases it.
    pub number: u8,
    /// Its first address.
    pub address: u32,
    /// Its size, bytes.
    pub size_bytes: u32,
}

impl Sector {
    /// The address after its last byte.
    pub const fn end(&self) -> u32 {
        self.address + self.size_bytes
    }
}

/// The sectors of a 512 KiB STM32F411xE / STM32F446xE (module doc).
pub const SECTORS_512K: [Sector; 8] = [
    Sector {
        number: 0,
        address: 0x0800_0000,
        size_bytes: 16 * 1024,
    },
    Sector {
        number: 1,
        address: 0x0800_4000,
        size_bytes: 16 * 1024,
    },
    Sector {
        number: 2,
        address: 0x0800_8000,
        size_bytes: 16 * 1024,
    },
    Sector {
        number: 3,
        address: 0x0800_C000,
        size_bytes: 16 * 1024,
    },
    Sector {
        number: 4,
        address: 0x0801_0000,
        size_bytes: 64 * 1024,
    },
    Sector {
        number: 5,
        address: 0x0802_0000,
        size_bytes: 128 * 1024,
    },
    Sector {
        number: 6,
        address: 0x0804_0000,
        size_bytes: 128 * 1024,
    },
    Sector {
        number: 7,
        address: 0x0806_0000,
        size_bytes: 128 * 1024,
    },
];

/// The two sectors that hold the parameter records ([`crate::persist::Slot`] A and B).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StorageSectors {
    /// Page A.
    pub a: Sector,
    /// Page B.
    pub b: Sector,
}

impl StorageSectors {
    /// The sector of `slot`.
    pub const fn sector(&self, slot: crate::persist::Slot) -> Sector {
        match slot {
            crate::persist::Slot::A => self.a,
            crate::persist::Slot::B => self.b,
        }
    }
}

/// Storage of the STM32F411xE and STM32F446xE: sectors 6 and 7.
pub const STORAGE_F411: StorageSectors = StorageSectors {
    a: SECTORS_512K[6],
    b: SECTORS_512K[7],
};

/// Bytes of flash left to the code below the storage: [`FLASH_BASE`] up to the first
/// storage sector (the `FLASH` length of the firmware's `memory.x`).
pub const fn code_flash_len(storage: &StorageSectors) -> u32 {
    let first = if storage.a.address < storage.b.address {
        storage.a.address
    } else {
        storage.b.address
    };
    first - FLASH_BASE
}

/// The flash the firmware build may take, bytes: sectors 0–4 of [`SECTORS_512K`]
/// (16 + 16 + 16 + 16 + 64 KiB = 128 KiB), leaving sector 5 to a debug build and
/// sectors 6–7 to the records. `cargo xtask size` holds the build to it.
pub const FIRMWARE_FLASH_BUDGET: u32 = SECTORS_512K[5].address - FLASH_BASE;

/// Longest programming time of one 32-bit word (x32 parallelism), µs.
pub const WORD_PROGRAM_MAX_US: u32 = 100;

/// The longest erase of a sector of `size_bytes` with x32 parallelism, µs (module doc),
/// or `None` for a size the table does not list.
pub const fn sector_erase_max_us(size_bytes: u32) -> Option<u32> {
    match size_bytes {
        0x4000 => Some(500_000),
        0x1_0000 => Some(1_100_000),
        0x2_0000 => Some(2_000_000),
        _ => None,
    }
}

/// Words to program for a record of `record_len` bytes (the last one padded with 0xFF).
pub const fn words_for(record_len: usize) -> u32 {
    record_len.div_ceil(4) as u32
}

/// Slack on top of the flash's own worst case, µs: the rest of the persistence work
/// (encoding, the read-back, restoring the watchdog) and a margin.
pub const PERSIST_SLACK_US: u32 = 50_000;

/// How long the watchdog must at least wait while the firmware erases `sector` and
/// programs a record of `record_len` bytes, µs: the longest erase, the longest
/// programming of every word, and [`PERSIST_SLACK_US`]. `None` for a sector size the
/// datasheet table does not list.
pub const fn persist_watchdog_timeout_us(sector: &Sector, record_len: usize) -> Option<u32> {
    match sector_erase_max_us(sector.size_bytes) {
        Some(erase) => Some(erase + words_for(record_len) * WORD_PROGRAM_MAX_US + PERSIST_SLACK_US),
        None => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::persist::{Slot, MAX_RECORD_LEN};
    use crate::stm32f4::chip::Chip;
    use crate::stm32f4::watchdog::{IwdgConfig, IwdgPrescaler};

    #[test]
    fn the_sectors_tile_512_kib_without_gaps() {
        let mut next = FLASH_BASE;
        for (i, s) in SECTORS_512K.iter().enumerate() {
            assert_eq!(usize::from(s.number), i);
            assert_eq!(s.address, next, "sector {i}");
            next = s.end();
        }
        assert_eq!(next - FLASH_BASE, 512 * 1024);
    }

    #[test]
    fn storage_is_the_last_two_128_kib_sectors_and_the_code_gets_the_rest() {
        let s = STORAGE_F411;
        assert_eq!((s.a.number, s.a.address), (6, 0x0804_0000));
        assert_eq!((s.b.number, s.b.address), (7, 0x0806_0000));
        assert_eq!(s.sector(Slot::B), s.b);
        assert_eq!(code_flash_len(&s), 256 * 1024);
        assert_eq!(FIRMWARE_FLASH_BUDGET, 128 * 1024);
        assert!(FIRMWARE_FLASH_BUDGET < code_flash_len(&s));
        // A record is far smaller than a sector.
        assert!(MAX_RECORD_LEN as u32 <= s.a.size_bytes);
    }

    #[test]
    fn the_watchdog_outlasts_the_worst_erase_at_the_fastest_lsi() {
        let sector = STORAGE_F411.a;
        let needed = persist_watchdog_timeout_us(&sector, MAX_RECORD_LEN).unwrap();
        // 2 s erase + 102 words × 100 µs + 50 ms.
        assert_eq!(words_for(MAX_RECORD_LEN), 102);
        assert_eq!(needed, 2_060_200);
        let lsi = Chip::F411.lsi_hz();
        let config = IwdgConfig::at_least_us(needed, lsi.2).unwrap();
        // The firmware's setting (board/f411/flash.rs): ÷32, reload 3025.
        assert_eq!(
            (config.prescaler, config.reload),
            (IwdgPrescaler::Div32, 3025),
            "{config:?}"
        );
        let spread = config.spread(lsi);
        assert!(spread.min_us >= needed, "{spread:?}");
        // Not absurdly long either: under 6 s at the slowest LSI.
        assert!(spread.max_us < 6_000_000, "{spread:?}");
        assert_eq!(sector_erase_max_us(12_345), None);
        assert_eq!(words_for(5), 2);
    }
}
