//! Motor drivers behind one small trait, on embedded-hal 1.0 only.
//!
//! [`Motor`] turns a signed duty (−1…1, a fraction of the supply voltage) into pin
//! states. [`Tb6612Channel`] is one channel of a TB6612FNG (one PWM, two direction
//! inputs); [`Drv8833Channel`] is one channel of a DRV8833-style bridge (two PWM inputs,
//! no direction pins). [`DriveTrain`] holds the two wheels and the driver's shared enable
//! line (TB6612 STBY, DRV8833 nSLEEP) and is what the control task writes to.
//!
//! All the HAL's pins and PWM channels are infallible, so the bounds ask for
//! `Error = Infallible` and no error path exists.

use core::convert::Infallible;

use controller_core::controller::MotorCommand;
use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;

/// One motor of a bridge.
pub trait Motor {
    /// Drives the motor at `duty` (−1…1 of the supply; positive is forward, 0 coasts).
    /// Values outside the range are clamped, NaN is taken as 0.
    fn drive(&mut self, duty: f32);
}

/// |`duty`| clamped to [0, 1] as a compare value of `pwm` (NaN → 0).
fn compare_value<P: SetDutyCycle>(pwm: &P, duty: f32) -> u16 {
    let magnitude = if duty >= 0.0 { duty } else { -duty };
    let max = pwm.max_duty_cycle();
    if magnitude >= 1.0 {
        max
    } else if magnitude > 0.0 {
        // Rounded; `as` saturates, and the product is below `max` + 0.5 here.
        (magnitude * f32::from(max) + 0.5) as u16
    } else {
        0
    }
}

/// One channel of a TB6612FNG: PWM on PWMx, direction on xIN1/xIN2.
///
/// | duty | IN1 | IN2 | PWM      | bridge          |
/// |------|-----|-----|----------|-----------------|
/// | > 0  | H   | L   | \|duty\| | forward         |
/// | < 0  | L   | H   | \|duty\| | reverse         |
/// | 0    | L   | L   | 0        | off (coasting)  |
#[cfg_attr(feature = "drv8833", allow(dead_code))]
pub struct Tb6612Channel<PWM, IN1, IN2> {
    pwm: PWM,
    in1: IN1,
    in2: IN2,
    inverted: bool,
}

#[cfg_attr(feature = "drv8833", allow(dead_code))]
impl<PWM, IN1, IN2> Tb6612Channel<PWM, IN1, IN2>
where
    PWM: SetDutyCycle<Error = Infallible>,
    IN1: OutputPin<Error = Infallible>,
    IN2: OutputPin<Error = Infallible>,
{
    /// A channel on these pins; `inverted` swaps forward and reverse (motor leads swapped
    /// or motor mounted mirrored). Starts off.
    pub fn new(pwm: PWM, in1: IN1, in2: IN2, inverted: bool) -> Self {
        let mut channel = Self {
            pwm,
            in1,
            in2,
            inverted,
        };
        channel.drive(0.0);
        channel
    }
}

impl<PWM, IN1, IN2> Motor for Tb6612Channel<PWM, IN1, IN2>
where
    PWM: SetDutyCycle<Error = Infallible>,
    IN1: OutputPin<Error = Infallible>,
    IN2: OutputPin<Error = Infallible>,
{
    fn drive(&mut self, duty: f32) {
        let duty = if self.inverted { -duty } else { duty };
        let compare = compare_value(&self.pwm, duty);
        let (in1, in2) = match compare {
            0 => (false, false),
            _ if duty > 0.0 => (true, false),
            _ => (false, true),
        };
        // Never both high (that is short brake on a TB6612, not what 0 means here).
        let Ok(()) = self.in1.set_state(in1.into());
        let Ok(()) = self.in2.set_state(in2.into());
        let Ok(()) = self.pwm.set_duty_cycle(compare);
    }
}

/// One channel of a DRV8833-style bridge: two PWM inputs, no direction pins. Forward is
/// PWM on IN1 with IN2 low, reverse the other way round (fast decay); 0 is both low
/// (coasting).
///
/// Selected by the `drv8833` feature: four PWM channels (TIM3 CH1–CH4 on PA6, PA7, PB0,
/// PB1) and nSLEEP on the pin that is STBY for the TB6612.
#[cfg_attr(not(feature = "drv8833"), allow(dead_code))]
pub struct Drv8833Channel<P1, P2> {
    in1: P1,
    in2: P2,
    inverted: bool,
}

#[cfg_attr(not(feature = "drv8833"), allow(dead_code))]
impl<P1, P2> Drv8833Channel<P1, P2>
where
    P1: SetDutyCycle<Error = Infallible>,
    P2: SetDutyCycle<Error = Infallible>,
{
    /// A channel on these two PWM outputs; `inverted` swaps forward and reverse. Starts
    /// off.
    pub fn new(in1: P1, in2: P2, inverted: bool) -> Self {
        let mut channel = Self { in1, in2, inverted };
        channel.drive(0.0);
        channel
    }
}

impl<P1, P2> Motor for Drv8833Channel<P1, P2>
where
    P1: SetDutyCycle<Error = Infallible>,
    P2: SetDutyCycle<Error = Infallible>,
{
    fn drive(&mut self, duty: f32) {
        let duty = if self.inverted { -duty } else { duty };
        let (a, b) = if duty > 0.0 {
            (compare_value(&self.in1, duty), 0)
        } else {
            (0, compare_value(&self.in2, duty))
        };
        // Lower the side that goes to 0 first so both are never driven together.
        if a == 0 {
            let Ok(()) = self.in1.set_duty_cycle(0);
            let Ok(()) = self.in2.set_duty_cycle(b);
        } else {
            let Ok(()) = self.in2.set_duty_cycle(0);
            let Ok(()) = self.in1.set_duty_cycle(a);
        }
    }
}

/// Both wheels and the driver's enable line.
pub struct DriveTrain<L, R, EN> {
    left: L,
    right: R,
    enable: EN,
}

impl<L: Motor, R: Motor, EN: OutputPin<Error = Infallible>> DriveTrain<L, R, EN> {
    /// A drive train, disabled with both motors off.
    pub fn new(left: L, right: R, enable: EN) -> Self {
        let mut drive = Self {
            left,
            right,
            enable,
        };
        drive.apply(MotorCommand::STOP, false);
        drive
    }

    /// Applies `duty` when `enabled`; otherwise both duties 0 and the driver disabled.
    /// The duties are zeroed before the driver is disabled and the driver enabled before
    /// any duty is raised.
    pub fn apply(&mut self, duty: MotorCommand, enabled: bool) {
        if enabled {
            let Ok(()) = self.enable.set_high();
            self.left.drive(duty.left);
            self.right.drive(duty.right);
        } else {
            self.left.drive(0.0);
            self.right.drive(0.0);
            let Ok(()) = self.enable.set_low();
        }
    }
}
