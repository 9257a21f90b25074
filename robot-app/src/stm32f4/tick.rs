//! Control periods elapsed since the last step, measured on the tick timer itself.
//!
//! The tick timer counts freely (32 bits, wrapping) and its compare register holds the
//! next deadline, a point on the fixed grid `first_due + k × period`. On each entry the
//! control task reads the counter; [`TickSchedule::on_entry`] says how many grid points
//! have passed since the previous step (1 when on time, more when the task started late
//! by a period or more, never 0) and moves the deadline to the first grid point after
//! the counter, so a late start neither drifts the grid nor leaves the compare behind the
//! counter for a whole wrap. All comparisons are wrap-safe as long as a deadline is never
//! more than 2³¹ counts away (35 minutes at 1 MHz).

use core::num::NonZeroU32;

/// True once the free-running counter `now` has reached `due` (wrap-safe).
pub const fn has_reached(now: u32, due: u32) -> bool {
    (now.wrapping_sub(due) as i32) >= 0
}

/// The deadline grid of the control tick, in counts of the tick timer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TickSchedule {
    period: NonZeroU32,
    due: u32,
}

impl TickSchedule {
    /// A grid of `period` counts whose first deadline is `first_due`.
    pub const fn new(period: NonZeroU32, first_due: u32) -> Self {
        Self {
            period,
            due: first_due,
        }
    }

    /// The next deadline, the value for the compare register.
    pub const fn due(&self) -> u32 {
        self.due
    }

    /// The period, counts.
    pub const fn period(&self) -> NonZeroU32 {
        self.period
    }

    /// The step entered with the counter at `now`: the control periods since the previous
    /// step (≥ 1), and the deadline moves to the first grid point after `now`. `None`,
    /// and nothing changes, if `now` has not reached the deadline (a spurious entry).
    pub fn on_entry(&mut self, now: u32) -> Option<NonZeroU32> {
        if !has_reached(now, self.due) {
            return None;
        }
        let late = now.wrapping_sub(self.due);
        let extra = late / self.period.get();
        // extra + 1 grid points have passed (the one at `due` and `extra` more).
        self.due = self
            .due
            .wrapping_add(extra.wrapping_add(1).wrapping_mul(self.period.get()));
        NonZeroU32::new(extra.saturating_add(1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: u32 = 1000;

    fn schedule(first_due: u32) -> TickSchedule {
        TickSchedule::new(NonZeroU32::new(P).unwrap(), first_due)
    }

    #[test]
    fn on_time_and_late_entries() {
        let mut s = schedule(P);
        let n = |v: u32| NonZeroU32::new(v);
        assert_eq!(s.on_entry(P + 12), n(1)); // usual interrupt latency
        assert_eq!(s.due(), 2 * P);
        assert_eq!(s.on_entry(2 * P + 999), n(1)); // late, but before the next tick
        assert_eq!(s.due(), 3 * P);
        assert_eq!(s.on_entry(4 * P + 500), n(2)); // started 1.5 periods late
        assert_eq!(s.due(), 5 * P);
        assert_eq!(s.on_entry(15 * P), n(11)); // exactly on a later grid point
        assert_eq!(s.due(), 16 * P);
    }

    #[test]
    fn a_spurious_entry_changes_nothing() {
        let mut s = schedule(5 * P);
        assert_eq!(s.on_entry(5 * P - 1), None);
        assert_eq!(s.due(), 5 * P);
        assert_eq!(s.on_entry(5 * P), NonZeroU32::new(1));
    }

    #[test]
    fn wraps_around_the_counter() {
        let first = u32::MAX - 1500;
        let mut s = schedule(first);
        assert_eq!(s.on_entry(first + 10), NonZeroU32::new(1));
        assert_eq!(s.due(), first.wrapping_add(P));
        // The next deadline is past the wrap; enter 2.2 periods after it.
        let now = first.wrapping_add(P).wrapping_add(2 * P + 200);
        assert!(now < first);
        assert_eq!(s.on_entry(now), NonZeroU32::new(3));
        assert_eq!(s.due(), first.wrapping_add(4 * P));
        assert!(has_reached(now, first));
        assert!(!has_reached(first, now));
    }

    #[test]
    fn elapsed_periods_add_up_to_the_real_time_whatever_the_delays() {
        // Entries at grid point k plus a delay of 0-3.5 periods; the elapsed periods
        // reported must sum to the grid points passed, with no drift and never 0.
        let mut s = schedule(P);
        let mut total = 0u64;
        let mut seed = 0x2545_F491u32;
        let mut k: u64 = 1;
        for _ in 0..10_000 {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            let delay = seed % (7 * P / 2);
            let now = (k * P as u64) as u32 + delay;
            let elapsed = s.on_entry(now).unwrap().get();
            total += u64::from(elapsed);
            // The next deadline is the first grid point after `now`, in the future.
            assert!(!has_reached(now, s.due()));
            assert_eq!(s.due() % P, 0);
            k = u64::from(s.due() / P);
            assert_eq!(total, k - 1);
        }
    }
}
