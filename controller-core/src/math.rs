//! The one place where the core computes `sqrt`, `sin`, `cos`, `atan2`, `exp` and `ln`.
//!
//! Every function here is built from IEEE-754 `f32` add, subtract, multiply and divide
//! only (never a fused multiply-add, never `f64`), so a host build and a Cortex-M4F build
//! produce the same bits. The one exception is [`sqrt`], which is correctly rounded by
//! IEEE-754 on both sides: the FPU's `vsqrt.f32` on the M4F and `libm::sqrtf` elsewhere.
//!
//! Do not call `x.sqrt()`, `x.sin()` … on an `f32` anywhere in this crate: under
//! `cargo test` those resolve to `std`'s implementations, which the firmware does not
//! have, and the host and target would silently compute different numbers.
//!
//! | function | max error (measured over its domain, see tests) | M4F cost |
//! |---|---|---|
//! | [`sin`], [`cos`], [`sin_cos`] | ≤ 2e-7 absolute for \|x\| ≤ 8π; ≤ 1e-5 for \|x\| ≤ 1e4 | ~40 instructions |
//! | [`atan2`] | ≤ 3e-7 rad | ~50 instructions, 1–2 divisions |
//! | [`sqrt`] | correctly rounded | a call to `vsqrt.f32` (14 cycles) |
//! | [`exp`], [`ln`] | ≤ 4e-7 relative / ≤ 2e-7 absolute (see tests) | ~30 instructions, 1 division for `ln` (only the wheel-loop tune uses them, never the control step) |
//!
//! The alternatives were measured and rejected: `micromath`'s `sqrt` is ~5 % off, and
//! `libm`'s `sinf`/`cosf` evaluate in `f64`, which is software on the M4F (1200–2100
//! instructions per call).

use core::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};

/// 2/π, used to find the quadrant of an angle.
const FRAC_2_PI: f32 = core::f32::consts::FRAC_2_PI;
/// π/2 split in three parts (Cody–Waite), so that `x - k·π/2` stays exact for moderate `k`.
const PIO2_HI: f32 = 1.570_312_5;
const PIO2_MID: f32 = 4.837_513e-4;
const PIO2_LO: f32 = 7.549_79e-8;

/// Rounds to the nearest integer, ties away from zero. Saturates for huge or NaN input
/// (NaN gives 0), never panics.
#[inline]
pub fn round_to_i32(x: f32) -> i32 {
    if x >= 0.0 {
        (x + 0.5) as i32
    } else {
        (x - 0.5) as i32
    }
}

/// 1.5 · 2²³: adding and subtracting it rounds an `f32` of magnitude < 2²² to the nearest
/// integer (ties to even) in two additions, the same on every IEEE-754 machine.
const ROUNDING_SHIFTER: f32 = 12_582_912.0;

/// Sine and cosine of `r` for |r| ≤ π/4 (minimax polynomials, Cephes `sinf`/`cosf`).
#[inline]
fn sin_cos_kernel(r: f32) -> (f32, f32) {
    let z = r * r;
    let s = r + r * z * (-1.666_665_5e-1 + z * (8.332_161e-3 + z * -1.951_529_6e-4));
    let c = 1.0 - 0.5 * z + z * z * (4.166_664_6e-2 + z * (-1.388_731_6e-3 + z * 2.443_315_7e-5));
    (s, c)
}

/// Sine and cosine of an angle in radians, computed together (one range reduction).
///
/// Accurate to ~2e-7 for |x| ≤ 8π and to 1e-5 up to |x| = 1e4; angles in the core are
/// wrapped to (−π, π] first. Non-finite input gives NaN (and |x| ≥ 2²² garbage), never
/// a panic.
pub fn sin_cos(x: f32) -> (f32, f32) {
    // Quadrant k = round(x·2/π). For non-finite x, kf is not finite either and r is NaN.
    let kf = (x * FRAC_2_PI + ROUNDING_SHIFTER) - ROUNDING_SHIFTER;
    let r = ((x - kf * PIO2_HI) - kf * PIO2_MID) - kf * PIO2_LO;
    let (s, c) = sin_cos_kernel(r);
    match (kf as i32) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Sine of an angle in radians. See [`sin_cos`] for accuracy.
#[inline]
pub fn sin(x: f32) -> f32 {
    sin_cos(x).0
}

/// Cosine of an angle in radians. See [`sin_cos`] for accuracy.
#[inline]
pub fn cos(x: f32) -> f32 {
    sin_cos(x).1
}

/// Below this x², [`sinc`] uses its series (|x| < 0.1).
const SINC_SERIES_MAX_X2: f32 = 1e-2;

/// sin(x)/x, with its removable singularity at x = 0 evaluated by a series, never by 0/0.
///
/// This is the factor of the paper's eq. (34), (cos θ_e sin θ_e / θ_e), and odometry's
/// chord factor, whose argument is a fraction of a step's turn (|x| < 0.1): there the
/// series alone is used and no sine is evaluated.
pub fn sinc(x: f32) -> f32 {
    if x * x < SINC_SERIES_MAX_X2 {
        sinc_series(x * x)
    } else {
        sin(x) / x
    }
}

/// sin x / x = 1 − x²/6 + x⁴/120 − x⁶/5040 for `z` = x² < 0.01; the next term, x⁸/362880,
/// is < 3e-13.
#[inline]
fn sinc_series(z: f32) -> f32 {
    // The x⁶ term is < 2e-10, under half an ulp of the sum (≈ 1), so it does not change
    // the f32 result; it is kept for the series' stated accuracy.
    1.0 - z * (1.0 / 6.0) + z * z * (1.0 / 120.0) - z * z * z * (1.0 / 5040.0)
}

/// sin(x)/x when sin(x) is already known (`sin_x`): saves a second evaluation of the sine.
/// Near 0 the series is used and `sin_x` is ignored.
#[inline]
pub fn sinc_with_sin(x: f32, sin_x: f32) -> f32 {
    let z = x * x;
    // `<=`: equivalent, as in `sinc`.
    if z < SINC_SERIES_MAX_X2 {
        sinc_series(z)
    } else {
        sin_x / x
    }
}

/// Arc tangent of `a` for 0 ≤ a ≤ 1 (Cephes `atanf` polynomial, with the π/8 reduction).
#[inline]
fn atan_unit(a: f32) -> f32 {
    // tan(π/8).
    let (base, t) = if a > 0.414_213_57 {
        (FRAC_PI_4, (a - 1.0) / (a + 1.0))
    } else {
        (0.0, a)
    };
    let z = t * t;
    let p = (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z;
    base + (t + t * p)
}

/// Four-quadrant arc tangent of `y/x`, in radians, in [−π, π].
///
/// `atan2(0, 0)` is 0 (no division by zero); non-finite input gives NaN or a finite
/// value, never a panic.
pub fn atan2(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let (lo, hi) = if ax >= ay { (ay, ax) } else { (ax, ay) };
    if hi == 0.0 {
        return 0.0;
    }
    let mut angle = atan_unit(lo / hi);
    if ay > ax {
        angle = FRAC_PI_2 - angle;
    }
    if x < 0.0 {
        angle = PI - angle;
    }
    if y < 0.0 {
        -angle
    } else {
        angle
    }
}

// The Cortex-M4F's FPU has a correctly rounded `vsqrt.f32` (14 cycles). Stable Rust cannot
// name the FPU registers in inline `asm!` for this target (the `vfp2` feature is unstable
// there), so it is a two-instruction leaf function: under the hard-float ABI the argument
// and the result are both in s0.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
core::arch::global_asm!(
    ".section .text.controller_core_vsqrt_f32,\"ax\",%progbits",
    ".global controller_core_vsqrt_f32",
    ".type controller_core_vsqrt_f32,%function",
    ".fpu fpv4-sp-d16",
    ".thumb_func",
    "controller_core_vsqrt_f32:",
    "vsqrt.f32 s0, s0",
    "bx lr",
    ".size controller_core_vsqrt_f32, . - controller_core_vsqrt_f32",
);

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
extern "C" {
    fn controller_core_vsqrt_f32(x: f32) -> f32;
}

/// Square root, correctly rounded (IEEE-754), identical bits on host and Cortex-M4F.
///
/// Negative input gives NaN.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        // SAFETY: the function above reads s0 and writes s0 and touches nothing else,
        // which is exactly the hard-float AAPCS contract of `extern "C" fn(f32) -> f32`.
        unsafe { controller_core_vsqrt_f32(x) }
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// Euclidean length √(x² + y²) of a vector in metres (or any unit).
#[inline]
pub fn hypot(x: f32, y: f32) -> f32 {
    sqrt(x * x + y * y)
}

/// Absolute value (bit operation, so also correct for −0 and NaN).
#[inline]
pub fn abs(x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0x7fff_ffff)
}

/// Clamps `x` into `[lo, hi]`. NaN is returned unchanged so that faults stay visible.
#[inline]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

/// Wraps an angle in radians into (−π, π]. Non-finite input is returned unchanged so that
/// the caller's fault check sees it.
pub fn wrap_angle(a: f32) -> f32 {
    // The common case in one comparison (±π itself takes the slow path, which maps −π to π).
    if abs(a) < PI {
        return a;
    }
    if !a.is_finite() {
        return a;
    }
    let turns = round_to_i32(a / TAU) as f32;
    let mut w = a - turns * TAU;
    if w <= -PI {
        w += TAU;
    } else if w > PI {
        w -= TAU;
    }
    w
}

/// ln 2 split in two (Cody–Waite): `n · LN2_HI` is exact for |n| ≤ 2⁸.
const LN2_HI: f32 = 0.693_145_75;
const LN2_LO: f32 = 1.428_606_8e-6;

/// e^x. Underflows to 0 below −87.3 and saturates to +∞ above 88.7 (like `f32::exp`); NaN
/// gives NaN.
pub fn exp(x: f32) -> f32 {
    if x.is_nan() {
        return x;
    }
    if x > 88.7 {
        return f32::INFINITY;
    }
    if x < -87.3 {
        return 0.0;
    }
    // x = n ln 2 + r, |r| ≤ ln 2 / 2; e^x = 2ⁿ e^r with e^r from its Taylor series to r⁷
    // (truncation below 3e-9 relative).
    let n = round_to_i32(x * core::f32::consts::LOG2_E);
    let nf = n as f32;
    let r = (x - nf * LN2_HI) - nf * LN2_LO;
    let p = 1.0
        + r * (1.0
            + r * (0.5
                + r * (1.0 / 6.0
                    + r * (1.0 / 24.0
                        + r * (1.0 / 120.0 + r * (1.0 / 720.0 + r * (1.0 / 5040.0)))))));
    // 2ⁿ for n in −126..=128, as two factors so neither leaves the normal range.
    let half = n / 2;
    p * pow2(half) * pow2(n - half)
}

/// 2ⁿ for n in −126..=127 (clamped), built from its bits.
fn pow2(n: i32) -> f32 {
    let biased = (n.clamp(-126, 127) + 127) as u32;
    f32::from_bits(biased << 23)
}

/// Natural logarithm. ln 0 = −∞, ln of a negative number or NaN is NaN, ln ∞ = ∞.
pub fn ln(x: f32) -> f32 {
    // Written so that NaN takes the first branch.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(x > 0.0) {
        return if x == 0.0 {
            f32::NEG_INFINITY
        } else {
            f32::NAN
        };
    }
    if x == f32::INFINITY {
        return x;
    }
    // Subnormals: scale into the normal range first (`<=`: equivalent, the scaling is exact).
    let (x, mut e) = if x < f32::MIN_POSITIVE {
        (x * 8_388_608.0, -23)
    } else {
        (x, 0)
    };
    let bits = x.to_bits();
    e += ((bits >> 23) & 0xff) as i32 - 127;
    // The mantissa m in [1, 2), then in [√½, √2) so |z| below is ≤ 0.172.
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    if m > core::f32::consts::SQRT_2 {
        m *= 0.5;
        e += 1;
    }
    // ln m = 2 atanh z, z = (m − 1)/(m + 1), by its series to z⁹ (error below 1e-9).
    let z = (m - 1.0) / (m + 1.0);
    let z2 = z * z;
    let series = 2.0 * z * (1.0 + z2 * (1.0 / 3.0 + z2 * (0.2 + z2 * (1.0 / 7.0 + z2 / 9.0))));
    let ef = e as f32;
    ef * LN2_HI + (ef * LN2_LO + series)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn max_err(f: impl Fn(f32) -> f32, g: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
        let n = 200_000;
        (0..=n)
            .map(|i| {
                let x = (lo + (hi - lo) * i as f64 / n as f64) as f32;
                (f(x) as f64 - g(x as f64)).abs()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn sin_cos_within_2e7_on_eight_pi() {
        let r = 8.0 * core::f64::consts::PI;
        assert!(max_err(sin, f64::sin, -r, r) < 2e-7);
        assert!(max_err(cos, f64::cos, -r, r) < 2e-7);
    }

    #[test]
    fn sin_cos_within_1e5_up_to_1e4() {
        assert!(max_err(sin, f64::sin, -1e4, 1e4) < 1e-5);
        assert!(max_err(cos, f64::cos, -1e4, 1e4) < 1e-5);
    }

    #[test]
    fn sin_cos_hand_values() {
        assert_eq!(sin(0.0), 0.0);
        assert_eq!(cos(0.0), 1.0);
        assert!((sin(FRAC_PI_2) - 1.0).abs() < 1e-7);
        assert!((cos(PI) + 1.0).abs() < 1e-7);
        assert!((sin(PI / 6.0) - 0.5).abs() < 1e-7);
    }

    #[test]
    fn atan2_matches_f64_everywhere() {
        let mut worst = 0.0f64;
        for i in 0..720 {
            let a = i as f64 * core::f64::consts::PI / 360.0;
            for r in [1e-6, 0.3, 1.0, 7.0, 1e5] {
                let (y, x) = ((r * a.sin()) as f32, (r * a.cos()) as f32);
                let exact = (y as f64).atan2(x as f64);
                worst = worst.max((atan2(y, x) as f64 - exact).abs());
            }
        }
        assert!(worst < 3e-7, "worst atan2 error {worst}");
        assert_eq!(atan2(0.0, 0.0), 0.0);
        assert!((atan2(1.0, 0.0) - FRAC_PI_2).abs() < 1e-7);
        assert!((atan2(0.0, -1.0) - PI).abs() < 1e-7);
        assert!((atan2(-1.0, -1.0) + 3.0 * FRAC_PI_4).abs() < 1e-7);
    }

    #[test]
    fn sqrt_is_correctly_rounded() {
        for i in 0..100_000u32 {
            let x = f32::from_bits(0x3000_0000 + i * 9973);
            let exact = (x as f64).sqrt() as f32; // f64 sqrt then round = correctly rounded f32
            assert_eq!(sqrt(x).to_bits(), exact.to_bits(), "x = {x}");
        }
        assert_eq!(sqrt(0.0), 0.0);
        assert!(sqrt(-1.0).is_nan());
    }

    #[test]
    fn sinc_is_continuous_through_zero() {
        assert_eq!(sinc(0.0), 1.0);
        for x in [1e-8f32, 1e-4, 9.9e-3, 1.01e-2, 0.5, 3.0] {
            let exact = (x as f64).sin() / x as f64;
            assert!((sinc(x) as f64 - exact).abs() < 1e-6, "x = {x}");
            assert_eq!(sinc(-x), sinc(x));
        }
    }

    #[test]
    fn the_series_holds_to_the_top_of_its_range() {
        // Just under |x| = 0.1, where the series gives way to sin x / x: its x⁴ term
        // (8e-7 there) counts, so the series must match sin x / x to f32 precision.
        for x in [0.0999f32, -0.0999, 0.09, 0.05] {
            let exact = (x as f64).sin() / x as f64;
            for value in [sinc(x), sinc_with_sin(x, sin(x))] {
                let rel = ((value as f64 - exact) / exact).abs();
                assert!(rel < 1.5e-7, "x = {x}: {value} vs {exact} ({rel:e})");
            }
        }
    }

    #[test]
    fn wrap_angle_lands_in_half_open_interval() {
        assert_eq!(wrap_angle(PI), PI);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-6);
        assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-6);
        assert!((wrap_angle(-7.0) - (-7.0 + TAU)).abs() < 1e-6);
        assert!((wrap_angle(100.0) - (100.0 - 16.0 * TAU)).abs() < 1e-4);
        assert!(wrap_angle(f32::NAN).is_nan());
        for i in -1000..1000 {
            let w = wrap_angle(i as f32 * 0.37);
            assert!(w > -PI && w <= PI);
        }
    }

    /// f32 values within `ulps` representable steps either side of `x`.
    fn neighbours(x: f32, ulps: u32) -> impl Iterator<Item = f32> {
        let bits = x.to_bits();
        (bits - ulps..=bits + ulps).map(f32::from_bits)
    }

    /// The exact wrap of `a` (computed in f64), for comparison.
    fn wrap_f64(a: f64) -> f64 {
        let tau = core::f64::consts::TAU;
        let w = a - tau * (a / tau).round();
        if w <= -core::f64::consts::PI {
            w + tau
        } else if w > core::f64::consts::PI {
            w - tau
        } else {
            w
        }
    }

    /// Angular distance between two angles, rad, in [0, π].
    fn angle_between(a: f64, b: f64) -> f64 {
        wrap_f64(a - b).abs()
    }

    #[test]
    fn wrap_angle_is_exact_to_rounding_around_every_odd_multiple_of_pi() {
        // Near (2k + 1)π the reduction a − round(a/2π)·2π lands on either side of ±π;
        // the result must still be in (−π, π] and equal to a modulo 2π.
        for k in -60i32..60 {
            let centre = ((2 * k + 1) as f64 * core::f64::consts::PI) as f32;
            for a in neighbours(centre.abs(), 64).map(|a| a.copysign(centre)) {
                let w = wrap_angle(a);
                assert!(w > -PI && w <= PI, "wrap_angle({a}) = {w}");
                // TAU as f32 is 1.7e-7 off 2π: that error times the turns, plus rounding.
                let tol = 2e-7 * (k.abs() as f64 + 1.0) + 4.0 * f64::from(f32::EPSILON * a.abs());
                let err = angle_between(f64::from(w), f64::from(a));
                assert!(err <= tol, "wrap_angle({a}) = {w}, off by {err}");
            }
        }
    }

    #[test]
    fn wrap_angle_is_odd_and_exact_to_rounding_everywhere() {
        // Mirror symmetry: wrapping −a gives exactly −(wrapping a), so a left turn and the
        // mirrored right turn get the same treatment, bit for bit.
        for i in 1..200_000 {
            let a = i as f32 * 0.003_7;
            let (w, m) = (wrap_angle(a), wrap_angle(-a));
            if w.abs() < PI {
                assert_eq!(m.to_bits(), (-w).to_bits(), "a = {a}: {w} vs {m}");
            }
            let tol = 2e-7 * (f64::from(a) / 6.0 + 1.0) + 4.0 * f64::from(f32::EPSILON * a);
            assert!(angle_between(f64::from(w), f64::from(a)) <= tol, "a = {a}");
        }
    }

    #[test]
    fn sinc_is_within_an_ulp_or_two_near_zero() {
        // Around the switch from the series to sin x / x, and well inside both.
        let mut worst = 0.0f64;
        for i in -3000..=3000 {
            let x = i as f32 * 1e-5;
            let exact = if x == 0.0 {
                1.0
            } else {
                (x as f64).sin() / x as f64
            };
            worst = worst.max((sinc(x) as f64 - exact).abs());
        }
        assert!(worst <= 1.2e-7, "worst sinc error near 0: {worst}");
        // Near 0 the series is used and the sine passed in is ignored.
        assert_eq!(sinc_with_sin(1e-3, 123.0), sinc(1e-3));
        assert_eq!(sinc_with_sin(-1e-3, f32::NAN), sinc(1e-3));
        // Away from 0 the sine passed in is used.
        assert_eq!(sinc_with_sin(0.5, 0.25), 0.5);
    }

    #[test]
    fn atan2_is_odd_in_y_and_mirrors_in_x() {
        for i in 0..=1000 {
            let a = i as f64 * core::f64::consts::PI / 1000.0;
            for r in [1e-3f64, 1.0, 50.0] {
                let (y, x) = ((r * a.sin()) as f32, (r * a.cos()) as f32);
                if y == 0.0 {
                    continue;
                }
                let t = atan2(y, x);
                assert_eq!(atan2(-y, x), -t, "({y}, {x})");
                assert!((atan2(y, -x) - (PI - t)).abs() <= 3e-7, "({y}, {x})");
                assert!(t > 0.0 && t <= PI);
            }
        }
        // On the axes and the diagonals, to the last bit.
        assert_eq!(atan2(2.0, 0.0), FRAC_PI_2);
        assert_eq!(atan2(-2.0, 0.0), -FRAC_PI_2);
        assert_eq!(atan2(0.0, 2.0), 0.0);
        assert_eq!(atan2(3.0, 3.0), FRAC_PI_4);
        assert_eq!(atan2(-3.0, -3.0), -3.0 * FRAC_PI_4);
    }

    #[test]
    fn clamp_and_abs() {
        assert_eq!(clamp(-1.0, 0.0, 2.0), 0.0);
        assert_eq!(clamp(3.0, 0.0, 2.0), 2.0);
        assert_eq!(clamp(1.5, 0.0, 2.0), 1.5);
        assert!(clamp(f32::NAN, 0.0, 2.0).is_nan());
        assert_eq!(abs(-0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(abs(-2.5), 2.5);
        assert_eq!(hypot(3.0, -4.0), 5.0);
    }

    #[test]
    fn exp_and_ln_match_f64_over_their_range() {
        let rel = |f: &dyn Fn(f32) -> f32, g: &dyn Fn(f64) -> f64, lo: f64, hi: f64| {
            let n = 100_000;
            (0..=n)
                .map(|i| {
                    let x = (lo + (hi - lo) * i as f64 / n as f64) as f32;
                    let exact = g(x as f64);
                    ((f(x) as f64 - exact) / exact.abs().max(1e-30)).abs()
                })
                .fold(0.0, f64::max)
        };
        assert!(rel(&exp, &f64::exp, -87.0, 88.0) < 4e-7);
        assert!(rel(&exp, &f64::exp, -1.0, 1.0) < 2e-7);
        // ln: relative error away from 1, absolute near it (where ln → 0).
        assert!(rel(&ln, &f64::ln, 1e-30, 0.5) < 2e-7);
        assert!(rel(&ln, &f64::ln, 2.0, 1e30) < 2e-7);
        assert!(max_err(ln, f64::ln, 0.5, 2.0) < 2e-7);
        assert!(max_err(|x| ln(exp(x)), |x| x, -20.0, 20.0) < 3e-6);
    }

    #[test]
    fn ln_holds_its_series_accuracy_over_a_whole_octave() {
        // m sweeps [√½, √2) here, so z reaches its largest, 0.172, where the series' last
        // term (z⁹, 3e-8) still counts: the result stays within 9e-8 of ln x (measured
        // 6.9e-8; without the last term's right sign it is 1.2e-7).
        let worst = (0..=200_000)
            .map(|i| {
                let x = (0.70 + 0.72 * i as f64 / 200_000.0) as f32;
                (ln(x) as f64 - (x as f64).ln()).abs()
            })
            .fold(0.0, f64::max);
        assert!(worst < 9e-8, "{worst:e}");
    }

    #[test]
    fn exp_and_ln_at_their_edges() {
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(ln(1.0), 0.0);
        assert_eq!(exp(-100.0), 0.0);
        assert_eq!(exp(100.0), f32::INFINITY);
        assert!(exp(f32::NAN).is_nan());
        assert_eq!(ln(0.0), f32::NEG_INFINITY);
        assert!(ln(-1.0).is_nan() && ln(f32::NAN).is_nan());
        assert_eq!(ln(f32::INFINITY), f32::INFINITY);
        // Subnormal input.
        let tiny = 1e-40f32;
        assert!((ln(tiny) as f64 - (tiny as f64).ln()).abs() < 1e-5);
        // The top of the range: e^88.7 is just below f32::MAX.
        assert!(exp(88.7).is_finite() && exp(88.7) > 3.0e38);
        assert!((exp(-87.0) as f64 / (-87.0f64).exp() - 1.0).abs() < 1e-6);
        // The bottom of the range is computed, not flushed: e^−87.3 is 1.22e-38, a normal
        // f32 (only below −87.3 does the result underflow to 0).
        assert!((exp(-87.3) as f64 / (-87.3f32 as f64).exp() - 1.0).abs() < 1e-6);
        assert!((ln(2.0) - core::f32::consts::LN_2).abs() <= f32::EPSILON);
    }
}
