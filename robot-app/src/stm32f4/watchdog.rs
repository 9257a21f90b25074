//! The independent watchdog (IWDG): prescaler and reload for a timeout, and what that
//! timeout really is over the LSI's spread.
//!
//! The IWDG counts LSI periods divided by the prescaler down from the reload value; the
//! chip resets when the counter reaches 0, so a feed buys (reload + 1) prescaled LSI
//! periods (RM0383 §17.3 and Table 90: ÷4 gives 0.125 ms with reload 0 and 512 ms with
//! reload 0xFFF at 32 kHz). The LSI is an RC oscillator: 17–47 kHz over temperature and
//! supply ([`Chip::lsi_hz`](super::chip::Chip::lsi_hz)), so the real timeout spreads by
//! −32 % / +88 % around its value at the typical 32 kHz.

use core::fmt;

/// The IWDG_PR prescaler.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum IwdgPrescaler {
    /// ÷4 (PR = 0).
    Div4,
    /// ÷8 (PR = 1).
    Div8,
    /// ÷16 (PR = 2).
    Div16,
    /// ÷32 (PR = 3).
    Div32,
    /// ÷64 (PR = 4).
    Div64,
    /// ÷128 (PR = 5).
    Div128,
    /// ÷256 (PR = 6; 7 is also ÷256).
    Div256,
}

impl IwdgPrescaler {
    const ALL: [IwdgPrescaler; 7] = [
        IwdgPrescaler::Div4,
        IwdgPrescaler::Div8,
        IwdgPrescaler::Div16,
        IwdgPrescaler::Div32,
        IwdgPrescaler::Div64,
        IwdgPrescaler::Div128,
        IwdgPrescaler::Div256,
    ];

    /// The IWDG_PR.PR field value.
    pub const fn pr_bits(self) -> u8 {
        match self {
            IwdgPrescaler::Div4 => 0,
            IwdgPrescaler::Div8 => 1,
            IwdgPrescaler::Div16 => 2,
            IwdgPrescaler::Div32 => 3,
            IwdgPrescaler::Div64 => 4,
            IwdgPrescaler::Div128 => 5,
            IwdgPrescaler::Div256 => 6,
        }
    }

    /// The division of the LSI.
    pub const fn divider(self) -> u32 {
        4 << self.pr_bits()
    }
}

/// The largest IWDG_RLR value (12 bits).
pub const MAX_RELOAD: u16 = 0xFFF;

/// A timeout the IWDG cannot be set to, in µs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WatchdogError {
    /// Shorter than one LSI tick at ÷4, µs.
    TooShort(u32),
    /// Longer than 4096 ticks at ÷256, µs.
    TooLong(u32),
}

impl fmt::Display for WatchdogError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            WatchdogError::TooShort(us) => write!(f, "watchdog timeout {us} us is too short"),
            WatchdogError::TooLong(us) => write!(f, "watchdog timeout {us} us is too long"),
        }
    }
}

impl core::error::Error for WatchdogError {}

/// The watchdog's timeout over the LSI's spread, µs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimeoutSpread {
    /// At the fastest LSI (shortest timeout).
    pub min_us: u32,
    /// At the typical LSI.
    pub nominal_us: u32,
    /// At the slowest LSI (longest timeout).
    pub max_us: u32,
}

/// An IWDG setting: prescaler (IWDG_PR) and reload (IWDG_RLR).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IwdgConfig {
    /// The prescaler.
    pub prescaler: IwdgPrescaler,
    /// The reload value, 0–[`MAX_RELOAD`].
    pub reload: u16,
}

impl IwdgConfig {
    /// The setting whose timeout at `lsi_hz` is nearest to `timeout_us`, with the
    /// smallest prescaler that can reach it (the finest step: a feed can land anywhere
    /// within a prescaled tick, so the timeout is only known to one tick).
    pub const fn for_timeout_us(timeout_us: u32, lsi_hz: u32) -> Result<Self, WatchdogError> {
        let mut i = 0;
        while i < IwdgPrescaler::ALL.len() {
            let prescaler = IwdgPrescaler::ALL[i];
            let tick_ns = 1_000_000_000u64 * prescaler.divider() as u64 / lsi_hz as u64;
            // Nearest whole number of ticks.
            let ticks = (timeout_us as u64 * 1000 + tick_ns / 2) / tick_ns;
            if ticks == 0 {
                return Err(WatchdogError::TooShort(timeout_us));
            }
            if ticks <= MAX_RELOAD as u64 + 1 {
                return Ok(IwdgConfig {
                    prescaler,
                    reload: (ticks - 1) as u16,
                });
            }
            i += 1;
        }
        Err(WatchdogError::TooLong(timeout_us))
    }

    /// The shortest setting whose timeout is at least `timeout_us` even at `fastest_lsi_hz`
    /// (the top of the LSI's spread, where the timeout is shortest), with the smallest
    /// prescaler that reaches it. For a watchdog that must outlast a known worst case,
    /// such as a flash erase.
    pub const fn at_least_us(timeout_us: u32, fastest_lsi_hz: u32) -> Result<Self, WatchdogError> {
        let mut i = 0;
        while i < IwdgPrescaler::ALL.len() {
            let prescaler = IwdgPrescaler::ALL[i];
            // Whole ticks, rounded up: ⌈timeout · f_LSI / (10⁶ · divider)⌉.
            let per_tick = 1_000_000u64 * prescaler.divider() as u64;
            let ticks = (timeout_us as u64 * fastest_lsi_hz as u64).div_ceil(per_tick);
            if ticks <= MAX_RELOAD as u64 + 1 {
                return Ok(IwdgConfig {
                    prescaler,
                    reload: if ticks == 0 { 0 } else { (ticks - 1) as u16 },
                });
            }
            i += 1;
        }
        Err(WatchdogError::TooLong(timeout_us))
    }

    /// The timeout at `lsi_hz`, µs: (reload + 1) × divider / f_LSI.
    pub const fn timeout_us(&self, lsi_hz: u32) -> u32 {
        ((self.reload as u64 + 1) * self.prescaler.divider() as u64 * 1_000_000 / lsi_hz as u64)
            as u32
    }

    /// The timeout at the fastest, typical and slowest LSI `(min, typ, max)` Hz.
    pub const fn spread(&self, lsi_hz: (u32, u32, u32)) -> TimeoutSpread {
        TimeoutSpread {
            min_us: self.timeout_us(lsi_hz.2),
            nominal_us: self.timeout_us(lsi_hz.1),
            max_us: self.timeout_us(lsi_hz.0),
        }
    }

    /// One prescaled tick at `lsi_hz`, µs (rounded down): the uncertainty of the timeout
    /// after a feed.
    pub const fn tick_us(&self, lsi_hz: u32) -> u32 {
        self.prescaler.divider() * 1_000_000 / lsi_hz
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stm32f4::chip::Chip;

    const LSI: (u32, u32, u32) = (17_000, 32_000, 47_000);

    #[test]
    fn ten_ms_uses_the_finest_prescaler() {
        let c = IwdgConfig::for_timeout_us(10_000, 32_000).unwrap();
        assert_eq!(
            c,
            IwdgConfig {
                prescaler: IwdgPrescaler::Div4,
                reload: 79
            }
        );
        assert_eq!(c.timeout_us(32_000), 10_000);
        assert_eq!(c.tick_us(32_000), 125);
        // Over the LSI's 17-47 kHz: 6.8 ms to 18.8 ms.
        assert_eq!(
            c.spread(LSI),
            TimeoutSpread {
                min_us: 6_808,
                nominal_us: 10_000,
                max_us: 18_823
            }
        );
        assert_eq!(Chip::F411.lsi_hz(), LSI);
    }

    #[test]
    fn the_hal_rounding_of_50_ms() {
        // stm32f4xx-hal 0.23 turns a 50 ms request into /256 with reload 6.
        let hal = IwdgConfig {
            prescaler: IwdgPrescaler::Div256,
            reload: 6,
        };
        assert_eq!(
            hal.spread(LSI),
            TimeoutSpread {
                min_us: 38_127,
                nominal_us: 56_000,
                max_us: 105_411
            }
        );
        assert_eq!(hal.tick_us(32_000), 8_000);
    }

    #[test]
    fn at_least_holds_at_the_fastest_lsi() {
        // 2.06 s at 47 kHz: ÷32 ticks of 680.9 µs, 3026 of them (rounded up).
        let c = IwdgConfig::at_least_us(2_060_100, LSI.2).unwrap();
        assert_eq!(
            c,
            IwdgConfig {
                prescaler: IwdgPrescaler::Div32,
                reload: 3025
            }
        );
        assert!(c.timeout_us(LSI.2) >= 2_060_100);
        // One tick fewer would not be enough.
        let shorter = IwdgConfig {
            reload: c.reload - 1,
            ..c
        };
        assert!(shorter.timeout_us(LSI.2) < 2_060_100);
        assert_eq!(c.spread(LSI).nominal_us, 3_026_000);
        // A short one keeps the finest prescaler; an impossible one is refused.
        assert_eq!(
            IwdgConfig::at_least_us(1_000, LSI.2).map(|c| c.prescaler),
            Ok(IwdgPrescaler::Div4)
        );
        assert_eq!(
            IwdgConfig::at_least_us(30_000_000, LSI.2),
            Err(WatchdogError::TooLong(30_000_000))
        );
    }

    #[test]
    fn each_timeout_picks_the_smallest_fitting_prescaler() {
        for (us, prescaler, reload) in [
            (125, IwdgPrescaler::Div4, 0),
            (512_000, IwdgPrescaler::Div4, 4095),
            (512_250, IwdgPrescaler::Div8, 2048),
            (250_000, IwdgPrescaler::Div4, 1999),
            (4_000_000, IwdgPrescaler::Div32, 3999),
            (32_768_000, IwdgPrescaler::Div256, 4095),
        ] {
            let c = IwdgConfig::for_timeout_us(us, 32_000).unwrap();
            assert_eq!((c.prescaler, c.reload), (prescaler, reload), "{us} us");
            assert_eq!(c.prescaler.divider(), 4 << c.prescaler.pr_bits());
        }
        assert_eq!(
            IwdgConfig::for_timeout_us(50, 32_000),
            Err(WatchdogError::TooShort(50))
        );
        assert_eq!(
            IwdgConfig::for_timeout_us(33_000_000, 32_000),
            Err(WatchdogError::TooLong(33_000_000))
        );
    }
}
