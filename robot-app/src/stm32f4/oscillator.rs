//! The external high-speed oscillator (HSE): which one a board has, how long it may take
//! to start, and what the robot reports when it runs without it.
//!
//! The HSI (16 MHz RC) is trimmed to ±1 % at 25 °C and drifts by a few percent over
//! temperature (DS10314, HSI oscillator characteristics); every control period, timeout
//! and the link's baud rate inherit that error. A crystal is good to tens of ppm. The
//! boards have one:
//!
//! | board | HSE | RCC_CR |
//! |---|---|---|
//! | WeAct Black Pill | 25 MHz crystal on OSC_IN/OSC_OUT | HSEON |
//! | Nucleo-64 | 8 MHz from the ST-LINK's MCO into OSC_IN (UM1724: SB50 on, the default; check the board in hand) | HSEBYP, then HSEON |
//!
//! stm32f4xx-hal 0.23 waits for HSERDY without a timeout, so the firmware starts the HSE
//! itself first and waits at most [`HSE_STARTUP_TIMEOUT_US`]; only an oscillator that
//! started is handed to the HAL, and one that did not leaves the clock on the HSI with a
//! warning ([`ClockSource::InternalFallback`]). The datasheet gives the crystal's startup
//! time t_SU(HSE) as 2 ms typical with V_DD stable ([`HSE_STARTUP_TYPICAL_US`], measured
//! with a standard 8 MHz crystal; it varies with the crystal and its load capacitors) and
//! no maximum. An external clock is ready a few of its cycles after HSEON.

use link::ClockSource;

/// An external oscillator on OSC_IN.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hse {
    /// A crystal or resonator between OSC_IN and OSC_OUT (RCC_CR.HSEBYP = 0), Hz.
    Crystal(u32),
    /// A clock signal on OSC_IN, OSC_OUT free (RCC_CR.HSEBYP = 1), Hz.
    ExternalClock(u32),
}

/// The crystal frequencies the HSE oscillator accepts, Hz (DS10314, 4–26 MHz).
pub const CRYSTAL_RANGE_HZ: (u32, u32) = (4_000_000, 26_000_000);
/// The frequencies of an external clock on OSC_IN in bypass, Hz (DS10314, 1–50 MHz).
pub const EXTERNAL_CLOCK_RANGE_HZ: (u32, u32) = (1_000_000, 50_000_000);

/// The datasheet's typical HSE crystal startup time, µs (t_SU(HSE), 2 ms).
pub const HSE_STARTUP_TYPICAL_US: u32 = 2_000;
/// How long the firmware waits for HSERDY before it falls back to the HSI, µs: ten times
/// the typical startup, and well inside the 170 ms that the watchdog running during the
/// start (`WATCHDOG_INIT`) lasts at the fastest LSI.
pub const HSE_STARTUP_TIMEOUT_US: u32 = 10 * HSE_STARTUP_TYPICAL_US;

impl Hse {
    /// Its frequency, Hz.
    pub const fn hz(self) -> u32 {
        match self {
            Hse::Crystal(hz) | Hse::ExternalClock(hz) => hz,
        }
    }

    /// True for an external clock (RCC_CR.HSEBYP set before HSEON).
    pub const fn bypass(self) -> bool {
        matches!(self, Hse::ExternalClock(_))
    }

    /// True when its frequency is one the oscillator accepts in its mode.
    pub const fn in_range(self) -> bool {
        let (lo, hi) = match self {
            Hse::Crystal(_) => CRYSTAL_RANGE_HZ,
            Hse::ExternalClock(_) => EXTERNAL_CLOCK_RANGE_HZ,
        };
        self.hz() >= lo && self.hz() <= hi
    }

    /// What the robot reports once it knows whether this oscillator started.
    pub const fn report(self, started: bool) -> ClockSource {
        match (self, started) {
            (Hse::Crystal(hz), true) => ClockSource::Crystal { hz },
            (Hse::ExternalClock(hz), true) => ClockSource::ExternalClock { hz },
            (_, false) => ClockSource::InternalFallback {
                expected_hz: self.hz(),
            },
        }
    }
}

/// Cycles of a clock at `clock_hz` in `us` microseconds (rounded up; saturating): the
/// bound of a wait timed by the cycle counter.
pub const fn cycles_in_us(us: u32, clock_hz: u32) -> u32 {
    let cycles = (us as u64 * clock_hz as u64).div_ceil(1_000_000);
    if cycles > u32::MAX as u64 {
        u32::MAX
    } else {
        cycles as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stm32f4::chip::HSI_HZ;
    use crate::stm32f4::watchdog::IwdgConfig;

    #[test]
    fn the_boards_oscillators_are_in_range_and_report_what_started() {
        let black_pill = Hse::Crystal(25_000_000);
        let nucleo = Hse::ExternalClock(8_000_000);
        assert!(black_pill.in_range() && nucleo.in_range());
        assert!(!black_pill.bypass() && nucleo.bypass());
        assert!(!Hse::Crystal(50_000_000).in_range());
        assert!(Hse::ExternalClock(50_000_000).in_range());
        assert_eq!(
            black_pill.report(true),
            ClockSource::Crystal { hz: 25_000_000 }
        );
        assert_eq!(
            nucleo.report(true),
            ClockSource::ExternalClock { hz: 8_000_000 }
        );
        assert_eq!(
            nucleo.report(false),
            ClockSource::InternalFallback {
                expected_hz: 8_000_000
            }
        );
    }

    #[test]
    fn the_startup_wait_is_timed_in_hsi_cycles_and_ends_before_the_init_watchdog() {
        // 20 ms of the 16 MHz HSI, which the core runs on while it waits.
        assert_eq!(cycles_in_us(HSE_STARTUP_TIMEOUT_US, HSI_HZ), 320_000);
        assert_eq!(cycles_in_us(1, 1_500_000), 2, "rounded up");
        assert_eq!(cycles_in_us(u32::MAX, u32::MAX), u32::MAX, "saturates");
        // Even with the HSI 8 % slow (its worst over temperature), 20 ms of its cycles
        // last under 22 ms, far inside the init watchdog's shortest 170 ms.
        let init = IwdgConfig::for_timeout_us(250_000, 32_000).unwrap();
        let shortest_us = init.spread((17_000, 32_000, 47_000)).min_us;
        assert!(u64::from(HSE_STARTUP_TIMEOUT_US) * 100 / 92 < u64::from(shortest_us));
    }
}
