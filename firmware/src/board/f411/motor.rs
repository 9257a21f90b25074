//! Motor drivers behind one small trait, on embedded-hal 1.0 only.
//!
//! Both drivers run in slow decay: duty 0 with the driver enabled is a **short brake**, a
//! disabled driver (TB6612FNG STBY low, DRV8833 nSLEEP low) lets the motors **coast**.
//! The input states and the order of transitions are decided in
//! `robot_app::stm32f4::bridge` (host-tested); this module writes them to pins.
//!
//! | command | TB6612FNG IN1 / IN2 / PWM | DRV8833 IN1 / IN2 |
//! |---|---|---|
//! | forward, duty d | H / L / d | 100 % / PWM (1 − d) |
//! | reverse, duty d | L / H / d | PWM (1 − d) / 100 % |
//! | brake (duty 0, enabled) | H / H / 0 | 100 % / 100 % |
//! | coast (disabled) | L / L / 0 | 0 / 0 |
//!
//! The PWM timer's compare registers are preloaded (stm32f4xx-hal sets OCxPE): a new
//! compare takes effect at the next update event, within one 50 µs PWM period, while
//! the TB6612's direction pins act at once. [`DriveTrain`] runs every command through
//! `robot_app::stm32f4::bridge::DriveSequencer`, so a change of direction first spends one
//! control step (1 ms, twenty PWM periods) in brake: the direction pins only flip when the
//! latched compare is 0 (TB6612), and a DRV8833 channel never changes both of its inputs
//! in one step. Arming spends one step putting the inputs in brake before the enable
//! line rises. Neither bridge can short the supply whatever its inputs do (both have
//! internal dead time); the sequence prevents a wrong drive of up to one PWM period.
//!
//! All the HAL's pins and PWM channels are infallible, so the bounds ask for
//! `Error = Infallible` and no error path exists.

use core::convert::Infallible;

use controller_core::controller::MotorCommand;
use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;
use robot_app::stm32f4::bridge::{
    command_for, drv8833_inputs, tb6612_inputs, BridgeCommand, DriveSequencer, Drv8833Inputs,
};

/// One motor channel of a bridge.
pub trait Bridge {
    /// The PWM period in compare counts (a compare of this value is always on).
    fn max_compare(&self) -> u16;
    /// Sets the channel's inputs for `command`.
    fn apply(&mut self, command: BridgeCommand);
}

/// One channel of a TB6612FNG: PWM on PWMx, direction on xIN1/xIN2.
#[cfg_attr(feature = "drv8833", allow(dead_code))]
pub struct Tb6612Channel<PWM, IN1, IN2> {
    pwm: PWM,
    in1: IN1,
    in2: IN2,
}

#[cfg_attr(feature = "drv8833", allow(dead_code))]
impl<PWM, IN1, IN2> Tb6612Channel<PWM, IN1, IN2>
where
    PWM: SetDutyCycle<Error = Infallible>,
    IN1: OutputPin<Error = Infallible>,
    IN2: OutputPin<Error = Infallible>,
{
    /// A channel on these pins, coasting.
    pub fn new(pwm: PWM, in1: IN1, in2: IN2) -> Self {
        let mut channel = Self { pwm, in1, in2 };
        channel.apply(BridgeCommand::Coast);
        channel
    }
}

impl<PWM, IN1, IN2> Bridge for Tb6612Channel<PWM, IN1, IN2>
where
    PWM: SetDutyCycle<Error = Infallible>,
    IN1: OutputPin<Error = Infallible>,
    IN2: OutputPin<Error = Infallible>,
{
    fn max_compare(&self) -> u16 {
        self.pwm.max_duty_cycle()
    }

    fn apply(&mut self, command: BridgeCommand) {
        let inputs = tb6612_inputs(command);
        // Pins first (they act at once), then the compare (latched at the next update).
        let Ok(()) = self.in1.set_state(inputs.in1.into());
        let Ok(()) = self.in2.set_state(inputs.in2.into());
        let Ok(()) = self.pwm.set_duty_cycle(inputs.pwm_compare);
    }
}

/// One channel of a DRV8833-style bridge: two PWM inputs, no direction pins.
///
/// Selected by the `drv8833` feature: four PWM channels (TIM3 CH1–CH4 on PA6, PA7, PB0,
/// PB1) and nSLEEP on the pin that is STBY for the TB6612.
#[cfg_attr(not(feature = "drv8833"), allow(dead_code))]
pub struct Drv8833Channel<P1, P2> {
    in1: P1,
    in2: P2,
    last: Drv8833Inputs,
}

#[cfg_attr(not(feature = "drv8833"), allow(dead_code))]
impl<P1, P2> Drv8833Channel<P1, P2>
where
    P1: SetDutyCycle<Error = Infallible>,
    P2: SetDutyCycle<Error = Infallible>,
{
    /// A channel on these two PWM outputs (same timer, same period), coasting.
    pub fn new(in1: P1, in2: P2) -> Self {
        let mut channel = Self {
            in1,
            in2,
            last: Drv8833Inputs { in1: 0, in2: 0 },
        };
        channel.apply(BridgeCommand::Coast);
        channel
    }
}

impl<P1, P2> Bridge for Drv8833Channel<P1, P2>
where
    P1: SetDutyCycle<Error = Infallible>,
    P2: SetDutyCycle<Error = Infallible>,
{
    fn max_compare(&self) -> u16 {
        self.in1.max_duty_cycle()
    }

    fn apply(&mut self, command: BridgeCommand) {
        let next = drv8833_inputs(command, self.max_compare());
        // The input that rises towards brake first: alone, it can only brake.
        if self.last.in2_first(next) {
            let Ok(()) = self.in2.set_duty_cycle(next.in2);
            let Ok(()) = self.in1.set_duty_cycle(next.in1);
        } else {
            let Ok(()) = self.in1.set_duty_cycle(next.in1);
            let Ok(()) = self.in2.set_duty_cycle(next.in2);
        }
        self.last = next;
    }
}

/// Both wheels, their wiring polarity and the driver's enable line.
pub struct DriveTrain<L, R, EN> {
    left: L,
    right: R,
    enable: EN,
    left_inverted: bool,
    right_inverted: bool,
    sequencer: DriveSequencer,
}

impl<L: Bridge, R: Bridge, EN: OutputPin<Error = Infallible>> DriveTrain<L, R, EN> {
    /// A drive train, disabled and coasting. `*_inverted` swaps forward and reverse of a
    /// wheel (motor leads swapped, or the motor mounted mirrored).
    pub fn new(left: L, right: R, enable: EN, left_inverted: bool, right_inverted: bool) -> Self {
        let mut drive = Self {
            left,
            right,
            enable,
            left_inverted,
            right_inverted,
            sequencer: DriveSequencer::new(),
        };
        drive.apply(MotorCommand::STOP, false);
        drive
    }

    /// Applies `duty` (each −1…1, positive forward) when `enabled`; otherwise disables
    /// the driver and lets both motors coast. Call once per control step.
    pub fn apply(&mut self, duty: MotorCommand, enabled: bool) {
        let signed = |d: f32, inverted: bool| if inverted { -d } else { d };
        let want_left = command_for(
            signed(duty.left, self.left_inverted),
            self.left.max_compare(),
        );
        let want_right = command_for(
            signed(duty.right, self.right_inverted),
            self.right.max_compare(),
        );
        let out = self.sequencer.next(enabled, want_left, want_right);
        if out.enable {
            self.left.apply(out.left);
            self.right.apply(out.right);
            let Ok(()) = self.enable.set_high();
        } else {
            // Disable first: the bridge is off before its inputs change.
            let Ok(()) = self.enable.set_low();
            self.left.apply(out.left);
            self.right.apply(out.right);
        }
    }
}
