//! Quadrature encoder counts: wrap-safe deltas and a wheel-speed estimate.
//!
//! A timer in encoder mode counts edges modulo 2ⁿ (n = 16 or 32 on an STM32). The core
//! never sees raw counts, only the signed number of ticks since the previous step, taken
//! with [`WrappingCounter`].
//!
//! ## Quantisation at low speed
//!
//! With 12 lines × 4 edges × a 1:30 gearbox (1440 ticks per wheel revolution) and a 1 kHz
//! loop, one tick per step is 4.4 rad/s: a per-step difference is useless as a speed.
//! [`SpeedEstimator`] therefore averages over a sliding window of the last W steps:
//! ω̂ = (Σ ticks over W steps) · (2π / ticks_per_rev) / (W · T).
//! Its resolution is 2π / (ticks_per_rev · W · T) (0.22 rad/s for W = 20 at 1 kHz, i.e.
//! 7 mm/s of rim speed for a 65 mm wheel), its delay W·T/2, and it is exact (no drift, no
//! lost ticks) because it is a difference of integer counts. Before W steps have been seen
//! it averages over the steps it has.

/// Largest averaging window of [`SpeedEstimator`], in control steps.
pub const MAX_SPEED_WINDOW_STEPS: usize = 64;

/// Turns successive raw readings of an n-bit up/down counter into signed deltas, correct
/// across the counter's wrap as long as fewer than 2ⁿ⁻¹ ticks pass between two readings.
#[derive(Clone, Copy, Debug)]
pub struct WrappingCounter {
    last_raw: u32,
    /// 32 − n: the shift that sign-extends an n-bit difference.
    shift: u32,
}

impl WrappingCounter {
    /// A counter of `bits` width (clamped to 1..=32; 16 for TIM3/TIM4, 32 for TIM2/TIM5)
    /// whose current raw reading is `raw`.
    pub fn new(bits: u32, raw: u32) -> Self {
        let bits = bits.clamp(1, 32);
        Self {
            last_raw: raw,
            shift: 32 - bits,
        }
    }

    /// Signed ticks between the previous reading and `raw` (the new reading), computed
    /// with `wrapping_sub` at the counter's own width.
    pub fn delta(&mut self, raw: u32) -> i32 {
        let diff = raw.wrapping_sub(self.last_raw) << self.shift;
        self.last_raw = raw;
        (diff as i32) >> self.shift
    }
}

/// Sliding-window wheel-speed estimate from per-step tick deltas (see the module doc).
#[derive(Clone, Debug)]
pub struct SpeedEstimator {
    ring: [i32; MAX_SPEED_WINDOW_STEPS],
    window: usize,
    head: usize,
    filled: usize,
    /// Σ ring. Exact in i32: |ticks| per step is bounded by the encoder-jump fault
    /// ([`crate::params::Params::max_ticks_per_step`] ≤ 2²⁴), times ≤ 64 steps.
    sum: i32,
    rad_per_tick_per_s: f32,
    /// rad_per_tick_per_s / filled: turns the tick sum into rad/s without a division.
    scale: f32,
}

impl SpeedEstimator {
    /// An estimator averaging over `window_steps` (clamped to 1..=64) control steps of
    /// period T, for a wheel with `rad_per_tick` rad of wheel rotation per encoder tick.
    /// `steps_per_s` is 1/T.
    pub fn new(window_steps: usize, rad_per_tick: f32, steps_per_s: f32) -> Self {
        Self {
            ring: [0; MAX_SPEED_WINDOW_STEPS],
            window: window_steps.clamp(1, MAX_SPEED_WINDOW_STEPS),
            head: 0,
            filled: 0,
            sum: 0,
            rad_per_tick_per_s: rad_per_tick * steps_per_s,
            scale: 0.0,
        }
    }

    /// Adds one step's tick delta and returns the wheel speed estimate, rad/s.
    pub fn update(&mut self, ticks: i32) -> f32 {
        self.sum = self
            .sum
            .wrapping_add(ticks)
            .wrapping_sub(self.ring[self.head]);
        self.ring[self.head] = ticks;
        self.head += 1;
        if self.head == self.window {
            self.head = 0;
        }
        if self.filled < self.window {
            self.filled += 1;
            self.scale = self.rad_per_tick_per_s / self.filled as f32;
        }
        self.speed_rad_s()
    }

    /// The current estimate, rad/s (0 before the first update).
    pub fn speed_rad_s(&self) -> f32 {
        self.sum as f32 * self.scale
    }

    /// Forgets the history (after a fault or a mode change).
    pub fn reset(&mut self) {
        self.ring = [0; MAX_SPEED_WINDOW_STEPS];
        self.head = 0;
        self.filled = 0;
        self.sum = 0;
        self.scale = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn sixteen_bit_wrap_forward_and_back() {
        let mut c = WrappingCounter::new(16, 65_530);
        assert_eq!(c.delta(4), 10); // 65530 → 65535 → 0 → 4
        assert_eq!(c.delta(65_534), -6); // back across zero
        assert_eq!(c.delta(65_534), 0);
    }

    #[test]
    fn thirty_two_bit_wrap() {
        let mut c = WrappingCounter::new(32, u32::MAX - 2);
        assert_eq!(c.delta(5), 8);
        assert_eq!(c.delta(u32::MAX), -6);
    }

    #[test]
    fn speed_window_averages_sparse_ticks() {
        // 1440 ticks/rev, 1 kHz, window 20: one tick every 4 steps is 250 ticks/s.
        let rad_per_tick = core::f32::consts::TAU / 1440.0;
        let mut est = SpeedEstimator::new(20, rad_per_tick, 1000.0);
        let mut last = 0.0;
        for k in 0..200 {
            last = est.update(i32::from(k % 4 == 0));
        }
        let expected = 250.0 * rad_per_tick; // 1.0908 rad/s
        assert!((last - expected).abs() < 1e-5, "{last} vs {expected}");
    }

    #[test]
    fn speed_uses_partial_window_at_start() {
        let mut est = SpeedEstimator::new(10, 0.01, 1000.0);
        assert_eq!(est.speed_rad_s(), 0.0);
        assert!((est.update(3) - 30.0).abs() < 1e-4); // 3 ticks in 1 ms = 0.03 rad / 1 ms
        est.reset();
        assert_eq!(est.speed_rad_s(), 0.0);
    }

    proptest! {
        /// Odometry input across a counter wrap equals the input without one.
        #[test]
        fn deltas_across_wrap_equal_deltas_without(
            bits in prop::sample::select(vec![16u32, 32]),
            start in any::<u32>(),
            steps in prop::collection::vec(-20_000i32..20_000, 1..200),
        ) {
            let modulus_mask = if bits == 32 { u32::MAX } else { (1u32 << bits) - 1 };
            let mut counter = WrappingCounter::new(bits, start & modulus_mask);
            let mut raw = start & modulus_mask;
            for &ticks in &steps {
                raw = raw.wrapping_add(ticks as u32) & modulus_mask;
                prop_assert_eq!(counter.delta(raw), ticks);
            }
        }
    }
}
