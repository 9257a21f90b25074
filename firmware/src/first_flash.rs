//! What the first-flash programs (`examples/`: `hello`, `encoders`, `motors`, `supply`;
//! `docs/first-flash.md`) share on top of the board layer: on the F411, a 1 kHz loop on
//! the firmware's own control tick ([`Bench`]), and on both boards, their panic handling
//! ([`stop_after_panic`]).
//!
//! The programs bring the board up with the firmware's own [`board::init`]: the same
//! watchdog, brown-out level, clock set-up, pin map, PWM with the driver in standby,
//! encoders, supply ADC and link USART as the application, so what they show is what the
//! firmware will see.

use core::panic::PanicInfo;

use crate::board;
use crate::robot::ROBOT;

/// Encoder counts per wheel turn of [`ROBOT`] (lines × 4 edges × gear ratio: 1440 for
/// the reference robot), as the core counts them (`Params::ticks_per_wheel_rev`).
pub const TICKS_PER_WHEEL_TURN: f32 =
    ROBOT.encoder_lines_per_motor_rev as f32 * 4.0 * ROBOT.gear_ratio;

#[cfg(not(feature = "qemu"))]
pub use self::f411::Bench;

/// A program's panic: the motors off first ([`board::force_motors_off`]), then the
/// location over defmt, then [`board::halt_after_failure`] (on the F411 the watchdog,
/// still running, resets the chip; under QEMU the emulation ends with a failure).
pub fn stop_after_panic(info: &PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    // SAFETY: interrupts are off and nothing but this function runs from here on.
    unsafe { board::force_motors_off() };
    match info.location() {
        Some(at) => defmt::error!("panic at {=str}:{=u32}; motors off", at.file(), at.line()),
        None => defmt::error!("panic; motors off"),
    }
    board::halt_after_failure()
}

#[cfg(not(feature = "qemu"))]
mod f411 {
    use robot_app::Sensors;

    use crate::board::{Board, ControlIo, Watchdog};

    /// A program's 1 kHz loop on the F411: the control tick (TIM5) polled, not taken as
    /// an interrupt, and the watchdog (still at `board::WATCHDOG_INIT`, 170–471 ms) fed
    /// at every step, so a program that stops stepping resets the chip with its motors
    /// coasting.
    pub struct Bench {
        /// The board's sensors and actuators.
        pub io: ControlIo,
        watchdog: Watchdog,
        steps: u32,
    }

    impl Bench {
        /// Starts the tick of `board`: the first step comes one control period later.
        pub fn start(board: Board) -> Self {
            let mut io = board.io;
            io.start();
            Self {
                io,
                watchdog: board.watchdog,
                steps: 0,
            }
        }

        /// Waits for the next control period, feeds the watchdog and reads the sensors
        /// (encoder counts since the previous step, forward positive; the supply of the
        /// conversion the previous [`ControlIo::apply_outputs`] started, NaN before the
        /// first; the button).
        pub fn next_step(&mut self) -> Sensors {
            loop {
                if let Some(sensors) = self.io.sense(self.steps) {
                    self.watchdog.feed();
                    self.steps = self.steps.wrapping_add(sensors.periods.get());
                    return sensors;
                }
            }
        }

        /// Control periods since [`Bench::start`] (1 ms each at the robot's 1 kHz),
        /// counting the periods a late step missed; wraps after 49 days.
        pub fn periods(&self) -> u32 {
            self.steps
        }
    }
}
