//! Differential-drive kinematics, paper eqs. (1)–(10).
//!
//! Frames: the **world frame** is fixed (x east, y north, θ counter-clockwise from x);
//! the **robot frame** has its x axis along the robot's heading and y to its left.

use crate::math;

/// A point in the world frame, in metres.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct Point {
    /// x coordinate, world frame, m.
    pub x_m: f32,
    /// y coordinate, world frame, m.
    pub y_m: f32,
}

impl Point {
    /// A point at (`x_m`, `y_m`) in the world frame, m.
    pub const fn new(x_m: f32, y_m: f32) -> Self {
        Self { x_m, y_m }
    }

    /// Distance to `other`, m.
    pub fn distance_to(self, other: Point) -> f32 {
        math::hypot(other.x_m - self.x_m, other.y_m - self.y_m)
    }
}

/// A robot pose in the world frame: position in m, heading θ in rad, wrapped to (−π, π].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct Pose {
    /// x position, world frame, m.
    pub x_m: f32,
    /// y position, world frame, m.
    pub y_m: f32,
    /// Heading, world frame, rad, counter-clockwise from the x axis, in (−π, π].
    pub theta_rad: f32,
}

impl Pose {
    /// A pose at (`x_m`, `y_m`) with heading `theta_rad` (wrapped to (−π, π]).
    pub fn new(x_m: f32, y_m: f32, theta_rad: f32) -> Self {
        Self {
            x_m,
            y_m,
            theta_rad: math::wrap_angle(theta_rad),
        }
    }

    /// The position part of the pose, world frame, m.
    pub const fn position(&self) -> Point {
        Point::new(self.x_m, self.y_m)
    }

    /// True when every field is finite.
    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite() && self.theta_rad.is_finite()
    }
}

/// Body velocity of the robot (paper: v_m, ω_m): forward speed in m/s along the robot's
/// x axis and yaw rate in rad/s, counter-clockwise positive.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct BodyVelocity {
    /// Forward speed v, robot frame, m/s.
    pub v_m_s: f32,
    /// Yaw rate ω, rad/s, counter-clockwise positive.
    pub omega_rad_s: f32,
}

impl BodyVelocity {
    /// A body velocity of `v_m_s` (m/s) and `omega_rad_s` (rad/s).
    pub const fn new(v_m_s: f32, omega_rad_s: f32) -> Self {
        Self { v_m_s, omega_rad_s }
    }
}

/// Angular speeds of the two driving wheels, rad/s, positive when the wheel drives the
/// robot forward.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct WheelSpeeds {
    /// Left wheel ω_l, rad/s.
    pub left_rad_s: f32,
    /// Right wheel ω_r, rad/s.
    pub right_rad_s: f32,
}

impl WheelSpeeds {
    /// Wheel speeds of `left_rad_s` and `right_rad_s`, rad/s.
    pub const fn new(left_rad_s: f32, right_rad_s: f32) -> Self {
        Self {
            left_rad_s,
            right_rad_s,
        }
    }
}

/// Geometry of a differential-drive robot: the radius of each wheel and the track width,
/// all in m.
///
/// The two radii may differ (odometry calibration measures them); eqs. (1)–(4) then use
/// each wheel's own radius. Build it with
/// [`DiffDrive::new`] (equal wheels) or [`DiffDrive::with_wheel_radii`], which reject
/// non-positive or non-finite sizes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffDrive {
    wheel_radius_left_m: f32,
    wheel_radius_right_m: f32,
    track_width_m: f32,
    /// 1/R_l and 1/R_r, 1/m: inverse kinematics runs every control step, and a
    /// multiplication is cheaper than a division on the Cortex-M4F.
    inverse_radius_per_m: [f32; 2],
}

/// Why a [`DiffDrive`] could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum GeometryError {
    /// A wheel radius was ≤ 0 or not finite.
    NonPositiveWheelRadius,
    /// The track width L was ≤ 0 or not finite.
    NonPositiveTrackWidth,
}

impl core::fmt::Display for GeometryError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            GeometryError::NonPositiveWheelRadius => "the wheel radius must be > 0 m",
            GeometryError::NonPositiveTrackWidth => "the track width must be > 0 m",
        })
    }
}

impl core::error::Error for GeometryError {}

fn positive(x: f32) -> bool {
    x > 0.0 && x.is_finite()
}

impl DiffDrive {
    /// Geometry with both wheels of radius R = `wheel_radius_m` and track width
    /// L = `track_width_m` (distance between the wheels' contact points), both in m and > 0.
    pub fn new(wheel_radius_m: f32, track_width_m: f32) -> Result<Self, GeometryError> {
        Self::with_wheel_radii(wheel_radius_m, wheel_radius_m, track_width_m)
    }

    /// Geometry with left and right wheel radii R_l = `left_m`, R_r = `right_m` and track
    /// width L = `track_width_m`, all in m and > 0.
    pub fn with_wheel_radii(
        left_m: f32,
        right_m: f32,
        track_width_m: f32,
    ) -> Result<Self, GeometryError> {
        if !(positive(left_m) && positive(right_m)) {
            return Err(GeometryError::NonPositiveWheelRadius);
        }
        if !positive(track_width_m) {
            return Err(GeometryError::NonPositiveTrackWidth);
        }
        Ok(Self {
            wheel_radius_left_m: left_m,
            wheel_radius_right_m: right_m,
            track_width_m,
            inverse_radius_per_m: [1.0 / left_m, 1.0 / right_m],
        })
    }

    /// Left wheel radius R_l, m.
    pub const fn wheel_radius_left_m(&self) -> f32 {
        self.wheel_radius_left_m
    }

    /// Right wheel radius R_r, m.
    pub const fn wheel_radius_right_m(&self) -> f32 {
        self.wheel_radius_right_m
    }

    /// The smaller of the two wheel radii, m (the wheel that limits the rim speed).
    pub fn min_wheel_radius_m(&self) -> f32 {
        if self.wheel_radius_left_m < self.wheel_radius_right_m {
            self.wheel_radius_left_m
        } else {
            self.wheel_radius_right_m
        }
    }

    /// Track width L, m.
    pub const fn track_width_m(&self) -> f32 {
        self.track_width_m
    }

    /// Eq. (1): rim speeds (v_l, v_r) in m/s of wheels turning at `wheels` (rad/s).
    pub fn rim_speeds(&self, wheels: WheelSpeeds) -> (f32, f32) {
        (
            self.wheel_radius_left_m * wheels.left_rad_s,
            self.wheel_radius_right_m * wheels.right_rad_s,
        )
    }

    /// Eqs. (2)/(4): body velocity produced by wheel speeds (rad/s).
    ///
    /// v = (R_r ω_r + R_l ω_l)/2, ω = (R_r ω_r − R_l ω_l)/L.
    pub fn forward(&self, wheels: WheelSpeeds) -> BodyVelocity {
        let (v_left, v_right) = self.rim_speeds(wheels);
        BodyVelocity {
            v_m_s: 0.5 * (v_right + v_left),
            omega_rad_s: (v_right - v_left) / self.track_width_m,
        }
    }

    /// Inverse of eq. (4): the wheel speeds (rad/s) that produce `body`.
    ///
    /// ω_r = (v + ωL/2)/R_r, ω_l = (v − ωL/2)/R_l.
    pub fn inverse(&self, body: BodyVelocity) -> WheelSpeeds {
        let half_turn = 0.5 * body.omega_rad_s * self.track_width_m;
        WheelSpeeds {
            left_rad_s: (body.v_m_s - half_turn) * self.inverse_radius_per_m[0],
            right_rad_s: (body.v_m_s + half_turn) * self.inverse_radius_per_m[1],
        }
    }
}

/// Time derivative of a pose, world frame: (ẋ, ẏ) in m/s and θ̇ in rad/s.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PoseRate {
    /// ẋ, world frame, m/s.
    pub x_dot_m_s: f32,
    /// ẏ, world frame, m/s.
    pub y_dot_m_s: f32,
    /// θ̇, rad/s.
    pub theta_dot_rad_s: f32,
}

/// Eqs. (5)/(7)/(8): the unicycle model ṗ = J(p) q, with J = [[cos θ, 0], [sin θ, 0], [0, 1]].
///
/// The result satisfies the no-slip constraint (3), ẋ sin θ − ẏ cos θ = 0.
pub fn pose_rate(pose: &Pose, body: BodyVelocity) -> PoseRate {
    let (sin_theta, cos_theta) = math::sin_cos(pose.theta_rad);
    PoseRate {
        x_dot_m_s: body.v_m_s * cos_theta,
        y_dot_m_s: body.v_m_s * sin_theta,
        theta_dot_rad_s: body.omega_rad_s,
    }
}

/// Tracking error of eq. (9): the reference pose seen from the robot, in the **robot
/// frame** (x_e ahead, y_e to the left, m) and the heading error θ_e = θ_r − θ (rad,
/// wrapped to (−π, π]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct TrackingError {
    /// Along-track error x_e, robot frame, m (positive: reference ahead of the robot).
    pub x_e_m: f32,
    /// Cross-track error y_e, robot frame, m (positive: reference to the robot's left).
    pub y_e_m: f32,
    /// Heading error θ_e = θ_r − θ, rad, in (−π, π].
    pub theta_e_rad: f32,
}

impl TrackingError {
    /// Position error √(x_e² + y_e²), m.
    pub fn position_m(&self) -> f32 {
        math::hypot(self.x_e_m, self.y_e_m)
    }
}

/// Eq. (9): the tracking error of `robot` with respect to `reference`, robot frame.
pub fn tracking_error(robot: &Pose, reference: &Pose) -> TrackingError {
    tracking_error_with_heading(robot, math::sin_cos(robot.theta_rad), reference)
}

/// Eq. (9) when (sin θ, cos θ) of the robot's heading is already known
/// (`sin_cos_theta`, e.g. from [`crate::odometry::Odometry::heading_sin_cos`]): saves a
/// sine and a cosine per steering step.
pub fn tracking_error_with_heading(
    robot: &Pose,
    sin_cos_theta: (f32, f32),
    reference: &Pose,
) -> TrackingError {
    let dx = reference.x_m - robot.x_m;
    let dy = reference.y_m - robot.y_m;
    let (sin_theta, cos_theta) = sin_cos_theta;
    TrackingError {
        x_e_m: cos_theta * dx + sin_theta * dy,
        y_e_m: -sin_theta * dx + cos_theta * dy,
        theta_e_rad: math::wrap_angle(reference.theta_rad - robot.theta_rad),
    }
}

/// Eq. (10): the rate of the tracking error when the robot moves at `robot` and the
/// reference at `reference` (body velocities). Units: m/s, m/s, rad/s.
///
/// ẋ_e = ω y_e − v + v_r cos θ_e, ẏ_e = −ω x_e + v_r sin θ_e, θ̇_e = ω_r − ω.
pub fn tracking_error_rate(
    error: &TrackingError,
    robot: BodyVelocity,
    reference: BodyVelocity,
) -> TrackingError {
    let (sin_e, cos_e) = math::sin_cos(error.theta_e_rad);
    TrackingError {
        x_e_m: robot.omega_rad_s * error.y_e_m - robot.v_m_s + reference.v_m_s * cos_e,
        y_e_m: -robot.omega_rad_s * error.x_e_m + reference.v_m_s * sin_e,
        theta_e_rad: reference.omega_rad_s - robot.omega_rad_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f32::consts::FRAC_PI_2;
    use proptest::prelude::*;

    fn robot() -> DiffDrive {
        DiffDrive::new(0.0325, 0.15).unwrap()
    }

    #[test]
    fn rejects_bad_geometry() {
        assert_eq!(
            DiffDrive::new(0.0, 0.1),
            Err(GeometryError::NonPositiveWheelRadius)
        );
        assert_eq!(
            DiffDrive::new(-0.03, 0.1),
            Err(GeometryError::NonPositiveWheelRadius)
        );
        assert_eq!(
            DiffDrive::new(f32::NAN, 0.1),
            Err(GeometryError::NonPositiveWheelRadius)
        );
        assert_eq!(
            DiffDrive::new(0.03, 0.0),
            Err(GeometryError::NonPositiveTrackWidth)
        );
        assert_eq!(
            DiffDrive::new(0.03, f32::INFINITY),
            Err(GeometryError::NonPositiveTrackWidth)
        );
    }

    #[test]
    fn geometry_errors_name_the_dimension() {
        let radius = std::format!("{}", GeometryError::NonPositiveWheelRadius);
        let track = std::format!("{}", GeometryError::NonPositiveTrackWidth);
        assert!(radius.contains("wheel radius"), "{radius}");
        assert!(track.contains("track width"), "{track}");
    }

    #[test]
    fn forward_hand_values() {
        // R = 0.0325 m, L = 0.15 m; ω_l = 10, ω_r = 20 rad/s:
        // v_l = 0.325, v_r = 0.65 m/s; v = 0.4875 m/s; ω = 0.325/0.15 = 2.1667 rad/s.
        let body = robot().forward(WheelSpeeds::new(10.0, 20.0));
        assert!((body.v_m_s - 0.4875).abs() < 1e-6);
        assert!((body.omega_rad_s - 2.166_666_7).abs() < 1e-5);
        assert_eq!(
            robot().rim_speeds(WheelSpeeds::new(10.0, 20.0)),
            (0.325, 0.65)
        );
    }

    #[test]
    fn inverse_hand_values() {
        // v = 0.25 m/s, ω = 0.2 rad/s: ω_r = (0.25 + 0.015)/0.0325 = 8.1538,
        // ω_l = (0.25 − 0.015)/0.0325 = 7.2308 rad/s.
        let w = robot().inverse(BodyVelocity::new(0.25, 0.2));
        assert!((w.right_rad_s - 8.153_846).abs() < 1e-4);
        assert!((w.left_rad_s - 7.230_769).abs() < 1e-4);
    }

    #[test]
    fn unequal_wheels_use_their_own_radius() {
        // R_l = 0.03, R_r = 0.035, L = 0.15; ω_l = ω_r = 10 rad/s: rim speeds 0.30 and
        // 0.35 m/s, so v = 0.325 m/s and the robot turns left at 0.05/0.15 rad/s.
        let g = DiffDrive::with_wheel_radii(0.03, 0.035, 0.15).unwrap();
        let body = g.forward(WheelSpeeds::new(10.0, 10.0));
        assert!((body.v_m_s - 0.325).abs() < 1e-6);
        assert!((body.omega_rad_s - 0.333_333_3).abs() < 1e-5);
        let back = g.inverse(body);
        assert!((back.left_rad_s - 10.0).abs() < 1e-4 && (back.right_rad_s - 10.0).abs() < 1e-4);
        assert_eq!(g.min_wheel_radius_m(), 0.03);
        assert_eq!(
            DiffDrive::with_wheel_radii(0.03, -1.0, 0.15),
            Err(GeometryError::NonPositiveWheelRadius)
        );
    }

    #[test]
    fn pose_rate_respects_no_slip_constraint() {
        let pose = Pose::new(1.0, 2.0, 0.7);
        let rate = pose_rate(&pose, BodyVelocity::new(0.3, -0.4));
        let (s, c) = (0.7f32.sin(), 0.7f32.cos());
        // Eq. (3): ẋ sin θ − ẏ cos θ = 0.
        assert!((rate.x_dot_m_s * s - rate.y_dot_m_s * c).abs() < 1e-7);
        assert!((rate.x_dot_m_s - 0.3 * c).abs() < 1e-6);
        assert_eq!(rate.theta_dot_rad_s, -0.4);
    }

    #[test]
    fn tracking_error_hand_values() {
        // Robot at origin facing +y; reference at (1, 2) facing +x.
        // Robot frame: ahead = +y, left = −x. x_e = 2, y_e = −1, θ_e = 0 − π/2.
        let e = tracking_error(&Pose::new(0.0, 0.0, FRAC_PI_2), &Pose::new(1.0, 2.0, 0.0));
        assert!((e.x_e_m - 2.0).abs() < 1e-6);
        assert!((e.y_e_m + 1.0).abs() < 1e-6);
        assert!((e.theta_e_rad + FRAC_PI_2).abs() < 1e-6);
        assert!((e.position_m() - 5f32.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn tracking_error_rate_matches_finite_difference() {
        // Eq. (10) against a finite difference of eq. (9) along both unicycles.
        let robot_pose = Pose::new(0.2, -0.1, 0.4);
        let ref_pose = Pose::new(1.0, 0.5, 1.1);
        let robot_vel = BodyVelocity::new(0.3, 0.5);
        let ref_vel = BodyVelocity::new(0.25, 0.2);
        let dt = 1e-3f32;
        let advance = |p: &Pose, b: BodyVelocity| {
            let r = pose_rate(p, b);
            Pose::new(
                p.x_m + r.x_dot_m_s * dt,
                p.y_m + r.y_dot_m_s * dt,
                p.theta_rad + r.theta_dot_rad_s * dt,
            )
        };
        let e0 = tracking_error(&robot_pose, &ref_pose);
        let e1 = tracking_error(
            &advance(&robot_pose, robot_vel),
            &advance(&ref_pose, ref_vel),
        );
        let rate = tracking_error_rate(&e0, robot_vel, ref_vel);
        assert!(((e1.x_e_m - e0.x_e_m) / dt - rate.x_e_m).abs() < 2e-3);
        assert!(((e1.y_e_m - e0.y_e_m) / dt - rate.y_e_m).abs() < 2e-3);
        assert!(((e1.theta_e_rad - e0.theta_e_rad) / dt - rate.theta_e_rad).abs() < 2e-3);
    }

    proptest! {
        #[test]
        fn forward_inverse_is_identity(
            r in 0.01f32..0.2, l in 0.05f32..1.0, v in -2.0f32..2.0, w in -10.0f32..10.0
        ) {
            let dd = DiffDrive::new(r, l).unwrap();
            let back = dd.forward(dd.inverse(BodyVelocity::new(v, w)));
            prop_assert!((back.v_m_s - v).abs() <= 1e-5 * (1.0 + v.abs() + w.abs() * l));
            prop_assert!((back.omega_rad_s - w).abs() <= 1e-4 * (1.0 + w.abs() + v.abs() / l));
        }

        #[test]
        fn inverse_forward_is_identity(
            r in 0.01f32..0.2, l in 0.05f32..1.0, wl in -50.0f32..50.0, wr in -50.0f32..50.0
        ) {
            let dd = DiffDrive::new(r, l).unwrap();
            let back = dd.inverse(dd.forward(WheelSpeeds::new(wl, wr)));
            prop_assert!((back.left_rad_s - wl).abs() <= 1e-4 * (1.0 + wl.abs() + wr.abs()));
            prop_assert!((back.right_rad_s - wr).abs() <= 1e-4 * (1.0 + wl.abs() + wr.abs()));
        }
    }
}
