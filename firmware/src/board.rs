//! The board: clock, pin map and wiring polarity. The one place to edit for other wiring.
//!
//! | Signal                      | Pin  | Peripheral            | Black Pill | Nucleo-64       |
//! |-----------------------------|------|-----------------------|------------|-----------------|
//! | Left encoder A              | PA15 | TIM2 CH1 (32-bit QEI) | A15        | CN7-17          |
//! | Left encoder B              | PB3  | TIM2 CH2              | B3         | D3 (CN9-4)      |
//! | Right encoder A             | PB6  | TIM4 CH1 (16-bit QEI) | B6         | D10 (CN5-3)     |
//! | Right encoder B             | PB7  | TIM4 CH2              | B7         | CN7-21          |
//! | TB6612 PWMA (left motor)    | PA6  | TIM3 CH1, 20 kHz      | A6         | D12 (CN5-5)     |
//! | TB6612 PWMB (right motor)   | PA7  | TIM3 CH2, 20 kHz      | A7         | D11 (CN5-4)     |
//! | TB6612 AIN1 / AIN2          | PB12 / PB13 | GPIO out       | B12 / B13  | CN10-16 / -30   |
//! | TB6612 BIN1 / BIN2          | PB14 / PB15 | GPIO out       | B14 / B15  | CN10-28 / -26   |
//! | TB6612 STBY                 | PB10 | GPIO out (high = run) | B10        | D6 (CN9-7)      |
//! | DRV8833 only: AIN2 / BIN2   | PB0 / PB1 | TIM3 CH3 / CH4   | B0 / B1    | A3 / CN10-24    |
//! | Arm button (active low)     | PA0 / PC13 | GPIO in         | KEY (PA0)  | B1 USER (PC13)  |
//! | Status LED                  | PC13 / PA5 | GPIO out        | C13 (low = on) | LD2 (PA5, high = on) |
//! | Supply sense (divider)      | PA1  | ADC1_IN1, analog      | A1         | A1 (CN8-2)      |
//! | Control tick                | —    | TIM5 CC1 IRQ, 1 kHz   | —          | —               |
//! | SWD (probe)                 | PA13 / PA14 | SWDIO / SWCLK  | SWD header | ST-LINK         |
//!
//! The encoder inputs get the internal pull-ups (30–50 kΩ) and a digital filter
//! ([`encoder`](crate::encoder)); add 4.7 kΩ pull-ups to 3.3 V at the MCU for
//! open-collector encoders next to the motor wires. Put a 10 kΩ pull-down on STBY so the
//! driver stays in standby while the MCU is in reset (its pins float then). The supply
//! divider is 39 kΩ (supply to PA1) over 10 kΩ (PA1 to GND) with 100 nF from PA1 to GND
//! ([`supply`](crate::supply)).
//!
//! Everything chip-specific the firmware writes is derived here from [`CHIP`] and
//! [`SYSCLK_HZ`] through `robot_app::hw`, whose host tests check it against the
//! reference manuals.

use core::convert::Infallible;

use robot_app::hw::chip::{Chip, HSI_HZ};
use robot_app::hw::clock::{self, ClockPlan};
use robot_app::hw::supply::{AdcPrescaler, Divider, SampleTime};
use robot_app::hw::watchdog::IwdgConfig;
use stm32f4xx_hal::gpio::{self, Analog, Input, Output, PushPull};
use stm32f4xx_hal::hal::digital::InputPin;
use stm32f4xx_hal::pac;

/// The part this build is for (one cargo feature each).
#[cfg(feature = "stm32f411")]
pub const CHIP: Chip = Chip::F411;
/// The part this build is for (one cargo feature each).
#[cfg(feature = "stm32f401")]
pub const CHIP: Chip = Chip::F401;
/// The part this build is for (one cargo feature each).
#[cfg(feature = "stm32f446")]
pub const CHIP: Chip = Chip::F446;

/// System clock from the HSI (16 MHz RC) through the PLL, Hz. No crystal needed, so the
/// same binary runs on a Black Pill (25 MHz crystal) and a Nucleo (no crystal).
#[cfg(not(feature = "stm32f401"))]
pub const SYSCLK_HZ: u32 = 100_000_000;
/// System clock of the STM32F401, Hz: 72 MHz, not its 84 MHz maximum, because for 84 MHz
/// from the HSI stm32f4xx-hal writes PLLN = 168, below RM0368's minimum of 192; for 72 MHz
/// it writes M = 8, N = 216, P = 6, which RM0368 allows.
#[cfg(feature = "stm32f401")]
pub const SYSCLK_HZ: u32 = 72_000_000;

/// The clock configuration for [`CHIP`] at [`SYSCLK_HZ`]: PLL, bus dividers, flash wait
/// states, voltage scale (`robot_app::hw::clock::plan`). `clock::configure` checks the
/// registers against it after the HAL has written them.
pub const CLOCK_PLAN: ClockPlan = match clock::plan(CHIP, HSI_HZ, SYSCLK_HZ) {
    Ok(plan) => plan,
    Err(_) => panic!("SYSCLK_HZ is not reachable within the chip's limits"),
};

/// Motor PWM frequency, Hz: above hearing.
pub const PWM_HZ: u32 = 20_000;
const _: () = assert!(
    CLOCK_PLAN.tree.timclk1_hz % PWM_HZ == 0 && CLOCK_PLAN.tree.timclk1_hz / PWM_HZ <= 65_536,
    "the PWM period must be a whole number of 16-bit timer counts"
);

/// Counting rate of the free-running tick timer (TIM5), Hz: 1 µs resolution.
pub const TICK_TIMER_HZ: u32 = 1_000_000;
const _: () = assert!(CLOCK_PLAN.tree.timclk1_hz % TICK_TIMER_HZ == 0);

/// Independent watchdog while `init` runs: 250 ms at the typical LSI (170–471 ms over its
/// spread), started before the clock set-up so that no wait in `init` can hang forever.
pub const WATCHDOG_INIT: IwdgConfig = match IwdgConfig::for_timeout_us(250_000, CHIP.lsi_hz().1) {
    Ok(config) => config,
    Err(_) => panic!("init watchdog timeout out of range"),
};

/// Independent watchdog from the end of `init` on: 10 ms at the typical LSI (÷4, reload
/// 79; 6.8–18.8 ms over the LSI's 17–47 kHz). The control task feeds it every 1 ms step.
pub const WATCHDOG_RUN: IwdgConfig = match IwdgConfig::for_timeout_us(10_000, CHIP.lsi_hz().1) {
    Ok(config) => config,
    Err(_) => panic!("watchdog timeout out of range"),
};

/// The supply divider: 39 kΩ from the supply to PA1, 10 kΩ from PA1 to GND (ratio
/// 0.2041, full scale 16.2 V at 3.3 V), with 100 nF from PA1 to GND (corner 200 Hz).
pub const SUPPLY_DIVIDER: Divider = Divider {
    top_ohm: 39_000.0,
    bottom_ohm: 10_000.0,
};

/// V_DDA = V_REF+ on both boards (the 3.3 V regulator), V: the ADC's reference. Its
/// tolerance (typically ±1–2 %) is the supply reading's.
pub const ADC_REFERENCE_V: f32 = 3.3;

/// ADCCLK prescaler: the smallest that keeps ADCCLK ≤ 36 MHz (25 MHz on the F411).
pub const ADC_PRESCALER: AdcPrescaler =
    match AdcPrescaler::for_pclk2(CLOCK_PLAN.tree.pclk2_hz, CHIP.max_adc_clock_hz()) {
        Some(prescaler) => prescaler,
        None => panic!("PCLK2 too fast for the ADC"),
    };

/// Supply sampling time: 480 ADCCLK cycles (19.2 µs at 25 MHz), long enough for a
/// 276 kΩ source; the divider's 8 kΩ needs only 28 cycles.
pub const SUPPLY_SAMPLE_TIME: SampleTime = SampleTime::Cycles480;

/// Wiring polarity: set so that a positive duty drives the wheel forward and forward
/// wheel rotation counts up. Flip after the bring-up check in the README.
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

/// Left encoder timer: 32-bit TIM2.
pub type LeftEncoderTimer = pac::TIM2;
/// Right encoder timer: 16-bit TIM4.
pub type RightEncoderTimer = pac::TIM4;
/// Timer of both motor PWM channels.
pub type PwmTimer = pac::TIM3;
/// Timer whose channel-1 compare is the 1 kHz control tick (interrupt `TIM5`), counting
/// freely at 1 MHz.
pub type TickTimer = pac::TIM5;

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

/// Every pin the firmware uses, configured, by function. With feature `drv8833` the
/// bridge inputs are PWM on both sides (PA6/PB0 left, PA7/PB1 right), nSLEEP is on the
/// STBY pin, and PB12–PB15 stay low, unused.
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
    pub left_dir: (Out<'B', 12>, Out<'B', 13>),
    /// TB6612 BIN1, BIN2 (right motor direction), low.
    pub right_dir: (Out<'B', 14>, Out<'B', 15>),
    /// TB6612 STBY, low (standby) until armed.
    pub standby: Out<'B', 10>,
    /// The arm button.
    pub button: ButtonPin,
    /// The status LED, off.
    pub led: Led,
    /// The supply divider's output (ADC1 channel 1), analog mode.
    pub supply: gpio::PA1<Analog>,
}

/// GPIOB pins that [`force_motors_off`] drives low: STBY (PB10) and the four direction
/// inputs (PB12–PB15). Must match [`Pins`].
const MOTOR_GPIOB_PINS: [u8; 5] = [10, 12, 13, 14, 15];

impl Pins {
    /// Configures the pins of ports A, B and C for their functions; every output that
    /// can move a motor starts low.
    pub fn new(
        gpioa: gpio::gpioa::Parts,
        gpiob: gpio::gpiob::Parts,
        gpioc: gpio::gpioc::Parts,
    ) -> Self {
        use stm32f4xx_hal::gpio::PinState::Low;
        use stm32f4xx_hal::gpio::Pull;

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
                gpiob.pb12.into_push_pull_output_in_state(Low),
                gpiob.pb13.into_push_pull_output_in_state(Low),
            ),
            right_dir: (
                gpiob.pb14.into_push_pull_output_in_state(Low),
                gpiob.pb15.into_push_pull_output_in_state(Low),
            ),
            standby: gpiob.pb10.into_push_pull_output_in_state(Low),
            button,
            led,
            supply: gpioa.pa1.into_analog(),
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

/// Why the chip reset, read from RCC_CSR; clears the flags for the next boot.
///
/// RM0383 §6.3, RCC_CSR: BORRSTF is set "when a POR/PDR or BOR reset occurs", so after a
/// power-on both PORRSTF and BORRSTF are set; a brown-out alone is BORRSTF without
/// PORRSTF. Every internal reset also drives NRST low, so PINRSTF accompanies the other
/// flags; a pin reset alone is PINRSTF with nothing else. (With the factory option bytes
/// BOR is off and only the POR/PDR threshold resets the chip.)
pub fn take_reset_flags(rcc: &pac::RCC) -> controller_core::supervisor::ResetFlags {
    let csr = rcc.csr().read();
    let flags = controller_core::supervisor::ResetFlags {
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
