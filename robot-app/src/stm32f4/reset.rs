//! Why the chip reset: the reset flags of RCC_CSR and the [`ResetCause`] they mean.
//!
//! RM0383 §6.3.21 (RCC_CSR): BORRSTF is set "when a POR/PDR or BOR reset occurs", so after
//! a power-on both PORRSTF and BORRSTF are set, and a brown-out alone is BORRSTF without
//! PORRSTF. Every internal reset also drives NRST low, so PINRSTF accompanies every other
//! flag; a pin reset alone is PINRSTF with nothing else.

use controller_core::supervisor::ResetCause;

/// The raw reset flags of an STM32F4's RCC_CSR, one `bool` per flag.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ResetFlags {
    /// LPWRRSTF: low-power reset.
    pub low_power: bool,
    /// WWDGRSTF: window watchdog reset.
    pub window_watchdog: bool,
    /// IWDGRSTF: independent watchdog reset.
    pub independent_watchdog: bool,
    /// SFTRSTF: software reset.
    pub software: bool,
    /// PORRSTF: power-on / power-down reset.
    pub power_on: bool,
    /// PINRSTF: NRST pin reset (also set by every other reset source, which drives NRST).
    pub pin: bool,
    /// BORRSTF: brown-out reset (also set by a power-on reset, together with PORRSTF).
    pub brown_out: bool,
}

impl ResetFlags {
    /// The cause that explains these flags (module doc): the pin is the cause only when
    /// nothing else is set, and BOR is a brown-out only without POR.
    pub const fn cause(self) -> ResetCause {
        if self.independent_watchdog || self.window_watchdog {
            ResetCause::Watchdog
        } else if self.software {
            ResetCause::Software
        } else if self.low_power {
            ResetCause::LowPower
        } else if self.power_on {
            ResetCause::PowerOn
        } else if self.brown_out {
            ResetCause::BrownOut
        } else if self.pin {
            ResetCause::Pin
        } else {
            ResetCause::Unknown
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_combination_of_flags_names_its_cause() {
        let f = |set: fn(&mut ResetFlags)| {
            let mut flags = ResetFlags {
                pin: true,
                ..ResetFlags::default()
            };
            set(&mut flags);
            flags.cause()
        };
        assert_eq!(f(|_| {}), ResetCause::Pin);
        assert_eq!(f(|x| x.power_on = true), ResetCause::PowerOn);
        assert_eq!(
            f(|x| {
                x.power_on = true;
                x.brown_out = true;
            }),
            ResetCause::PowerOn
        );
        // BOR alone: the supply dipped while running.
        assert_eq!(f(|x| x.brown_out = true), ResetCause::BrownOut);
        assert_eq!(
            f(|x| {
                x.power_on = true;
                x.independent_watchdog = true;
            }),
            ResetCause::Watchdog
        );
        assert_eq!(f(|x| x.window_watchdog = true), ResetCause::Watchdog);
        assert_eq!(f(|x| x.software = true), ResetCause::Software);
        assert_eq!(f(|x| x.low_power = true), ResetCause::LowPower);
        assert_eq!(ResetFlags::default().cause(), ResetCause::Unknown);
    }
}
