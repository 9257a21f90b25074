//! Sums and constants in `f32` without the drift of plain rounding.
//!
//! - [`CompensatedSum`]: odometry adds a sub-millimetre step to x and y 1000 times a
//!   second; in plain `f32` every addition rounds to the sum's ulp, and over a day the
//!   rounding adds up to millimetres. Kahan's compensation carries what each addition
//!   lost into the next one.
//! - [`DoubleF32`]: constants computed once at start-up to about 48 bits with plain `f32`
//!   operations (the same bits on the host and on the Cortex-M4F, no soft `f64`), to seed
//!   the fixed-point accumulators of [`crate::fixed`].

use core::f32::consts::TAU;

/// 2π − `TAU` (the `f32` nearest 2π is 1.75e-7 too large).
const TAU_LO: f32 = -1.748_455_6e-7;

/// A running sum of many small `f32` increments that keeps the rounding error of each
/// addition (Kahan's compensated summation).
///
/// `x += Δx` in plain `f32` loses up to half an ulp of `x` per step: at |x| ≈ 1 m that is
/// 6e-8 m, and after a day of 1 kHz steps (8.6e7) the lost parts add up to millimetres.
/// The compensation term carries what each addition dropped into the next one.
///
/// Its limit: the compensation is folded into the next increment, and the part of it
/// below that increment's own ulp is lost. With increments that vary (odometry's
/// x and y steps) those losses do not add up — 1e-7 m in a day on the paper's circle.
/// With the same tiny increment every step they do (a heading summed this way lost
/// 1.8e-7 rad per lap): such sums are kept in fixed point instead ([`crate::fixed`]).
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
}

/// A number carried as an unevaluated sum hi + lo of two `f32`s (about 48 significant
/// bits), with the error-free transformations that compute with it in plain `f32`
/// arithmetic (Dekker, Knuth): the same bits on the host and on the Cortex-M4F, and no
/// soft `f64` in the firmware. Used only to compute constants once, at start-up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DoubleF32 {
    /// The leading part.
    pub hi: f32,
    /// The trailing part, |lo| ≤ ulp(hi)/2.
    pub lo: f32,
}

/// a + b = s + e exactly (Knuth's TwoSum).
fn two_sum(a: f32, b: f32) -> (f32, f32) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// Splits `a` into two halves of 12 significant bits (Veltkamp), a = hi + lo.
fn split(a: f32) -> (f32, f32) {
    let c = 4097.0 * a;
    let hi = c - (c - a);
    (hi, a - hi)
}

/// a · b = p + e exactly (Dekker's TwoProduct, no fused multiply-add).
fn two_product(a: f32, b: f32) -> (f32, f32) {
    let p = a * b;
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
}

impl DoubleF32 {
    /// 2π to about 48 bits.
    pub const TAU: DoubleF32 = DoubleF32 {
        hi: TAU,
        lo: TAU_LO,
    };

    /// `x` exactly.
    pub const fn from_f32(x: f32) -> Self {
        Self { hi: x, lo: 0.0 }
    }

    fn normalized(hi: f32, lo: f32) -> Self {
        let (hi, lo) = two_sum(hi, lo);
        Self { hi, lo }
    }
}

impl core::ops::Mul<f32> for DoubleF32 {
    type Output = Self;

    /// self · b.
    fn mul(self, b: f32) -> Self {
        let (p, e) = two_product(self.hi, b);
        Self::normalized(p, e + self.lo * b)
    }
}

impl core::ops::Div<f32> for DoubleF32 {
    type Output = Self;

    /// self / b (b ≠ 0; a zero or non-finite b gives a non-finite result).
    fn div(self, b: f32) -> Self {
        let q = self.hi / b;
        let (p, e) = two_product(q, b);
        let remainder = ((self.hi - p) - e) + self.lo;
        Self::normalized(q, remainder / b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn as_f64(d: DoubleF32) -> f64 {
        f64::from(d.hi) + f64::from(d.lo)
    }

    #[test]
    fn double_f32_computes_constants_to_about_48_bits() {
        // 2π · 0.0325 / 1440 / 0.15, the reference robot's heading per tick.
        let (r, t, l) = (0.0325f32, 1440.0f32, 0.15f32);
        let d = DoubleF32::TAU * r / t / l;
        let exact = core::f64::consts::TAU * f64::from(r) / f64::from(t) / f64::from(l);
        let rel = (as_f64(d) - exact).abs() / exact;
        assert!(rel < 1e-13, "{rel:e}");
        // A plain f32 computation is off by ~1e-8…1e-7.
        let plain = core::f32::consts::TAU * r / t / l;
        assert!((f64::from(plain) - exact).abs() / exact > 1e-9);
        assert!((as_f64(DoubleF32::TAU) - core::f64::consts::TAU).abs() < 1e-14);
        assert_eq!(as_f64(DoubleF32::from_f32(0.5)), 0.5);
    }

    #[test]
    fn results_are_normalised() {
        // hi is the f32 nearest the value and |lo| ≤ ulp(hi)/2, as the type promises
        // (users take `.hi` alone as the rounded constant).
        let values = [
            DoubleF32::TAU * 0.0325 / 1440.0,
            DoubleF32::from_f32(0.25) / 1000.0 / 7.853_982,
            DoubleF32::from_f32(1.0) / 3.0,
            DoubleF32::TAU * 3.0 * 7.0,
        ];
        for d in values {
            let half_ulp = f64::from(f32::from_bits(d.hi.to_bits() + 1) - d.hi) / 2.0;
            assert!(f64::from(d.lo).abs() <= half_ulp, "{d:?}");
            assert_eq!(d.hi, as_f64(d) as f32, "{d:?}");
        }
    }

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
}
