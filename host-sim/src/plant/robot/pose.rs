//! The wheel-ground contact and the true pose.
//!
//! Contract: the contact point of wheel i moves (1 − s_i)·R_i per radian of wheel
//! rotation over the ground (`ground_per_rad`, re-derived whenever the slip changes;
//! lifted, 0); the true pose moves along the arc those two distances define on the true
//! track width, exactly for a constant curvature over a plant step.
//!
//! ## True pose and slip
//!
//! Each plant step (an RK4 step, or a whole control period taken exactly) the wheels turn
//! by Δφ_l, Δφ_r. Wheel i moves its contact
//! point by (1 − s_i)·R_i·Δφ_i over the ground, s_i being a longitudinal slip ratio
//! (0 = pure rolling). The true pose moves along the arc those two distances define on the
//! true track width L — exact for a constant curvature over the 0.1 ms step. The heading's
//! cosine and sine are advanced by a small-angle rotation each step and renormalised once
//! per `Plant::advance` call, so there is no trigonometry in the inner loop.

use robot_files::plant::Load;
use robot_files::truth::{wrap_angle, TruePose};

use super::{Plant, PlantError};

/// The true pose as the integrator carries it: position, unwrapped heading and the
/// heading's (cos θ, sin θ), advanced by small rotations (no trigonometry per step).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PoseTrack {
    /// Position, world frame, m.
    x_m: f64,
    y_m: f64,
    /// Unwrapped heading, rad.
    theta_rad: f64,
    /// (cos θ, sin θ), advanced by small rotations and renormalised once per
    /// `Plant::advance` call ([`PoseTrack::renormalise`]).
    heading: [f64; 2],
}

impl PoseTrack {
    /// At the origin, heading 0.
    pub(super) const ORIGIN: Self = Self {
        x_m: 0.0,
        y_m: 0.0,
        theta_rad: 0.0,
        heading: [1.0, 0.0],
    };

    /// At `pose`, the heading's cosine and sine taken from its angle.
    pub(super) fn at(pose: TruePose) -> Self {
        Self {
            x_m: pose.x_m,
            y_m: pose.y_m,
            theta_rad: pose.theta_rad,
            heading: [pose.theta_rad.cos(), pose.theta_rad.sin()],
        }
    }

    /// Moves along the arc of ground distances `dl`, `dr` (m, left and right contact
    /// points) on a track of 1/`inv_l` m: the chord ds·sinc(Δθ/2) along heading θ + Δθ/2,
    /// then the heading turned by Δθ as two half-angle rotations.
    #[inline(always)]
    pub(super) fn roll(&mut self, dl: f64, dr: f64, inv_l: f64) {
        let [c, s] = self.heading;
        let ds = 0.5 * (dl + dr);
        let dth = (dr - dl) * inv_l;
        let half = 0.5 * dth;
        let (sin_h, cos_h) = small_sin_cos(half);
        let chord = ds * sin_h_over_h(half);
        let (cm, sm) = (c * cos_h - s * sin_h, s * cos_h + c * sin_h);
        self.x_m += chord * cm;
        self.y_m += chord * sm;
        self.heading = [cm * cos_h - sm * sin_h, sm * cos_h + cm * sin_h];
        self.theta_rad += dth;
    }

    /// After a run of [`PoseTrack::roll`]s: one Newton step of 1/√(c² + s²) removes the
    /// rounding drift of the rotations, and the heading is wrapped to (−π, π].
    pub(super) fn renormalise(&mut self) {
        let [c, s] = self.heading;
        let norm = 0.5 * (3.0 - (c * c + s * s));
        self.heading = [c * norm, s * norm];
        self.theta_rad = wrap_angle(self.theta_rad);
    }

    /// The pose, heading wrapped.
    pub(super) fn true_pose(&self) -> TruePose {
        TruePose {
            x_m: self.x_m,
            y_m: self.y_m,
            theta_rad: wrap_angle(self.theta_rad),
        }
    }
}

impl Plant {
    /// Places the robot at `pose` (world frame) with wheel speeds `speeds` [left, right]
    /// (rad/s). Wheel angles restart at 0. The bridge and fault state are kept (a blocked
    /// wheel's speed stays 0).
    pub fn reset(&mut self, pose: TruePose, speeds: [f64; 2]) {
        self.pose = PoseTrack::at(pose);
        self.speed = speeds;
        for (w, blocked) in self.speed.iter_mut().zip(self.blocked) {
            if blocked {
                *w = 0.0;
            }
        }
        self.angle = [0.0; 2];
    }

    /// Turns the robot on the spot by `yaw_rad` (rad, counter-clockwise positive) about
    /// the middle of its axle, as hands turning it on the floor would: the wheels' state
    /// is kept (what the encoders count of the wheels' roll is the caller's).
    pub fn rotate_by_hand(&mut self, yaw_rad: f64) {
        let mut pose = self.pose.true_pose();
        pose.theta_rad = wrap_angle(pose.theta_rad + yaw_rad);
        self.pose = PoseTrack::at(pose);
    }

    /// True pose, world frame.
    pub fn pose(&self) -> TruePose {
        self.pose.true_pose()
    }

    /// Wheel speeds [left, right] that drive the *true* robot (true radii, track width
    /// and slip) at forward speed `v_m_s` (m/s) and yaw rate `omega_rad_s` (rad/s).
    /// Lifted, the wheels turn as they would on the ground (the robot stays put).
    pub fn wheel_speeds_for(&self, v_m_s: f64, omega_rad_s: f64) -> [f64; 2] {
        let g = &self.params.geometry;
        let half = 0.5 * omega_rad_s * g.track_width_m;
        [
            (v_m_s - half) / ((1.0 - self.slip[0]) * g.wheel_radius_left_m),
            (v_m_s + half) / ((1.0 - self.slip[1]) * g.wheel_radius_right_m),
        ]
    }

    /// Sets the wheels turning for forward speed `v_m_s` (m/s) and yaw rate
    /// `omega_rad_s` (rad/s) of the true robot ([`Plant::wheel_speeds_for`]), at the
    /// present pose: a start in motion. Refused, nothing changed, when a wheel would turn
    /// faster than its motor's no-load speed on the present supply, which no drive from
    /// rest could have reached (with slip s the wheel turns 1/(1 − s) times faster than
    /// it rolls).
    pub fn start_in_motion(&mut self, v_m_s: f64, omega_rad_s: f64) -> Result<(), PlantError> {
        let speeds = self.wheel_speeds_for(v_m_s, omega_rad_s);
        let no_load_rad_s = self.drives.map(|d| d.steady_speed_rad_s(self.supply_v));
        // `≤` is false for NaN: a NaN speed is refused too. The wheel beyond its no-load
        // speed is named, the faster one if both are.
        let within = [0, 1].map(|i| speeds[i].abs() <= no_load_rad_s[i]);
        let i = if within[0] || within[1] {
            usize::from(within[0])
        } else {
            usize::from(speeds[1].abs() > speeds[0].abs())
        };
        if !within[i] {
            return Err(PlantError::BeyondNoLoadSpeed {
                wheel: ["left", "right"][i],
                needed_rad_s: speeds[i].abs(),
                slip: self.slip[i],
                no_load_rad_s: no_load_rad_s[i],
                supply_v: self.supply_v,
            });
        }
        let pose = self.pose();
        self.reset(pose, speeds);
        Ok(())
    }

    /// True body velocity (forward m/s, yaw rad/s) from the wheel speeds and slip.
    pub fn body_velocity(&self) -> (f64, f64) {
        let vl = self.ground_per_rad[0] * self.speed[0];
        let vr = self.ground_per_rad[1] * self.speed[1];
        (
            0.5 * (vl + vr),
            (vr - vl) / self.params.geometry.track_width_m,
        )
    }

    pub(super) fn update_ground_per_rad(&mut self) {
        let g = &self.params.geometry;
        self.ground_per_rad = match self.params.load {
            Load::Ground => [
                (1.0 - self.slip[0]) * g.wheel_radius_left_m,
                (1.0 - self.slip[1]) * g.wheel_radius_right_m,
            ],
            // In the air a wheel moves nothing.
            Load::Lifted => [0.0; 2],
        };
    }
}

/// (sin a, cos a) for the tiny angles of one plant step (Taylor to a⁵ / a⁴: error < 1e-16
/// for |a| < 2e-3), falling back to the library for larger ones. Constants are
/// multiplied, not divided: a division by 6 is not exact, so the compiler keeps it a
/// (slow) division.
#[inline]
fn small_sin_cos(a: f64) -> (f64, f64) {
    let z = a * a;
    if z < 4e-6 {
        (
            a * (1.0 - z * (1.0 / 6.0) * (1.0 - z * (1.0 / 20.0))),
            1.0 - z * 0.5 * (1.0 - z * (1.0 / 12.0)),
        )
    } else {
        a.sin_cos()
    }
}

/// sin(a)/a, with the series near 0.
#[inline]
fn sin_h_over_h(a: f64) -> f64 {
    let z = a * a;
    if z < 4e-6 {
        1.0 - z * (1.0 / 6.0) * (1.0 - z * (1.0 / 20.0))
    } else {
        a.sin() / a
    }
}
