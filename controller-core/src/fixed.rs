//! Fixed-point accumulators for the two quantities summed all day: the heading and the
//! reference's position along its path.
//!
//! Both grow by nearly the same small increment every step. In `f32` that increment is a
//! rounded constant, and its rounding error, the same every step, adds up: the heading
//! summed in `f32` (even compensated, see [`crate::compensated::CompensatedSum`]) was off
//! by 5e-4 rad after a day of the paper's circle, 0.6 mm of position; and an `f32` sum of
//! v_r·T would put the reference 1 mm late (T = 1 ms is 4.7e-8 too large in `f32`, over
//! the day's 21.6 km). Here each is a binary fraction of a whole (a turn,
//! a path) in a `u64`: the increment is an integer computed once to about 48 bits
//! ([`DoubleF32`]), the sums are exact integer additions whose wrap-around is the angle's
//! or the lap's wrap, and the bits are the same on the host and the Cortex-M4F. What is
//! left is the constant's own error: below 1e-9 rad and 1e-10 m a day.

use core::f32::consts::PI;

use crate::compensated::DoubleF32;
use crate::math;

/// 2³², as `f32` (exact).
const TWO_POW_32: f32 = 4_294_967_296.0;

/// An angle as a binary fraction of a turn: 2⁻⁶⁴ turn (3.4e-19 rad) per unit.
///
/// Integer wrap-around is the angle's wrap, so a sum of these never needs a wrap test and
/// never drifts: adding a whole turn's worth of units returns the same bits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BinaryAngle(u64);

/// π·2²⁹, rounded (1 686 629 713): radians per unit of the upper 32 bits of a
/// [`BinaryAngle`] (2π/2³² = π/2³¹) times 2⁶⁰, to 3e-10 relative. The conversion
/// multiplies in integers and scales by a power of two, so its only `f32` rounding is the
/// final one, unbiased. (Multiplying by the `f32` nearest π/2³¹, 2.8e-8 too large, and
/// rounding twice, made every heading 2.8e-8 too large; even in θ·sin θ, that moved the
/// odometry 0.6 mm a day along x on the paper's circle.)
const PI_TIMES_2_POW_29: i64 = 1_686_629_713;

/// 2⁻²⁸, exact.
const TWO_POW_MINUS_28: f32 = 1.0 / 268_435_456.0;

impl BinaryAngle {
    /// The angle `rad` (rad, any value; wrapped), to 2⁻³² turn (1.5e-9 rad).
    pub fn from_rad(rad: f32) -> Self {
        // (−π, π] scaled to (−2³¹, 2³¹]; the cast saturates +2³¹ (θ = π) to 2³¹ − 1.
        let upper = (math::wrap_angle(rad) * (2_147_483_648.0 / PI)) as i32;
        Self(u64::from(upper as u32) << 32)
    }

    /// The angle in (−π, π], rad, rounded to `f32`.
    pub fn to_rad(self) -> f32 {
        let upper = i64::from((self.0 >> 32) as u32 as i32);
        // θ·2⁶⁰ (|·| < 2⁶²), then θ·2²⁸ in an i32 (the shift drops < 2⁻²⁸ rad).
        let scaled = ((upper * PI_TIMES_2_POW_29) >> 32) as i32;
        let rad = scaled as f32 * TWO_POW_MINUS_28;
        // −2³¹ units, and values rounded onto it, are −π: the same angle as π.
        if rad <= -PI {
            PI
        } else {
            rad
        }
    }

    /// This angle turned by `turn` (wrapping, as angles do).
    #[must_use]
    pub const fn add(self, turn: AngleDelta) -> Self {
        Self(self.0.wrapping_add(turn.0 as u64))
    }

    /// The turn from `other` to this angle, wrapped to [−½, ½) turn.
    #[must_use]
    pub const fn minus(self, other: Self) -> AngleDelta {
        AngleDelta(self.0.wrapping_sub(other.0) as i64)
    }
}

/// A signed change of a [`BinaryAngle`], 2⁻⁶⁴ turn per unit; sums wrap modulo a turn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AngleDelta(i64);

impl AngleDelta {
    /// `turns` of a turn (|turns| < ½), converted to within 1 unit plus the 2⁻⁴⁸ relative
    /// error of `turns` itself. Half a turn or more saturates.
    pub fn from_turns(turns: DoubleF32) -> Self {
        let scale = TWO_POW_32 * TWO_POW_32;
        // hi·2⁶⁴ is an integer whenever |hi| ≥ 2⁻⁴¹, and exact in i64 below ½ turn.
        let hi = (turns.hi * scale) as i64;
        let lo = (turns.lo * scale) as i64;
        Self(hi.wrapping_add(lo))
    }

    /// `rad` radians (|rad| < π; beyond, saturated), to 24 bits of `rad` itself: for the
    /// small per-step turns of a rate sensor, whose rounding is unbiased.
    pub fn from_rad(rad: f32) -> Self {
        Self((rad * (TWO_POW_32 * TWO_POW_32 / core::f32::consts::TAU)) as i64)
    }

    /// The change in radians, in [−π, π), rounded to `f32`.
    pub fn to_rad(self) -> f32 {
        self.0 as f32 * (core::f32::consts::TAU / (TWO_POW_32 * TWO_POW_32))
    }

    /// `count` times this change, modulo a turn (an exact integer product: no rounding).
    #[must_use]
    pub const fn times(self, count: i32) -> Self {
        Self(self.0.wrapping_mul(count as i64))
    }

    /// The sum of two changes, modulo a turn.
    #[must_use]
    pub const fn plus(self, other: Self) -> Self {
        Self(self.0.wrapping_add(other.0))
    }

    /// The difference of two changes, modulo a turn.
    #[must_use]
    pub const fn minus(self, other: Self) -> Self {
        Self(self.0.wrapping_sub(other.0))
    }
}

/// A position along a path as a binary fraction of the path's length: 2⁻⁶⁴ of the path
/// per unit (2⁻⁶⁴ × 7.85 m = 4e-19 m on the paper's circle).
///
/// On a closed path, integer wrap-around is the lap's wrap, as [`BinaryAngle`]'s is the
/// turn's; on an open path sums saturate at [`PathFraction::END`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct PathFraction(u64);

impl PathFraction {
    /// The start of the path.
    pub const START: Self = Self(0);
    /// The end of an open path (one unit short of a whole lap).
    pub const END: Self = Self(u64::MAX);

    /// The fraction `fraction` of the path ([0, 1]; 1 and beyond are the end, below 0 and
    /// NaN the start), to 2⁻⁶⁴ plus the 2⁻⁴⁸ relative error of `fraction` itself.
    pub fn from_fraction(fraction: DoubleF32) -> Self {
        let scale = TWO_POW_32 * TWO_POW_32;
        // Both casts saturate; hi·2⁶⁴ is an integer whenever hi ≥ 2⁻⁴¹.
        let hi = (fraction.hi * scale) as u64;
        let lo = (fraction.lo * scale) as i64;
        Self(hi.saturating_add_signed(lo))
    }

    /// `count` times this fraction, modulo a lap (exact).
    #[must_use]
    pub const fn times_wrapping(self, count: u32) -> Self {
        Self(self.0.wrapping_mul(count as u64))
    }

    /// `count` times this fraction, saturating at the end.
    #[must_use]
    pub const fn times_saturating(self, count: u32) -> Self {
        Self(self.0.saturating_mul(count as u64))
    }

    /// The sum, modulo a lap.
    #[must_use]
    pub const fn plus_wrapping(self, other: Self) -> Self {
        Self(self.0.wrapping_add(other.0))
    }

    /// The sum, saturating at the end.
    #[must_use]
    pub const fn plus_saturating(self, other: Self) -> Self {
        Self(self.0.saturating_add(other.0))
    }

    /// The arc length, m, on a path `length_m` (m) long, in [0, `length_m`].
    pub fn of_length_m(self, length_m: f32) -> f32 {
        // The upper 32 bits, in one unsigned conversion, scaled by length/2³²: exact
        // within the f32 rounding of the result.
        let upper = (self.0 >> 32) as u32 as f32;
        math::clamp(upper * (length_m / TWO_POW_32), 0.0, length_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::TAU;

    #[test]
    fn binary_angle_round_trips_and_stays_wrapped() {
        for rad in [
            0.0f32,
            1.0,
            -1.0,
            3.0,
            -3.0,
            PI - 1e-6,
            1e-6 - PI,
            7.0,
            -20.0,
        ] {
            let back = BinaryAngle::from_rad(rad).to_rad();
            let expected = math::wrap_angle(rad);
            assert!(math::wrap_angle(back - expected).abs() < 1e-6, "{rad}");
            assert!(back > -PI && back <= PI);
        }
        assert_eq!(BinaryAngle::from_rad(PI).to_rad(), PI);
        assert_eq!(BinaryAngle::from_rad(-PI).to_rad(), PI);
        assert_eq!(BinaryAngle(1 << 63).to_rad(), PI);
    }

    #[test]
    fn to_rad_has_no_scale_error() {
        // Over 10⁵ angles spread across the circle, the mean relative error of the f32
        // heading must be far below the 2.8e-8 of a conversion through the f32 π.
        let step = AngleDelta::from_turns(DoubleF32::from_f32(1.0) / 99_991.0);
        let (mut a, mut sum, mut n) = (BinaryAngle::default(), 0.0f64, 0.0f64);
        for k in 1..99_991i64 {
            a = a.add(step);
            let exact = (k as f64 / 99_991.0 * TAU + core::f64::consts::PI).rem_euclid(TAU)
                - core::f64::consts::PI;
            if exact.abs() > 0.1 {
                sum += (f64::from(a.to_rad()) - exact) / exact;
                n += 1.0;
            }
        }
        assert!((sum / n).abs() < 1e-9, "mean relative error {:e}", sum / n);
    }

    #[test]
    fn a_turn_of_increments_comes_back_to_the_same_bits() {
        // A quarter turn, exactly representable: four of them are a whole turn.
        let quarter = AngleDelta::from_turns(DoubleF32::from_f32(0.25));
        let start = BinaryAngle::from_rad(0.7);
        let mut a = start;
        for _ in 0..4 {
            a = a.add(quarter);
        }
        assert_eq!(a, start);
        assert!((start.add(quarter).to_rad() - (0.7 + core::f32::consts::FRAC_PI_2)).abs() < 1e-6);
        assert!(
            (start.add(quarter.times(-1)).to_rad() - (0.7 - core::f32::consts::FRAC_PI_2)).abs()
                < 1e-6
        );
    }

    #[test]
    fn a_day_of_heading_increments_does_not_drift() {
        // The reference robot's heading per tick (R = 0.0325 m, 1440 ticks, L = 0.15 m),
        // 1.7e8 ticks of one wheel (a day of the paper's circle): the binary angle must
        // equal the exact product modulo a turn to 1e-9 rad.
        let turns = DoubleF32::from_f32(0.0325) / 1440.0 / 0.15;
        let per_tick = AngleDelta::from_turns(turns);
        let mut a = BinaryAngle::default();
        let ticks = 170_000_000i64;
        for _ in 0..ticks / 10_000 {
            a = a.add(per_tick.times(10_000));
        }
        let turns_f64 = f64::from(0.0325f32) / 1440.0 / f64::from(0.15f32);
        let exact = (ticks as f64 * turns_f64 * TAU).rem_euclid(TAU);
        let exact = if exact > core::f64::consts::PI {
            exact - TAU
        } else {
            exact
        };
        assert!(
            (f64::from(a.to_rad()) - exact).abs() < 1e-6,
            "{} {exact}",
            a.to_rad()
        );
        // The fixed-point product equals the step-by-step sum bit for bit.
        let mut b = BinaryAngle::default();
        for _ in 0..1000 {
            b = b.add(per_tick);
        }
        assert_eq!(b, BinaryAngle::default().add(per_tick.times(1000)));
        assert_eq!(per_tick.minus(per_tick), AngleDelta::default());
    }

    #[test]
    fn path_fraction_converts_wraps_and_saturates() {
        let length = 7.853_982f32;
        for f in [0.0f32, 1e-6, 0.25, 0.5, 0.999] {
            let s = PathFraction::from_fraction(DoubleF32::from_f32(f)).of_length_m(length);
            assert!((s - f * length).abs() <= 1e-6, "{f} {s}");
        }
        assert_eq!(
            PathFraction::from_fraction(DoubleF32::from_f32(-1.0)),
            PathFraction::START
        );
        assert_eq!(
            PathFraction::from_fraction(DoubleF32::from_f32(f32::NAN)),
            PathFraction::START
        );
        assert_eq!(
            PathFraction::from_fraction(DoubleF32::from_f32(1.0)),
            PathFraction::END
        );
        assert_eq!(PathFraction::END.of_length_m(length), length);
        let quarter = PathFraction::from_fraction(DoubleF32::from_f32(0.25));
        let three_quarters = PathFraction::from_fraction(DoubleF32::from_f32(0.75));
        // A lap wraps on a closed path and stops at the end of an open one.
        assert_eq!(
            three_quarters.plus_wrapping(quarter.times_wrapping(2)),
            quarter
        );
        assert_eq!(
            three_quarters.plus_saturating(quarter.times_wrapping(2)),
            PathFraction::END
        );
        assert_eq!(quarter.times_saturating(5), PathFraction::END);
        assert_eq!(quarter.times_wrapping(5), quarter);
    }

    #[test]
    fn a_day_of_arc_length_does_not_drift() {
        // 0.25 m/s at 1 kHz for a day on the 7.854 m circle: 8.64e7 periods; the position
        // must be 21 600 m modulo the lap, to 1 µm.
        let length = 7.853_982f32;
        let per_period = PathFraction::from_fraction(DoubleF32::from_f32(0.25) / 1000.0 / length);
        let mut s = PathFraction::START;
        for _ in 0..86_400 {
            s = s.plus_wrapping(per_period.times_wrapping(1000));
        }
        let exact = 21_600.0f64.rem_euclid(f64::from(length));
        let got = f64::from(s.of_length_m(length));
        assert!((got - exact).abs() < 1e-6, "{got} {exact}");
    }
}
