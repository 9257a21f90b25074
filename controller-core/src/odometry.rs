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

use crate::kinematics::{DiffDrive, Pose};
use crate::math;

/// Pose estimate integrated from wheel-tick deltas, world frame.
#[derive(Clone, Copy, Debug)]
pub struct Odometry {
    pose: Pose,
    geometry: DiffDrive,
    rad_per_tick: f32,
}

impl Odometry {
    /// Odometry for `geometry`, with `rad_per_tick` rad of wheel rotation per encoder tick,
    /// starting at `start` (world frame).
    pub fn new(geometry: DiffDrive, rad_per_tick: f32, start: Pose) -> Self {
        Self {
            pose: start,
            geometry,
            rad_per_tick,
        }
    }

    /// Current pose estimate, world frame.
    pub const fn pose(&self) -> Pose {
        self.pose
    }

    /// Overwrites the pose estimate (for example from an external localisation fix).
    pub fn set_pose(&mut self, pose: Pose) {
        self.pose = Pose::new(pose.x_m, pose.y_m, pose.theta_rad);
    }

    /// Integrates one step in which the wheels turned `left_ticks` and `right_ticks`
    /// (signed, forward positive) and returns the new pose.
    pub fn update(&mut self, left_ticks: i32, right_ticks: i32) -> Pose {
        let metres_per_tick = self.rad_per_tick * self.geometry.wheel_radius_m();
        let s_left = left_ticks as f32 * metres_per_tick;
        let s_right = right_ticks as f32 * metres_per_tick;
        let ds = 0.5 * (s_right + s_left);
        let dtheta = (s_right - s_left) / self.geometry.track_width_m();
        let half = 0.5 * dtheta;
        let chord = ds * math::sinc(half);
        let (sin_mid, cos_mid) = math::sin_cos(self.pose.theta_rad + half);
        self.pose = Pose {
            x_m: self.pose.x_m + chord * cos_mid,
            y_m: self.pose.y_m + chord * sin_mid,
            theta_rad: math::wrap_angle(self.pose.theta_rad + dtheta),
        };
        self.pose
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::encoder::WrappingCounter;
    use core::f32::consts::{PI, TAU};
    use proptest::prelude::*;

    fn odo() -> Odometry {
        // R = 0.05 m, L = 0.2 m, 1000 ticks per revolution.
        Odometry::new(
            DiffDrive::new(0.05, 0.2).unwrap(),
            TAU / 1000.0,
            Pose::default(),
        )
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
        assert!((a.theta_rad - b.theta_rad).abs() < 1e-5);
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
