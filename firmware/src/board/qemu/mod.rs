//! The emulated board: QEMU's `netduinoplus2` (an STM32F405), running the very same
//! application as the F411, with the robot's wheels simulated by `host-sim pil` behind
//! an emulated USART (processor in the loop).
//!
//! QEMU models the USARTs, the timers' update interrupts, the NVIC and SysTick; it does
//! not model RCC, GPIO, DMA, the timers' encoder and PWM modes, the ADC, the independent
//! watchdog, the flash interface or DWT. So this board has no clock set-up, pins,
//! encoders, PWM, supply ADC, watchdog or storage. In their place:
//!
//! | what | F411 board | this board |
//! |---|---|---|
//! | control tick | TIM5 compare every 1 ms | the plant's step message pends TIM5 ([`plant_port`]) |
//! | periods since the last step | TIM5's free-running count | the step message (never 0) |
//! | encoders, supply, button | TIM2/TIM4, ADC1, a pin | the step message |
//! | gyro (when an IMU is fitted) | the ICM-42688-P on SPI2, read at the step's start | the step message's reading, if it has one |
//! | duties and bridge | TIM3 PWM, driver pins | the answer message |
//! | link | USART2 on PA2/PA3 | USART2 (QEMU's second `-serial`) |
//! | step timing | DWT CYCCNT, cycles | SysTick under `-icount shift=0`, instructions ([`instructions`]) |
//! | watchdog, storage | IWDG, flash sectors 6–7 | none (`PersistParams` is refused: no storage) |
//!
//! **One task body, two bindings.** The control task is bound to TIM5 on both boards.
//! On the F411 the timer's compare raises it every period; here TIM5 never runs, and
//! the plant port's receive interrupt pends TIM5 in the NVIC when a whole step message
//! has arrived. The task reads its sensors through [`ControlIo::sense`], which takes
//! that message, so the body does not know which board it runs on.
//!
//! **SysTick counts instructions, and is nothing else.** Under `-icount shift=0` it
//! advances 0.168 ticks per executed instruction; the firmware uses no RTIC monotonic,
//! so SysTick is free to be the instruction counter, and its interrupt stays off.
//!
//! USART numbering: QEMU maps its `-serial` options in order onto USART1, USART2, …, so
//! the first is the plant port (USART1) and the second the link (USART2, as on the
//! F411). QEMU's USART ignores the baud rate (BRR), has no overrun flag and keeps TXE
//! set (a write to DR goes out at once); it raises RXNE and TXE interrupts.

mod instructions;
mod plant_port;

use controller_core::supervisor::ResetCause;
use link::{BrownOutReset, ClockSource};
use lockstep::{BoardStep, PlantStep};
use robot_app::channel::ring::{Consumer, Producer, Ring};
use robot_app::persist::Slot;
use robot_app::stm32f4::watchdog::{IwdgConfig, IwdgPrescaler};
use robot_app::{Actuation, ControlSide, Sensors};
use stm32f4xx_hal::pac;

pub use self::instructions::{work_counter, work_since, work_units, WORK_UNIT};
pub use self::plant_port::PlantPort;

/// What `Info` reports as the chip.
pub const NAME: &str = "STM32F405 (QEMU netduinoplus2)";

/// The link's baud rate as on the F411 ([`link::LINK_BAUD`]); QEMU ignores it (BRR is
/// not modelled), and the link's telemetry cap is computed from it as on the robot.
pub const LINK_BAUD: u32 = link::LINK_BAUD;

/// The F411's run-time watchdog setting, for the shared code (nothing runs it here).
pub const WATCHDOG_RUN: IwdgConfig = IwdgConfig {
    prescaler: IwdgPrescaler::Div4,
    reload: 79,
};
/// The F411's persistence watchdog setting, for the shared code (never used: no
/// storage).
pub const WATCHDOG_PERSIST: IwdgConfig = WATCHDOG_RUN;

/// Steps the plant may have in flight: one (lockstep), and one of slack.
const STEP_SLOTS: usize = 2;

/// What `init` got from the board.
pub struct Board {
    /// The control task's sensors and actuators: the two ends of the plant port.
    pub io: ControlIo,
    /// No watchdog: QEMU does not model the IWDG.
    pub watchdog: Watchdog,
    /// USART2, enabled with its receive interrupt on.
    pub link_usart: pac::USART2,
    /// No storage.
    pub storage: Option<Storage>,
    /// QEMU does not model RCC_CSR: always `Unknown`.
    pub reset: ResetCause,
    /// The plant port (USART1), for its interrupt task.
    pub plant: PlantPort,
    /// No oscillator of its own: time is the emulator's.
    pub clock: ClockSource,
    /// No supply: not applicable.
    pub brown_out_reset: BrownOutReset,
}

/// Brings the emulated board up: SysTick as the instruction counter (calibrated), the
/// plant port on USART1 and the link on USART2, both with their receive interrupts on.
pub fn init(dp: pac::Peripherals, cp: cortex_m::Peripherals) -> Board {
    instructions::start(cp.SYST);

    let steps = cortex_m::singleton!(: Ring<PlantStep, STEP_SLOTS> = Ring::new());
    let replies = cortex_m::singleton!(: Ring<BoardStep, STEP_SLOTS> = Ring::new());
    let (Some(steps), Some(replies)) = (steps, replies) else {
        defmt::panic!("board::init ran twice");
    };
    let (step_tx, step_rx) = steps.split();
    let (reply_tx, reply_rx) = replies.split();

    // CR1 = UE | TE | RE | RXNEIE: all QEMU's model needs (RM0090 §30.6.4 for a real
    // F405 would also want RCC's USART clock and BRR; QEMU models neither).
    for cr1 in [dp.USART1.cr1(), dp.USART2.cr1()] {
        cr1.write(|w| {
            w.ue()
                .set_bit()
                .te()
                .set_bit()
                .re()
                .set_bit()
                .rxneie()
                .set_bit()
        });
    }
    defmt::info!(
        "board: {=str}, {=u32} SysTick ticks per 10^6 instructions",
        NAME,
        instructions::ticks_per_million()
    );
    Board {
        io: ControlIo {
            steps: step_rx,
            replies: reply_tx,
        },
        watchdog: Watchdog,
        link_usart: dp.USART2,
        storage: None,
        reset: ResetCause::Unknown,
        plant: PlantPort::new(dp.USART1, step_tx, reply_rx),
        clock: ClockSource::Simulated,
        brown_out_reset: BrownOutReset::NotApplicable,
    }
}

/// The steering task has run the outer loop's job the step lent it: the step's answer
/// may go.
#[inline(always)]
pub fn steering_done() {
    plant_port::release_answer();
    rtic::pend(pac::Interrupt::USART1);
}

/// Tells the plant that the firmware is up: both USARTs are enabled, so nothing it
/// sends from now on is lost (`lockstep::READY`).
pub fn announce_ready() {
    plant_port::send_ready();
}

/// The control task's ends of the plant port.
pub struct ControlIo {
    steps: Consumer<'static, PlantStep, STEP_SLOTS>,
    replies: Producer<'static, BoardStep, STEP_SLOTS>,
}

impl ControlIo {
    /// Nothing to start: the plant's first step message starts the first step.
    pub fn start(&mut self) {}

    /// The sensors of the step message that pended this step; `None` when none waits.
    /// A step of the plant never overruns: the plant waits for the answer.
    #[inline(always)]
    pub fn sense(&mut self, heartbeat: u32) -> Option<Sensors> {
        let step = self.steps.pop()?;
        Some(Sensors {
            ticks: step.ticks,
            periods: step.periods,
            supply_v: step.supply_v,
            button_pressed: step.button_pressed,
            overrun: false,
            background_heartbeat: heartbeat,
            gyro: step.gyro,
        })
    }

    /// Queues the step's answer for the plant port, which sends it once this task has
    /// returned (same priority, so it never preempts the step). When the step lent the
    /// outer loop a job, the answer is held until the steering task has run it
    /// ([`steering_done`]): the plant's next step message then cannot start the next
    /// step before the outer loop is back, however the host's bytes fall in virtual
    /// time. The pose and error are `control`'s telemetry.
    #[inline(always)]
    pub fn actuate(&mut self, out: &Actuation, control: &ControlSide<'_>) {
        let telemetry = control.controller().telemetry();
        plant_port::hold_answer(out.steering_lent);
        // The plant sends the next step only after this answer: the slot is free.
        let _ = self.replies.push(BoardStep {
            duty: out.duty,
            bridge: out.bridge,
            state: out.state,
            run_mode: out.run_mode,
            faults: out.faults,
            battery_low: out.battery_low,
            event: out.event,
            missed_ticks_total: out.missed_ticks_total,
            overruns_total: out.overruns_total,
            pose: telemetry.pose,
            error: telemetry.error,
            steering_updated: telemetry.steering_updated,
        });
        if !out.steering_lent {
            rtic::pend(pac::Interrupt::USART1);
        }
    }

    /// Nothing to check: see [`ControlIo::sense`].
    #[inline(always)]
    pub fn end_step(&mut self) {}
}

/// The independent watchdog's stand-in: QEMU does not model the IWDG.
pub struct Watchdog;

/// Never happens: there is no watchdog to update.
#[derive(Clone, Copy, Debug, defmt::Format)]
pub struct UpdateStuck;

impl Watchdog {
    /// Nothing to feed.
    #[inline(always)]
    pub fn feed(&mut self) {}

    /// Nothing to change.
    pub fn set_timeout(&mut self, _config: IwdgConfig) -> Result<(), UpdateStuck> {
        Ok(())
    }
}

/// No storage on this board: a type with no values, so `Option<Storage>` is always
/// `None` and `PersistParams` is refused with `NoStorage`.
pub enum Storage {}

/// Never happens: see [`Storage`].
#[derive(Clone, Copy, Debug)]
pub enum FlashError {}

impl defmt::Format for FlashError {
    fn format(&self, _f: defmt::Formatter<'_>) {
        match *self {}
    }
}

impl Storage {
    /// Unreachable: see [`Storage`].
    pub fn page(&self, _slot: Slot) -> &'static [u8] {
        match *self {}
    }

    /// Unreachable: see [`Storage`].
    pub fn erase_and_program(&mut self, _slot: Slot, _record: &[u8]) -> Result<(), FlashError> {
        match *self {}
    }
}

/// No motors to stop: the plant keeps the last answer's duties until QEMU exits, which
/// the panic and hard-fault handlers make it do at once ([`halt_after_failure`]).
///
/// # Safety
///
/// None needed; `unsafe` only to match the F411 board's function.
pub unsafe fn force_motors_off() {}

/// Ends the emulation with a failure status (semihosting `exit(1)`), so that a run
/// that panicked fails at once instead of hanging.
pub fn halt_after_failure() -> ! {
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
