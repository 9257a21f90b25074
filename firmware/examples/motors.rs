//! First-flash program 3: each motor in turn, a short low-voltage pulse each way, with
//! the encoders' answer. **Lift the wheels off the ground first.**
//!
//! Brings the board up with the firmware's own set-up (pin map, 20 kHz PWM, the bridge
//! sequence of `board::ControlIo`, encoders, supply ADC) and waits, the driver in
//! standby, for a press and release of the button, and half a second more. Then, for the
//! left motor forward, the left backward, the right forward and the right backward:
//!
//! 1. the duty that puts [`PULSE_MAX_V`] (2 V) across the motor on the supply measured
//!    just before (`robot_app::first_flash::pulse_duty`; refused on an unmeasured supply,
//!    one below 3 V or one above the bridge's rating);
//! 2. that duty for [`PULSE_MAX_MS`] (300 ms), then the driver back in standby while the
//!    wheel coasts down for 400 ms, counting both encoders all along;
//! 3. a log line: the duty and volts, both wheels' counts, and the verdict for the pulsed
//!    wheel (`as commanded`, `REVERSED`: motor or encoder inverted, or `NO MOTION`), and
//!    a warning when the other wheel moved instead (motors or encoders swapped left for
//!    right).
//!
//! Pressing the button during a test, or a supply reading that leaves its bounds, stops
//! the motors at once and ends the round. Press again for another round.

#![no_std]
#![no_main]

use controller_core::controller::{MotorCommand, TickDeltas};
use defmt_rtt as _;
use firmware_board::robot::{BRIDGE, ROBOT};
use firmware_board::{board, first_flash};
use robot_app::first_flash::{
    pulse_duty, pulse_steps, EncoderAnswer, PulseError, PULSE_MAX_MS, PULSE_MAX_V,
};
use stm32f4xx_hal::pac;

#[cfg(feature = "qemu")]
compile_error!("`motors` needs the F411 board's motor driver: build it without `qemu`");

/// Control periods the wheel coasts down after a pulse, still counted (400 ms at 1 kHz).
const COAST_PERIODS: u32 = ROBOT.control_rate_hz * 2 / 5;
/// Control periods between the button's release and the first pulse (500 ms at 1 kHz).
const SETTLE_PERIODS: u32 = ROBOT.control_rate_hz / 2;

/// Which wheel a test pulses, and which way.
#[derive(Clone, Copy)]
struct Test {
    left: bool,
    forward: bool,
}

impl Test {
    const ROUND: [Test; 4] = [
        Test {
            left: true,
            forward: true,
        },
        Test {
            left: true,
            forward: false,
        },
        Test {
            left: false,
            forward: true,
        },
        Test {
            left: false,
            forward: false,
        },
    ];

    fn name(self) -> &'static str {
        match (self.left, self.forward) {
            (true, true) => "left motor forward",
            (true, false) => "left motor backward",
            (false, true) => "right motor forward",
            (false, false) => "right motor backward",
        }
    }

    /// The command that drives this test's wheel at `duty` (0…1) its way, the other at 0.
    fn command(self, duty: f32) -> MotorCommand {
        let signed = if self.forward { duty } else { -duty };
        if self.left {
            MotorCommand {
                left: signed,
                right: 0.0,
            }
        } else {
            MotorCommand {
                left: 0.0,
                right: signed,
            }
        }
    }
}

/// Why a round ended early.
enum Stop {
    /// No pulse could be planned on this supply.
    Supply(PulseError),
    /// The button was pressed.
    Button,
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let (Some(device), Some(core)) = (pac::Peripherals::take(), cortex_m::Peripherals::take())
    else {
        defmt::panic!("the peripherals were taken twice");
    };
    let mut bench = first_flash::Bench::start(board::init(device, core));
    loop {
        defmt::info!(
            "motors: LIFT THE WHEELS, then press and release the button: each motor gets {=f32} V for {=u32} ms, forward then backward",
            PULSE_MAX_V,
            PULSE_MAX_MS
        );
        wait_for_press(&mut bench);
        settle(&mut bench);
        for test in Test::ROUND {
            match run(&mut bench, test) {
                Ok(()) => {}
                Err(Stop::Supply(e)) => {
                    defmt::error!(
                        "{=str}: no pulse: {}",
                        test.name(),
                        defmt::Display2Format(&e)
                    );
                    break;
                }
                Err(Stop::Button) => {
                    defmt::warn!("{=str}: stopped by the button; motors off", test.name());
                    wait_for_release(&mut bench);
                    break;
                }
            }
        }
    }
}

/// Steps with the driver in standby until the button has been pressed and released.
fn wait_for_press(bench: &mut first_flash::Bench) {
    let mut pressed = false;
    loop {
        let sensors = bench.next_step();
        bench.io.apply_outputs(MotorCommand::STOP, false, false);
        match (pressed, sensors.button_pressed) {
            (false, true) => pressed = true,
            (true, false) => return,
            _ => {}
        }
    }
}

/// Steps with the driver in standby for [`SETTLE_PERIODS`], the button ignored: the
/// hand leaves the robot and the button's contacts stop bouncing before the first pulse.
fn settle(bench: &mut first_flash::Bench) {
    let mut elapsed = 0u32;
    while elapsed < SETTLE_PERIODS {
        elapsed += bench.next_step().periods.get();
        bench.io.apply_outputs(MotorCommand::STOP, false, false);
    }
}

/// Steps with the driver in standby until the button is released.
fn wait_for_release(bench: &mut first_flash::Bench) {
    while bench.next_step().button_pressed {
        bench.io.apply_outputs(MotorCommand::STOP, false, false);
    }
    bench.io.apply_outputs(MotorCommand::STOP, false, false);
}

/// One test: plan the pulse on the supply measured at rest, drive it, coast, count,
/// report. The driver is in standby whenever this returns.
fn run(bench: &mut first_flash::Bench, test: Test) -> Result<(), Stop> {
    // At rest, the driver in standby: the conversion the last step started.
    let supply_v = bench.next_step().supply_v;
    bench.io.apply_outputs(MotorCommand::STOP, false, false);
    let duty = pulse_duty(supply_v, PULSE_MAX_V, BRIDGE.max_supply_v()).map_err(Stop::Supply)?;
    let pulse_periods = pulse_steps(PULSE_MAX_MS, ROBOT.control_rate_hz);
    let mut counts = TickDeltas { left: 0, right: 0 };
    let mut elapsed = 0u32;
    while elapsed < pulse_periods + COAST_PERIODS {
        let sensors = bench.next_step();
        elapsed += sensors.periods.get();
        counts.left = counts.left.wrapping_add(sensors.ticks.left);
        counts.right = counts.right.wrapping_add(sensors.ticks.right);
        if sensors.button_pressed {
            bench.io.apply_outputs(MotorCommand::STOP, false, false);
            return Err(Stop::Button);
        }
        let driving = elapsed < pulse_periods;
        if driving {
            // The supply under load must stay in the bounds the pulse was planned in.
            if let Err(e) = pulse_duty(sensors.supply_v, PULSE_MAX_V, BRIDGE.max_supply_v()) {
                bench.io.apply_outputs(MotorCommand::STOP, false, false);
                return Err(Stop::Supply(e));
            }
            bench.io.apply_outputs(test.command(duty), true, true);
        } else {
            bench.io.apply_outputs(MotorCommand::STOP, false, false);
        }
    }

    let ticks_per_turn = first_flash::TICKS_PER_WHEEL_TURN;
    let (pulsed, other) = if test.left {
        (counts.left, counts.right)
    } else {
        (counts.right, counts.left)
    };
    let answer = EncoderAnswer::of(pulsed, test.forward, ticks_per_turn);
    defmt::info!(
        "{=str}: duty {=f32} ({=f32} V on {=f32} V) for {=u32} ms: left {=i32} counts, right {=i32} counts: {=str}",
        test.name(),
        duty,
        duty * supply_v,
        supply_v,
        PULSE_MAX_MS,
        counts.left,
        counts.right,
        answer.name(),
    );
    if EncoderAnswer::of(other, test.forward, ticks_per_turn) != EncoderAnswer::NoMotion {
        defmt::warn!(
            "{=str}: the other wheel moved: motors or encoders swapped left for right",
            test.name()
        );
    }
    Ok(())
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    first_flash::stop_after_panic(info)
}
