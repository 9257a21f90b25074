//! Firmware for a two-wheel differential-drive robot on an STM32F411 (Black Pill or
//! Nucleo-F411RE) with a TB6612FNG driver: the Jin & Tack (2011) path follower of
//! `controller-core`, run at 1 kHz by RTIC 2.
//!
//! The story of the board, top to bottom:
//!
//! 1. [`app::init`] reads why the chip reset and what the previous run's panic record says
//!    ([`panic_record`]), starts the independent watchdog with a long timeout (so nothing
//!    in `init` can hang), brings the clock to 100 MHz from the internal oscillator with
//!    the voltage scale it needs ([`clock`]), configures the pins ([`board`]), starts
//!    20 kHz PWM with the driver in standby, the two quadrature encoders with their input
//!    filters, the supply ADC ([`supply`]), builds the controller for this robot
//!    ([`robot`]) and its safety `Supervisor`, starts the 1 kHz tick ([`tick`]) and,
//!    last, shortens the watchdog to 10 ms ([`watchdog`]).
//! 2. [`app::control`] runs on every tick (a compare on a free-running hardware timer, so
//!    drift-free, and it counts the periods it missed): read the encoders, the button and
//!    the supply, let the supervisor step the controller and decide, write the duties and
//!    the driver's enable line, feed the watchdog if the supervisor says so, start the
//!    next supply conversion, and every 50th step hand a [`telemetry::Report`] to the
//!    background.
//! 3. [`app::report`] and [`app::log_event`] log over defmt/RTT at the lowest task
//!    priority; [`app::idle`] counts a heartbeat that proves the background runs, and
//!    sleeps.
//!
//! Everything that decides what the motors get lives in `controller_core::supervisor`,
//! where host tests exercise it. If anything panics or faults, [`panic()`] and `HardFault`
//! force the PWM outputs and the driver's inputs low first, then write the panic record,
//! then log.

#![no_std]
#![no_main]

mod board;
mod clock;
mod encoder;
mod motor;
#[cfg(feature = "panic-canary")]
mod panic_canary;
mod panic_record;
mod robot;
mod supply;
mod telemetry;
mod tick;
mod watchdog;

use defmt_rtt as _;

#[rtic::app(device = stm32f4xx_hal::pac, dispatchers = [USART6])]
mod app {
    use core::num::NonZeroU32;
    use core::sync::atomic::{AtomicU32, Ordering};

    use controller_core::controller::Controller;
    use controller_core::params::Params;
    use controller_core::reference::Reference;
    use controller_core::supervisor::{Event, Inputs, ResetCause, Supervisor};
    use cortex_m::peripheral::DWT;
    use robot_app::panic_record::PanicRecord;
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::qei::Qei;
    use stm32f4xx_hal::timer::PwmChannel;

    use crate::board::{self, polarity, Led, Out, Pins, PwmTimer};
    use crate::encoder::{self, Encoders};
    use crate::motor::DriveTrain;
    #[cfg(feature = "drv8833")]
    use crate::motor::Drv8833Channel;
    #[cfg(not(feature = "drv8833"))]
    use crate::motor::Tb6612Channel;
    use crate::supply::Supply;
    use crate::telemetry::{self, Report, StepTiming};
    use crate::tick::Tick;
    use crate::watchdog::Watchdog;
    use crate::{clock, panic_record, robot};

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

    /// The control period in counts of the tick timer (1000 µs at 1 kHz).
    const TICK_PERIOD: NonZeroU32 =
        match NonZeroU32::new(board::TICK_TIMER_HZ / robot::ROBOT.control_rate_hz) {
            Some(period) => period,
            None => panic!("control rate above the tick timer's rate"),
        };
    // The bridge sequence needs each step's compares latched before the next step.
    const _: () = assert!(robot::ROBOT.control_rate_hz * 2 <= board::PWM_HZ);

    /// Incremented by the idle loop: proof for the supervisor that the background runs.
    static HEARTBEAT: AtomicU32 = AtomicU32::new(0);

    #[shared]
    struct Shared {
        /// The previous run's panic or hard-fault record, reported at boot; kept for the
        /// link's information and statistics.
        previous_failure: Option<PanicRecord>,
    }

    #[local]
    struct Local {
        tick: Tick,
        encoders: Encoders,
        drive: Drive,
        controller: Controller,
        supervisor: Supervisor,
        watchdog: Watchdog,
        button: board::ButtonPin,
        led: Led,
        supply: Supply,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        let mut cp = cx.core;

        // Why did we reset, and did the previous run leave a record? Read (and clear)
        // before anything else touches RCC or that RAM.
        let reset = ResetCause::from_flags(board::take_reset_flags(&dp.RCC));
        let previous_failure = panic_record::take();

        // The watchdog first, with a long timeout, so that no wait below (the HAL's PLL
        // lock included) can hang init: it resets the chip with the motors never enabled.
        #[cfg(feature = "halt-stops-watchdog")]
        crate::watchdog::stop_while_halted(&dp.DBGMCU);
        let mut watchdog = match Watchdog::start(dp.IWDG, board::WATCHDOG_INIT) {
            Ok(watchdog) => watchdog,
            Err(e) => defmt::panic!("watchdog: {}", e),
        };

        // Clock: HSI → PLL → SYSCLK_HZ at the voltage scale it needs, read back.
        let (mut rcc, clocks) = match clock::configure(dp.RCC, &dp.PWR, &dp.FLASH) {
            Ok(configured) => configured,
            Err(e) => defmt::panic!("clock: {}", e),
        };

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
        let (pwm, (ch1, ch2, _ch3, _ch4)) = dp.TIM3.pwm_hz(board::PWM_HZ.Hz(), &mut rcc);
        let pwm_counts = u32::from(pwm.get_max_duty());
        if pwm_counts != board::CLOCK_PLAN.tree.timclk1_hz / board::PWM_HZ {
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
            // PB12–PB15 (the TB6612's direction inputs) are not needed: they stay low.
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
        let encoders = Encoders::new(
            Qei::new(dp.TIM2, pins.left_encoder, &mut rcc),
            Qei::new(dp.TIM4, pins.right_encoder, &mut rcc),
        );

        // Supply: one conversion per step, started at its end.
        let supply = Supply::new(dp.ADC1, &dp.ADC_COMMON, pins.supply, &mut rcc);

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
        let supervisor = match Supervisor::new(robot::supervisor_config(), &params, reset) {
            Ok(supervisor) => supervisor,
            Err(e) => defmt::panic!("robot::supervisor_config(): {}", e),
        };

        // The fixed-rate tick: TIM5 compare on a free-running 1 MHz count.
        let tick = Tick::start(dp.TIM5, &mut rcc, TICK_PERIOD);

        if let Some(failure) = &previous_failure {
            log_failure(failure);
        }
        defmt::info!(
            "boot: reset cause {}, sysclk {=u32} Hz (VOSRDY after {=u32} reads), encoder filter {=u8:#06b}, path {}, law {=str}, {} when armed, press the button to arm",
            reset,
            clocks.sysclk_hz,
            clocks.vos_polls,
            encoder::INPUT_FILTER.code,
            robot::PATH,
            robot::LAW.name(),
            supervisor.run_mode(),
        );

        // Last: the run-time watchdog. From here on the control task must feed it.
        if let Err(e) = watchdog.set_timeout(board::WATCHDOG_RUN) {
            defmt::panic!("watchdog: {}", e);
        }

        let local = Local {
            tick,
            encoders,
            drive,
            controller,
            supervisor,
            watchdog,
            button: pins.button,
            led: pins.led,
            supply,
        };
        (Shared { previous_failure }, local)
    }

    /// The control step, on every tick: sense, decide, act, report.
    #[task(
        binds = TIM5,
        priority = 2,
        local = [
            tick, encoders, drive, controller, supervisor, watchdog, button, led, supply,
            step: u32 = 0,
            overran: bool = false,
            timing: StepTiming = StepTiming { cycles: 0, max_cycles: 0, missed_ticks: 0 },
            pending_event: Option<Event> = None,
        ]
    )]
    fn control(cx: control::Context) {
        let start = DWT::cycle_count();
        let l = cx.local;
        // Periods since the last step (1 unless this one started a period or more late).
        let Some(elapsed) = l.tick.on_entry() else {
            return; // entered before the deadline: not a tick
        };
        l.timing.missed_ticks = l.timing.missed_ticks.saturating_add(elapsed.get() - 1);

        // Sense.
        let supply_v = l.supply.read_volts();
        let input = Inputs {
            ticks: l.encoders.read(),
            periods: elapsed,
            // No conversion ready reads as NaN: the supervisor treats an unreadable supply
            // as a low one (after its debounce).
            supply_v: supply_v.unwrap_or(f32::NAN),
            button_pressed: board::button_pressed(l.button),
            overrun: *l.overran,
            background_heartbeat: HEARTBEAT.load(Ordering::Relaxed),
            command: None,
        };

        // Decide: the supervisor steps the controller and says what the motors get.
        let out = l.supervisor.step(l.controller, input);

        // Act.
        l.drive.apply(out.duty, out.bridge.enabled());
        if out.feed_watchdog {
            l.watchdog.feed();
        }
        l.led.set(telemetry::led_on(out.state, *l.step));
        l.supply.start();
        l.timing.cycles = DWT::cycle_count().wrapping_sub(start);
        l.timing.max_cycles = l.timing.max_cycles.max(l.timing.cycles);

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
            let _dropped = report::spawn(Report::new(*l.step, &out, t, *l.timing, supply_v));
        }

        // Test builds only: a known panic path for `cargo xtask panic-check` to find.
        #[cfg(feature = "panic-canary")]
        core::hint::black_box(crate::panic_canary::index());

        *l.step = l.step.wrapping_add(1);
        // Fixed rate: if the next deadline already came while this step ran, it overran.
        *l.overran = l.tick.is_pending();
    }

    /// Logs one telemetry line; every [`FAILURE_REPEAT_REPORTS`]th report also repeats the
    /// previous run's failure record, for a probe attached after the boot log.
    #[task(priority = 1, shared = [previous_failure], local = [reports: u32 = 0])]
    async fn report(mut cx: report::Context, report: Report) {
        if report.faults.any() {
            defmt::warn!("{}", report);
        } else {
            defmt::info!("{}", report);
        }
        *cx.local.reports = cx.local.reports.wrapping_add(1);
        if *cx.local.reports % FAILURE_REPEAT_REPORTS == 0 {
            cx.shared.previous_failure.lock(|failure| {
                if let Some(f) = failure {
                    log_failure(f);
                }
            });
        }
    }

    /// Reports between two repetitions of the previous run's failure record (10 s).
    const FAILURE_REPEAT_REPORTS: u32 = 10 * robot::TELEMETRY_HZ;

    /// Logs a panic or hard-fault record of the previous run.
    fn log_failure(failure: &PanicRecord) {
        defmt::warn!(
            "previous run ended in a {=str} at {=str}:{=u32} (pc {=u32:#010x}): {=str}",
            failure.kind().name(),
            failure.file(),
            failure.line(),
            failure.pc(),
            failure.message(),
        );
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
/// panic record in RAM that survives the reset (reported at the next boot), then the
/// message over defmt (lost if the panic interrupted a log frame of its own priority),
/// then stop (`udf`: probe-rs prints a backtrace; the watchdog, running since the start of
/// `init`, resets the chip, which comes back disarmed).
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    // SAFETY: interrupts are off and nothing runs after this handler.
    unsafe { board::force_motors_off() };
    // A panic inside the logger (or while logging this one) must not recurse.
    if PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        cortex_m::asm::udf()
    }
    let mut record = match info.location() {
        Some(at) => robot_app::panic_record::PanicRecord::panic(at.file(), at.line()),
        None => robot_app::panic_record::PanicRecord::panic("", 0),
    };
    // Bounded: keeps the message's first bytes, never fails.
    let _ = core::fmt::write(record.message_mut(), format_args!("{}", info.message()));
    panic_record::store(&record);
    defmt::error!(
        "panic at {=str}:{=u32}: {=str}; motors off",
        record.file(),
        record.line(),
        record.message()
    );
    cortex_m::asm::udf()
}

/// Hard fault: motors off, the record (unless a panic already wrote one: its `udf` ends
/// here), log where, wait for the watchdog. A stack overflow under flip-link locks the
/// core up before this handler can run (the exception entry itself cannot push its
/// frame); then only the watchdog stops the motors.
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    // SAFETY: nothing else runs once the core is in the hard-fault handler.
    unsafe { board::force_motors_off() };
    if !PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        panic_record::store(&robot_app::panic_record::PanicRecord::hard_fault(
            frame.pc(),
        ));
    }
    defmt::error!("hard fault at pc {=u32:#010x}; motors off", frame.pc());
    loop {
        cortex_m::asm::nop();
    }
}
