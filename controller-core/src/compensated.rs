//! Compensated (Kahan) summation: long sums of small `f32` increments without drift.
//!
//! Odometry adds a sub-millimetre step to each coordinate 1000 times a second, and the
//! time-indexed reference adds 2.5 mm of arc length 100 times a second. In plain `f32`
//! every addition rounds to the sum's ulp, and over a day the rounding adds up to
//! millimetres of position and hundredths of a radian of heading. [`CompensatedSum`]
//! carries what each addition lost into the next one.

use core::f32::consts::{PI, TAU};

/// 2π − `TAU` (the `f32` nearest 2π is 1.75e-7 too large): what a wrap by `TAU` leaves out.
const TAU_LO: f32 = -1.748_455_6e-7;

/// A running sum of many small `f32` increments that keeps the rounding error of each
/// addition (Kahan's compensated summation).
///
/// `x += Δx` in plain `f32` loses up to half an ulp of `x` per step: at |x| ≈ 1 m that is
/// 6e-8 m, and after a day of 1 kHz steps (8.6e7) the lost parts add up to millimetres.
/// The compensation term carries what each addition dropped into the next one, so the
/// error stays at about one ulp of the sum however many steps are taken.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CompensatedSum {
    sum: f32,
    /// The negative of the low-order part lost by the last addition.
    compensation: f32,
}

impl CompensatedSum {
    /// A sum starting at `value`.
    pub const fn new(value: f32) -> Self {
        Self {
            sum: value,
            compensation: 0.0,
        }
    }

    /// The sum (within about one ulp of the exact sum of everything added).
    pub const fn value(&self) -> f32 {
        self.sum
    }

    /// Adds `x`.
    #[inline]
    pub fn add(&mut self, x: f32) {
        let y = x - self.compensation;
        let t = self.sum + y;
        self.compensation = (t - self.sum) - y;
        self.sum = t;
    }

    /// Subtracts `modulus` (> 0) while the sum is ≥ `modulus`, e.g. to keep an arc length
    /// within one lap. Exact for a sum below 2·`modulus` (Sterbenz's lemma), so the
    /// compensation stays valid; a jump of many laps at once (never in the control loop)
    /// falls back to the `f32` remainder. A non-finite sum is left as it is, for the
    /// caller's fault check to see.
    #[inline]
    pub fn wrap_below(&mut self, modulus: f32) {
        if !(self.sum.is_finite() && modulus > 0.0) || self.sum < modulus {
            return;
        }
        self.sum -= modulus;
        if self.sum >= modulus {
            self.sum %= modulus;
        }
    }

    /// Adds `x` and wraps the sum into (−π, π] (for an angle in rad). The wrap subtracts
    /// or adds 2π exactly: `TAU` (exact by Sterbenz's lemma) plus its rounding error
    /// carried in the compensation, so turning circles for a day does not drift.
    #[inline]
    pub fn add_wrapped(&mut self, x: f32) {
        self.add(x);
        // The common case in one comparison.
        if crate::math::abs(self.sum) < PI {
            return;
        }
        if self.sum > PI {
            self.sum -= TAU;
            self.compensation += TAU_LO;
        } else if self.sum <= -PI {
            self.sum += TAU;
            self.compensation -= TAU_LO;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compensated_sum_keeps_what_plain_f32_loses() {
        // 10⁶ additions of 1e-4 to 1.0: plain f32 drifts by ~1e-2 (each addition rounds
        // to a multiple of 1.2e-7), the compensated sum stays within an ulp of 101.
        let mut plain = 1.0f32;
        let mut kahan = CompensatedSum::new(1.0);
        for _ in 0..1_000_000 {
            plain += 1e-4;
            kahan.add(1e-4);
        }
        let exact = 1.0 + 1_000_000.0 * f64::from(1e-4f32);
        assert!((f64::from(plain) - exact).abs() > 1e-3, "{plain}");
        assert!(
            (f64::from(kahan.value()) - exact).abs() < 2e-5,
            "{}",
            kahan.value()
        );
    }

    #[test]
    fn wrapped_angle_sum_turns_many_times_without_drift() {
        // 1000 turns in steps of 2π/997: the heading must come back to the start.
        let step = (core::f64::consts::TAU / 997.0) as f32;
        let mut a = CompensatedSum::new(0.5);
        for _ in 0..997 * 1000 {
            a.add_wrapped(step);
            assert!(a.value() > -PI && a.value() <= PI);
        }
        // The f32 step is 997·step ≠ 2π by its own rounding: compare with that.
        let exact = (0.5 + 997_000.0 * f64::from(step)).rem_euclid(core::f64::consts::TAU);
        let exact = if exact > core::f64::consts::PI {
            exact - core::f64::consts::TAU
        } else {
            exact
        };
        assert!(
            (f64::from(a.value()) - exact).abs() < 1e-6,
            "{} vs {exact}",
            a.value()
        );
    }

    #[test]
    fn wrap_below_keeps_a_lap_counter_exact() {
        let mut s = CompensatedSum::new(7.0);
        s.add(1.5);
        s.wrap_below(7.853_982);
        assert!((s.value() - 0.646_018).abs() < 1e-6);
        s.add(100.0);
        s.wrap_below(7.853_982);
        assert!((0.0..7.853_982).contains(&s.value()));
        let mut inf = CompensatedSum::new(f32::INFINITY);
        inf.wrap_below(1.0);
        assert!(inf.value().is_infinite());
    }
}
