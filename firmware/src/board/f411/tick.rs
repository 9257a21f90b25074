//! The control tick: TIM5 (32 bits) counting freely at
//! `board::TICK_TIMER_HZ`, its channel-1 compare interrupt at the
//! next point of a fixed grid (`robot_app::stm32f4::tick`).
//!
//! Registers (RM0383 §13.4, TIM2–TIM5): PSC = f_TIM / 1 MHz − 1 (99 on the F411), loaded
//! by an update event (EGR.UG); ARR = 0xFFFF_FFFF (reset value: the counter wraps after
//! 2³² µs, 71.6 min); CCMR1 = 0 (channel 1 output compare, frozen, OC1PE = 0 so a new
//! CCR1 applies at once, which a moving deadline needs); CCR1 = the next deadline;
//! DIER.CC1IE = 1; CR1.CEN = 1. SR.CC1IF is set when CNT = CCR1.
//!
//! Why a compare on a free-running counter instead of the update interrupt at the period:
//! the counter is then a clock, so each entry can tell from CNT alone how many periods
//! have passed, however late it starts, without the drift and the phase guesswork of
//! timing entries with DWT CYCCNT (which also stops while the core sleeps in WFI unless
//! the debug clock is kept on).

use core::num::NonZeroU32;

use robot_app::stm32f4::tick::{has_reached, TickSchedule};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::rcc::{Enable, Rcc, Reset};

use super::{TickTimer, CLOCK_PLAN, TICK_TIMER_HZ};

/// The control tick on [`TickTimer`].
pub struct Tick {
    tim: TickTimer,
    schedule: TickSchedule,
}

impl Tick {
    /// TIM5 clocked, reset and counting at [`TICK_TIMER_HZ`], but not yet running and
    /// with no interrupt enabled.
    pub fn new(tim: TickTimer, rcc: &mut Rcc) -> Self {
        pac::TIM5::enable(rcc);
        pac::TIM5::reset(rcc);
        let psc = CLOCK_PLAN.tree.timclk1_hz / TICK_TIMER_HZ - 1;
        tim.psc().write(|w| w.psc().set(psc as u16));
        tim.arr().write(|w| w.arr().set(u32::MAX));
        // Load PSC now (it is preloaded); this also zeroes CNT and sets UIF.
        tim.egr().write(|w| w.ug().set_bit());
        Self {
            tim,
            schedule: TickSchedule::new(NonZeroU32::MIN, 0),
        }
    }

    /// Starts counting with the first deadline one `period` (in 1 µs counts) from now,
    /// and enables the compare interrupt.
    pub fn start(&mut self, period: NonZeroU32) {
        self.schedule = TickSchedule::new(period, period.get());
        self.tim.ccr1().write(|w| w.ccr().set(self.schedule.due()));
        self.tim.sr().reset();
        self.tim.dier().write(|w| w.cc1ie().set_bit());
        self.tim.cr1().write(|w| w.cen().set_bit());
    }

    /// At the start of each control step: acknowledges the interrupt, returns the control
    /// periods since the previous step (`None` for a spurious entry, before the deadline)
    /// and arms the next deadline. If that deadline has already gone by while it was being
    /// written, the interrupt is raised at once (EGR.CC1G), so no deadline is lost.
    pub fn on_entry(&mut self) -> Option<NonZeroU32> {
        // rc_w0: 0 to CC1IF, 1 (no effect) to the other flags.
        self.tim.sr().write(|w| w.cc1if().clear());
        let elapsed = self.schedule.on_entry(self.tim.cnt().read().bits())?;
        let due = self.schedule.due();
        self.tim.ccr1().write(|w| w.ccr().set(due));
        if has_reached(self.tim.cnt().read().bits(), due) {
            self.tim.egr().write(|w| w.cc1g().set_bit());
        }
        Some(elapsed)
    }

    /// True when the next deadline has already passed (its interrupt is pending): checked
    /// at the end of a step, the step overran its period.
    pub fn is_pending(&self) -> bool {
        self.tim.sr().read().cc1if().bit_is_set()
    }
}
