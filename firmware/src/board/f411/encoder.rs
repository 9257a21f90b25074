//! The two wheel encoders: timers in quadrature mode, read once per step into signed tick
//! deltas with the core's wrap-safe [`WrappingCounter`] at each timer's own width.
//!
//! stm32f4xx-hal's `Qei::new` writes TIMx_CCMR1 whole (CC1S = 01, CC2S = 01: TI1, TI2
//! inputs) and so leaves both input filters off (IC1F = IC2F = 0), next to motor wires
//! switching at 20 kHz. [`Encoders::new`] then sets IC1F and IC2F (bits 7:4 and 15:12,
//! read-modify-write, nothing else touched; RM0383 allows changing ICxF at any time,
//! only CCxS needs the channel off) to the strongest filter that still passes the
//! shortest real pulse four times over (`robot_app::stm32f4::encoder_filter`): at 200 rad/s,
//! twice the core's plausibility limit and 2.6 times the motor's no-load speed on a full
//! 3S pack, a 12-line encoder behind 1:30 runs at 11.5 kHz per channel, whose high or low
//! time is 21.8 µs even at a 25 % duty cycle. With the timer at 100 MHz and CKD = 00 that
//! is IC1F = IC2F = 1111 (f_DTS/32, N = 8): levels held 2.56 µs pass, pulses shorter than
//! 2.24 µs never do.

use controller_core::controller::TickDeltas;
use controller_core::encoder::WrappingCounter;
use robot_app::stm32f4::encoder_filter::{self, Ckd, FilterTiming};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::qei::Qei;

use super::{polarity, LeftEncoderTimer, RightEncoderTimer, CLOCK_PLAN};
use crate::robot;

/// The encoder duty cycle assumed at worst (an ideal encoder has 0.5).
const MIN_ENCODER_DUTY: f32 = 0.25;
/// How many times longer than the filter's pass time the shortest pulse must be.
const FILTER_MARGIN: f32 = 4.0;

/// The shortest high or low time of an encoder channel at twice the core's plausibility
/// limit, s (21.8 µs for the reference robot).
pub const SHORTEST_PULSE_S: f32 = encoder_filter::shortest_pulse_s(
    robot::ROBOT.encoder_lines_per_motor_rev,
    robot::ROBOT.gear_ratio,
    2.0 * robot::ROBOT.max_plausible_wheel_speed_rad_s,
    MIN_ENCODER_DUTY,
);

/// The input filter for the robot's encoders on this clock (module doc), chosen at
/// compile time.
pub const INPUT_FILTER: FilterTiming = encoder_filter::strongest_filter(
    CLOCK_PLAN.tree.timclk1_hz,
    Ckd::Div1,
    SHORTEST_PULSE_S / FILTER_MARGIN,
);
const _: () = assert!(
    INPUT_FILTER.code != 0,
    "no input filter passes the encoder's pulses"
);

/// A timer's count as (counter width in bits, value): the width follows from the type the
/// HAL reads it as (`u32` for TIM2/TIM5, `u16` for TIM3/TIM4).
fn reading<T: Into<u32>>(count: T) -> (u32, u32) {
    ((core::mem::size_of::<T>() * 8) as u32, count.into())
}

/// Both encoders and the last raw count of each.
pub struct Encoders {
    left: Qei<LeftEncoderTimer>,
    right: Qei<RightEncoderTimer>,
    left_count: WrappingCounter,
    right_count: WrappingCounter,
}

impl Encoders {
    /// Sets both timers' input filters to [`INPUT_FILTER`] (module doc) and starts
    /// counting from the timers' current values.
    pub fn new(left: Qei<LeftEncoderTimer>, right: Qei<RightEncoderTimer>) -> Self {
        let code = INPUT_FILTER.code;
        // SAFETY: the two timers are owned by `left` and `right`, which never write CCMR1
        // after `Qei::new`; IC1F/IC2F are 4-bit fields and `code` is 0..=15. CKD (CR1
        // bits 9:8) is 00 after Qei::new, as `input_filter` assumes.
        unsafe {
            (*pac::TIM2::ptr())
                .ccmr1_input()
                .modify(|_, w| w.ic1f().bits(code).ic2f().bits(code));
            (*pac::TIM4::ptr())
                .ccmr1_input()
                .modify(|_, w| w.ic1f().bits(code).ic2f().bits(code));
        }
        let (left_bits, left_raw) = reading(left.count());
        let (right_bits, right_raw) = reading(right.count());
        Self {
            left_count: WrappingCounter::new(left_bits, left_raw),
            right_count: WrappingCounter::new(right_bits, right_raw),
            left,
            right,
        }
    }

    /// Ticks counted since the previous call, forward positive (see
    /// `board::polarity`).
    pub fn read(&mut self) -> TickDeltas {
        let left = self.left_count.delta(reading(self.left.count()).1);
        let right = self.right_count.delta(reading(self.right.count()).1);
        TickDeltas {
            left: if polarity::LEFT_ENCODER_INVERTED {
                left.wrapping_neg()
            } else {
                left
            },
            right: if polarity::RIGHT_ENCODER_INVERTED {
                right.wrapping_neg()
            } else {
                right
            },
        }
    }
}
