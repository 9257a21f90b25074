//! First-flash program 2: both encoders, turned by hand.
//!
//! Brings the board up with the firmware's own set-up (motor driver in standby: the
//! wheels turn freely) and, five times a second, logs each wheel's count since the start
//! (forward positive, after the wiring polarity of `board::polarity`), how many wheel
//! turns that is (`robot::ROBOT`: counts per wheel turn), and its speed over the last
//! 200 ms, rad/s. Lines are logged only while a wheel moves, and once a second otherwise.
//!
//! What to check: turning the left wheel forward (the way it turns when the robot drives
//! ahead) makes the left count rise, and only the left; one full turn adds the configured
//! counts per turn (1440 for the reference robot). A count that falls, the other wheel's
//! count moving, or a turn worth another figure is a wiring or configuration error that
//! `docs/first-flash.md` explains how to fix.

#![no_std]
#![no_main]

use controller_core::controller::MotorCommand;
use defmt_rtt as _;
use firmware_board::robot::ROBOT;
use firmware_board::{board, first_flash};
use robot_app::first_flash::wheel_speed_rad_s;
use stm32f4xx_hal::pac;

#[cfg(feature = "qemu")]
compile_error!("`encoders` needs the F411 board's encoder timers: build it without `qemu`");

/// Control periods per report (200 ms at 1 kHz).
const REPORT_PERIODS: u32 = ROBOT.control_rate_hz / 5;
/// Reports between two lines while both wheels stand still (one a second).
const QUIET_REPORTS: u32 = 5;

#[cortex_m_rt::entry]
fn main() -> ! {
    let (Some(device), Some(core)) = (pac::Peripherals::take(), cortex_m::Peripherals::take())
    else {
        defmt::panic!("the peripherals were taken twice");
    };
    let mut bench = first_flash::Bench::start(board::init(device, core));
    let ticks_per_turn = first_flash::TICKS_PER_WHEEL_TURN;
    defmt::info!(
        "encoders: turn each wheel forward by hand; its count must rise by {=f32} per turn",
        ticks_per_turn
    );

    let (mut left, mut right) = (0i32, 0i32);
    let (mut window_left, mut window_right) = (0i32, 0i32);
    let mut window_periods = 0u32;
    let mut quiet = 0u32;
    loop {
        let sensors = bench.next_step();
        bench.io.apply_outputs(MotorCommand::STOP, false, false);
        window_left = window_left.wrapping_add(sensors.ticks.left);
        window_right = window_right.wrapping_add(sensors.ticks.right);
        window_periods += sensors.periods.get();
        if window_periods < REPORT_PERIODS {
            continue;
        }
        left = left.wrapping_add(window_left);
        right = right.wrapping_add(window_right);
        let moving = window_left != 0 || window_right != 0;
        quiet = if moving { 0 } else { quiet + 1 };
        if moving || quiet >= QUIET_REPORTS {
            quiet = 0;
            let window_s = window_periods as f32 / ROBOT.control_rate_hz as f32;
            defmt::info!(
                "left {=i32} counts ({=f32} turns, {=f32} rad/s) | right {=i32} counts ({=f32} turns, {=f32} rad/s)",
                left,
                left as f32 / ticks_per_turn,
                wheel_speed_rad_s(window_left, ticks_per_turn, window_s),
                right,
                right as f32 / ticks_per_turn,
                wheel_speed_rad_s(window_right, ticks_per_turn, window_s),
            );
        }
        window_left = 0;
        window_right = 0;
        window_periods = 0;
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    first_flash::stop_after_panic(info)
}
