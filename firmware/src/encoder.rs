//! The two wheel encoders: timers in quadrature mode, read once per step into signed tick
//! deltas with the core's wrap-safe [`WrappingCounter`] at each timer's own width.

use controller_core::controller::TickDeltas;
use controller_core::encoder::WrappingCounter;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::qei::Qei;

use crate::board::{polarity, LeftEncoderTimer, RightEncoderTimer};

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
    /// Starts counting from the timers' current values.
    pub fn new(left: Qei<LeftEncoderTimer>, right: Qei<RightEncoderTimer>) -> Self {
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
    /// [`polarity`](crate::board::polarity)).
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
