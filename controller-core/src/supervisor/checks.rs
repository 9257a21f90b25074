//! The supervisor's fault detectors. Each sees only what the firmware has: tick counts,
//! the step count and its elapsed periods, the voltages the wheel loops applied, the
//! controller's own estimate and the supply measurement, never a simulator's truth.

use crate::controller::Telemetry;
use crate::kinematics::Pose;
use crate::math;

use super::config::{BatteryCheck, DivergenceCheck, MissedTickCheck, SaturationCheck, StallCheck};

/// Counts missed control ticks per window and spots long gaps.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct MissedTicks {
    /// Missed ticks since boot (saturating).
    pub(super) total: u32,
    in_window: u32,
    window_age: u32,
}

impl MissedTicks {
    /// Starts a fresh counting window (the total is kept).
    pub(super) fn restart_window(&mut self) {
        self.in_window = 0;
        self.window_age = 0;
    }

    /// A step that covered `periods` control periods; true when `check` says that is a
    /// fault.
    pub(super) fn update(&mut self, periods: u32, check: &MissedTickCheck) -> bool {
        let missed = periods.saturating_sub(1);
        self.total = self.total.saturating_add(missed);
        self.window_age = self.window_age.saturating_add(periods);
        if self.window_age >= check.window_steps {
            self.window_age = 0;
            self.in_window = 0;
        }
        self.in_window = self.in_window.saturating_add(missed);
        self.in_window > check.max_per_window || periods >= check.max_gap_periods
    }
}

/// Each wheel's count of steps driven without the motion the drive asks for (see
/// [`StallCheck`]): up on a step driven (|u| ≥ `min_volts`) with the wheel slower than
/// `min_speed_rad_s` in the driven direction, down on a step neither driven nor moving,
/// back to 0 as soon as the wheel is seen moving. A wheel whose encoder is silent under a
/// drive that dips below `min_volts` now and then (the outer loop steering on another
/// heading source) still reaches the limit; a wheel that turns never keeps a count.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Stall {
    steps: [u32; 2],
}

impl Stall {
    pub(super) fn reset(&mut self) {
        self.steps = [0; 2];
    }

    /// One armed step; returns [left stalled, right stalled].
    pub(super) fn update(&mut self, telemetry: &Telemetry, check: &StallCheck) -> [bool; 2] {
        let volts = telemetry.wheel_loop.volts;
        let wheels = [
            (volts.left_v, telemetry.wheel_speed.left_rad_s),
            (volts.right_v, telemetry.wheel_speed.right_rad_s),
        ];
        let mut stalled = [false; 2];
        for (i, (volts, speed)) in wheels.into_iter().enumerate() {
            let driven = math::abs(volts) >= check.min_volts;
            let moving = if driven {
                let direction = if volts >= 0.0 { 1.0 } else { -1.0 };
                speed * direction >= check.min_speed_rad_s
            } else {
                math::abs(speed) >= check.min_speed_rad_s
            };
            self.steps[i] = match (moving, driven) {
                (true, _) => 0,
                (false, true) => self.steps[i].saturating_add(1),
                (false, false) => self.steps[i].saturating_sub(1),
            };
            stalled[i] = self.steps[i] >= check.timeout_steps;
        }
        stalled
    }
}

/// How much of each wheel's recent time its loop spent saturated, counted per fixed
/// window (the window restarts when it is full).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Saturation {
    age: u32,
    saturated: [u32; 2],
}

impl Saturation {
    pub(super) fn reset(&mut self) {
        *self = Self::default();
    }

    /// One armed step covering `periods`; [left, right] true when that wheel's loop has
    /// been saturated for more than the allowed fraction of the window so far.
    pub(super) fn update(
        &mut self,
        telemetry: &Telemetry,
        periods: u32,
        check: &SaturationCheck,
    ) -> [bool; 2] {
        if self.age >= check.window_steps {
            self.reset();
        }
        self.age = self.age.saturating_add(periods);
        let mut over = [false; 2];
        for (i, count) in self.saturated.iter_mut().enumerate() {
            if telemetry.wheel_loop.saturated[i] {
                *count = count.saturating_add(periods);
                // Only a count that grew can newly exceed the limit, and one that
                // exceeded it faulted the robot then: the limit is computed in those
                // steps only.
                over[i] = *count as f32 > check.max_fraction * check.window_steps as f32;
            }
        }
        over
    }
}

/// The controller's tracking error stuck above its bound.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Divergence {
    /// Periods since arming into path following.
    armed_periods: u32,
    /// Periods the error has been above the bound.
    above_periods: u32,
}

impl Divergence {
    pub(super) fn reset(&mut self) {
        *self = Self::default();
    }

    /// One path-following step covering `periods`; true when the error has stayed above
    /// the bound for `check.persist_steps` after the settling window.
    pub(super) fn update(
        &mut self,
        telemetry: &Telemetry,
        periods: u32,
        check: &DivergenceCheck,
    ) -> bool {
        self.armed_periods = self.armed_periods.saturating_add(periods);
        if self.armed_periods <= check.settle_steps {
            return false;
        }
        // A NaN error is caught as a non-finite fault; it does not count here.
        if telemetry.error.position_m() > check.bound_m {
            self.above_periods = self.above_periods.saturating_add(periods);
        } else {
            self.above_periods = 0;
        }
        self.above_periods >= check.persist_steps
    }
}

/// True when the estimated `pose` is more than `radius_m` from `start` (world frame, m).
pub(super) fn outside_geofence(pose: &Pose, start: &Pose, radius_m: f32) -> bool {
    pose.position().distance_to(start.position()) > radius_m
}

/// The supply judged against the battery and bridge limits, debounced.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Supply {
    low_steps: u32,
    high_steps: u32,
    warn_steps: u32,
}

/// What [`Supply::update`] concluded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct SupplyVerdict {
    /// Below the warning threshold (debounced).
    pub(super) warn: bool,
    /// Below the fault threshold (debounced).
    pub(super) low: bool,
    /// Above the bridge's maximum (debounced).
    pub(super) high: bool,
}

impl Supply {
    /// One step with the filtered supply `supply_v` (V) against `check` and the bridge's
    /// `max_supply_v` (V).
    pub(super) fn update(
        &mut self,
        supply_v: f32,
        check: &BatteryCheck,
        max_supply_v: f32,
    ) -> SupplyVerdict {
        let count = |steps: &mut u32, condition: bool| {
            *steps = if condition {
                steps.saturating_add(1)
            } else {
                0
            };
            *steps >= check.debounce_steps
        };
        // A NaN supply is below every threshold: "at least" fails for it.
        let at_least = |threshold: f32| supply_v >= threshold;
        SupplyVerdict {
            warn: count(&mut self.warn_steps, !at_least(check.warn_v)),
            low: count(&mut self.low_steps, !at_least(check.fault_v)),
            high: count(&mut self.high_steps, supply_v > max_supply_v),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drive::WheelVolts;
    use crate::kinematics::{TrackingError, WheelSpeeds};

    #[test]
    fn missed_ticks_fault_on_a_long_gap_or_too_many_in_a_window() {
        let check = MissedTickCheck {
            window_steps: 1000,
            max_per_window: 20,
            max_gap_periods: 10,
        };
        let mut m = MissedTicks::default();
        assert!(!m.update(1, &check));
        assert!(!m.update(9, &check), "a gap of 9 periods is tolerated");
        assert_eq!(m.total, 8);
        assert!(m.update(10, &check), "a gap of 10 periods is not");
        // 21 single misses within one window.
        let mut m = MissedTicks::default();
        let mut faulted = false;
        for k in 0..21 {
            faulted = m.update(2, &check);
            assert_eq!(faulted, k == 20, "miss {k}");
        }
        assert!(faulted);
        // Spread over windows they are fine.
        let mut m = MissedTicks::default();
        for _ in 0..100 {
            assert!(!m.update(2, &check));
            for _ in 0..100 {
                m.update(1, &check);
            }
        }
        assert_eq!(m.total, 100);
    }

    fn telemetry(volts: f32, speed: f32, error_m: f32) -> Telemetry {
        let mut t = Telemetry::default();
        t.wheel_loop.volts = WheelVolts {
            left_v: volts,
            right_v: volts,
        };
        t.wheel_speed = WheelSpeeds::new(speed, speed);
        t.error = TrackingError {
            x_e_m: error_m,
            y_e_m: 0.0,
            theta_e_rad: 0.0,
        };
        t
    }

    /// A stall after 3 steps driven with ≥ 3.6 V and turning slower than 1 rad/s.
    const STALL: StallCheck = StallCheck {
        min_volts: 3.6,
        min_speed_rad_s: 1.0,
        timeout_steps: 3,
    };

    /// Divergence: 100 steps to settle, then 50 steps over 0.5 m.
    const DIVERGENCE: DivergenceCheck = DivergenceCheck {
        settle_steps: 100,
        bound_m: 0.5,
        persist_steps: 50,
    };

    #[test]
    fn stall_needs_drive_without_motion_in_the_driven_direction() {
        let check = STALL;
        let mut s = Stall::default();
        // Driven forward, turning backwards (wrong polarity): counts.
        let t = telemetry(4.0, -5.0, 0.0);
        assert_eq!(s.update(&t, &check), [false, false]);
        assert_eq!(s.update(&t, &check), [false, false]);
        assert_eq!(s.update(&t, &check), [true, true]);
        // Turning the driven way resets the count; a small voltage never counts.
        s.reset();
        assert_eq!(s.update(&telemetry(4.0, 5.0, 0.0), &check), [false, false]);
        for _ in 0..5 {
            assert_eq!(s.update(&telemetry(3.5, 0.0, 0.0), &check), [false, false]);
        }
        // Driven backwards and not turning backwards.
        for _ in 0..2 {
            s.update(&telemetry(-4.0, 0.5, 0.0), &check);
        }
        assert_eq!(s.update(&telemetry(-4.0, 0.5, 0.0), &check), [true, true]);
    }

    #[test]
    fn a_silent_wheel_under_a_drive_that_dips_now_and_then_still_stalls() {
        let check = STALL;
        let mut s = Stall::default();
        let (driven, dip) = (telemetry(4.0, 0.0, 0.0), telemetry(1.0, 0.0, 0.0));
        // Driven, a dip below min_volts, driven: the dip takes one step off, it does not
        // start the count again (2 − 1 + 1 = 2, then 3).
        assert_eq!(s.update(&driven, &check), [false, false]);
        assert_eq!(s.update(&driven, &check), [false, false]);
        assert_eq!(s.update(&dip, &check), [false, false]);
        assert_eq!(s.update(&driven, &check), [false, false]);
        assert_eq!(s.update(&driven, &check), [true, true]);
        // Dips alone drain the count to 0 and no further: three driven steps again.
        for _ in 0..10 {
            s.update(&dip, &check);
        }
        assert_eq!(s.update(&driven, &check), [false, false]);
        assert_eq!(s.update(&driven, &check), [false, false]);
        assert_eq!(s.update(&driven, &check), [true, true]);
        // A wheel seen turning under a small voltage (either way) clears it at once.
        s.update(&telemetry(1.0, -2.0, 0.0), &check);
        assert_eq!(s.update(&driven, &check), [false, false]);
        assert_eq!(s.update(&driven, &check), [false, false]);
    }

    #[test]
    fn a_wheel_driven_backwards_and_turning_backwards_is_not_stalled() {
        let check = STALL;
        let mut s = Stall::default();
        for _ in 0..10 {
            assert_eq!(
                s.update(&telemetry(-4.0, -5.0, 0.0), &check),
                [false, false]
            );
        }
    }

    #[test]
    fn a_reset_stall_count_starts_from_zero() {
        let check = STALL;
        let mut s = Stall::default();
        let stuck = telemetry(4.0, 0.0, 0.0);
        s.update(&stuck, &check);
        s.update(&stuck, &check);
        s.reset();
        // Two more stuck steps after the reset: still under the 3-step timeout.
        assert_eq!(s.update(&stuck, &check), [false, false]);
        assert_eq!(s.update(&stuck, &check), [false, false]);
        assert_eq!(s.update(&stuck, &check), [true, true]);
    }

    #[test]
    fn a_reset_divergence_check_waits_for_the_settling_window_again() {
        let check = DIVERGENCE;
        let mut d = Divergence::default();
        let near = telemetry(0.0, 0.0, 0.1);
        let far = telemetry(0.0, 0.0, 1.0);
        for _ in 0..200 {
            assert!(!d.update(&near, 1, &check));
        }
        // A new run: far off the path at first, as a run that starts away from it is.
        d.reset();
        for k in 0..100 {
            assert!(
                !d.update(&far, 1, &check),
                "step {k} of the new settling window"
            );
        }
    }

    #[test]
    fn saturation_over_half_a_window_is_flagged() {
        let check = SaturationCheck {
            window_steps: 100,
            max_fraction: 0.5,
        };
        let mut s = Saturation::default();
        let mut saturated = Telemetry::default();
        saturated.wheel_loop.saturated = [true, false];
        let free = Telemetry::default();
        // 50 saturated steps are allowed, the 51st is not.
        for k in 0..50 {
            assert_eq!(s.update(&saturated, 1, &check), [false, false], "{k}");
        }
        assert_eq!(s.update(&saturated, 1, &check), [true, false]);
        // A new window starts afresh: bursts shorter than half a window never count up.
        let mut s = Saturation::default();
        for _ in 0..10 {
            for _ in 0..40 {
                assert_eq!(s.update(&saturated, 1, &check), [false, false]);
            }
            for _ in 0..60 {
                s.update(&free, 1, &check);
            }
        }
    }

    #[test]
    fn divergence_waits_for_the_settling_window_then_for_persistence() {
        let check = DIVERGENCE;
        let mut d = Divergence::default();
        let far = telemetry(0.0, 0.0, 1.0);
        for _ in 0..100 {
            assert!(!d.update(&far, 1, &check), "inside the settling window");
        }
        for k in 0..50 {
            assert_eq!(d.update(&far, 1, &check), k == 49, "step {k}");
        }
        // An error that dips under the bound restarts the count.
        d.reset();
        for _ in 0..100 {
            d.update(&far, 1, &check);
        }
        for _ in 0..40 {
            d.update(&far, 1, &check);
        }
        assert!(!d.update(&telemetry(0.0, 0.0, 0.1), 1, &check));
        for _ in 0..49 {
            assert!(!d.update(&far, 1, &check));
        }
        assert!(d.update(&far, 1, &check));
        // Late steps count for the time they covered.
        let mut d = Divergence::default();
        assert!(!d.update(&far, 100, &check));
        assert!(d.update(&far, 50, &check));
    }

    #[test]
    fn geofence_is_a_distance_from_the_start() {
        let start = Pose::new(1.0, 1.0, 0.0);
        assert!(!outside_geofence(&Pose::new(3.0, 1.0, 2.0), &start, 2.5));
        assert!(outside_geofence(&Pose::new(3.0, 3.0, 0.0), &start, 2.5));
        // On the fence (3-4-5, exact in f32) is still inside.
        assert!(!outside_geofence(&Pose::new(4.0, 5.0, 0.0), &start, 5.0));
    }

    #[test]
    fn the_top_of_the_supply_range_is_allowed() {
        // The driver's maximum itself is in range; only above it counts as high.
        let check = BatteryCheck {
            warn_v: 5.0,
            fault_v: 4.6,
            debounce_steps: 1,
        };
        let mut s = Supply::default();
        assert!(!s.update(13.5, &check, 13.5).high);
        assert!(s.update(13.6, &check, 13.5).high);
    }

    #[test]
    fn supply_checks_are_debounced_and_nan_is_low() {
        let check = BatteryCheck {
            warn_v: 5.0,
            fault_v: 4.6,
            debounce_steps: 3,
        };
        let mut s = Supply::default();
        let v = |s: &mut Supply, volts| s.update(volts, &check, 13.5);
        assert_eq!(v(&mut s, 4.8), SupplyVerdict::default());
        v(&mut s, 4.8);
        assert_eq!(
            v(&mut s, 4.8),
            SupplyVerdict {
                warn: true,
                low: false,
                high: false
            }
        );
        // A 2-step sag to 4 V does not fault.
        v(&mut s, 4.0);
        v(&mut s, 4.0);
        assert!(!v(&mut s, 4.8).low);
        for _ in 0..2 {
            v(&mut s, f32::NAN);
        }
        assert!(v(&mut s, f32::NAN).low);
        for _ in 0..2 {
            v(&mut s, 14.0);
        }
        assert!(v(&mut s, 14.0).high);
    }
}
