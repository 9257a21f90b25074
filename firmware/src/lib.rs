//! What the firmware (`src/main.rs`) and its first-flash programs (`examples/`) share:
//! the board layer, the robot's definition and the tasks' timing.
//!
//! | module | what it is |
//! |---|---|
//! | [`board`] | everything that differs between the STM32F411 robot and QEMU's `netduinoplus2`: the one pin map, the one clock set-up, timers, ADC, watchdog, storage |
//! | [`robot`] | the robot's parameters, built-in paths and safety settings |
//! | [`stats`] | each task's own time and the stack's high-water mark |
//! | [`first_flash`] | what the first-flash programs add on top of the board: their 1 kHz loop and their panic handling |
//!
//! Built only for `thumbv7em-none-eabihf` (see `README.md`); never a host crate.

#![no_std]

pub mod board;
pub mod first_flash;
pub mod robot;
pub mod stats;

#[cfg(all(feature = "qemu", any(feature = "nucleo", feature = "drv8833")))]
compile_error!("the `qemu` board has no button, LED or motor driver: drop `nucleo` / `drv8833`");
