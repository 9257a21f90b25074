//! The real board: an STM32F411 (WeAct Black Pill, or an ST Nucleo-F411RE with feature
//! `nucleo`) with a TB6612FNG (or, with feature `drv8833`, a DRV8833) motor driver.
//!
//! | Signal                      | Pin  | Peripheral            | Black Pill | Nucleo-64       |
//! |-----------------------------|------|-----------------------|------------|-----------------|
//! | Left encoder A              | PA15 | TIM2 CH1 (32-bit QEI) | A15        | CN7-17          |
//! | Left encoder B              | PB3  | TIM2 CH2              | B3         | D3 (CN9-4)      |
//! | Right encoder A             | PB6  | TIM4 CH1 (16-bit QEI) | B6         | D10 (CN5-3)     |
//! | Right encoder B             | PB7  | TIM4 CH2              | B7         | CN7-21          |
//! | TB6612 PWMA (left motor)    | PA6  | TIM3 CH1, 20 kHz      | A6         | D12 (CN5-5)     |
//! | TB6612 PWMB (right motor)   | PA7  | TIM3 CH2, 20 kHz      | A7         | D11 (CN5-4)     |
//! | TB6612 AIN1 / AIN2          | PB4 / PB5   | GPIO out       | B4 / B5    | D5 (CN9-6) / D4 (CN9-5) |
//! | TB6612 BIN1 / BIN2          | PB8 / PB9   | GPIO out       | B8 / B9    | D15 (CN5-10) / D14 (CN5-9) |
//! | TB6612 STBY                 | PB10 | GPIO out (high = run) | B10        | D6 (CN9-7)      |
//! | DRV8833 only: AIN2 / BIN2   | PB0 / PB1 | TIM3 CH3 / CH4   | B0 / B1    | A3 / CN10-24    |
//! | Arm button (active low)     | PA0 / PC13 | GPIO in         | KEY (PA0)  | B1 USER (PC13)  |
//! | Status LED                  | PC13 / PA5 | GPIO out        | C13 (low = on) | LD2 (PA5, high = on) |
//! | Supply sense (divider)      | PA1  | ADC1_IN1, analog      | A1         | A1 (CN8-2)      |
//! | IMU SCLK (optional, [`imu`]) | PB13 | SPI2 SCK, AF5, 12.5 MHz | B13      | CN10-30         |
//! | IMU SDO (MISO)              | PB14 | SPI2 MISO, AF5, pull-down | B14    | CN10-28         |
//! | IMU SDI (MOSI)              | PB15 | SPI2 MOSI, AF5        | B15        | CN10-26         |
//! | IMU CS                      | PB12 | GPIO out (low = selected) | B12    | CN10-16         |
//! | Link TX (robot → host)      | PA2  | USART2 TX, AF7        | A2 → adapter RX | ST-LINK VCP (no wire) |
//! | Link RX (host → robot)      | PA3  | USART2 RX, AF7, pull-up | A3 ← adapter TX | ST-LINK VCP (no wire) |
//! | Control tick                | —    | TIM5 CC1 IRQ, 1 kHz   | —          | —               |
//! | Parameter storage           | —    | flash sectors 6 and 7 (0x0804_0000, 0x0806_0000, 128 KiB each) | — | — |
//! | SWD (probe)                 | PA13 / PA14 | SWDIO / SWCLK  | SWD header | ST-LINK         |
//! | System clock ([`HSE`])      | PH0 / PH1 | OSC_IN / OSC_OUT | 25 MHz crystal | 8 MHz ST-LINK MCO on OSC_IN (SB50) |
//!
//! The link runs at [`LINK_BAUD`] 8N1 (3.3 V logic: a USB-serial adapter's RX to PA2,
//! TX to PA3, GND to GND; on the Nucleo the ST-LINK's virtual COM port is already wired
//! to PA2/PA3 through SB13/SB14). The encoder inputs get the internal pull-ups
//! (30–50 kΩ) and a digital filter ([`encoder`]); add 4.7 kΩ pull-ups to 3.3 V at the
//! MCU for open-collector encoders next to the motor wires. Put a 10 kΩ pull-down on
//! STBY so the driver stays in standby while the MCU is in reset (its pins float then).
//! The supply divider is 39 kΩ (supply to PA1) over 10 kΩ (PA1 to GND) with 100 nF from
//! PA1 to GND ([`supply`]).
//!
//! Everything chip-specific the firmware writes is derived here from [`CHIP`], [`HSE`]
//! and [`SYSCLK_HZ`] through `robot_app::stm32f4`, whose host tests check it against the
//! reference manuals. `init` sets the brown-out reset to level 3 the first time it runs
//! on a chip ([`brown_out`]) and runs the clock from the [`HSE`], or the HSI when it does
//! not start ([`clock`]).

mod brown_out;
mod clock;
mod encoder;
mod flash;
mod imu;
mod motor;
mod pins;
mod supply;
mod tick;
mod wait;
mod watchdog;

use core::num::NonZeroU32;

use controller_core::controller::MotorCommand;
use controller_core::supervisor::ResetCause;
use cortex_m::peripheral::{DWT, NVIC};
use link::{BrownOutReset, ClockSource};
use robot_app::stm32f4::chip::{Chip, HSI_HZ};
use robot_app::stm32f4::clock::{self as clock_plan, ClockPlan};
use robot_app::stm32f4::oscillator::Hse;
use robot_app::stm32f4::supply::{AdcPrescaler, Divider, SampleTime};
use robot_app::stm32f4::usart::BaudSetting;
use robot_app::stm32f4::watchdog::IwdgConfig;
use robot_app::{Actuation, ControlSide, Sensors};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::qei::Qei;
use stm32f4xx_hal::rcc::{Enable, Reset};
use stm32f4xx_hal::timer::PwmChannel;

pub use self::clock::read_back as clock_read_back;
pub use self::flash::{Storage, WATCHDOG_PERSIST};
use self::motor::DriveTrain;
#[cfg(feature = "drv8833")]
use self::motor::Drv8833Channel;
#[cfg(not(feature = "drv8833"))]
use self::motor::Tb6612Channel;
pub use self::pins::force_motors_off;
use self::pins::{polarity, Led, Out, Pins};
pub use self::watchdog::Watchdog;
use crate::robot;

/// The part this build is for (one cargo feature each).
#[cfg(feature = "stm32f411")]
pub const CHIP: Chip = Chip::F411;
/// The part this build is for (one cargo feature each).
#[cfg(feature = "stm32f401")]
pub const CHIP: Chip = Chip::F401;
/// The part this build is for (one cargo feature each).
#[cfg(feature = "stm32f446")]
pub const CHIP: Chip = Chip::F446;

/// What `Info` reports as the chip.
pub const NAME: &str = CHIP.name();

/// System clock through the PLL, Hz: 100 MHz, the F411's maximum.
#[cfg(not(feature = "stm32f401"))]
pub const SYSCLK_HZ: u32 = 100_000_000;
/// System clock of the STM32F401, Hz: 72 MHz, not its 84 MHz maximum, because for 84 MHz
/// from the HSI stm32f4xx-hal writes PLLN = 168, below RM0368's minimum of 192; for 72 MHz
/// it writes M = 8, N = 216, P = 6, which RM0368 allows.
#[cfg(feature = "stm32f401")]
pub const SYSCLK_HZ: u32 = 72_000_000;

/// The board's external oscillator: the WeAct Black Pill's 25 MHz crystal.
#[cfg(not(feature = "nucleo"))]
pub const HSE: Hse = Hse::Crystal(25_000_000);
/// The board's external oscillator: a Nucleo-64's 8 MHz from the ST-LINK's MCO on OSC_IN
/// (HSE bypass; UM1724's default solder bridges).
#[cfg(feature = "nucleo")]
pub const HSE: Hse = Hse::ExternalClock(8_000_000);
const _: () = assert!(
    HSE.in_range(),
    "the HSE's frequency is outside its datasheet range"
);

/// The clock configuration for [`CHIP`] at [`SYSCLK_HZ`] from the [`HSE`]: PLL, bus
/// dividers, flash wait states, voltage scale (`robot_app::stm32f4::clock::plan`).
/// `clock::configure` checks the registers against it after the HAL has written them.
pub const CLOCK_PLAN: ClockPlan = match clock_plan::plan(CHIP, HSE.hz(), SYSCLK_HZ) {
    Ok(plan) => plan,
    Err(_) => panic!("SYSCLK_HZ is not reachable from the HSE within the chip's limits"),
};

/// The clock configuration from the HSI (16 MHz RC), used when the [`HSE`] does not
/// start: the same bus and timer clocks, wait states and voltage scale as
/// [`CLOCK_PLAN`] (checked below), so every timer and baud setting derived from
/// [`CLOCK_PLAN`] holds on either, only less accurately on this one.
pub const FALLBACK_CLOCK_PLAN: ClockPlan = match clock_plan::plan(CHIP, HSI_HZ, SYSCLK_HZ) {
    Ok(plan) => plan,
    Err(_) => panic!("SYSCLK_HZ is not reachable from the HSI within the chip's limits"),
};
const _: () = assert!(
    CLOCK_PLAN.tree.same_as(&FALLBACK_CLOCK_PLAN.tree)
        && CLOCK_PLAN.flash_wait_states == FALLBACK_CLOCK_PLAN.flash_wait_states
        && CLOCK_PLAN.scale as u8 == FALLBACK_CLOCK_PLAN.scale as u8,
    "the HSE and HSI plans must give the same clocks"
);

/// Motor PWM frequency, Hz: above hearing.
pub const PWM_HZ: u32 = 20_000;
const _: () = assert!(
    CLOCK_PLAN.tree.timclk1_hz % PWM_HZ == 0 && CLOCK_PLAN.tree.timclk1_hz / PWM_HZ <= 65_536,
    "the PWM period must be a whole number of 16-bit timer counts"
);
// The bridge sequence needs each step's compares latched before the next step.
const _: () = assert!(robot::ROBOT.control_rate_hz * 2 <= PWM_HZ);

/// Counting rate of the free-running tick timer (TIM5), Hz: 1 µs resolution.
pub const TICK_TIMER_HZ: u32 = 1_000_000;
const _: () = assert!(CLOCK_PLAN.tree.timclk1_hz % TICK_TIMER_HZ == 0);

/// The control period in counts of the tick timer (1000 µs at 1 kHz).
const TICK_PERIOD: NonZeroU32 = match NonZeroU32::new(TICK_TIMER_HZ / robot::ROBOT.control_rate_hz)
{
    Some(period) => period,
    None => panic!("control rate above the tick timer's rate"),
};

/// The link's baud rate (8N1), bit/s: the protocol's [`link::LINK_BAUD`] (230 400). A
/// character then takes 43.4 µs; the receive interrupt, above every task (priority 4),
/// takes each before the next arrives as long as nothing masks interrupts for longer
/// (`docs/realtime.md`). Both the ST-LINK's virtual COM
/// port and common USB-serial adapters (CP2102, CH340, FT232) run it.
pub const LINK_BAUD: u32 = link::LINK_BAUD;

/// USART2_BRR for [`LINK_BAUD`] on APB1 (50 MHz on the F411: 217, 0.006 % fast).
pub const LINK_BRR: BaudSetting = match BaudSetting::for_baud(CLOCK_PLAN.tree.pclk1_hz, LINK_BAUD) {
    Ok(setting) => setting,
    Err(_) => panic!("LINK_BAUD is not reachable from PCLK1"),
};

/// Independent watchdog while `init` runs: 250 ms at the typical LSI (170–471 ms over its
/// spread), started before the clock set-up so that no wait in `init` can hang forever
/// (lengthened to [`WATCHDOG_PERSIST`] only around a brown-out level write).
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

/// Left encoder timer: 32-bit TIM2.
pub type LeftEncoderTimer = pac::TIM2;
/// Right encoder timer: 16-bit TIM4.
pub type RightEncoderTimer = pac::TIM4;
/// Timer of both motor PWM channels.
pub type PwmTimer = pac::TIM3;
/// Timer whose channel-1 compare is the 1 kHz control tick (interrupt `TIM5`), counting
/// freely at 1 MHz.
pub type TickTimer = pac::TIM5;

/// A TB6612 channel on a PWM channel `C` of [`PwmTimer`] and two direction pins.
#[cfg(not(feature = "drv8833"))]
type Channel<const C: u8, const IN1: u8, const IN2: u8> =
    Tb6612Channel<PwmChannel<PwmTimer, C>, Out<'B', IN1>, Out<'B', IN2>>;
/// Both motors and STBY, pins as in the table.
#[cfg(not(feature = "drv8833"))]
type Drive = DriveTrain<Channel<0, 4, 5>, Channel<1, 8, 9>, Out<'B', 10>>;
/// A DRV8833 channel on PWM channels `C1` (IN1) and `C2` (IN2) of [`PwmTimer`].
#[cfg(feature = "drv8833")]
type Channel<const C1: u8, const C2: u8> =
    Drv8833Channel<PwmChannel<PwmTimer, C1>, PwmChannel<PwmTimer, C2>>;
/// Both motors and nSLEEP, pins as in the table.
#[cfg(feature = "drv8833")]
type Drive = DriveTrain<Channel<0, 2>, Channel<1, 3>, Out<'B', 10>>;

/// What `init` got from the board.
pub struct Board {
    /// The control task's sensors and actuators.
    pub io: ControlIo,
    /// The running independent watchdog (still at [`WATCHDOG_INIT`]).
    pub watchdog: Watchdog,
    /// USART2, enabled at [`LINK_BAUD`] with its receive interrupt on.
    pub link_usart: pac::USART2,
    /// The parameter storage (flash sectors 6 and 7; `None` on the STM32F401).
    pub storage: Option<Storage>,
    /// Why the chip reset.
    pub reset: ResetCause,
    /// What the system clock runs from.
    pub clock: ClockSource,
    /// The brown-out reset level in force.
    pub brown_out_reset: BrownOutReset,
}

/// Interrupts the RTIC application binds only for the other board (its `plant_port` task,
/// compiled out here): RTIC 2 sets the priority of and unmasks every bound interrupt
/// before `init`, whether or not its task is compiled in, so [`init`] masks these again
/// and an unexpected one can never run the default handler. `cargo xtask`'s task check
/// holds this list to the tasks the F411 build leaves out.
pub const UNUSED_INTERRUPTS: [pac::Interrupt; 1] = [pac::Interrupt::USART1];

/// Brings the board up (see the crate doc for the order): reset cause, watchdog,
/// brown-out level, clock, pins, PWM with the driver in standby, encoders, supply ADC,
/// the IMU if one answers (about 47 ms), link USART, storage. The control tick is not
/// started yet ([`ControlIo::start`]).
pub fn init(dp: pac::Peripherals, mut cp: cortex_m::Peripherals) -> Board {
    // Why did we reset? Read (and clear) before anything else touches RCC.
    let reset = pins::take_reset_flags(&dp.RCC).cause();
    for interrupt in UNUSED_INTERRUPTS {
        NVIC::mask(interrupt);
        NVIC::unpend(interrupt);
    }

    // The watchdog first, with a long timeout, so that no wait below (the HAL's PLL
    // lock included) can hang init: it resets the chip with the motors never enabled.
    #[cfg(feature = "halt-stops-watchdog")]
    watchdog::stop_while_halted(&dp.DBGMCU);
    let mut watchdog = match Watchdog::start(dp.IWDG, WATCHDOG_INIT) {
        Ok(watchdog) => watchdog,
        Err(e) => defmt::panic!("watchdog: {}", e),
    };

    // Cycle counter for the bounded waits below and the step timing; keep the debug port
    // clocked during WFI so the probe can read the RTT buffer while the core sleeps.
    cp.DCB.enable_trace();
    cp.DWT.enable_cycle_counter();
    dp.DBGMCU.cr().modify(|_, w| w.dbg_sleep().set_bit());

    // Brown-out reset at level 3 (once per chip), while still on the HSI at 0 wait states.
    let brown_out = brown_out::ensure_level(&dp.FLASH, &mut watchdog);

    // Clock: HSE (or the HSI if it does not start) → PLL → SYSCLK_HZ at the voltage
    // scale it needs, read back.
    let (mut rcc, clocks) = match clock::configure(dp.RCC, &dp.PWR, &dp.FLASH) {
        Ok(configured) => configured,
        Err(e) => defmt::panic!("clock: {}", e),
    };
    if clocks.source.is_fallback() {
        defmt::warn!(
            "clock: the HSE ({=u32} Hz) did not start within {=u32} us; running from the HSI (±1 % at 25 °C, a few % over temperature)",
            HSE.hz(),
            robot_app::stm32f4::oscillator::HSE_STARTUP_TIMEOUT_US,
        );
    }

    let pins = Pins::new(
        dp.GPIOA.split(&mut rcc),
        dp.GPIOB.split(&mut rcc),
        dp.GPIOC.split(&mut rcc),
    );

    // Motors: 20 kHz PWM channels on one timer, duty 0, driver in standby.
    let (pwm, (ch1, ch2, _ch3, _ch4)) = dp.TIM3.pwm_hz(PWM_HZ.Hz(), &mut rcc);
    let pwm_counts = u32::from(pwm.get_max_duty());
    if pwm_counts != CLOCK_PLAN.tree.timclk1_hz / PWM_HZ {
        defmt::panic!("PWM period is {=u32} counts", pwm_counts);
    }
    let mut left_pwm = ch1.with(pins.left_pwm);
    let mut right_pwm = ch2.with(pins.right_pwm);
    left_pwm.enable();
    right_pwm.enable();
    #[cfg(not(feature = "drv8833"))]
    let drive: Drive = {
        let (ain1, ain2) = pins.left_dir;
        let (bin1, bin2) = pins.right_dir;
        DriveTrain::new(
            Tb6612Channel::new(left_pwm, ain1, ain2),
            Tb6612Channel::new(right_pwm, bin1, bin2),
            pins.standby,
            polarity::LEFT_MOTOR_INVERTED,
            polarity::RIGHT_MOTOR_INVERTED,
        )
    };
    #[cfg(feature = "drv8833")]
    let drive: Drive = {
        // PB4, PB5, PB8, PB9 (the TB6612's direction inputs) are not needed: they stay low.
        let _unused = (pins.left_dir, pins.right_dir);
        let mut left_b = _ch3.with(pins.left_pwm_b);
        let mut right_b = _ch4.with(pins.right_pwm_b);
        left_b.enable();
        right_b.enable();
        DriveTrain::new(
            Drv8833Channel::new(left_pwm, left_b),
            Drv8833Channel::new(right_pwm, right_b),
            pins.standby,
            polarity::LEFT_MOTOR_INVERTED,
            polarity::RIGHT_MOTOR_INVERTED,
        )
    };

    // Encoders: 32-bit TIM2 (left) and 16-bit TIM4 (right) in quadrature mode, with
    // the input filter for this robot's fastest edges.
    let encoders = encoder::Encoders::new(
        Qei::new(dp.TIM2, pins.left_encoder, &mut rcc),
        Qei::new(dp.TIM4, pins.right_encoder, &mut rcc),
    );

    // Supply: one conversion per step, started at its end.
    let supply = supply::Supply::new(dp.ADC1, &dp.ADC_COMMON, pins.supply, &mut rcc);

    // The IMU, if one is fitted (WHO_AM_I): its gyro read at the start of every step.
    let imu = imu::Imu::probe(dp.SPI2, pins.imu, &mut rcc);

    // The link: USART2 at LINK_BAUD, 8N1 (RM0383 §19.6). RCC_APB1ENR.USART2EN on, the
    // peripheral reset (CR1–CR3 = 0: 8 data bits, no parity, 1 stop bit, 16×
    // oversampling, no flow control, no DMA); BRR from `robot_app::stm32f4::usart`; then
    // CR1 = UE | TE | RE | RXNEIE (the transmit interrupt is the driver's to switch).
    let _link_pins = (pins.link_tx, pins.link_rx);
    pac::USART2::enable(&mut rcc);
    pac::USART2::reset(&mut rcc);
    let link_usart = dp.USART2;
    link_usart.brr().write(|w| {
        w.div_mantissa()
            .set(LINK_BRR.mantissa())
            .div_fraction()
            .set(LINK_BRR.fraction())
    });
    link_usart.cr1().write(|w| {
        w.ue()
            .set_bit()
            .te()
            .set_bit()
            .re()
            .set_bit()
            .rxneie()
            .set_bit()
    });

    defmt::info!(
        "board: {=str}, sysclk {=u32} Hz from the {=str} (VOSRDY after {=u32} reads), brown-out reset {=str}, encoder filter {=u8:#06b}, link {=u32} Bd (BRR {=u16})",
        NAME,
        clocks.sysclk_hz,
        if clocks.source.is_fallback() { "HSI" } else { "HSE" },
        clocks.vos_polls,
        brown_out.name(),
        encoder::INPUT_FILTER.code,
        LINK_BRR.actual_baud,
        LINK_BRR.brr,
    );

    Board {
        io: ControlIo {
            tick: tick::Tick::new(dp.TIM5, &mut rcc),
            encoders,
            drive,
            button: pins.button,
            led: pins.led,
            supply,
            imu,
            overran: false,
        },
        watchdog,
        link_usart,
        storage: Storage::new(dp.FLASH),
        reset,
        clock: clocks.source,
        brown_out_reset: brown_out.report(),
    }
}

/// The control task's hardware: the tick, encoders, motors, button, LED, supply and
/// the IMU (if fitted).
pub struct ControlIo {
    tick: tick::Tick,
    encoders: encoder::Encoders,
    drive: Drive,
    button: pins::ButtonPin,
    led: Led,
    supply: supply::Supply,
    /// The IMU found at start-up, if any.
    imu: Option<imu::Imu>,
    /// The previous step was still running when its successor's period began.
    overran: bool,
}

impl ControlIo {
    /// Starts the 1 kHz tick (the last thing `init` does before the watchdog is
    /// shortened): the first step comes one period later.
    pub fn start(&mut self) {
        self.tick.start(TICK_PERIOD);
    }

    /// At the start of a control step: acknowledges the tick and reads the sensors (the
    /// gyro first: one SPI burst, about 5 µs, when an IMU was found);
    /// `None` for an entry before the deadline (not a tick). `heartbeat` is the idle
    /// loop's counter.
    #[inline(always)]
    pub fn sense(&mut self, heartbeat: u32) -> Option<Sensors> {
        let periods = self.tick.on_entry()?;
        let gyro = self.imu.as_mut().and_then(imu::Imu::sample);
        // No conversion ready reads as NaN: the supervisor treats an unreadable supply
        // as a low one (after its debounce).
        let supply_v = self.supply.read_volts().unwrap_or(f32::NAN);
        Some(Sensors {
            ticks: self.encoders.read(),
            periods,
            supply_v,
            button_pressed: pins::button_pressed(&mut self.button),
            overrun: self.overran,
            background_heartbeat: heartbeat,
            gyro,
        })
    }

    /// Writes the step's outputs: duties and the driver's enable line, the LED, and
    /// starts the next supply conversion.
    #[inline(always)]
    pub fn actuate(&mut self, out: &Actuation, _control: &ControlSide<'_>) {
        self.apply_outputs(out.duty, out.bridge.enabled(), out.led_on);
    }

    /// Writes `duty` (each −1…1, positive forward) and the driver's enable line through
    /// the bridge sequence, the LED, and starts the next supply conversion: what
    /// [`ControlIo::actuate`] does with a step's outputs, for the first-flash programs,
    /// which run no control step.
    #[inline(always)]
    pub fn apply_outputs(&mut self, duty: MotorCommand, bridge_enabled: bool, led_on: bool) {
        self.drive.apply(duty, bridge_enabled);
        self.led.set(led_on);
        self.supply.start();
    }

    /// At the end of a step: if the next deadline already came, this step overran.
    #[inline(always)]
    pub fn end_step(&mut self) {
        self.overran = self.tick.is_pending();
    }
}

/// The steering task has run the outer loop's job the step lent it: nothing waits for
/// that on this board (the tick starts the next step).
#[inline(always)]
pub fn steering_done() {}

/// A free-running count for timing the tasks: DWT CYCCNT, CPU cycles.
#[inline(always)]
pub fn work_counter() -> u32 {
    DWT::cycle_count()
}

/// Cycles [`work_counter`] advanced since it read `started` (CYCCNT wraps at 2³², as
/// the difference does).
#[inline(always)]
pub fn work_since(started: u32) -> u32 {
    work_counter().wrapping_sub(started)
}

/// What [`work_counter`] counts, for the log.
pub const WORK_UNIT: &str = "cycles";

/// Converts a [`work_since`] difference to [`WORK_UNIT`]s.
#[inline(always)]
pub fn work_units(delta: u32) -> u32 {
    delta
}

/// The USART2 data register's reads and writes are the link driver's; nothing else to
/// do on this board when the firmware starts.
pub fn announce_ready() {}

/// After a panic or hard fault: stop here (`udf`: probe-rs prints a backtrace); the
/// watchdog, running since the start of `init`, resets the chip, which comes back
/// disarmed.
pub fn halt_after_failure() -> ! {
    cortex_m::asm::udf()
}

/// The emulated board's plant port has no counterpart here (a type with no values: the
/// RTIC application names it in a compile-time `Send` check even where its task is
/// compiled out).
pub enum PlantPort {}
