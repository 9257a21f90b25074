//! What the board found when it started: the clock it runs from, its brown-out reset
//! level (both in [`RobotInfo`](crate::RobotInfo)), and the record of the failure that
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
