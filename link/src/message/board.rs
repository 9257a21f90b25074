//! What the board is and found when it started: its motor bridge, the clock it runs from,
//! its brown-out reset level (all in [`RobotInfo`](crate::RobotInfo)), and the record of the failure that
//! ended the previous run ([`Request::GetPanicRecord`](crate::Request::GetPanicRecord)).

use core::fmt;

use heapless::String;
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Capacity of [`PanicReport::file`], bytes of UTF-8 (the end of the source path).
pub const PANIC_FILE_CAP: usize = 52;
/// Capacity of [`PanicReport::message`], bytes of UTF-8 (the start of the message).
pub const PANIC_MESSAGE_CAP: usize = 56;

/// What the robot's system clock is derived from. Every speed, timeout and the baud rate
/// carry this oscillator's error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum ClockSource {
    /// No oscillator of its own: the virtual robot, or an emulated chip (time is the
    /// simulation's).
    Simulated,
    /// An external crystal (the STM32's HSE), of `hz`.
    Crystal {
        /// The crystal's frequency, Hz.
        hz: u32,
    },
    /// An external clock fed to the oscillator input (HSE bypass), of `hz`.
    ExternalClock {
        /// The clock's frequency, Hz.
        hz: u32,
    },
    /// The internal RC oscillator (the STM32's HSI: ±1 % at 25 °C, a few percent over
    /// temperature), because the external crystal or clock of `expected_hz` did not start
    /// within its timeout at boot. The robot still runs, less accurately.
    InternalFallback {
        /// The frequency of the crystal or clock that did not start, Hz.
        expected_hz: u32,
    },
}

impl ClockSource {
    /// True when the external oscillator the board is built for did not start.
    pub const fn is_fallback(&self) -> bool {
        matches!(self, ClockSource::InternalFallback { .. })
    }
}

impl fmt::Display for ClockSource {
    /// `25 MHz crystal`, `8 MHz external clock`, `simulated`, or the fallback with why.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ClockSource::Simulated => f.write_str("simulated"),
            ClockSource::Crystal { hz } => write!(f, "{} crystal", Megahertz(hz)),
            ClockSource::ExternalClock { hz } => write!(f, "{} external clock", Megahertz(hz)),
            ClockSource::InternalFallback { expected_hz } => write!(
                f,
                "internal RC oscillator: the {} external oscillator did not start, so every \
                 speed, timeout and the baud rate are off by up to a few percent",
                Megahertz(expected_hz)
            ),
        }
    }
}

/// A frequency in Hz printed in MHz, without a fraction when it is whole.
struct Megahertz(u32);

impl fmt::Display for Megahertz {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (whole, rest) = (self.0 / 1_000_000, self.0 % 1_000_000);
        if rest == 0 {
            write!(f, "{whole} MHz")
        } else {
            write!(f, "{whole}.{:06} MHz", rest)
        }
    }
}

/// A Li-ion (or LiPo) cell's voltage at full charge, V: an `N`S pack reads N × this
/// straight off the charger.
pub const LI_ION_CELL_FULL_V: f32 = 4.2;

/// The motor bridge on the robot's board. Its motor supply VM is the battery itself,
/// whether or not the robot is armed: the firmware's refusal to arm above
/// [`BridgeChip::max_supply_v`] keeps the motors still, not the bridge safe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum BridgeChip {
    /// Toshiba TB6612FNG: VM 2.5–13.5 V operating, 15 V absolute maximum.
    Tb6612fng,
    /// TI DRV8833: VM 2.7–10.8 V operating, 11.8 V absolute maximum (SLVSAR1,
    /// "Recommended Operating Conditions" and "Absolute Maximum Ratings").
    Drv8833,
}

impl BridgeChip {
    /// Every bridge the firmware drives.
    pub const ALL: [BridgeChip; 2] = [BridgeChip::Tb6612fng, BridgeChip::Drv8833];

    /// The highest motor supply the chip is rated to operate at, V: the highest a robot's
    /// `drive.max_supply_v` may be, above which the supervisor faults.
    pub const fn max_supply_v(self) -> f32 {
        match self {
            BridgeChip::Tb6612fng => 13.5,
            BridgeChip::Drv8833 => 10.8,
        }
    }

    /// The chip's absolute maximum motor supply, V: above it the bridge may be damaged,
    /// driving or not.
    pub const fn absolute_max_v(self) -> f32 {
        match self {
            BridgeChip::Tb6612fng => 15.0,
            BridgeChip::Drv8833 => 11.8,
        }
    }

    /// The most Li-ion cells in series whose full charge is within
    /// [`BridgeChip::max_supply_v`]: 3 (12.6 V) on the TB6612FNG, 2 (8.4 V) on the DRV8833.
    pub const fn max_li_ion_cells(self) -> u8 {
        (self.max_supply_v() / LI_ION_CELL_FULL_V) as u8
    }

    /// The part's name: `TB6612FNG` or `DRV8833`.
    pub const fn name(self) -> &'static str {
        match self {
            BridgeChip::Tb6612fng => "TB6612FNG",
            BridgeChip::Drv8833 => "DRV8833",
        }
    }
}

impl fmt::Display for BridgeChip {
    /// The batteries the bridge takes, e.g. `DRV8833: 2S Li-ion (8.4 V full) at most`
    /// (the sentence the docs use, checked against this).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let cells = self.max_li_ion_cells();
        let full_dv = u32::from(cells) * 42;
        write!(
            f,
            "{}: {cells}S Li-ion ({}.{} V full) at most",
            self.name(),
            full_dv / 10,
            full_dv % 10
        )
    }
}

/// The supply level below which the chip holds itself in reset (the STM32F4's brown-out
/// reset, set in its option bytes). The thresholds are the chip's; the robot's own names
/// them (`robot_app::stm32f4::option_bytes`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum BrownOutReset {
    /// Not a chip: an emulated board, which has no supply.
    NotApplicable,
    /// Off (the factory setting): only the power-on/power-down reset, near 1.7 V, stops the
    /// chip, far below the 2.7 V its flash needs at full speed.
    Off,
    /// Level 1: the chip runs down to about 2.1 V.
    Level1,
    /// Level 2: the chip runs down to about 2.4 V.
    Level2,
    /// Level 3: the chip runs down to about 2.7 V, which its flash wait states at full
    /// speed and its ×32 programming need. A robot persists parameters only at this level.
    Level3,
}

impl BrownOutReset {
    /// True at level 3: the chip cannot run with its supply below the 2.7 V that flash
    /// writes need.
    pub const fn guards_flash_writes(self) -> bool {
        matches!(self, BrownOutReset::Level3)
    }
}

impl fmt::Display for BrownOutReset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            BrownOutReset::NotApplicable => "not applicable (no supply)",
            BrownOutReset::Off => "off",
            BrownOutReset::Level1 => "level 1",
            BrownOutReset::Level2 => "level 2",
            BrownOutReset::Level3 => "level 3",
        })
    }
}

/// What ended a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum FailureKind {
    /// A Rust panic: the file, line and start of the message are known.
    Panic,
    /// A hard fault: the faulting program counter is known.
    HardFault,
}

/// The record of the failure that ended a previous run, as the robot kept it in RAM that
/// survives a reset: answer to
/// [`Request::GetPanicRecord`](crate::Request::GetPanicRecord).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub struct PanicReport {
    /// Panic or hard fault.
    pub kind: FailureKind,
    /// The end of the source path (empty for a hard fault).
    pub file: String<PANIC_FILE_CAP>,
    /// The source line (0 for a hard fault).
    pub line: u32,
    /// The faulting program counter (0 for a panic).
    pub pc: u32,
    /// The start of the panic's message (may be empty).
    pub message: String<PANIC_MESSAGE_CAP>,
}

impl fmt::Display for PanicReport {
    /// `panic at src/motor.rs:12: index out of bounds` or `hard fault at pc 0x08001234`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.kind {
            FailureKind::Panic => {
                write!(f, "panic at {}:{}", self.file, self.line)?;
                if !self.message.is_empty() {
                    write!(f, ": {}", self.message)?;
                }
                Ok(())
            }
            FailureKind::HardFault => write!(f, "hard fault at pc 0x{:08x}", self.pc),
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;

    #[test]
    fn the_clock_reads_in_mhz_and_a_fallback_says_what_it_costs() {
        assert_eq!(
            ClockSource::Crystal { hz: 25_000_000 }.to_string(),
            "25 MHz crystal"
        );
        assert_eq!(
            ClockSource::ExternalClock { hz: 8_000_000 }.to_string(),
            "8 MHz external clock"
        );
        assert_eq!(
            ClockSource::Crystal { hz: 12_288_000 }.to_string(),
            "12.288000 MHz crystal"
        );
        let fallback = ClockSource::InternalFallback {
            expected_hz: 25_000_000,
        };
        assert!(fallback.is_fallback());
        assert!(!ClockSource::Simulated.is_fallback());
        assert!(fallback
            .to_string()
            .starts_with("internal RC oscillator: the 25 MHz external oscillator did not start"));
    }

    #[test]
    fn each_bridge_takes_the_packs_whose_full_charge_is_within_its_operating_rating() {
        assert_eq!(
            BridgeChip::Tb6612fng.to_string(),
            "TB6612FNG: 3S Li-ion (12.6 V full) at most"
        );
        assert_eq!(
            BridgeChip::Drv8833.to_string(),
            "DRV8833: 2S Li-ion (8.4 V full) at most"
        );
        for bridge in BridgeChip::ALL {
            let cells = f32::from(bridge.max_li_ion_cells());
            let full_v = cells * LI_ION_CELL_FULL_V;
            assert!(full_v <= bridge.max_supply_v(), "{bridge}");
            assert!(
                full_v + LI_ION_CELL_FULL_V > bridge.max_supply_v(),
                "{bridge}"
            );
            assert!(bridge.max_supply_v() < bridge.absolute_max_v(), "{bridge}");
        }
        // One more cell on the DRV8833 (a full 3S pack) is above even its absolute maximum.
        assert!(3.0 * LI_ION_CELL_FULL_V > BridgeChip::Drv8833.absolute_max_v());
    }

    #[test]
    fn only_level_3_guards_flash_writes() {
        for level in [
            BrownOutReset::NotApplicable,
            BrownOutReset::Off,
            BrownOutReset::Level1,
            BrownOutReset::Level2,
        ] {
            assert!(!level.guards_flash_writes(), "{level}");
        }
        assert!(BrownOutReset::Level3.guards_flash_writes());
    }

    #[test]
    fn a_failure_reads_as_where_it_happened() {
        let panic = PanicReport {
            kind: FailureKind::Panic,
            file: crate::bounded("src/motor.rs"),
            line: 12,
            pc: 0,
            message: crate::bounded("index out of bounds"),
        };
        assert_eq!(
            panic.to_string(),
            "panic at src/motor.rs:12: index out of bounds"
        );
        let fault = PanicReport {
            kind: FailureKind::HardFault,
            file: String::new(),
            line: 0,
            pc: 0x0800_1234,
            message: String::new(),
        };
        assert_eq!(fault.to_string(), "hard fault at pc 0x08001234");
    }
}
