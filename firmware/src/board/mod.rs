//! The board layer: everything that differs between the real robot and the emulated
//! one, behind the same names, chosen by the cargo feature `qemu`.
//!
//! | board | feature | what it is |
//! |---|---|---|
//! | [`f411`](self) | (default) | the STM32F411 robot: clocks, pins, encoder timers, PWM, ADC, IWDG, flash storage, link on USART2 |
//! | `qemu` | `qemu` | QEMU's `netduinoplus2`: the wheels are `host-sim`'s plant behind USART1 in lockstep, link on USART2 |
//!
//! Each board provides, under the same names:
//!
//! - `Board` and `init(device, core)`: what the application needs, configured, and what
//!   the board found (`reset`, `clock`, `brown_out_reset`), which `Info` reports;
//! - `ControlIo`: the control task's `sense` (sensors, or `None` when the entry is not a
//!   step), `actuate` (the step's outputs) and `end_step` (overrun check), plus `start`
//!   (the tick: a timer on the F411, the plant's first message on QEMU);
//! - `Watchdog` (`feed`, `set_timeout`), `WATCHDOG_RUN`, `WATCHDOG_PERSIST`;
//! - `Storage` (`page`, `erase_and_program`) and `FlashError`;
//! - `work_counter`, `work_since`, `work_units`, `WORK_UNIT`: the clock the tasks are
//!   timed with (cycles on the F411, instructions under QEMU), and a wrap-aware
//!   difference of its readings;
//! - `LINK_BAUD`, `NAME`, `announce_ready`, `force_motors_off`, `halt_after_failure`.
//!
//! The RTIC application (`crate::app`) is the same code for both: its control task is
//! bound to TIM5 on both, triggered by the timer on the F411 and pended by the plant
//! port on QEMU.

#[cfg(not(feature = "qemu"))]
mod f411;
#[cfg(not(feature = "qemu"))]
pub use self::f411::*;

#[cfg(feature = "qemu")]
mod qemu;
#[cfg(feature = "qemu")]
pub use self::qemu::*;
