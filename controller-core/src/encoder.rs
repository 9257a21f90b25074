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
//! lost ticks) because it is a difference of integer counts. It starts as a wheel that
//! has been at rest for the whole window. A step that began late (missed ticks) reports
//! how many periods its ticks span, and the estimate divides by the elapsed time, not by
//! the number of calls. [`crate::params::Params::new`] rejects a window whose one-tick
//! quantum is a coarse fraction of the wheel's top speed.

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
///
/// Each step adds its tick delta and the number of control periods it covered (1 on
/// time, more when the step started late and absorbed missed ticks), so the estimate is
/// ticks per *elapsed time*, not per call. The window holds the last W steps.
#[derive(Clone)]
pub struct SpeedEstimator {
    /// Tick deltas of the last `window` steps (a ring; only `window` entries are used).
    ticks: [i32; MAX_SPEED_WINDOW_STEPS],
    /// Control periods of the same steps, saturated at 65 535 (65 s at 1 kHz; only a
    /// flash erase or a debugger halt covers more). Two bytes, not four: 256 B of RAM
    /// less for the robot's two wheels.
    periods: [u16; MAX_SPEED_WINDOW_STEPS],
    window: usize,
    head: usize,
    /// Σ ticks. Exact in i32: |ticks| per step is bounded by the encoder-jump fault
    /// ([`crate::params::Params::max_ticks_per_step`] ≤ 2²⁴), times ≤ 64 steps.
    tick_sum: i32,
    /// Σ periods (≥ `window`: the ring starts as `window` steps of one period at rest).
    period_sum: u32,
    /// Wheel rad per tick × steps per second.
    rad_per_tick_per_s: f32,
    /// `rad_per_tick_per_s / period_sum`, refreshed only when `period_sum` changes.
    scale: f32,
}

impl SpeedEstimator {
    /// An estimator averaging over `window_steps` (clamped to 1..=64) control steps of
    /// period T, for a wheel with `rad_per_tick` rad of wheel rotation per encoder tick.
    /// `steps_per_s` is 1/T. It starts as if the wheel had been at rest for the whole
    /// window.
    pub fn new(window_steps: usize, rad_per_tick: f32, steps_per_s: f32) -> Self {
        let mut estimator = Self {
            ticks: [0; MAX_SPEED_WINDOW_STEPS],
            periods: [1; MAX_SPEED_WINDOW_STEPS],
            window: 1,
            head: 0,
            tick_sum: 0,
            period_sum: 1,
            rad_per_tick_per_s: 0.0,
            scale: 0.0,
        };
        estimator.reconfigure(window_steps, rad_per_tick, steps_per_s);
        estimator
    }

    /// Makes this estimator the one [`SpeedEstimator::new`] builds with these arguments,
    /// in place (no estimator on the stack of the interrupt that installs new parameters).
    pub fn reconfigure(&mut self, window_steps: usize, rad_per_tick: f32, steps_per_s: f32) {
        self.window = window_steps.clamp(1, MAX_SPEED_WINDOW_STEPS);
        self.rad_per_tick_per_s = rad_per_tick * steps_per_s;
        self.reset();
    }

    /// Adds one step's tick delta `ticks`, counted over `periods` control periods (≥ 1;
    /// more than 65 535 count as 65 535), and returns the wheel speed estimate, rad/s.
    pub fn update(&mut self, ticks: i32, periods: core::num::NonZeroU32) -> f32 {
        let periods = u16::try_from(periods.get()).unwrap_or(u16::MAX);
        // The ring is MAX_SPEED_WINDOW_STEPS (a power of two) long: masking keeps every
        // index in range whatever `head` holds, with no bounds check to fail.
        let slot = self.head & (MAX_SPEED_WINDOW_STEPS - 1);
        self.tick_sum = self
            .tick_sum
            .wrapping_add(ticks)
            .wrapping_sub(self.ticks[slot]);
        self.ticks[slot] = ticks;
        // Only a late step entering or leaving the window changes the elapsed time.
        let leaving = self.periods[slot];
        if periods != leaving {
            self.periods[slot] = periods;
            self.period_sum = self
                .period_sum
                .wrapping_add(u32::from(periods))
                .wrapping_sub(u32::from(leaving));
            self.scale = self.rad_per_tick_per_s / self.period_sum as f32;
        }
        self.head = if slot + 1 >= self.window { 0 } else { slot + 1 };
        self.speed_rad_s()
    }

    /// The current estimate, rad/s.
    pub fn speed_rad_s(&self) -> f32 {
        self.tick_sum as f32 * self.scale
    }

    /// Forgets the history: the wheel is taken to have been at rest for the whole window
    /// (after a fault, or when a run starts).
    pub fn reset(&mut self) {
        // Only the window's slots: `head` stays below `window`, so the others are never
        // read, and a new window comes with a reset (`reconfigure`). On the Cortex-M4F
        // clearing all 64 slots of both wheels cost the steps that install or arm
        // about 400 instructions.
        let window = self.window;
        self.ticks.iter_mut().take(window).for_each(|t| *t = 0);
        self.periods.iter_mut().take(window).for_each(|p| *p = 1);
        self.head = 0;
        self.tick_sum = 0;
        self.period_sum = self.window as u32;
        self.scale = self.rad_per_tick_per_s / self.period_sum as f32;
    }

    /// Fills the window as if the wheel had turned at `speed_rad_s` (rad/s) for the whole
    /// window, one period per step, with the ticks an encoder would have counted (whole
    /// ticks, the fractions carried from step to step). For a run that starts in motion
    /// (see [`crate::controller::Controller::seed_motion`]).
    pub fn seed(&mut self, speed_rad_s: f32) {
        self.reset();
        let ticks_per_step = speed_rad_s / self.rad_per_tick_per_s;
        if !ticks_per_step.is_finite() {
            return;
        }
        // What `window` updates of one period each would leave, written directly (the
        // step that arms in motion pays for this: about half the instructions): slot
        // k − 1 holds step k's ticks, the sum is the last total, the periods stay 1 and
        // the next update overwrites slot 0, the oldest.
        let mut counted = 0i32;
        for (k, slot) in (1..).zip(self.ticks.iter_mut().take(self.window)) {
            let total = crate::math::round_to_i32(k as f32 * ticks_per_step);
            *slot = total.wrapping_sub(counted);
            counted = total;
        }
        self.tick_sum = counted;
        self.head = 0;
    }
}

/// The state as it is read: the slots of the ring past the window are never read (they
/// may hold what a wider window left), so they are not shown.
impl core::fmt::Debug for SpeedEstimator {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let window = ..self.window;
        f.debug_struct("SpeedEstimator")
            .field("ticks", &self.ticks.get(window).unwrap_or_default())
            .field("periods", &self.periods.get(window).unwrap_or_default())
            .field("window", &self.window)
            .field("head", &self.head)
            .field("tick_sum", &self.tick_sum)
            .field("period_sum", &self.period_sum)
            .field("rad_per_tick_per_s", &self.rad_per_tick_per_s)
            .field("scale", &self.scale)
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::num::NonZeroU32;
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
    fn a_narrower_window_reads_and_shows_only_its_own_slots() {
        let mut wide = SpeedEstimator::new(30, 0.01, 1000.0);
        for _ in 0..30 {
            wide.update(3, NonZeroU32::MIN);
        }
        wide.reconfigure(4, 0.01, 1000.0);
        let mut narrow = SpeedEstimator::new(4, 0.01, 1000.0);
        assert_eq!(format!("{wide:?}"), format!("{narrow:?}"));
        assert!(format!("{narrow:?}").contains("ticks: [0, 0, 0, 0], periods: [1, 1, 1, 1],"));
        // The slots past the window still hold the wide window's ticks: never read.
        for k in 0..10 {
            let one = NonZeroU32::MIN;
            assert_eq!(wide.update(k, one), narrow.update(k, one), "step {k}");
        }
    }

    #[test]
    fn speed_window_averages_sparse_ticks() {
        // 1440 ticks/rev, 1 kHz, window 20: one tick every 4 steps is 250 ticks/s.
        let rad_per_tick = core::f32::consts::TAU / 1440.0;
        let mut est = SpeedEstimator::new(20, rad_per_tick, 1000.0);
        let mut last = 0.0;
        for k in 0..200 {
            last = est.update(i32::from(k % 4 == 0), ONE);
        }
        let expected = 250.0 * rad_per_tick; // 1.0908 rad/s
        assert!((last - expected).abs() < 1e-5, "{last} vs {expected}");
    }

    const ONE: NonZeroU32 = NonZeroU32::MIN;

    #[test]
    fn starts_as_a_wheel_at_rest_for_the_whole_window() {
        let mut est = SpeedEstimator::new(10, 0.01, 1000.0);
        assert_eq!(est.speed_rad_s(), 0.0);
        // 3 ticks in the newest of 10 one-period steps: 0.03 rad in 10 ms = 3 rad/s.
        assert!((est.update(3, ONE) - 3.0).abs() < 1e-5);
        est.reset();
        assert_eq!(est.speed_rad_s(), 0.0);
    }

    #[test]
    fn a_late_step_counts_the_time_it_covered() {
        // 5 ticks per period, window 4. A step that started one period late carries 10
        // ticks over 2 periods: the speed must not double.
        let mut est = SpeedEstimator::new(4, 0.01, 1000.0);
        for _ in 0..4 {
            est.update(5, ONE);
        }
        assert!((est.speed_rad_s() - 50.0).abs() < 1e-4);
        let two = NonZeroU32::new(2).unwrap();
        assert!((est.update(10, two) - 50.0).abs() < 1e-4);
        // Once the late step has left the window the divisor is back to 4 periods.
        for _ in 0..4 {
            est.update(5, ONE);
        }
        assert!((est.speed_rad_s() - 50.0).abs() < 1e-4);
        // Counting the late step as one period would have read 60 rad/s.
    }

    #[test]
    fn a_step_over_a_long_stall_saturates_and_leaves_the_window_cleanly() {
        // 100 000 periods (a 100 s halt at 1 kHz) count as 65 535, not as their low 16
        // bits (34 464): 65 535 ticks over them read 1 tick per period.
        let mut est = SpeedEstimator::new(2, 0.01, 1000.0);
        est.update(0, ONE);
        let long = NonZeroU32::new(100_000).unwrap();
        let speed = est.update(65_535, long);
        let expected = 65_535.0 * 0.01 * 1000.0 / 65_536.0;
        assert!((speed - expected).abs() < 1e-3, "{speed} vs {expected}");
        // Two on-time steps later the stall has left: 5 ticks per period again.
        est.update(5, ONE);
        assert!((est.update(5, ONE) - 50.0).abs() < 1e-4);
    }

    #[test]
    fn seeding_fills_the_window_with_a_steady_speed() {
        // 1440 ticks per turn at 1 kHz: 7 rad/s is 1.604 ticks per step; 20 steps hold 32.
        let rad_per_tick = core::f32::consts::TAU / 1440.0;
        let mut est = SpeedEstimator::new(20, rad_per_tick, 1000.0);
        est.seed(7.0);
        assert!(
            (est.speed_rad_s() - 7.0).abs() <= 0.22,
            "{}",
            est.speed_rad_s()
        );
        est.seed(-7.0);
        assert!(
            (est.speed_rad_s() + 7.0).abs() <= 0.22,
            "{}",
            est.speed_rad_s()
        );
        est.seed(f32::NAN);
        assert_eq!(est.speed_rad_s(), 0.0);
    }

    proptest! {
        /// Seeding leaves exactly what `window` one-period updates with the seeded ticks
        /// leave: the same speed now and after any further steps.
        #[test]
        fn seeding_equals_filling_the_window_step_by_step(
            window in 1usize..=MAX_SPEED_WINDOW_STEPS,
            speed in -80.0f32..80.0,
            later in prop::collection::vec((-40i32..40, 1u32..4), 0..80),
        ) {
            let rad_per_tick = core::f32::consts::TAU / 1440.0;
            let mut seeded = SpeedEstimator::new(window, rad_per_tick, 1000.0);
            seeded.update(17, ONE);
            seeded.seed(speed);
            let mut stepped = SpeedEstimator::new(window, rad_per_tick, 1000.0);
            let ticks_per_step = speed / stepped.rad_per_tick_per_s;
            let mut counted = 0i32;
            for k in 1..=window {
                let total = crate::math::round_to_i32(k as f32 * ticks_per_step);
                stepped.update(total - counted, ONE);
                counted = total;
            }
            prop_assert_eq!(seeded.speed_rad_s().to_bits(), stepped.speed_rad_s().to_bits());
            for (ticks, periods) in later {
                let periods = core::num::NonZeroU32::new(periods).unwrap_or(ONE);
                let a = seeded.update(ticks, periods);
                let b = stepped.update(ticks, periods);
                prop_assert_eq!(a.to_bits(), b.to_bits());
            }
        }
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
