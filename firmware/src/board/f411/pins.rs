//! The F411 board's pins: what each one does, configured by [`Pins::new`], and the
//! writes that stop the motors from a fault handler. The wiring table is in the
//! [board module](super).

use core::convert::Infallible;

use stm32f4xx_hal::gpio::{self, Analog, Input, Output, PushPull};
use stm32f4xx_hal::hal::digital::InputPin;
use stm32f4xx_hal::pac;

use super::PwmTimer;

/// The reference wiring's polarity (`docs/hardware.md`, "Wiring"): what the board calls
/// forward for each motor output and encoder input. A robot wired otherwise is corrected
/// by its parameters (`wiring`, found by `station bringup`: `docs/bring-up.md`), not by
/// editing these.
pub mod polarity {
    /// The left motor's leads are swapped (positive duty would turn it backwards).
    pub const LEFT_MOTOR_INVERTED: bool = false;
    /// The right motor's leads are swapped. The right motor is mounted mirrored, so with
    /// identical wiring it turns the other way.
    pub const RIGHT_MOTOR_INVERTED: bool = true;
    /// The left encoder counts down when the wheel turns forward.
    pub const LEFT_ENCODER_INVERTED: bool = false;
    /// The right encoder counts down when the wheel turns forward (mirrored mounting).
    pub const RIGHT_ENCODER_INVERTED: bool = true;
}

/// Motor driver direction / standby output.
pub type Out<const P: char, const N: u8> = gpio::Pin<P, N, Output<PushPull>>;

/// The arm button: Black Pill KEY (PA0, to ground, internal pull-up).
#[cfg(not(feature = "nucleo"))]
pub type ButtonPin = gpio::PA0<Input>;
/// The arm button: Nucleo B1 USER (PC13, external pull-up, low when pressed).
#[cfg(feature = "nucleo")]
pub type ButtonPin = gpio::PC13<Input>;

/// The status LED: Black Pill blue LED on PC13, lit when low.
#[cfg(not(feature = "nucleo"))]
pub type LedPin = gpio::PC13<Output<PushPull>>;
/// The status LED: Nucleo LD2 on PA5, lit when high.
#[cfg(feature = "nucleo")]
pub type LedPin = gpio::PA5<Output<PushPull>>;

/// The IMU's SPI2 pins (AF5 on every STM32F4 the firmware builds for) and its chip
/// select.
pub struct ImuPins {
    /// SPI2 SCK (PB13, AF5), fast edges for 12.5 MHz.
    pub sck: gpio::PB13<gpio::Alternate<5>>,
    /// SPI2 MISO (PB14, AF5), with the pull-down: with no IMU fitted it reads 0x00,
    /// never a floating pattern that could pass for an identity.
    pub miso: gpio::PB14<gpio::Alternate<5>>,
    /// SPI2 MOSI (PB15, AF5), fast edges.
    pub mosi: gpio::PB15<gpio::Alternate<5>>,
    /// The IMU's chip select (PB12), high (deselected).
    pub chip_select: Out<'B', 12>,
}

/// Every pin the firmware uses, configured, by function. With feature `drv8833` the
/// bridge inputs are PWM on both sides (PA6/PB0 left, PA7/PB1 right), nSLEEP is on the
/// STBY pin, and the TB6612's direction pins (PB4, PB5, PB8, PB9) stay low, unused.
pub struct Pins {
    /// Left encoder A, B (TIM2 CH1, CH2), alternate function with pull-up.
    pub left_encoder: (
        gpio::PA15<gpio::Alternate<1>>,
        gpio::PB3<gpio::Alternate<1>>,
    ),
    /// Right encoder A, B (TIM4 CH1, CH2), alternate function with pull-up.
    pub right_encoder: (gpio::PB6<gpio::Alternate<2>>, gpio::PB7<gpio::Alternate<2>>),
    /// PWM of the left motor (TIM3 CH1, TB6612 PWMA).
    pub left_pwm: gpio::PA6,
    /// PWM of the right motor (TIM3 CH2, TB6612 PWMB).
    pub right_pwm: gpio::PA7,
    /// DRV8833 IN2 of the left motor (TIM3 CH3).
    #[cfg(feature = "drv8833")]
    pub left_pwm_b: gpio::PB0,
    /// DRV8833 IN2 of the right motor (TIM3 CH4).
    #[cfg(feature = "drv8833")]
    pub right_pwm_b: gpio::PB1,
    /// TB6612 AIN1, AIN2 (left motor direction), low.
    pub left_dir: (Out<'B', 4>, Out<'B', 5>),
    /// TB6612 BIN1, BIN2 (right motor direction), low.
    pub right_dir: (Out<'B', 8>, Out<'B', 9>),
    /// The IMU's bus (found or not at start-up: `super::imu`).
    pub imu: ImuPins,
    /// TB6612 STBY, low (standby) until armed.
    pub standby: Out<'B', 10>,
    /// The arm button.
    pub button: ButtonPin,
    /// The status LED, off.
    pub led: Led,
    /// The supply divider's output (ADC1 channel 1), analog mode.
    pub supply: gpio::PA1<Analog>,
    /// The link's transmit line (USART2 TX, AF7), push-pull.
    pub link_tx: gpio::PA2<gpio::Alternate<7>>,
    /// The link's receive line (USART2 RX, AF7), with the pull-up: an unplugged line
    /// idles high (a mark) instead of floating into false start bits.
    pub link_rx: gpio::PA3<gpio::Alternate<7>>,
}

/// GPIOB pins that [`force_motors_off`] drives low: STBY (PB10) and the four direction
/// inputs (PB4, PB5, PB8, PB9). Must match [`Pins`].
const MOTOR_GPIOB_PINS: [u8; 5] = [10, 4, 5, 8, 9];

impl Pins {
    /// Configures the pins of ports A, B and C for their functions; every output that
    /// can move a motor starts low.
    pub fn new(
        gpioa: gpio::gpioa::Parts,
        gpiob: gpio::gpiob::Parts,
        gpioc: gpio::gpioc::Parts,
    ) -> Self {
        use stm32f4xx_hal::gpio::PinState::{High, Low};
        use stm32f4xx_hal::gpio::{Pull, Speed};

        #[cfg(not(feature = "nucleo"))]
        let (button, led) = (
            gpioa.pa0.into_pull_up_input(),
            Led::new(
                gpioc
                    .pc13
                    .into_push_pull_output_in_state(gpio::PinState::High),
            ),
        );
        #[cfg(feature = "nucleo")]
        let (button, led) = (
            gpioc.pc13.into_input(),
            Led::new(gpioa.pa5.into_push_pull_output_in_state(Low)),
        );

        Self {
            left_encoder: (
                gpioa.pa15.into_alternate().internal_resistor(Pull::Up),
                gpiob.pb3.into_alternate().internal_resistor(Pull::Up),
            ),
            right_encoder: (
                gpiob.pb6.into_alternate().internal_resistor(Pull::Up),
                gpiob.pb7.into_alternate().internal_resistor(Pull::Up),
            ),
            left_pwm: gpioa.pa6,
            right_pwm: gpioa.pa7,
            #[cfg(feature = "drv8833")]
            left_pwm_b: gpiob.pb0,
            #[cfg(feature = "drv8833")]
            right_pwm_b: gpiob.pb1,
            left_dir: (
                gpiob.pb4.into_push_pull_output_in_state(Low),
                gpiob.pb5.into_push_pull_output_in_state(Low),
            ),
            right_dir: (
                gpiob.pb8.into_push_pull_output_in_state(Low),
                gpiob.pb9.into_push_pull_output_in_state(Low),
            ),
            imu: ImuPins {
                sck: gpiob.pb13.into_alternate().speed(Speed::High),
                miso: gpiob.pb14.into_alternate().internal_resistor(Pull::Down),
                mosi: gpiob.pb15.into_alternate().speed(Speed::High),
                chip_select: gpiob.pb12.into_push_pull_output_in_state(High),
            },
            standby: gpiob.pb10.into_push_pull_output_in_state(Low),
            button,
            led,
            supply: gpioa.pa1.into_analog(),
            link_tx: gpioa.pa2.into_alternate(),
            link_rx: gpioa.pa3.into_alternate().internal_resistor(Pull::Up),
        }
    }
}

/// Reads the arm button's level, true while pressed (both boards: active low).
pub fn button_pressed(button: &mut ButtonPin) -> bool {
    let level: Result<bool, Infallible> = button.is_low();
    let Ok(pressed) = level;
    pressed
}

/// The status LED, hiding whether it is lit high or low.
pub struct Led(LedPin);

impl Led {
    fn new(pin: LedPin) -> Self {
        Self(pin)
    }

    /// Lights (`true`) or darkens the LED.
    pub fn set(&mut self, on: bool) {
        // Black Pill: lit when low. Nucleo: lit when high.
        let high = if cfg!(feature = "nucleo") { on } else { !on };
        self.0.set_state(high.into());
    }
}

/// Stops both motors from any context, whatever owns the peripherals: the driver's enable
/// line (TB6612 STBY, DRV8833 nSLEEP) and the direction inputs low, every PWM channel of
/// [`PwmTimer`] forced inactive (low, at once: OCxM is not preloaded) and its compare
/// registers zeroed. Both drivers then leave the motors coasting. Used by the panic and
/// hard-fault handlers.
///
/// # Safety
///
/// Writes GPIOB and the PWM timer behind their owners' backs. Call it only where no other
/// code will run afterwards (panic, hard fault), or with interrupts disabled.
pub unsafe fn force_motors_off() {
    // SAFETY: the caller guarantees nothing else touches these registers any more; the
    // writes below are single-register stores that leave the peripherals consistent.
    let (gpiob, pwm) = unsafe { (&*pac::GPIOB::ptr(), &*PwmTimer::ptr()) };
    for pin in MOTOR_GPIOB_PINS {
        gpiob.bsrr().write(|w| w.br(pin).set_bit());
    }
    pwm.ccmr1_output()
        .modify(|_, w| w.oc1m().force_inactive().oc2m().force_inactive());
    pwm.ccmr2_output()
        .modify(|_, w| w.oc3m().force_inactive().oc4m().force_inactive());
    for channel in 0..4 {
        pwm.ccr(channel).write(|w| w.ccr().set(0));
    }
}

/// The reset flags of RCC_CSR (`robot_app::stm32f4::reset` decodes them); clears them
/// for the next boot. (With the factory option bytes BOR is off and only the POR/PDR
/// threshold resets the chip.)
pub fn take_reset_flags(rcc: &pac::RCC) -> robot_app::stm32f4::reset::ResetFlags {
    let csr = rcc.csr().read();
    let flags = robot_app::stm32f4::reset::ResetFlags {
        low_power: csr.lpwrrstf().bit_is_set(),
        window_watchdog: csr.wwdgrstf().bit_is_set(),
        independent_watchdog: csr.wdgrstf().bit_is_set(),
        software: csr.sftrstf().bit_is_set(),
        power_on: csr.porrstf().bit_is_set(),
        pin: csr.padrstf().bit_is_set(),
        brown_out: csr.borrstf().bit_is_set(),
    };
    rcc.csr().modify(|_, w| w.rmvf().set_bit());
    flags
}
