//! Firmware for a two-wheel differential-drive robot: the Jin & Tack (2011) path follower
//! of `controller-core`, run at 1 kHz by RTIC 2, with the runtime link of `robot-app`
//! (configure, drive and watch the robot over a serial line), on two boards:
//!
//! - the STM32F411 robot (Black Pill or Nucleo-F411RE) with a TB6612FNG driver, the
//!   default;
//! - QEMU's `netduinoplus2` (feature `qemu`), whose wheels are `host-sim`'s simulated
//!   plant in lockstep: processor in the loop.
//!
//! Everything that differs between the two is in [`board`]; this file is the same for
//! both. The board layer, [`robot`] and [`stats`] are the crate's library
//! (`firmware_board`), which the first-flash programs (`examples/`) share. The story,
//! top to bottom:
//!
//! 1. [`app::init`] reads a previous run's panic record ([`panic_record`]), brings the
//!    board up ([`board`]: on the F411 the watchdog with a long timeout first, the
//!    brown-out reset level, the clock from the board's oscillator, pins, PWM with the driver in standby, encoders, supply ADC, the IMU if one answers, the link USART),
//!    loads the parameters from flash or falls back to the built-in ones
//!    ([`persistence`], [`robot`]), builds the two sides of the application
//!    (`robot_app::start`: the control side and the link service, joined by lock-free
//!    channels), hands the outer loop to the steering task, starts the tick and, last,
//!    shortens the watchdog to 10 ms.
//! 2. [`app::control`] runs every control period (TIM5): the board's sensors, one
//!    `ControlSide::step` (supervisor and the controller's inner loop, the link's
//!    commands, installs while disarmed, telemetry sampling, a run's report), the board's
//!    actuators, the watchdog feed, and a pend of the link task when the step queued
//!    something for it. It never waits, logs, allocates or panics (`cargo xtask
//!    panic-check` proves the last from the release binary).
//! 3. [`app::steering`] runs the steering law (the outer loop) when a control step lent
//!    it a job, below the control task and before the next step, which applies its
//!    outcome (`robot_app::outer`). Same rules as the control task.
//! 4. [`app::link_uart`] (USART2, above every other task: the USART has no FIFO) moves
//!    bytes between the line and two rings ([`link_uart`]); [`app::link`] runs the link
//!    service between those rings ([`link_task`]) and writes flash when asked.
//! 5. [`app::idle`] counts a heartbeat that proves the background runs, and sleeps.
//!
//! | task | bound to | priority | shares |
//! |---|---|---|---|
//! | `link_uart` | USART2 | 4 | — |
//! | `control` | TIM5 | 3 | the watchdog (with `link`, locked only to change its timeout, in Persisting) |
//! | `plant_port` (`qemu` only) | USART1 | 3 | — |
//! | `steering` | [`app::STEERING_TASK_INTERRUPT`] (pended by the control task) | 2 | — |
//! | `link` | [`app::LINK_TASK_INTERRUPT`] (pended by software) | 1 | the watchdog |
//! | `idle` | — | 0 | — |
//!
//! The receive interrupt is the highest: at 230 400 Bd a character lasts 43.4 µs and
//! USART2 holds one, so no task may hold it off for longer (`docs/realtime.md`; a host
//! test in `xtask` checks the order). Between the control task, the steering task and
//! the link task nothing is locked:
//! they talk through `robot_app`'s single-producer single-consumer queues, mailboxes and
//! atomics. The link task is a
//! hardware task on an interrupt no peripheral raises, pended by software: a pend while
//! it runs makes it run again, so no wake-up is lost.
//!
//! If anything panics or faults, [`panic()`] and `HardFault` force the motor outputs low
//! first, then write the panic record, then log.

#![no_std]
#![no_main]

mod link_task;
mod link_uart;
#[cfg(feature = "panic-canary")]
mod panic_canary;
mod panic_record;
mod persistence;

use firmware_board::{board, robot, stats};

use defmt_rtt as _;

#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true)]
mod app {
    use core::sync::atomic::{AtomicU32, Ordering};

    use controller_core::supervisor::{Event, State};
    use robot_app::channel::ring::Ring;
    use robot_app::outer::OuterLoopWorker;
    use robot_app::panic_record::PanicRecord;
    use robot_app::{start, Channels, ControlSide};
    use stm32f4xx_hal::pac;

    use crate::board;
    use crate::link_task::LinkWorker;
    use crate::link_uart::{LinkUart, RX_RING, TX_RING};
    use crate::{panic_record, persistence, robot, stats};

    /// The interrupt the link task is bound to: EXTI line 4, which no peripheral raises
    /// here (no pin is routed to it, EXTI_IMR stays 0), so only software pends it.
    pub const LINK_TASK_INTERRUPT: pac::Interrupt = pac::Interrupt::EXTI4;

    /// The interrupt the steering task is bound to: EXTI line 3, which no peripheral
    /// raises either, pended by the control task when it lends the outer loop.
    pub const STEERING_TASK_INTERRUPT: pac::Interrupt = pac::Interrupt::EXTI3;

    /// Incremented by the idle loop: proof for the supervisor that the background runs.
    static HEARTBEAT: AtomicU32 = AtomicU32::new(0);

    #[shared]
    struct Shared {
        /// The independent watchdog: fed by the control task, lengthened by the link
        /// task around a flash write.
        watchdog: board::Watchdog,
    }

    #[local]
    struct Local {
        io: board::ControlIo,
        control: ControlSide<'static>,
        steering: OuterLoopWorker<'static>,
        uart: LinkUart,
        link: LinkWorker,
        #[cfg(feature = "qemu")]
        plant: board::PlantPort,
    }

    #[init(local = [
        channels: Channels = Channels::new(),
        rx_ring: Ring<u8, RX_RING> = Ring::new(),
        tx_ring: Ring<u8, TX_RING> = Ring::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        // Did a previous run leave a record? It stays until a host clears it over the
        // link (`GetPanicRecord`, `ClearPanicRecord`), across resets too.
        let previous_failure = panic_record::read();
        let mut board = board::init(cx.device, cx.core);
        if let Some(failure) = &previous_failure {
            log_failure(failure);
        }

        let params = persistence::load(board.storage.as_ref(), robot::default_params());
        let config = match robot::app_config(params, &board) {
            Ok(config) => config,
            Err(e) => defmt::panic!("built-in path {}: {}", robot::PATH, e),
        };
        let (mut control, service) = match start(cx.local.channels, config) {
            Ok(sides) => sides,
            Err(_) => defmt::panic!("the configuration in force is invalid"),
        };
        // Built in the channels at start, so held until the first lent job.
        let law = control
            .controller()
            .steering()
            .map_or("(lent)", |s| s.law().name());
        // The steering law runs in its own task, below the control task.
        let Some(steering) = control.lend_outer_loop() else {
            defmt::panic!("the outer loop was lent already");
        };
        defmt::info!(
            "boot: reset cause {}, path {}, law {=str}, {} when armed, link {=u32} Bd, tasks timed in {=str}",
            board.reset,
            robot::PATH,
            law,
            control.supervisor().run_mode(),
            board::LINK_BAUD,
            board::WORK_UNIT,
        );

        let (rx_in, rx_out) = cx.local.rx_ring.split();
        let (tx_in, tx_out) = cx.local.tx_ring.split();
        let uart = LinkUart::new(board.link_usart, rx_in, tx_out);
        let link = LinkWorker::new(service, rx_out, tx_in, board.storage);

        // Last: the tick, and the run-time watchdog. From here on the control task
        // must feed it.
        board.io.start();
        if let Err(e) = board.watchdog.set_timeout(board::WATCHDOG_RUN) {
            defmt::panic!("watchdog: {}", e);
        }
        board::announce_ready();

        let local = Local {
            io: board.io,
            control,
            steering,
            uart,
            link,
            #[cfg(feature = "qemu")]
            plant: board.plant,
        };
        (
            Shared {
                watchdog: board.watchdog,
            },
            local,
        )
    }

    /// The control step, every control period: sense, decide, act.
    #[task(binds = TIM5, priority = 3, shared = [watchdog], local = [io, control])]
    fn control(mut cx: control::Context) {
        let started = stats::start();
        let local = cx.local;
        let Some(sensors) = local.io.sense(HEARTBEAT.load(Ordering::Relaxed)) else {
            return; // entered before the deadline: not a tick
        };
        let out = local.control.step(sensors);
        local.io.actuate(&out, local.control);
        if out.feed_watchdog {
            cx.shared.watchdog.lock(|watchdog| watchdog.feed());
        }
        if out.steering_lent {
            rtic::pend(STEERING_TASK_INTERRUPT);
        }
        if out.link_has_work {
            rtic::pend(LINK_TASK_INTERRUPT);
        }
        // Test builds only: a known panic path for `cargo xtask panic-check` to find.
        #[cfg(feature = "panic-canary")]
        core::hint::black_box(crate::panic_canary::index());
        local.io.end_step();
        // One reading for every figure: they measure the same run.
        let elapsed = stats::own_time_since(started);
        stats::CONTROL.record(elapsed);
        match (out.state, out.event) {
            (State::Armed, None) => stats::CONTROL_ARMED.record(elapsed),
            (_, Some(Event::Armed(_))) => stats::CONTROL_ARMING.record(elapsed),
            _ => {}
        }
    }

    /// The steering law, on the job the last control step lent (see `robot_app::outer`).
    #[task(binds = EXTI3, priority = 2, local = [steering])]
    fn steering(cx: steering::Context) {
        let started = stats::start();
        let ran = cx.local.steering.run();
        let elapsed = stats::own_time_since(started);
        if ran {
            stats::STEERING.record(elapsed);
        }
        board::steering_done();
    }

    /// The plant port of the emulated board (see `board::PlantPort`).
    #[cfg(feature = "qemu")]
    #[task(binds = USART1, priority = 3, local = [plant])]
    fn plant_port(cx: plant_port::Context) {
        // The emulator's port, not the robot's work: charged, so that the tasks it
        // preempts do not count it, and not reported.
        let started = stats::start();
        cx.local.plant.on_interrupt();
        stats::own_time_since(started);
    }

    /// The link's USART: bytes between the line and the rings.
    #[task(binds = USART2, priority = 4, local = [uart])]
    fn link_uart(cx: link_uart::Context) {
        let started = stats::start();
        if cx.local.uart.on_interrupt() {
            rtic::pend(LINK_TASK_INTERRUPT);
        }
        stats::LINK_UART.record(stats::own_time_since(started));
    }

    /// The link service (see `crate::link_task`).
    #[task(binds = EXTI4, priority = 1, shared = [watchdog], local = [link])]
    fn link(mut cx: link::Context) {
        let started = stats::start();
        cx.local.link.run(&mut cx.shared.watchdog);
        stats::LINK.record(stats::own_time_since(started));
    }

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

    /// The lowest priority: count a heartbeat, then sleep until the next interrupt.
    #[idle]
    fn idle(_cx: idle::Context) -> ! {
        stats::repaint_after_start();
        loop {
            HEARTBEAT.fetch_add(1, Ordering::Relaxed);
            cortex_m::asm::wfi();
        }
    }
}

/// Set by the first panic.
static PANICKING: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);

/// Panic: motors off first (PWM outputs forced low, driver inputs and STBY low), then the
/// panic record (file and line) in RAM that survives the reset (reported at the next
/// boot), then the location over defmt (lost if the panic interrupted a log frame of its own priority),
/// then stop ([`board::halt_after_failure`]).
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    // SAFETY: interrupts are off and nothing runs after this handler.
    unsafe { board::force_motors_off() };
    // A panic inside the logger (or while logging this one) must not recurse.
    if PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        board::halt_after_failure()
    }
    // File and line only: formatting the message would link `core::fmt`'s machinery
    // (about 0.8 KiB of flash) for a path that must never run.
    let record = match info.location() {
        Some(at) => robot_app::panic_record::PanicRecord::panic(at.file(), at.line()),
        None => robot_app::panic_record::PanicRecord::panic("", 0),
    };
    panic_record::store(&record);
    defmt::error!(
        "panic at {=str}:{=u32}: {=str}; motors off",
        record.file(),
        record.line(),
        record.message()
    );
    board::halt_after_failure()
}

/// Hard fault: motors off, then, unless a panic is in progress (its `udf` ends here,
/// and its record and log are already written), the record and the log of where; then
/// stop. A stack overflow under flip-link locks the core up before this handler can run
/// (the exception entry itself cannot push its frame); then only the watchdog stops the
/// motors. A debugger's hard-fault vector catch halts the core before this handler too
/// (`docs/first-flash.md`, "Debugging").
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    // SAFETY: nothing else runs once the core is in the hard-fault handler.
    unsafe { board::force_motors_off() };
    if !PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        panic_record::store(&robot_app::panic_record::PanicRecord::hard_fault(
            frame.pc(),
        ));
        defmt::error!("hard fault at pc {=u32:#010x}; motors off", frame.pc());
    }
    #[cfg(feature = "qemu")]
    board::halt_after_failure();
    #[cfg(not(feature = "qemu"))]
    loop {
        cortex_m::asm::nop();
    }
}
