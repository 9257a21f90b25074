//! The reference the steering law chases: a point moving along a [`Path`].
//!
//! Two ways to move it:
//!
//! - [`ReferenceMode::TimeIndexed`] — the paper's "virtual robot" (section 3): at time
//!   t = k·T the reference is at arc length s₀ + v_r·t, whatever the real robot does.
//!   This is trajectory *tracking*. The arc length is accumulated per elapsed period in a
//!   [`CompensatedSum`] and wrapped once per lap of a closed path, so it never grows: a
//!   plain `v_r·t` in `f32` reaches 21 600 m after 24 h at 0.25 m/s, where an `f32` only
//!   resolves 1.95 mm and the reference would move in jerks.
//! - [`ReferenceMode::PathFollowing`] — the reference point is chosen from the robot's own
//!   progress: the robot's position is projected onto the path (searching a window around
//!   the previous projection, so a path that crosses itself is not short-cut) and the
//!   reference is placed `lookahead_m` further on. There is no time index: a robot that
//!   is held back is not chased by a reference running away from it.
//!
//! On an open path the reference stops at the end (v_r = ω_r = 0, `finished`), so the
//! robot comes to rest there instead of running on.

use crate::compensated::CompensatedSum;
use crate::kinematics::{BodyVelocity, Point, Pose};
use crate::math;
use crate::path::{Path, PathSample};

/// How far behind the previous projection the path-following search looks, m.
const SEARCH_BEHIND_M: f32 = 0.05;
/// How far ahead of the previous projection the path-following search looks, m.
const SEARCH_AHEAD_M: f32 = 0.5;

/// How the reference point moves along the path (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum ReferenceMode {
    /// The paper's time-indexed reference robot, starting `start_offset_m` (m) along the
    /// path at step 0.
    TimeIndexed {
        /// Arc length of the reference at step 0, m.
        start_offset_m: f32,
    },
    /// True path following: the reference is `lookahead_m` (m, ≥ 0) ahead of the robot's
    /// projection onto the path.
    PathFollowing {
        /// Distance along the path from the robot's projection to the reference, m.
        lookahead_m: f32,
    },
}

/// Why a [`Reference`] could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum ReferenceError {
    /// The reference speed was ≤ 0 or not finite.
    NonPositiveSpeed,
    /// The start offset or look-ahead distance was negative or not finite.
    BadDistance,
}

impl core::fmt::Display for ReferenceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ReferenceError::NonPositiveSpeed => "the reference speed must be > 0 m/s",
            ReferenceError::BadDistance => {
                "the start offset or look-ahead distance must be ≥ 0 m and finite"
            }
        })
    }
}

/// The reference at one instant: pose (world frame), its body velocity and progress.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct ReferenceState {
    /// Reference pose (x_r, y_r, θ_r), world frame, m and rad.
    pub pose: Pose,
    /// Reference forward speed v_r, m/s.
    pub v_m_s: f32,
    /// Reference yaw rate ω_r = v_r·κ, rad/s.
    pub omega_rad_s: f32,
    /// Arc length of the reference along the path, m, in [0, length].
    pub progress_m: f32,
    /// True once the reference has reached the end of an open path (it then stands still).
    pub finished: bool,
}

impl ReferenceState {
    /// The reference's body velocity (v_r, ω_r).
    pub const fn velocity(&self) -> BodyVelocity {
        BodyVelocity::new(self.v_m_s, self.omega_rad_s)
    }
}

/// A reference moving along a path at a set speed (see the module doc).
#[derive(Clone, Debug)]
pub struct Reference {
    path: Path,
    speed_m_s: f32,
    mode: ReferenceMode,
    /// Time-indexed only: arc length of the reference, m, wrapped into [0, length) on a
    /// closed path.
    progress: CompensatedSum,
    /// Path-following only: the robot's last projection, m (None before the first sample).
    projection_m: Option<f32>,
}

impl Reference {
    /// A reference moving along `path` at `speed_m_s` (m/s, > 0) in `mode`.
    pub fn new(path: Path, speed_m_s: f32, mode: ReferenceMode) -> Result<Self, ReferenceError> {
        if !(speed_m_s > 0.0 && speed_m_s.is_finite()) {
            return Err(ReferenceError::NonPositiveSpeed);
        }
        let distance = match mode {
            ReferenceMode::TimeIndexed { start_offset_m } => start_offset_m,
            ReferenceMode::PathFollowing { lookahead_m } => lookahead_m,
        };
        if !(distance >= 0.0 && distance.is_finite()) {
            return Err(ReferenceError::BadDistance);
        }
        let mut reference = Self {
            path,
            speed_m_s,
            mode,
            progress: CompensatedSum::default(),
            projection_m: None,
        };
        reference.restart();
        Ok(reference)
    }

    /// The path being followed.
    pub const fn path(&self) -> &Path {
        &self.path
    }

    /// The mode the reference moves in.
    pub const fn mode(&self) -> ReferenceMode {
        self.mode
    }

    /// Set speed v_r, m/s.
    pub const fn speed_m_s(&self) -> f32 {
        self.speed_m_s
    }

    /// Back to the start: the time-indexed reference returns to its start offset, and path
    /// following forgets its progress (the next sample searches the whole path).
    pub fn restart(&mut self) {
        let start_m = match self.mode {
            ReferenceMode::TimeIndexed { start_offset_m } => start_offset_m,
            ReferenceMode::PathFollowing { .. } => 0.0,
        };
        self.progress = CompensatedSum::new(self.path.normalize_m(start_m));
        self.projection_m = None;
    }

    /// The reference after `elapsed_s` (s, ≥ 0) more of time since the previous sample
    /// (0 for the first sample after [`Reference::restart`]), for a robot at `robot`
    /// (world frame).
    pub fn sample(&mut self, elapsed_s: f32, robot: &Pose) -> ReferenceState {
        let length = self.path.length_m();
        let (progress_m, finished) = match self.mode {
            // Already wrapped into [0, length) on a closed path; held near the end of an
            // open one.
            ReferenceMode::TimeIndexed { .. } => {
                let s = self.advance(elapsed_s);
                let finished = !self.path.is_closed() && s >= length;
                (math::clamp(s, 0.0, length), finished)
            }
            ReferenceMode::PathFollowing { lookahead_m } => {
                let s = self.project(robot.position()) + lookahead_m;
                let finished = !self.path.is_closed() && s >= length;
                (self.path.normalize_m(s), finished)
            }
        };
        let PathSample {
            point,
            heading_rad,
            curvature_per_m,
        } = self.path.sample_normalized(progress_m);
        let v_m_s = if finished { 0.0 } else { self.speed_m_s };
        ReferenceState {
            // The path's heading is already wrapped into (−π, π].
            pose: Pose {
                x_m: point.x_m,
                y_m: point.y_m,
                theta_rad: heading_rad,
            },
            v_m_s,
            omega_rad_s: v_m_s * curvature_per_m,
            progress_m,
            finished,
        }
    }

    /// Moves the time-indexed reference on by `elapsed_s` of travel at the set speed and
    /// returns its arc length, m: wrapped into [0, length) on a closed path (the
    /// subtraction is exact, s and the length being within a factor 2), held at the end
    /// of an open one.
    fn advance(&mut self, elapsed_s: f32) -> f32 {
        let length = self.path.length_m();
        let s = self.progress.value();
        if s < length || self.path.is_closed() {
            self.progress.add(self.speed_m_s * elapsed_s);
        }
        if self.path.is_closed() {
            self.progress.wrap_below(length);
        }
        self.progress.value()
    }

    /// Projects `p` onto the path near the previous projection and remembers it.
    fn project(&mut self, p: Point) -> f32 {
        let s = match self.projection_m {
            None => self.path.project(p, 0.0, f32::INFINITY, f32::INFINITY),
            Some(previous) => self
                .path
                .project(p, previous, SEARCH_BEHIND_M, SEARCH_AHEAD_M),
        };
        let s = self.path.normalize_m(s);
        self.projection_m = Some(s);
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f32::consts::{FRAC_PI_2, PI};

    fn circle() -> Path {
        Path::circle(Point::new(0.0, 0.0), 1.25, 0.0, true).unwrap()
    }

    #[test]
    fn rejects_bad_settings() {
        let e = Reference::new(
            circle(),
            0.0,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        );
        assert_eq!(e.unwrap_err(), ReferenceError::NonPositiveSpeed);
        let e = Reference::new(
            circle(),
            0.2,
            ReferenceMode::PathFollowing { lookahead_m: -1.0 },
        );
        assert_eq!(e.unwrap_err(), ReferenceError::BadDistance);
    }

    #[test]
    fn time_indexed_reference_moves_at_its_speed() {
        // v_r = 0.25 m/s on r = 1.25 m: ω_r = 0.2 rad/s; after 5 s the polar angle is 1 rad.
        let mut r = Reference::new(
            circle(),
            0.25,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap();
        let mut s = r.sample(0.0, &Pose::default());
        for _ in 0..500 {
            s = r.sample(0.01, &Pose::default());
        }
        assert!((s.pose.x_m - 1.25 * 1f32.cos()).abs() < 1e-5);
        assert!((s.pose.y_m - 1.25 * 1f32.sin()).abs() < 1e-5);
        assert!((s.pose.theta_rad - (1.0 + FRAC_PI_2)).abs() < 1e-5);
        assert!((s.omega_rad_s - 0.2).abs() < 1e-6);
        assert!(!s.finished);
    }

    #[test]
    fn open_path_reference_stops_at_the_end() {
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 1.0).unwrap();
        let mut r = Reference::new(
            line,
            0.5,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap();
        let s = r.sample(3.0, &Pose::default());
        assert!(s.finished);
        assert_eq!(s.v_m_s, 0.0);
        assert!((s.pose.x_m - 1.0).abs() < 1e-6);
    }

    #[test]
    fn path_following_reference_is_ahead_of_the_robot() {
        let mut r = Reference::new(
            circle(),
            0.25,
            ReferenceMode::PathFollowing { lookahead_m: 0.0 },
        )
        .unwrap();
        // Robot outside the circle at polar angle π/2: the reference is the nearest point.
        let s = r.sample(0.0, &Pose::new(0.0, 1.6, PI));
        assert!((s.pose.x_m).abs() < 1e-4 && (s.pose.y_m - 1.25).abs() < 1e-4);
        // Time does not move it: only the robot does.
        let s2 = r.sample(10.0, &Pose::new(0.0, 1.6, PI));
        assert!((s2.progress_m - s.progress_m).abs() < 1e-5);
    }

    #[test]
    fn a_day_on_the_circle_keeps_the_reference_smooth() {
        // 24 h at 0.25 m/s in 10 ms samples (8.64e6 of them): each sample must move the
        // reference by 2.5 mm (±1 µm), as on the first lap. An unwrapped f32 arc length
        // would be 21 600 m at the end and move in 1.95 mm jerks.
        let mut r = Reference::new(
            circle(),
            0.25,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap();
        let length = r.path().length_m();
        let mut previous = r.sample(0.0, &Pose::default()).progress_m;
        let mut total = 0.0f64;
        for k in 0..8_640_000u32 {
            let now = r.sample(0.01, &Pose::default()).progress_m;
            let mut step = now - previous;
            if step < 0.0 {
                step += length;
            }
            total += f64::from(step);
            if k % 1000 == 0 || k > 8_639_000 {
                assert!((step - 0.0025).abs() < 1e-6, "sample {k}: moved {step} m");
            }
            assert!((0.0..length).contains(&now));
            previous = now;
        }
        // And it has travelled the right distance in all (to the f32 rounding of one
        // step's 2.5 mm, 1e-7 relative).
        assert!((total - 21_600.0).abs() < 21_600.0 * 2e-7, "{total}");
    }

    #[test]
    fn restart_returns_to_the_start_offset() {
        let mut r = Reference::new(
            circle(),
            0.25,
            ReferenceMode::TimeIndexed {
                start_offset_m: 1.0,
            },
        )
        .unwrap();
        assert!((r.sample(0.0, &Pose::default()).progress_m - 1.0).abs() < 1e-6);
        r.sample(2.0, &Pose::default());
        r.restart();
        assert!((r.sample(0.0, &Pose::default()).progress_m - 1.0).abs() < 1e-6);
        assert_eq!(r.speed_m_s(), 0.25);
    }
}
