//! Dead-reckoning pose from encoder ticks, exact for a constant-curvature step.
//!
//! Over one step each wheel turns by a whole number of ticks; the rim distances are
//! s_l = R·Δφ_l and s_r = R·Δφ_r. Assuming constant wheel speeds within the step (the
//! robot then drives an arc, eq. (5) integrated exactly):
//!
//! Δs = (s_r + s_l)/2, Δθ = (s_r − s_l)/L,
//! x += Δs · sinc(Δθ/2) · cos(θ + Δθ/2), y += Δs · sinc(Δθ/2) · sin(θ + Δθ/2).
//!
//! The chord factor sinc(Δθ/2) is exact for an arc and tends to 1 for a straight step,
//! with no 0/0 (see [`math::sinc`]). Plain Euler (x += Δs cos θ) would be off by O(Δθ).

use crate::compensated::{CompensatedSum, DoubleF32};
use crate::fixed::{AngleDelta, BinaryAngle};
use crate::kinematics::{DiffDrive, Pose};
use crate::math;

/// Turns below this (rad, half a step's turn) use series for their sine and cosine.
const SMALL_HALF_TURN_RAD: f32 = 0.1;

/// Steps between two exact recomputations of the heading's sine and cosine.
const HEADING_RESYNC_STEPS: u8 = 64;

/// Pose estimate integrated from wheel-tick deltas, world frame.
///
/// x and y are [`CompensatedSum`]s and θ is a [`BinaryAngle`] advanced by an exact
/// integer number of units per tick, so a day-long run accumulates no rounding drift (a
/// plain `θ += Δθ` lost 0.029 rad of heading per hour on the paper's circle, a
/// compensated one 5e-4 rad per day). The heading is then exactly what the tick counts
/// say: θ₀ + 2π·(R_r·N_r − R_l·N_l)/(ticks per rev · L), modulo a turn.
///
/// The heading's sine and cosine are kept too, advanced by two small rotations per step
/// (series for the half turn, |Δθ/2| < 0.1 rad; exact below 1e-9) and recomputed from θ
/// every 64 steps, so they never drift more than ~4e-6 rad from θ. A step of the 1 kHz loop
/// then costs no sine at all, and the steering law reuses them
/// ([`Odometry::heading_sin_cos`]). A larger turn in one step (a spin seen at a low rate)
/// takes the exact path.
#[derive(Clone, Copy, Debug)]
pub struct Odometry {
    x: CompensatedSum,
    y: CompensatedSum,
    theta: BinaryAngle,
    /// (sin θ, cos θ).
    heading: (f32, f32),
    steps_since_resync: u8,
    /// Rim distance per tick of the left and right wheel, m.
    metres_per_tick: [f32; 2],
    /// Heading change per tick of the left and right wheel, 2π·R/(ticks per rev · L), rad
    /// (for the geometry of one step).
    rad_heading_per_tick: [f32; 2],
    /// The same as a fraction of a turn, for the heading sum.
    turn_per_tick: [AngleDelta; 2],
}

/// (sin, cos) of `h` for |h| < 0.1 rad: sin h = h(1 − h²/6 + h⁴/120), cos h = 1 − h²/2 +
/// h⁴/24. The terms left out, h⁷/5040 and h⁶/720, are below 2e-11 and 1.4e-9: under half
/// an ulp of the results (the cosine is ≥ 0.995, whose half ulp is 3e-8).
fn small_sin_cos(h: f32) -> (f32, f32) {
    let z = h * h;
    (
        h * (1.0 - z * (1.0 / 6.0) + z * z * (1.0 / 120.0)),
        1.0 - z * 0.5 + z * z * (1.0 / 24.0),
    )
}

/// (sin, cos) of the angle of (`sin_cos`) plus the angle of (`by`): a rotation.
fn rotate(sin_cos: (f32, f32), by: (f32, f32)) -> (f32, f32) {
    let ((s, c), (sb, cb)) = (sin_cos, by);
    (s * cb + c * sb, c * cb - s * sb)
}

impl Odometry {
    /// Odometry for `geometry`, with `ticks_per_rev` encoder ticks per wheel revolution,
    /// starting at `start` (world frame).
    pub fn new(geometry: DiffDrive, ticks_per_rev: f32, start: Pose) -> Self {
        let rad_per_tick = DoubleF32::TAU / ticks_per_rev;
        // R/(ticks per rev · L): the turn of the robot per tick of one wheel.
        let turn_per_tick = |radius_m: f32| {
            DoubleF32::from_f32(radius_m) / ticks_per_rev / geometry.track_width_m()
        };
        let [left, right] = [
            turn_per_tick(geometry.wheel_radius_left_m()),
            turn_per_tick(geometry.wheel_radius_right_m()),
        ];
        let mut odometry = Self {
            x: CompensatedSum::default(),
            y: CompensatedSum::default(),
            theta: BinaryAngle::default(),
            heading: (0.0, 1.0),
            steps_since_resync: 0,
            metres_per_tick: [
                (rad_per_tick * geometry.wheel_radius_left_m()).hi,
                (rad_per_tick * geometry.wheel_radius_right_m()).hi,
            ],
            rad_heading_per_tick: [
                (DoubleF32::TAU * left.hi).hi,
                (DoubleF32::TAU * right.hi).hi,
            ],
            turn_per_tick: [AngleDelta::from_turns(left), AngleDelta::from_turns(right)],
        };
        odometry.set_pose(start);
        odometry
    }

    /// Current pose estimate, world frame.
    pub fn pose(&self) -> Pose {
        Pose {
            x_m: self.x.value(),
            y_m: self.y.value(),
            theta_rad: self.theta.to_rad(),
        }
    }

    /// (sin θ, cos θ) of the current heading (within ~4e-6 of the exact values).
    pub const fn heading_sin_cos(&self) -> (f32, f32) {
        self.heading
    }

    /// Overwrites the pose estimate (for example from an external localisation fix).
    pub fn set_pose(&mut self, pose: Pose) {
        self.x = CompensatedSum::new(pose.x_m);
        self.y = CompensatedSum::new(pose.y_m);
        self.theta = BinaryAngle::from_rad(pose.theta_rad);
        self.resync_heading();
    }

    /// Recomputes the heading's sine and cosine exactly from θ and starts the count to
    /// the next recomputation afresh: the pose is unchanged, and what follows no longer
    /// depends on how many steps were integrated since the last one.
    pub fn resync_heading(&mut self) {
        self.heading = math::sin_cos(self.theta.to_rad());
        self.steps_since_resync = 0;
    }

    /// Integrates one step in which the wheels turned `left_ticks` and `right_ticks`
    /// (signed, forward positive) and returns the new pose.
    pub fn update(&mut self, left_ticks: i32, right_ticks: i32) -> Pose {
        let (n_left, n_right) = (left_ticks as f32, right_ticks as f32);
        let ds = 0.5 * (n_right * self.metres_per_tick[1] + n_left * self.metres_per_tick[0]);
        let [k_left, k_right] = self.rad_heading_per_tick;
        let dtheta = n_right * k_right - n_left * k_left;
        let half = 0.5 * dtheta;
        // Both branches compute the same pose to within f32 rounding; this test and the
        // resync count below only choose the cheaper one.
        if math::abs(half) < SMALL_HALF_TURN_RAD {
            let turn = small_sin_cos(half);
            let chord = ds * math::sinc(half);
            let (sin_mid, cos_mid) = rotate(self.heading, turn);
            self.x.add(chord * cos_mid);
            self.y.add(chord * sin_mid);
            self.turn(left_ticks, right_ticks);
            self.steps_since_resync += 1;
            if self.steps_since_resync >= HEADING_RESYNC_STEPS {
                self.resync_heading();
            } else {
                self.heading = rotate((sin_mid, cos_mid), turn);
            }
        } else {
            let chord = ds * math::sinc(half);
            let (sin_mid, cos_mid) = math::sin_cos(self.theta.to_rad() + half);
            self.x.add(chord * cos_mid);
            self.y.add(chord * sin_mid);
            self.turn(left_ticks, right_ticks);
            self.resync_heading();
        }
        self.pose()
    }

    /// Turns the heading by the step's ticks: exact integer arithmetic modulo a turn.
    fn turn(&mut self, left_ticks: i32, right_ticks: i32) {
        self.theta = self.theta.add(self.turn_of(left_ticks, right_ticks));
    }

    /// The heading change `left_ticks` and `right_ticks` make, exactly as
    /// [`Odometry::update`] applies it.
    pub const fn turn_of(&self, left_ticks: i32, right_ticks: i32) -> AngleDelta {
        let [left, right] = self.turn_per_tick;
        right.times(right_ticks).minus(left.times(left_ticks))
    }

    /// The heading, as the fixed-point angle it is summed in.
    pub const fn heading(&self) -> BinaryAngle {
        self.theta
    }

    /// Turns the heading by `by` (a small correction from another heading source, well
    /// below 0.1 rad), the position unchanged; the kept sine and cosine are rotated with
    /// it. Returns the new pose.
    pub fn turn_heading(&mut self, by: AngleDelta) -> Pose {
        self.theta = self.theta.add(by);
        let rad = by.to_rad();
        if math::abs(rad) < SMALL_HALF_TURN_RAD {
            self.heading = rotate(self.heading, small_sin_cos(rad));
        } else {
            self.resync_heading();
        }
        self.pose()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::encoder::WrappingCounter;
    use core::f32::consts::PI;
    use proptest::prelude::*;

    fn odo() -> Odometry {
        // R = 0.05 m, L = 0.2 m, 1000 ticks per revolution.
        Odometry::new(DiffDrive::new(0.05, 0.2).unwrap(), 1000.0, Pose::default())
    }

    #[test]
    fn straight_line_hand_value() {
        let mut o = odo();
        // 1000 ticks on both wheels = one revolution = 2π·0.05 = 0.31416 m forward.
        let p = o.update(1000, 1000);
        assert!((p.x_m - 0.314_159).abs() < 1e-5);
        assert_eq!(p.y_m, 0.0);
        assert_eq!(p.theta_rad, 0.0);
    }

    #[test]
    fn spin_in_place_hand_value() {
        let mut o = odo();
        // s_r = −s_l = 0.05·2π·(250/1000) = 0.0785 m, Δθ = (s_r − s_l)/L = 0.157/0.2 = π/4 rad.
        let p = o.update(-250, 250);
        assert!((p.theta_rad - PI / 4.0).abs() < 1e-5);
        assert!(p.x_m.abs() < 1e-7 && p.y_m.abs() < 1e-7);
    }

    #[test]
    fn one_big_arc_step_equals_many_small_ones() {
        // A quarter circle in 1 step and in 100 steps must agree: the arc update is exact.
        let mut coarse = odo();
        let mut fine = odo();
        coarse.update(3000, 5000);
        for _ in 0..100 {
            fine.update(30, 50);
        }
        let (a, b) = (coarse.pose(), fine.pose());
        assert!((a.x_m - b.x_m).abs() < 1e-5, "{a:?} {b:?}");
        assert!((a.y_m - b.y_m).abs() < 1e-5);
        // Both are a half turn (π): compare modulo 2π, either may have wrapped to −π.
        assert!(math::wrap_angle(a.theta_rad - b.theta_rad).abs() < 1e-5);
    }

    #[test]
    fn heading_stays_wrapped() {
        let mut o = odo();
        for _ in 0..100 {
            o.update(-300, 300);
        }
        let th = o.pose().theta_rad;
        assert!(th > -PI && th <= PI);
    }

    #[test]
    fn the_kept_heading_stays_on_the_exact_one() {
        // 100 000 steps of a gentle left curve at a typical 1 kHz step, and of a tight one
        // at the series' edge (127 ticks of difference: a half turn of 0.0997 rad a step):
        // the kept (sin, cos) must stay within 1e-5 of the exact sin and cos of θ.
        for ticks in [(3, 4), (10, 137)] {
            let mut o = odo();
            for _ in 0..100_000 {
                o.update(ticks.0, ticks.1);
                let (s, c) = o.heading_sin_cos();
                let th = f64::from(o.pose().theta_rad);
                assert!((f64::from(s) - th.sin()).abs() < 1e-5, "{ticks:?}");
                assert!((f64::from(c) - th.cos()).abs() < 1e-5, "{ticks:?}");
            }
        }
        let mut o = odo();
        o.set_pose(Pose::new(0.0, 0.0, 1.0));
        assert!((o.pose().theta_rad - 1.0).abs() < 2e-7);
        assert_eq!(o.heading_sin_cos(), math::sin_cos(o.pose().theta_rad));
    }

    #[test]
    fn the_series_is_as_accurate_as_f32_over_its_range() {
        // Within 3 ulp of sin h (|sin h| ≤ 0.1, ulp ≤ 7.5e-9) and 1 ulp of cos h.
        for i in -1000..=1000 {
            let h = i as f32 * (SMALL_HALF_TURN_RAD / 1000.0);
            let (s, c) = small_sin_cos(h);
            let x = f64::from(h);
            assert!((f64::from(s) - x.sin()).abs() < 2.3e-8, "sin {h}");
            assert!((f64::from(c) - x.cos()).abs() < 1.2e-7, "cos {h}");
        }
    }

    #[test]
    fn small_and_large_turns_agree() {
        // The same quarter arc in 1000 steps through the series and in 5 big exact steps.
        let mut fine = odo();
        let mut coarse = odo();
        for _ in 0..1000 {
            fine.update(3, 5);
        }
        for _ in 0..5 {
            coarse.update(600, 1000);
        }
        let (a, b) = (fine.pose(), coarse.pose());
        assert!(
            (a.x_m - b.x_m).abs() < 1e-5 && (a.y_m - b.y_m).abs() < 1e-5,
            "{a:?} {b:?}"
        );
        assert!((a.theta_rad - b.theta_rad).abs() < 1e-5);
    }

    #[test]
    fn unequal_wheels_curve_as_their_radii_say() {
        // R_l = 0.05, R_r = 0.055, L = 0.2, 1000 ticks per turn: equal ticks give rim
        // distances 0.31416 and 0.34558 m, so Δθ = 0.031416/0.2 = 0.15708 rad (left turn).
        let mut o = Odometry::new(
            DiffDrive::with_wheel_radii(0.05, 0.055, 0.2).unwrap(),
            1000.0,
            Pose::default(),
        );
        let p = o.update(1000, 1000);
        assert!((p.theta_rad - 0.157_08).abs() < 1e-5, "{p:?}");
        assert!(p.y_m > 0.0);
    }

    proptest! {
        /// Odometry fed through a 16-bit counter that wraps (raw counts start near the top)
        /// equals odometry fed the tick deltas directly, bit for bit.
        #[test]
        fn odometry_across_a_counter_wrap_equals_odometry_without_one(
            start_left in 65_000u32..65_536, start_right in 0u32..500,
            steps in prop::collection::vec((-40i32..40, -40i32..40), 1..400),
        ) {
            let mut direct = odo();
            let mut wrapped = odo();
            let mut left = WrappingCounter::new(16, start_left);
            let mut right = WrappingCounter::new(16, start_right);
            let (mut raw_left, mut raw_right) = (start_left, start_right);
            for &(dl, dr) in &steps {
                raw_left = raw_left.wrapping_add(dl as u32) & 0xffff;
                raw_right = raw_right.wrapping_add(dr as u32) & 0xffff;
                let a = direct.update(dl, dr);
                let b = wrapped.update(left.delta(raw_left), right.delta(raw_right));
                prop_assert_eq!(a.x_m.to_bits(), b.x_m.to_bits());
                prop_assert_eq!(a.y_m.to_bits(), b.y_m.to_bits());
                prop_assert_eq!(a.theta_rad.to_bits(), b.theta_rad.to_bits());
            }
        }
    }
}
