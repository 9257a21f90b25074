//! First-flash program 4: the supply measurement, to hold against a multimeter.
//!
//! Brings the board up with the firmware's own set-up (motor driver in standby) and,
//! twice a second, logs the motor supply as the firmware measures it (PA1, ADC1 channel
//! 1, through the divider `board::SUPPLY_DIVIDER`), the lowest and highest reading of the
//! last half second, and the voltage at the pin. Once at the start it logs the divider's
//! scale (supply volts per volt at the pin: (39 kΩ + 10 kΩ) / 10 kΩ = 4.9 for the
//! reference divider), the ADC reference it assumes (3.3 V) and the bridge's limit, above
//! which the firmware refuses to arm.
//!
//! A probe-only board has no way to type a figure in, so the program does not ask for
//! one. To correct the reading: measure the supply at the bridge with a multimeter, M
//! volts, while the program shows R volts; the corrected scale is scale × M / R
//! (`robot_app::first_flash::corrected_scale`). The station's bring-up (`station
//! bringup`, over the link, with the firmware) asks for the multimeter figure and writes
//! the corrected scale into the robot's parameters; this program only shows the
//! figures it needs.

#![no_std]
#![no_main]

use controller_core::controller::MotorCommand;
use defmt_rtt as _;
use firmware_board::robot::{BRIDGE, ROBOT};
use firmware_board::{board, first_flash};
use stm32f4xx_hal::pac;

#[cfg(feature = "qemu")]
compile_error!("`supply` needs the F411 board's ADC: build it without `qemu`");

/// Control periods per report (500 ms at 1 kHz).
const REPORT_PERIODS: u32 = ROBOT.control_rate_hz / 2;

#[cortex_m_rt::entry]
fn main() -> ! {
    let (Some(device), Some(core)) = (pac::Peripherals::take(), cortex_m::Peripherals::take())
    else {
        defmt::panic!("the peripherals were taken twice");
    };
    let mut bench = first_flash::Bench::start(board::init(device, core));
    let ratio = board::SUPPLY_DIVIDER.ratio();
    let scale = 1.0 / ratio;
    defmt::info!(
        "supply: divider {=f32} kΩ over {=f32} kΩ, scale {=f32} V per V at PA1 (full scale {=f32} V at the {=f32} V ADC reference); the bridge is rated to {=f32} V",
        board::SUPPLY_DIVIDER.top_ohm / 1000.0,
        board::SUPPLY_DIVIDER.bottom_ohm / 1000.0,
        scale,
        board::SUPPLY_DIVIDER.full_scale_v(board::ADC_REFERENCE_V),
        board::ADC_REFERENCE_V,
        BRIDGE.max_supply_v(),
    );
    defmt::info!(
        "measure the supply with a multimeter (M volts) while this shows R volts: the corrected scale is {=f32} x M / R (station bringup supply writes it)",
        scale
    );

    let (mut low, mut high) = (f32::INFINITY, f32::NEG_INFINITY);
    let mut latest = f32::NAN;
    let mut periods = 0u32;
    loop {
        let sensors = bench.next_step();
        // Starts the next conversion; the driver stays in standby.
        bench.io.apply_outputs(MotorCommand::STOP, false, false);
        if sensors.supply_v.is_finite() {
            latest = sensors.supply_v;
            low = low.min(latest);
            high = high.max(latest);
        }
        periods += sensors.periods.get();
        if periods < REPORT_PERIODS {
            continue;
        }
        if latest.is_finite() {
            defmt::info!(
                "supply {=f32} V (lowest {=f32}, highest {=f32} in the last 0.5 s); PA1 at {=f32} V{=str}",
                latest,
                low,
                high,
                latest * ratio,
                if latest > BRIDGE.max_supply_v() {
                    ": ABOVE the bridge's rating, the firmware will not arm"
                } else {
                    ""
                },
            );
        } else {
            defmt::warn!("supply: no conversion finished in the last 0.5 s");
        }
        (low, high) = (f32::INFINITY, f32::NEG_INFINITY);
        periods = 0;
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    first_flash::stop_after_panic(info)
}
