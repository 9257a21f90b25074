//! The brown-out reset level in the option bytes (FLASH_OPTCR.BOR_LEV), and the one value
//! the firmware writes to FLASH_OPTCR to set it.
//!
//! # Why level 3
//!
//! The clock plan runs the F411 at 100 MHz with 3 flash wait states, and the parameter
//! storage programs the flash 32 bits at a time (FLASH_CR.PSIZE = x32): RM0383 rates both
//! for V_DD 2.7–3.6 V only (Table 5 for the wait states; the program/erase parallelism
//! table for x32). The
//! factory option bytes leave the brown-out reset off (BOR_LEV = 11), so only the
//! power-on/power-down reset stops the chip, near 1.7 V: a sagging supply would keep the
//! core fetching from, and the link task writing to, a flash out of its rating. Level 3
//! (BOR_LEV = 00) holds the chip in reset below its threshold, which is above 2.7 V
//! (DS10314, "Embedded reset and power control block characteristics"):
//!
//! | level | BOR_LEV | RM0383's supply range | falling threshold min / typ / max | rising min / typ / max |
//! |---|---|---|---|---|
//! | 3 | `00` | 2.70–3.60 V | 2.75 / 2.83 / 2.88 V | 2.85 / 2.92 / 2.97 V |
//! | 2 | `01` | 2.40–2.70 V | 2.44 / 2.50 / 2.56 V | 2.53 / 2.59 / 2.63 V |
//! | 1 | `10` | 2.10–2.40 V | 2.13 / 2.19 / 2.24 V | 2.23 / 2.29 / 2.33 V |
//! | off | `11` | 1.62–2.10 V | POR/PDR only | |
//!
//! The hysteresis is about 100 mV. The 3.3 V regulators of both boards sit well above
//! level 3's rising threshold.
//!
//! # The write
//!
//! RM0383, "Programming user option bytes": unlock with the two keys in
//! FLASH_OPTKEYR (OPTLOCK clears), wait for FLASH_SR.BSY = 0, write the new option value
//! into FLASH_OPTCR, set OPTSTRT, wait for BSY = 0, set OPTLOCK. The value is the register
//! as read with only BOR_LEV replaced ([`optcr_with_bor_level`]): the read protection
//! (RDP, bits 15:8), the write protection (nWRP), the watchdog and reset options and the
//! reserved bits keep their values bit for bit, so the write can never change the
//! protection level. The datasheet gives no programming time for the option bytes; the
//! firmware waits at most [`OPTION_WRITE_TIMEOUT_US`] for BSY, under a watchdog that
//! outlasts it.

use link::BrownOutReset;

/// FLASH_OPTCR.OPTLOCK (bit 0): the option bytes are locked.
pub const OPTLOCK: u32 = 1 << 0;
/// FLASH_OPTCR.OPTSTRT (bit 1): start programming the option bytes.
pub const OPTSTRT: u32 = 1 << 1;
/// FLASH_OPTCR.BOR_LEV (bits 3:2).
pub const BOR_LEV_MASK: u32 = 0b11 << BOR_LEV_SHIFT;
const BOR_LEV_SHIFT: u32 = 2;
/// FLASH_OPTCR.RDP (bits 15:8): the read protection level (0xAA: level 0).
pub const RDP_MASK: u32 = 0xFF << 8;

/// FLASH_OPTKEYR's unlock sequence (RM0383, FLASH_OPTKEYR).
pub const OPTION_KEYS: [u32; 2] = [0x0819_2A3B, 0x4C5D_6E7F];

/// FLASH_OPTCR as the factory programs it on the F411 (RM0383, FLASH_OPTCR's reset value
/// 0x0FFF_AAED): locked, brown-out reset off, RDP level 0 (0xAA), nothing
/// write-protected, software watchdog.
pub const OPTCR_FACTORY: u32 = 0x0FFF_AAED;

/// The longest wait for FLASH_SR.BSY after OPTSTRT, µs. No datasheet lists the time of an
/// option-byte write; this is twice the longest erase of the smallest sector (16 KiB:
/// 500 ms at x32), far more than a one-word operation should take, and shorter than the
/// watchdog the firmware runs meanwhile (`WATCHDOG_PERSIST`, 2.06 s at the fastest LSI).
pub const OPTION_WRITE_TIMEOUT_US: u32 = 1_000_000;

/// A brown-out reset level (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BorLevel {
    /// BOR_LEV = 11: off; only POR/PDR resets the chip.
    Off,
    /// BOR_LEV = 10.
    Level1,
    /// BOR_LEV = 01.
    Level2,
    /// BOR_LEV = 00: resets below about 2.8 V.
    Level3,
}

/// One of the datasheet's thresholds, mV: (min, typ, max).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ThresholdMv {
    /// Minimum, mV.
    pub min: u16,
    /// Typical, mV.
    pub typ: u16,
    /// Maximum, mV.
    pub max: u16,
}

/// The lowest V_DD at which RM0383 rates 3 wait states at 90–100 MHz and x32 flash
/// programming, mV.
pub const FLASH_FULL_SPEED_MIN_MV: u16 = 2_700;

impl BorLevel {
    /// The level the firmware sets: the lowest one whose falling threshold, at its
    /// minimum, stays at or above [`FLASH_FULL_SPEED_MIN_MV`].
    pub const REQUIRED: BorLevel = {
        let levels = [BorLevel::Level1, BorLevel::Level2, BorLevel::Level3];
        let mut i = 0;
        loop {
            if i == levels.len() {
                panic!("no brown-out level guards the flash's supply range");
            }
            if let Some(falling) = levels[i].falling_threshold_mv() {
                if falling.min >= FLASH_FULL_SPEED_MIN_MV {
                    break levels[i];
                }
            }
            i += 1;
        }
    };

    /// The level FLASH_OPTCR's BOR_LEV field selects in `optcr`.
    pub const fn from_optcr(optcr: u32) -> BorLevel {
        match (optcr & BOR_LEV_MASK) >> BOR_LEV_SHIFT {
            0b00 => BorLevel::Level3,
            0b01 => BorLevel::Level2,
            0b10 => BorLevel::Level1,
            _ => BorLevel::Off,
        }
    }

    /// `"off"`, `"level 1"`, `"level 2"` or `"level 3"`.
    pub const fn name(self) -> &'static str {
        match self {
            BorLevel::Off => "off",
            BorLevel::Level1 => "level 1",
            BorLevel::Level2 => "level 2",
            BorLevel::Level3 => "level 3",
        }
    }

    /// The BOR_LEV field value (two bits, unshifted).
    pub const fn bits(self) -> u32 {
        match self {
            BorLevel::Level3 => 0b00,
            BorLevel::Level2 => 0b01,
            BorLevel::Level1 => 0b10,
            BorLevel::Off => 0b11,
        }
    }

    /// The supply threshold on a falling V_DD below which the chip resets (datasheet
    /// figures, module doc); `None` when off.
    pub const fn falling_threshold_mv(self) -> Option<ThresholdMv> {
        match self {
            BorLevel::Off => None,
            BorLevel::Level1 => Some(ThresholdMv {
                min: 2_130,
                typ: 2_190,
                max: 2_240,
            }),
            BorLevel::Level2 => Some(ThresholdMv {
                min: 2_440,
                typ: 2_500,
                max: 2_560,
            }),
            BorLevel::Level3 => Some(ThresholdMv {
                min: 2_750,
                typ: 2_830,
                max: 2_880,
            }),
        }
    }

    /// The supply threshold on a rising V_DD above which the chip leaves reset; `None`
    /// when off.
    pub const fn rising_threshold_mv(self) -> Option<ThresholdMv> {
        match self {
            BorLevel::Off => None,
            BorLevel::Level1 => Some(ThresholdMv {
                min: 2_230,
                typ: 2_290,
                max: 2_330,
            }),
            BorLevel::Level2 => Some(ThresholdMv {
                min: 2_530,
                typ: 2_590,
                max: 2_630,
            }),
            BorLevel::Level3 => Some(ThresholdMv {
                min: 2_850,
                typ: 2_920,
                max: 2_970,
            }),
        }
    }

    /// What the link reports for this level.
    pub const fn report(self) -> BrownOutReset {
        match self {
            BorLevel::Off => BrownOutReset::Off,
            BorLevel::Level1 => BrownOutReset::Level1,
            BorLevel::Level2 => BrownOutReset::Level2,
            BorLevel::Level3 => BrownOutReset::Level3,
        }
    }
}

/// The value to write to FLASH_OPTCR, unlocked, to select `level`: `optcr` (the register
/// as read) with BOR_LEV replaced, OPTLOCK and OPTSTRT clear, and every other bit, the
/// read protection byte included, unchanged. Setting OPTSTRT is a second write of this
/// value with [`OPTSTRT`] added.
pub const fn optcr_with_bor_level(optcr: u32, level: BorLevel) -> u32 {
    (optcr & !(BOR_LEV_MASK | OPTSTRT | OPTLOCK)) | (level.bits() << BOR_LEV_SHIFT)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn level_3_is_the_one_that_keeps_v_dd_at_2_7_v() {
        assert_eq!(BorLevel::REQUIRED, BorLevel::Level3);
        // Level 2 would let the chip run down to 2.44 V, below the 2.7 V rating.
        assert!(BorLevel::Level2.falling_threshold_mv().unwrap().min < FLASH_FULL_SPEED_MIN_MV);
        for level in [BorLevel::Level1, BorLevel::Level2, BorLevel::Level3] {
            let (falling, rising) = (
                level.falling_threshold_mv().unwrap(),
                level.rising_threshold_mv().unwrap(),
            );
            assert!(falling.min <= falling.typ && falling.typ <= falling.max);
            // About 100 mV of hysteresis.
            assert!(
                (80..=110).contains(&(rising.typ - falling.typ)),
                "{level:?}"
            );
        }
        assert_eq!(BorLevel::Off.falling_threshold_mv(), None);
    }

    #[test]
    fn the_field_decodes_as_rm0383_defines_it() {
        assert_eq!(BorLevel::from_optcr(OPTCR_FACTORY), BorLevel::Off);
        for level in [
            BorLevel::Off,
            BorLevel::Level1,
            BorLevel::Level2,
            BorLevel::Level3,
        ] {
            assert_eq!(BorLevel::from_optcr(level.bits() << 2), level);
        }
        assert_eq!(BorLevel::Level3.report(), BrownOutReset::Level3);
        assert_eq!(BorLevel::Off.report(), BrownOutReset::Off);
    }

    #[test]
    fn the_factory_value_gets_level_3_and_keeps_rdp_level_0() {
        // Read after unlocking: OPTLOCK clear.
        let unlocked = OPTCR_FACTORY & !OPTLOCK;
        let written = optcr_with_bor_level(unlocked, BorLevel::Level3);
        assert_eq!(written, 0x0FFF_AAE0);
        assert_eq!(written & RDP_MASK, 0xAA << 8, "RDP level 0 stays");
        assert_eq!(BorLevel::from_optcr(written), BorLevel::Level3);
        assert_eq!(written | OPTSTRT, 0x0FFF_AAE2);
    }

    proptest! {
        #[test]
        fn only_bor_lev_changes(optcr in any::<u32>(), bits in 0u32..4) {
            let level = BorLevel::from_optcr(bits << 2);
            let written = optcr_with_bor_level(optcr, level);
            let kept = !(BOR_LEV_MASK | OPTSTRT | OPTLOCK);
            prop_assert_eq!(written & kept, optcr & kept);
            prop_assert_eq!(written & RDP_MASK, optcr & RDP_MASK);
            prop_assert_eq!(BorLevel::from_optcr(written), level);
            prop_assert_eq!(written & (OPTSTRT | OPTLOCK), 0);
        }
    }
}
