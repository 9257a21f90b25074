//! First-flash program 1: the board comes up, and says how.
//!
//! Brings the board up with the firmware's own set-up (`board::init`: watchdog,
//! brown-out level, the clock from the board's oscillator, the pin map with the motor
//! driver in standby), then logs over defmt, once:
//!
//! - the chip, and the reset cause read from RCC_CSR (`power-on` after plugging in,
//!   `pin` after the reset button or the probe, `watchdog` after a stall);
//! - SYSCLK read back from RCC_CFGR and RCC_PLLCFGR (100 MHz from the PLL, fed by the
//!   HSE: the Black Pill's 25 MHz crystal or the Nucleo's 8 MHz ST-LINK clock) and what
//!   the clock set-up reports; `PLL from the HSI` means the HSE did not start; a warning
//!   when the registers disagree with what the set-up meant to write;
//! - the brown-out reset level.
//!
//! Then the LED blinks at 1 Hz; while the button is held it stays lit, and each press and
//! release is logged with how long the button was held. Nothing else is driven.
//!
//! Under QEMU (feature `qemu`: the emulated board, which models neither RCC nor GPIO) it
//! prints one line over semihosting instead, `hello under QEMU: …` with the reset cause
//! and the clock that board reports, and exits with status 0 (`cargo xtask first-flash`).

#![no_std]
#![no_main]

use defmt_rtt as _;
use firmware_board::{board, first_flash};
use stm32f4xx_hal::pac;

#[cortex_m_rt::entry]
fn main() -> ! {
    let (Some(device), Some(core)) = (pac::Peripherals::take(), cortex_m::Peripherals::take())
    else {
        defmt::panic!("the peripherals were taken twice");
    };
    let board = board::init(device, core);
    run(board)
}

/// The F411: the report over defmt, then the LED and the button.
#[cfg(not(feature = "qemu"))]
fn run(board: board::Board) -> ! {
    use robot_app::stm32f4::clock_read_back::{SysclkReadBack, SysclkSource};

    /// Half the LED's blink period, control periods (500 ms at 1 kHz).
    const BLINK_HALF_PERIOD: u32 = firmware_board::robot::ROBOT.control_rate_hz / 2;

    let sysclk: SysclkReadBack = board::clock_read_back();
    defmt::info!(
        "hello from the {=str}: reset cause {}, SYSCLK {=u32} Hz from the {=str} (read back from RCC), clock source {}, brown-out reset {}",
        board::NAME,
        board.reset,
        sysclk.hz,
        sysclk.source.name(),
        defmt::Display2Format(&board.clock),
        defmt::Display2Format(&board.brown_out_reset),
    );
    let from_hse = matches!(sysclk.source, SysclkSource::Pll { from_hse: true });
    if sysclk.hz != board::SYSCLK_HZ || from_hse == board.clock.is_fallback() {
        defmt::warn!(
            "the clock set-up meant {=u32} Hz from the PLL fed by the {=str}, but RCC reads {=u32} Hz from the {=str}",
            board::SYSCLK_HZ,
            if board.clock.is_fallback() { "HSI" } else { "HSE" },
            sysclk.hz,
            sysclk.source.name(),
        );
    }
    defmt::info!("the LED blinks at 1 Hz; hold the button to keep it lit");

    let mut bench = first_flash::Bench::start(board);
    let mut pressed_at: Option<u32> = None;
    let mut presses: u32 = 0;
    loop {
        let sensors = bench.next_step();
        let now = bench.periods();
        match (sensors.button_pressed, pressed_at) {
            (true, None) => {
                presses = presses.wrapping_add(1);
                pressed_at = Some(now);
                defmt::info!("button pressed ({=u32})", presses);
            }
            (false, Some(at)) => {
                pressed_at = None;
                defmt::info!(
                    "button released after {=u32} ms",
                    now.wrapping_sub(at).saturating_mul(1000)
                        / firmware_board::robot::ROBOT.control_rate_hz
                );
            }
            _ => {}
        }
        let blink_on = (now / BLINK_HALF_PERIOD) % 2 == 0;
        bench.io.apply_outputs(
            controller_core::controller::MotorCommand::STOP,
            false,
            blink_on || pressed_at.is_some(),
        );
    }
}

/// The emulated board: the report over semihosting, then exit.
#[cfg(feature = "qemu")]
fn run(board: board::Board) -> ! {
    use cortex_m_semihosting::{debug, hprintln};

    hprintln!(
        "hello under QEMU: reset cause {:?}, clock {}, chip {}",
        board.reset,
        board.clock,
        board::NAME
    );
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    first_flash::stop_after_panic(info)
}
