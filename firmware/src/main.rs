//! Firmware for a two-wheel differential-drive robot on an STM32F411 (Black Pill or
//! Nucleo-F411RE) with a TB6612FNG driver: the Jin & Tack (2011) path follower of
//! `controller-core`, run at 1 kHz by RTIC 2.
//!
//! The story of the board, top to bottom:
//!
//! 1. [`app::init`] reads why the chip reset, brings the clock to 100 MHz from the internal
//!    oscillator, configures the pins ([`board`]), starts 20 kHz PWM with the driver in
//!    standby, starts the two quadrature encoders, builds the controller for this robot
//!    ([`robot`]) and its safety [`Supervisor`], starts the 1 kHz tick and, last, the
//!    independent watchdog.
//! 2. [`app::control`] runs on every tick (hardware timer interrupt, so drift-free): read
//!    the encoders and the button, let the supervisor step the controller and decide, write
//!    the duties and the driver's enable line, feed the watchdog if the supervisor says
//!    so, and every 50th step hand a [`telemetry::Report`] to the background.
//! 3. [`app::report`] and [`app::log_event`] log over defmt/RTT at the lowest task
//!    priority; [`app::idle`] counts a heartbeat that proves the background runs, and
//!    sleeps.
//!
//! Everything that decides what the motors get lives in `controller_core::supervisor`,
//! where host tests exercise it. If anything panics or faults, [`panic`] and `HardFault`
//! force the PWM outputs and the driver's inputs low first, then log.

#![no_std]
#![no_main]

mod board;
mod encoder;
mod motor;
#[cfg(feature = "panic-canary")]
mod panic_canary;
mod robot;
mod telemetry;

use defmt_rtt as _;

#[rtic::app(device = stm32f4xx_hal::pac, dispatchers = [USART6])]
mod app {
    use core::sync::atomic::{AtomicU32, Ordering};

    use controller_core::controller::Controller;
    use controller_core::params::Params;
    use controller_core::reference::Reference;
    use controller_core::supervisor::{Event, Inputs, ResetCause, Supervisor};
    use cortex_m::peripheral::DWT;
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::qei::Qei;
    use stm32f4xx_hal::rcc;
    use stm32f4xx_hal::timer::{CounterHz, Event as TimerEvent, Flag, PwmChannel};
    use stm32f4xx_hal::watchdog::IndependentWatchdog;

    use crate::board::{self, polarity, Led, Out, Pins, PwmTimer, TickTimer};
    use crate::encoder::Encoders;
    use crate::motor::DriveTrain;
    #[cfg(feature = "drv8833")]
    use crate::motor::Drv8833Channel;
    #[cfg(not(feature = "drv8833"))]
    use crate::motor::Tb6612Channel;
    use crate::robot;
    use crate::telemetry::{self, Report};

    /// A TB6612 channel on a PWM channel `C` of [`PwmTimer`] and two direction pins.
    #[cfg(not(feature = "drv8833"))]
    type Channel<const C: u8, const IN1: u8, const IN2: u8> =
        Tb6612Channel<PwmChannel<PwmTimer, C>, Out<'B', IN1>, Out<'B', IN2>>;
    /// Both motors and STBY, pins as in [`board`].
    #[cfg(not(feature = "drv8833"))]
    type Drive = DriveTrain<Channel<0, 12, 13>, Channel<1, 14, 15>, Out<'B', 10>>;
    /// A DRV8833 channel on PWM channels `C1` (IN1) and `C2` (IN2) of [`PwmTimer`].
    #[cfg(feature = "drv8833")]
    type Channel<const C1: u8, const C2: u8> =
        Drv8833Channel<PwmChannel<PwmTimer, C1>, PwmChannel<PwmTimer, C2>>;
    /// Both motors and nSLEEP, pins as in [`board`].
    #[cfg(feature = "drv8833")]
    type Drive = DriveTrain<Channel<0, 2>, Channel<1, 3>, Out<'B', 10>>;

    /// Control steps between two telemetry reports.
    const REPORT_EVERY: u32 = robot::ROBOT.control_rate_hz / robot::TELEMETRY_HZ;
    const _: () = assert!(
        REPORT_EVERY > 0,
        "robot::TELEMETRY_HZ must not exceed the control rate"
    );

    /// Incremented by the idle loop: proof for the supervisor that the background runs.
    static HEARTBEAT: AtomicU32 = AtomicU32::new(0);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        tick: CounterHz<TickTimer>,
        encoders: Encoders,
        drive: Drive,
        controller: Controller,
        supervisor: Supervisor,
        watchdog: IndependentWatchdog,
        button: board::ButtonPin,
        led: Led,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        let mut cp = cx.core;

        // Why did we reset? Read (and clear) before anything else touches RCC.
        let reset = ResetCause::from_flags(board::take_reset_flags(&dp.RCC));

        // Clock: HSI → PLL → 100 MHz, whatever crystal the board has.
        let mut rcc = dp
            .RCC
            .freeze(rcc::Config::hsi().sysclk(board::SYSCLK_HZ.Hz()));

        // Cycle counter for the step timing; keep the debug port clocked during WFI so the
        // probe can read the RTT buffer while the core sleeps.
        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
        dp.DBGMCU.cr().modify(|_, w| w.dbg_sleep().set_bit());

        let pins = Pins::new(
            dp.GPIOA.split(&mut rcc),
            dp.GPIOB.split(&mut rcc),
            dp.GPIOC.split(&mut rcc),
        );

        // Motors: 20 kHz PWM channels on one timer, duty 0, driver in standby.
        let (_pwm, (ch1, ch2, _ch3, _ch4)) = dp.TIM3.pwm_hz(board::PWM_HZ.Hz(), &mut rcc);
        let mut left_pwm = ch1.with(pins.left_pwm);
        let mut right_pwm = ch2.with(pins.right_pwm);
        left_pwm.enable();
        right_pwm.enable();
        #[cfg(not(feature = "drv8833"))]
        let drive: Drive = {
            let (ain1, ain2) = pins.left_dir;
            let (bin1, bin2) = pins.right_dir;
            DriveTrain::new(
                Tb6612Channel::new(left_pwm, ain1, ain2, polarity::LEFT_MOTOR_INVERTED),
                Tb6612Channel::new(right_pwm, bin1, bin2, polarity::RIGHT_MOTOR_INVERTED),
                pins.standby,
            )
        };
        #[cfg(feature = "drv8833")]
        let drive: Drive = {
            // PB12–PB15 (the TB6612's direction inputs) are not needed: they stay low.
            let _unused = (pins.left_dir, pins.right_dir);
            let mut left_b = _ch3.with(pins.left_pwm_b);
            let mut right_b = _ch4.with(pins.right_pwm_b);
            left_b.enable();
            right_b.enable();
            DriveTrain::new(
                Drv8833Channel::new(left_pwm, left_b, polarity::LEFT_MOTOR_INVERTED),
                Drv8833Channel::new(right_pwm, right_b, polarity::RIGHT_MOTOR_INVERTED),
                pins.standby,
            )
        };

        // Encoders: 32-bit TIM2 (left) and 16-bit TIM4 (right) in quadrature mode.
        let encoders = Encoders::new(
            Qei::new(dp.TIM2, pins.left_encoder, &mut rcc),
            Qei::new(dp.TIM4, pins.right_encoder, &mut rcc),
        );

        // The controller for this robot, and the supervisor around it.
        let params = match Params::new(robot::ROBOT) {
            Ok(params) => params,
            Err(e) => defmt::panic!("robot::ROBOT is invalid: {}", e),
        };
        let (path, mode) = match robot::PATH.build() {
            Ok(built) => built,
            Err(e) => defmt::panic!("built-in path {}: {}", robot::PATH, e),
        };
        let reference = match Reference::new(path, robot::REFERENCE_SPEED_M_S, mode) {
            Ok(reference) => reference,
            Err(e) => defmt::panic!("reference: {}", e),
        };
        let controller = Controller::new(params, reference, robot::LAW, robot::PATH.start_pose());
        let supervisor = match Supervisor::new(robot::supervisor_config(), reset) {
            Ok(supervisor) => supervisor,
            Err(e) => defmt::panic!("robot::supervisor_config(): {}", e),
        };

        // The fixed-rate tick: TIM5's update interrupt at the control rate.
        let mut tick = dp.TIM5.counter_hz(&mut rcc);
        if tick.start(robot::ROBOT.control_rate_hz.Hz()).is_err() {
            defmt::panic!(
                "TIM5 cannot tick at {=u32} Hz",
                robot::ROBOT.control_rate_hz
            );
        }
        tick.listen(TimerEvent::Update);

        defmt::info!(
            "boot: reset cause {}, sysclk {=u32} Hz, path {}, law {=str}, {} when armed, press the button to arm",
            reset,
            rcc.clocks.sysclk().raw(),
            robot::PATH,
            robot::LAW.name(),
            supervisor.run_mode(),
        );

        // Last: the independent watchdog. From here on the control task must feed it.
        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        watchdog.start(board::WATCHDOG_TIMEOUT_MS.millis());

        let local = Local {
            tick,
            encoders,
            drive,
            controller,
            supervisor,
            watchdog,
            button: pins.button,
            led: pins.led,
        };
        (Shared {}, local)
    }

    /// The control step, on every tick: sense, decide, act, report.
    #[task(
        binds = TIM5,
        priority = 2,
        local = [
            tick, encoders, drive, controller, supervisor, watchdog, button, led,
            step: u32 = 0,
            overran: bool = false,
            max_cycles: u32 = 0,
            pending_event: Option<Event> = None,
        ]
    )]
    fn control(cx: control::Context) {
        let start = DWT::cycle_count();
        let l = cx.local;
        l.tick.clear_flags(Flag::Update);

        // Sense.
        let input = Inputs {
            ticks: l.encoders.read(),
            button_pressed: board::button_pressed(l.button),
            overrun: *l.overran,
            background_heartbeat: HEARTBEAT.load(Ordering::Relaxed),
        };

        // Decide: the supervisor steps the controller and says what the motors get.
        let out = l.supervisor.step(l.controller, input);

        // Act.
        l.drive.apply(out.duty, out.driver_enabled);
        if out.feed_watchdog {
            l.watchdog.feed();
        }
        l.led.set(telemetry::led_on(out.state, *l.step));
        let cycles = DWT::cycle_count().wrapping_sub(start);
        *l.max_cycles = (*l.max_cycles).max(cycles);

        // Report, without waiting: the background logs; a busy slot drops the sample.
        if let Some(event) = out.event {
            *l.pending_event = Some(event);
        }
        if let Some(event) = *l.pending_event {
            if log_event::spawn(event).is_ok() {
                *l.pending_event = None;
            }
        }
        if *l.step % REPORT_EVERY == 0 {
            let t = l.controller.telemetry();
            let _dropped = report::spawn(Report::new(*l.step, &out, t, cycles, *l.max_cycles));
        }

        // Test builds only: a known panic path for `cargo xtask panic-check` to find.
        #[cfg(feature = "panic-canary")]
        core::hint::black_box(crate::panic_canary::index());

        *l.step = l.step.wrapping_add(1);
        // Fixed rate: if the next tick already came while this step ran, it overran.
        *l.overran = l.tick.flags().contains(Flag::Update);
    }

    /// Logs one telemetry line.
    #[task(priority = 1)]
    async fn report(_cx: report::Context, report: Report) {
        if report.faults.any() {
            defmt::warn!("{}", report);
        } else {
            defmt::info!("{}", report);
        }
    }

    /// Logs a supervisor state change.
    #[task(priority = 1)]
    async fn log_event(_cx: log_event::Context, event: Event) {
        match event {
            Event::Faulted => defmt::error!("event: {}", event),
            _ => defmt::info!("event: {}", event),
        }
    }

    /// The lowest priority: count a heartbeat, then sleep until the next interrupt.
    #[idle]
    fn idle(_cx: idle::Context) -> ! {
        loop {
            HEARTBEAT.fetch_add(1, Ordering::Relaxed);
            cortex_m::asm::wfi();
        }
    }
}

/// Set by the first panic.
static PANICKING: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);

/// Panic: motors off first (PWM outputs forced low, driver inputs and STBY low), then the
/// message over defmt, then stop (`udf`: probe-rs prints a backtrace; without a probe the
/// watchdog resets the chip, which comes back disarmed; a panic in `init`, before the
/// watchdog starts, stays halted with the motors off).
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    // SAFETY: interrupts are off and nothing runs after this handler.
    unsafe { board::force_motors_off() };
    // A panic inside the logger (or while logging this one) must not recurse.
    if PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        cortex_m::asm::udf()
    }
    let message = info.message().as_str().unwrap_or("(formatted message)");
    match info.location() {
        Some(at) => defmt::error!(
            "panic at {=str}:{=u32}: {=str}; motors off",
            at.file(),
            at.line(),
            message
        ),
        None => defmt::error!("panic: {=str}; motors off", message),
    }
    cortex_m::asm::udf()
}

/// Hard fault: motors off, log where, wait for the watchdog.
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    // SAFETY: nothing else runs once the core is in the hard-fault handler.
    unsafe { board::force_motors_off() };
    defmt::error!("hard fault at pc {=u32:#010x}; motors off", frame.pc());
    loop {
        cortex_m::asm::nop();
    }
}
