//! Time as an integer count of control steps.
//!
//! An `f32` clock accumulated step by step loses millisecond resolution after a few hours
//! (2²⁴ ms ≈ 4.7 h). The core counts steps in a `u32` (49 days at 1 kHz) and only turns
//! them into seconds when asked, splitting whole seconds from the fraction so that the
//! fraction keeps full resolution.

use core::num::NonZeroU32;

/// A count of fixed-period control steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepClock {
    steps: u32,
    /// Steps per second; non-zero by type, so no division here can fail.
    rate_hz: NonZeroU32,
}

impl StepClock {
    /// A clock at step 0 ticking at `rate_hz` steps per second.
    pub const fn new(rate_hz: NonZeroU32) -> Self {
        Self { steps: 0, rate_hz }
    }

    /// Advances by one step (wrapping after 2³² steps).
    pub fn tick(&mut self) {
        self.steps = self.steps.wrapping_add(1);
    }

    /// Advances by `periods` steps (wrapping after 2³² steps): a step that began late
    /// covers the periods it missed.
    pub fn advance(&mut self, periods: NonZeroU32) {
        self.steps = self.steps.wrapping_add(periods.get());
    }

    /// Steps since start.
    pub const fn steps(&self) -> u32 {
        self.steps
    }

    /// Steps per second, Hz.
    pub const fn rate_hz(&self) -> u32 {
        self.rate_hz.get()
    }

    /// Whole seconds since start and the fraction of the current second (in [0, 1)).
    pub fn split_seconds(&self) -> (u32, f32) {
        (
            self.steps / self.rate_hz,
            (self.steps % self.rate_hz) as f32 / self.rate_hz.get() as f32,
        )
    }

    /// Elapsed time, s. Resolution degrades slowly with the whole-second part only.
    pub fn elapsed_s(&self) -> f32 {
        let (whole, frac) = self.split_seconds();
        whole as f32 + frac
    }

    /// Distance travelled at `speed_m_s` (m/s) since start, m.
    pub fn distance_m(&self, speed_m_s: f32) -> f32 {
        let (whole, frac) = self.split_seconds();
        speed_m_s * whole as f32 + speed_m_s * frac
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_whole_and_fraction() {
        let mut c = StepClock::new(KHZ);
        for _ in 0..2_345 {
            c.tick();
        }
        assert_eq!(c.split_seconds().0, 2);
        assert!((c.split_seconds().1 - 0.345).abs() < 1e-6);
        assert!((c.distance_m(0.5) - 1.1725).abs() < 1e-6);
    }

    #[test]
    fn keeps_millisecond_resolution_after_a_day() {
        // 24 h + 1 ms at 1 kHz: an accumulated f32 clock could not see the extra 1 ms.
        let mut c = StepClock::new(KHZ);
        c.steps = 86_400_000;
        let before = c.split_seconds();
        c.tick();
        assert_eq!(c.split_seconds().0, before.0);
        assert!((c.split_seconds().1 - 0.001).abs() < 1e-7);
    }

    const KHZ: NonZeroU32 = match NonZeroU32::new(1000) {
        Some(rate) => rate,
        None => NonZeroU32::MIN,
    };

    #[test]
    fn advance_counts_missed_periods() {
        let mut c = StepClock::new(KHZ);
        c.tick();
        c.advance(NonZeroU32::new(3).unwrap());
        assert_eq!(c.steps(), 4);
        assert!((c.elapsed_s() - 0.004).abs() < 1e-7);
        assert_eq!(c.rate_hz(), 1000);
    }

    #[test]
    fn elapsed_seconds_count_whole_seconds_and_the_fraction() {
        let mut c = StepClock::new(KHZ);
        assert_eq!(c.elapsed_s(), 0.0);
        for _ in 0..2_345 {
            c.tick();
        }
        assert!((c.elapsed_s() - 2.345).abs() < 1e-6);
        // 3 steps at 4 Hz: less than a second, all fraction.
        let mut slow = StepClock::new(NonZeroU32::new(4).unwrap());
        for _ in 0..3 {
            slow.tick();
        }
        assert_eq!(slow.elapsed_s(), 0.75);
        // After a day at 1 kHz the seconds are still whole and the half second is exact
        // (the resolution of the sum itself is that of an f32 near 86 400: 8 ms).
        let mut day = StepClock::new(KHZ);
        day.steps = 86_400_500;
        assert_eq!(day.elapsed_s(), 86_400.5);
    }
}
