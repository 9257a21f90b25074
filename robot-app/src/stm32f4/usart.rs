//! The USART's baud-rate register for a baud rate on a bus clock.
//!
//! RM0383 §19.3.4 (the same on the STM32F401, F405 and F446): with 16× oversampling
//! (USART_CR1.OVER8 = 0) the receiver and transmitter run at
//! `baud = f_CK / (16 × USARTDIV)`, and USART_BRR holds USARTDIV in 12.4 fixed point
//! (DIV_Mantissa in bits 15:4, DIV_Fraction in bits 3:0). So the register's whole value
//! is `16 × USARTDIV = f_CK / baud`, rounded to the nearest integer here (a fraction
//! that rounds up to 16 carries into the mantissa by itself). USARTDIV must be at least
//! 1 (BRR ≥ 16).
//!
//! The rounding leaves a baud-rate error. RM0383 §19.3.5 gives the receiver's tolerance
//! to the *sum* of both ends' deviations as 3.75 % (16× oversampling, a fractional
//! divider, 8 data bits, ONEBIT = 0); [`MAX_ERROR_PPM`] keeps this end to a quarter of
//! that, so a host adapter with a similar error still leaves a margin.

use core::fmt;

/// Largest deviation of the real baud rate from the one asked for, parts per million
/// (1 %).
pub const MAX_ERROR_PPM: u32 = 10_000;

/// A USART_BRR setting and what it gives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BaudSetting {
    /// The USART_BRR value (16 × USARTDIV).
    pub brr: u16,
    /// The baud rate it gives, rounded down, bit/s.
    pub actual_baud: u32,
    /// Its deviation from the requested rate, parts per million (positive: faster).
    pub error_ppm: i32,
}

/// A baud rate the USART cannot run at from its bus clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaudError {
    /// A baud rate of 0.
    Zero,
    /// USARTDIV would be below 1 (more than f_CK / 16), bit/s.
    TooFast(u32),
    /// USART_BRR would exceed 16 bits, bit/s.
    TooSlow(u32),
    /// The nearest setting is off by more than [`MAX_ERROR_PPM`]: (baud, error in ppm).
    Inexact(u32, i32),
}

impl fmt::Display for BaudError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            BaudError::Zero => f.write_str("baud rate 0"),
            BaudError::TooFast(baud) => write!(f, "baud rate {baud} is above the bus clock / 16"),
            BaudError::TooSlow(baud) => write!(f, "baud rate {baud} needs BRR above 0xFFFF"),
            BaudError::Inexact(baud, ppm) => {
                write!(f, "baud rate {baud} is only reached within {ppm} ppm")
            }
        }
    }
}

impl core::error::Error for BaudError {}

impl BaudSetting {
    /// The USART_BRR value for `baud` (bit/s) on a USART clocked at `pclk_hz` (Hz), 16×
    /// oversampling (see the module doc).
    pub const fn for_baud(pclk_hz: u32, baud: u32) -> Result<Self, BaudError> {
        if baud == 0 {
            return Err(BaudError::Zero);
        }
        let brr = (pclk_hz as u64 + baud as u64 / 2) / baud as u64;
        if brr < 16 {
            return Err(BaudError::TooFast(baud));
        }
        if brr > u16::MAX as u64 {
            return Err(BaudError::TooSlow(baud));
        }
        let actual_baud = (pclk_hz as u64 / brr) as u32;
        // (f / brr − baud) / baud in ppm, from exact integers.
        let error_ppm =
            ((pclk_hz as i64 * 1_000_000) / (brr as i64 * baud as i64) - 1_000_000) as i32;
        if error_ppm.unsigned_abs() > MAX_ERROR_PPM {
            return Err(BaudError::Inexact(baud, error_ppm));
        }
        Ok(BaudSetting {
            brr: brr as u16,
            actual_baud,
            error_ppm,
        })
    }

    /// DIV_Mantissa (USART_BRR bits 15:4).
    pub const fn mantissa(&self) -> u16 {
        self.brr >> 4
    }

    /// DIV_Fraction (USART_BRR bits 3:0), sixteenths.
    pub const fn fraction(&self) -> u8 {
        (self.brr & 0xF) as u8
    }
}

/// Time one 8N1 character takes on the line at `baud` (bit/s), ns: 10 bit times. The
/// receiver has this long to read its data register before the next character
/// overruns it (the STM32F4 USART has no FIFO).
pub const fn character_time_ns(baud: u32) -> u32 {
    if baud == 0 {
        return u32::MAX;
    }
    (10_000_000_000u64 / baud as u64) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// APB1 of the STM32F411 at 100 MHz SYSCLK (USART2's clock).
    const PCLK1: u32 = 50_000_000;

    #[test]
    fn the_link_rates_on_the_f411s_apb1() {
        // 50 MHz / 230 400 = 217.01: mantissa 13, fraction 9 (13.5625).
        let s = BaudSetting::for_baud(PCLK1, 230_400).unwrap();
        assert_eq!((s.brr, s.mantissa(), s.fraction()), (217, 13, 9));
        assert_eq!(s.actual_baud, 230_414);
        assert_eq!(s.error_ppm, 64);
        // 115 200: 434.03 → 434 (27.125).
        let s = BaudSetting::for_baud(PCLK1, 115_200).unwrap();
        assert_eq!((s.mantissa(), s.fraction()), (27, 2));
        assert_eq!(s.error_ppm, 64);
        // 921 600: 54.25 → 54, 0.47 % fast: still within the limit.
        let s = BaudSetting::for_baud(PCLK1, 921_600).unwrap();
        assert_eq!((s.brr, s.actual_baud, s.error_ppm), (54, 925_925, 4_693));
        // 460 800: 108.5 → 109 (rounds half up), 0.45 % slow.
        let s = BaudSetting::for_baud(PCLK1, 460_800).unwrap();
        assert_eq!((s.brr, s.error_ppm), (109, -4_524));
    }

    #[test]
    fn the_hsi_without_the_pll() {
        // 16 MHz / 115 200 = 138.9 → 139: 8.6875, the value RM0383's table lists.
        let s = BaudSetting::for_baud(16_000_000, 115_200).unwrap();
        assert_eq!((s.mantissa(), s.fraction()), (8, 11));
    }

    #[test]
    fn rates_the_usart_cannot_make_are_refused() {
        assert_eq!(BaudSetting::for_baud(PCLK1, 0), Err(BaudError::Zero));
        // Above f/16 (BRR 14).
        assert_eq!(
            BaudSetting::for_baud(PCLK1, 3_500_000),
            Err(BaudError::TooFast(3_500_000))
        );
        // Exactly f/16 is the fastest.
        assert_eq!(
            BaudSetting::for_baud(PCLK1, 3_125_000).map(|s| s.brr),
            Ok(16)
        );
        // 2.9 Mbit/s rounds to BRR 17 (2.94 Mbit/s): 1.4 % off.
        assert_eq!(
            BaudSetting::for_baud(PCLK1, 2_900_000),
            Err(BaudError::Inexact(2_900_000, 14_198))
        );
        // 300 baud from 50 MHz needs BRR 166 667.
        assert_eq!(
            BaudSetting::for_baud(PCLK1, 300),
            Err(BaudError::TooSlow(300))
        );
        assert_eq!(
            BaudError::Inexact(2_900_000, 14_198).to_string(),
            "baud rate 2900000 is only reached within 14198 ppm"
        );
    }

    #[test]
    fn a_character_takes_ten_bit_times() {
        assert_eq!(character_time_ns(230_400), 43_402);
        assert_eq!(character_time_ns(921_600), 10_850);
        assert_eq!(character_time_ns(0), u32::MAX);
    }
}
