//! SYSCLK as the RCC registers give it, decoded from RCC_CFGR and RCC_PLLCFGR (RM0383
//! §6.3.2–6.3.3): what a first-flash program prints to show the clock the board really
//! runs on, independent of the plan the firmware meant to write.
//!
//! | RCC_CFGR.SWS (bits 3:2) | SYSCLK |
//! |---|---|
//! | 00 | HSI, 16 MHz |
//! | 01 | HSE, the board's oscillator |
//! | 10 | main PLL: source (PLLSRC: HSE or HSI) / PLLM × PLLN / PLLP |
//! | 11 | not allowed (reads as [`SysclkSource::Invalid`]) |

use super::chip::HSI_HZ;
use super::clock::{PllConfig, PLLSRC_HSE};

/// What SYSCLK runs from, by RCC_CFGR.SWS.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SysclkSource {
    /// The internal 16 MHz RC oscillator.
    Hsi,
    /// The external oscillator, directly.
    Hse,
    /// The main PLL, fed by the HSE (`from_hse`) or the HSI.
    Pll {
        /// RCC_PLLCFGR.PLLSRC: the PLL's input is the HSE.
        from_hse: bool,
    },
    /// SWS = 11, which RM0383 does not allow.
    Invalid,
}

impl SysclkSource {
    /// A short name for logs: `HSI`, `HSE`, `PLL from the HSE`, `PLL from the HSI`, `invalid`.
    pub const fn name(self) -> &'static str {
        match self {
            SysclkSource::Hsi => "HSI",
            SysclkSource::Hse => "HSE",
            SysclkSource::Pll { from_hse: true } => "PLL from the HSE",
            SysclkSource::Pll { from_hse: false } => "PLL from the HSI",
            SysclkSource::Invalid => "invalid",
        }
    }
}

/// SYSCLK decoded from the registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SysclkReadBack {
    /// What SYSCLK runs from.
    pub source: SysclkSource,
    /// SYSCLK, Hz; 0 when the registers give none (SWS = 11, or a PLLM or PLLP of 0).
    pub hz: u32,
}

impl SysclkReadBack {
    /// Decodes RCC_CFGR (`cfgr`) and RCC_PLLCFGR (`pllcfgr`) for a board whose HSE runs
    /// at `hse_hz`. Never divides by zero: a PLLM of 0 (not allowed) gives 0 Hz.
    pub const fn from_registers(cfgr: u32, pllcfgr: u32, hse_hz: u32) -> SysclkReadBack {
        let (source, hz) = match (cfgr >> 2) & 0b11 {
            0b00 => (SysclkSource::Hsi, HSI_HZ),
            0b01 => (SysclkSource::Hse, hse_hz),
            0b10 => {
                let from_hse = pllcfgr & PLLSRC_HSE != 0;
                let input_hz = if from_hse { hse_hz } else { HSI_HZ };
                let pll = PllConfig::from_pllcfgr(pllcfgr);
                let hz = if pll.m == 0 {
                    0
                } else {
                    // u64: up to 50 MHz × 511 before the division.
                    (input_hz as u64 * pll.n as u64 / pll.m as u64 / pll.p as u64) as u32
                };
                (SysclkSource::Pll { from_hse }, hz)
            }
            _ => (SysclkSource::Invalid, 0),
        };
        SysclkReadBack { source, hz }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stm32f4::chip::Chip;
    use crate::stm32f4::clock::pll_for;

    /// RCC_CFGR with SWS = `sws` and the F411's 100 MHz prescalers (HPRE 1, PPRE1 2,
    /// PPRE2 1).
    fn cfgr(sws: u32) -> u32 {
        (sws << 2) | (0b100 << 10)
    }

    #[test]
    fn the_plans_of_both_boards_read_back_as_100_mhz_from_the_pll() {
        for (hse_hz, from_hse) in [(25_000_000, true), (8_000_000, true), (HSI_HZ, false)] {
            let pll = pll_for(Chip::F411, hse_hz, 100_000_000).unwrap();
            let pllcfgr = pll.pllcfgr_fields() | if from_hse { PLLSRC_HSE } else { 0 };
            let read = SysclkReadBack::from_registers(cfgr(0b10), pllcfgr, hse_hz);
            assert_eq!(read.source, SysclkSource::Pll { from_hse }, "{hse_hz}");
            assert_eq!(read.hz, 100_000_000, "{hse_hz}");
        }
    }

    #[test]
    fn the_pll_source_bit_picks_the_input() {
        // M = 8, N = 200, P = 4: 100 MHz from the 16 MHz HSI, 156.25 MHz from a 25 MHz HSE.
        let pll = PllConfig {
            m: 8,
            n: 200,
            p: 4,
            q: 9,
        };
        let from_hsi = SysclkReadBack::from_registers(cfgr(0b10), pll.pllcfgr_fields(), 25_000_000);
        assert_eq!(from_hsi.hz, 100_000_000);
        let from_hse = SysclkReadBack::from_registers(
            cfgr(0b10),
            pll.pllcfgr_fields() | PLLSRC_HSE,
            25_000_000,
        );
        assert_eq!(from_hse.hz, 156_250_000);
        assert_eq!(from_hse.source.name(), "PLL from the HSE");
    }

    #[test]
    fn direct_oscillators_and_the_reset_state() {
        // After reset (and under QEMU, which reads RCC as 0): the HSI.
        assert_eq!(
            SysclkReadBack::from_registers(0, 0, 25_000_000),
            SysclkReadBack {
                source: SysclkSource::Hsi,
                hz: 16_000_000
            }
        );
        assert_eq!(
            SysclkReadBack::from_registers(cfgr(0b01), 0, 8_000_000),
            SysclkReadBack {
                source: SysclkSource::Hse,
                hz: 8_000_000
            }
        );
    }

    #[test]
    fn register_values_rm0383_forbids_give_zero_hz_not_a_panic() {
        let invalid = SysclkReadBack::from_registers(cfgr(0b11), 0, 25_000_000);
        assert_eq!((invalid.source, invalid.hz), (SysclkSource::Invalid, 0));
        let no_m = SysclkReadBack::from_registers(cfgr(0b10), 200 << 6, 25_000_000);
        assert_eq!(no_m.hz, 0);
    }
}
