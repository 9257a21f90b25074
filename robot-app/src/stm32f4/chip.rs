//! The supported STM32F4 parts and the limits of their datasheets and reference manuals
//! that the register arithmetic of this module checks against.
//!
//! Sources: STM32F401 — RM0368 and DS9716; STM32F411 — RM0383 and DS10314; STM32F446 —
//! RM0390 and DS10693. Every figure below is for V_DD = V_DDA in 2.7–3.6 V (both boards run
//! at 3.3 V, and the brown-out reset keeps them above 2.7 V: [`super::option_bytes`]), no
//! over-drive.

/// One of the STM32F4 parts the firmware builds for (one cargo feature each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Chip {
    /// STM32F401xB/C/D/E: 84 MHz maximum.
    F401,
    /// STM32F411xC/E: 100 MHz maximum (the Black Pill and the Nucleo-F411RE).
    F411,
    /// STM32F446xC/E: 180 MHz with over-drive, 168 MHz without (only the latter here).
    F446,
}

/// A main-regulator voltage scale, PWR_CR.VOS. The value written to the two VOS bits is
/// the same on all three parts (RM0368/RM0383/RM0390, PWR_CR): `01` scale 3, `10` scale
/// 2, `11` scale 1; `00` is reserved and selects scale 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum VoltageScale {
    /// Scale 3: the lowest core voltage, the lowest HCLK limit.
    Scale3,
    /// Scale 2.
    Scale2,
    /// Scale 1: the highest core voltage and HCLK limit (not on the STM32F401).
    Scale1,
}

impl VoltageScale {
    /// The PWR_CR.VOS field value (bits 15:14) for this scale.
    pub const fn vos_bits(self) -> u8 {
        match self {
            VoltageScale::Scale3 => 0b01,
            VoltageScale::Scale2 => 0b10,
            VoltageScale::Scale1 => 0b11,
        }
    }

    /// The scale a PWR_CR.VOS field value selects (`00`, reserved, selects scale 3).
    pub const fn from_vos_bits(bits: u8) -> VoltageScale {
        match bits & 0b11 {
            0b11 => VoltageScale::Scale1,
            0b10 => VoltageScale::Scale2,
            _ => VoltageScale::Scale3,
        }
    }
}

impl Chip {
    /// The part's name, e.g. `"STM32F411"`.
    pub const fn name(self) -> &'static str {
        match self {
            Chip::F401 => "STM32F401",
            Chip::F411 => "STM32F411",
            Chip::F446 => "STM32F446",
        }
    }

    /// The highest HCLK each voltage scale allows, Hz, lowest scale first (general
    /// operating conditions of DS9716, DS10314 Table 14, DS10693; no over-drive).
    pub const fn scale_limits_hz(self) -> &'static [(VoltageScale, u32)] {
        match self {
            Chip::F401 => &[
                (VoltageScale::Scale3, 60_000_000),
                (VoltageScale::Scale2, 84_000_000),
            ],
            Chip::F411 => &[
                (VoltageScale::Scale3, 64_000_000),
                (VoltageScale::Scale2, 84_000_000),
                (VoltageScale::Scale1, 100_000_000),
            ],
            Chip::F446 => &[
                (VoltageScale::Scale3, 120_000_000),
                (VoltageScale::Scale2, 144_000_000),
                (VoltageScale::Scale1, 168_000_000),
            ],
        }
    }

    /// The highest SYSCLK/HCLK, Hz, at the part's highest voltage scale.
    pub const fn max_hclk_hz(self) -> u32 {
        let limits = self.scale_limits_hz();
        match limits.last() {
            Some(&(_, hz)) => hz,
            None => 0,
        }
    }

    /// The highest APB1 (PCLK1) frequency, Hz (DS9716: 42 MHz, DS10314: 50 MHz, DS10693:
    /// 45 MHz).
    pub const fn max_pclk1_hz(self) -> u32 {
        match self {
            Chip::F401 => 42_000_000,
            Chip::F411 => 50_000_000,
            Chip::F446 => 45_000_000,
        }
    }

    /// The highest APB2 (PCLK2) frequency, Hz (84, 100 and 90 MHz).
    pub const fn max_pclk2_hz(self) -> u32 {
        match self {
            Chip::F401 => 84_000_000,
            Chip::F411 => 100_000_000,
            Chip::F446 => 90_000_000,
        }
    }

    /// The upper HCLK bound, Hz, of each flash wait-state count at 2.7–3.6 V: entry `i`
    /// is the highest HCLK at which `i` wait states suffice (RM0368 Table 6, RM0383
    /// Table 5, RM0390 Table 5).
    pub const fn flash_wait_state_limits_hz(self) -> &'static [u32] {
        match self {
            Chip::F401 => &[30_000_000, 60_000_000, 84_000_000],
            Chip::F411 => &[30_000_000, 64_000_000, 90_000_000, 100_000_000],
            Chip::F446 => &[
                30_000_000,
                60_000_000,
                90_000_000,
                120_000_000,
                150_000_000,
                180_000_000,
            ],
        }
    }

    /// The main PLL's VCO output range, Hz: 192–432 MHz on the STM32F401 (RM0368),
    /// 100–432 MHz on the STM32F411 and STM32F446 (RM0383, RM0390; RCC_PLLCFGR.PLLN).
    pub const fn vco_range_hz(self) -> (u32, u32) {
        match self {
            Chip::F401 => (192_000_000, 432_000_000),
            Chip::F411 | Chip::F446 => (100_000_000, 432_000_000),
        }
    }

    /// The valid PLLN multipliers (RCC_PLLCFGR.PLLN): 192–432 on the STM32F401, 50–432
    /// on the others.
    pub const fn plln_range(self) -> (u16, u16) {
        match self {
            Chip::F401 => (192, 432),
            Chip::F411 | Chip::F446 => (50, 432),
        }
    }

    /// The highest ADC clock, Hz, at V_DDA 2.4–3.6 V: 36 MHz on all three (ADC
    /// characteristics of DS9716, DS10314, DS10693).
    pub const fn max_adc_clock_hz(self) -> u32 {
        36_000_000
    }

    /// The LSI (the watchdog's clock) over temperature and supply, Hz: (min, typical,
    /// max) = (17, 32, 47) kHz on all three (LSI oscillator characteristics of DS9716,
    /// DS10314, DS10693).
    pub const fn lsi_hz(self) -> (u32, u32, u32) {
        (17_000, 32_000, 47_000)
    }
}

/// The HSI RC oscillator, Hz (16 MHz on every STM32F4, factory-trimmed to ±1 % at 25 °C).
pub const HSI_HZ: u32 = 16_000_000;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vos_field_round_trips_and_reserved_value_is_scale_3() {
        for scale in [
            VoltageScale::Scale3,
            VoltageScale::Scale2,
            VoltageScale::Scale1,
        ] {
            assert_eq!(VoltageScale::from_vos_bits(scale.vos_bits()), scale);
        }
        // The PAC's reset value of PWR_CR is 0: VOS = 00, reserved, i.e. scale 3. That is
        // why the firmware modifies PWR_CR instead of writing it.
        assert_eq!(VoltageScale::from_vos_bits(0), VoltageScale::Scale3);
        // The F411's real reset value (0x0000_8000) is scale 2, rated to 84 MHz only.
        assert_eq!(
            VoltageScale::from_vos_bits((0x8000u32 >> 14) as u8),
            VoltageScale::Scale2
        );
    }

    #[test]
    fn limits_are_ordered() {
        for chip in [Chip::F401, Chip::F411, Chip::F446] {
            let scales = chip.scale_limits_hz();
            assert!(scales
                .windows(2)
                .all(|w| w[0].0 < w[1].0 && w[0].1 < w[1].1));
            let ws = chip.flash_wait_state_limits_hz();
            assert!(ws.windows(2).all(|w| w[0] < w[1]));
            assert!(*ws.last().unwrap() >= chip.max_hclk_hz());
            assert!(chip.max_pclk1_hz() < chip.max_pclk2_hz());
        }
        assert_eq!(Chip::F411.max_hclk_hz(), 100_000_000);
        assert_eq!(Chip::F401.max_hclk_hz(), 84_000_000);
    }
}
