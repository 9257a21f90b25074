//! # robot-app
//!
//! The robot's application logic with no board in it. The firmware (`firmware`, on the
//! STM32F411 and on the emulated `netduinoplus2` board) and the simulator's virtual robot
//! (`host-sim serve`) run exactly this code; what differs between them is only where the
//! numbers come from (timers, ADC, USART) and where they go (PWM, pins).
//!
//! - [`hw`] — register arithmetic of the STM32F4 boards (clock tree, watchdog, encoder
//!   input filter, motor bridge, supply ADC, tick), as pure functions with host tests, so
//!   that the values the firmware writes are checked without hardware.
//! - [`metrics`] — run metrics (settle time, final and windowed errors) accumulated at the
//!   control rate in fixed memory, the same on the robot and in the simulator.
//! - [`panic_record`] — the record of the last panic or hard fault that the firmware keeps
//!   in RAM across a reset: layout, bounded text, CRC.

#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod hw;
pub mod metrics;
pub mod panic_record;
