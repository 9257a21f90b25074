//! The reference the steering law chases: a point moving along a [`Path`].
//!
//! Two ways to move it:
//!
//! - [`ReferenceMode::TimeIndexed`] — the paper's "virtual robot" (section 3): at time
//!   t = k·T the reference is at arc length s₀ + v_r·t, whatever the real robot does.
//!   This is trajectory *tracking*. Time is counted in control periods, and the position
//!   along the path is accumulated per elapsed period as a binary fraction of the path
//!   ([`PathFraction`]: an exact integer sum of v_r/(rate·length), computed once to 48
//!   bits, whose integer wrap-around is the lap's). A plain `v_r·t` in `f32` reaches 21 600 m after 24 h at 0.25 m/s, where
//!   an `f32` only resolves 1.95 mm; an `f32` sum of `v_r·T` drifts by the rounding of
//!   `T` = 1 ms (5e-8) — 1 mm of phase a day. The fixed-point sum is within 1e-5 m of
//!   s₀ + v_r·k/rate after a day.
//! - [`ReferenceMode::PathFollowing`] — the reference point is chosen from the robot's own
//!   progress: the robot's position is projected onto the path (searching a window around
//!   the previous projection, so a path that crosses itself is not short-cut) and the
//!   reference is placed `lookahead_m` further on. There is no time index: a robot that
//!   is held back is not chased by a reference running away from it.
//!
//! On an open path the reference stops at the end (v_r = ω_r = 0, `finished`), so the
//! robot comes to rest there instead of running on.
//!
//! A run that pauses (the robot disarmed) and goes on [`Reference::resume`]s: the
//! time-indexed reference's clock counts only the periods it was sampled over, so it
//! stands still while the robot does and goes on from there; path following projects
//! the robot afresh. [`Reference::restart`] starts over from the start offset.

use core::num::NonZeroU32;

use crate::compensated::DoubleF32;
use crate::fixed::PathFraction;
use crate::kinematics::{BodyVelocity, Point, Pose};
use crate::path::{Path, PathError, PathSample, Segment};

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

/// Why [`Reference::rebuild`] refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RebuildError {
    /// The segments do not make a path.
    Path(PathError),
    /// The speed or the distance of the mode is out of range.
    Reference(ReferenceError),
}

impl core::fmt::Display for RebuildError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            RebuildError::Path(_) => "the segments do not make a path",
            RebuildError::Reference(_) => "the reference's speed or mode is out of range",
        })
    }
}

impl core::error::Error for RebuildError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            RebuildError::Path(e) => Some(e),
            RebuildError::Reference(e) => Some(e),
        }
    }
}

/// Speed and mode checks of [`Reference::new`].
fn check_motion(speed_m_s: f32, mode: ReferenceMode) -> Result<(), ReferenceError> {
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
    Ok(())
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

impl core::error::Error for ReferenceError {}

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
#[derive(Debug)]
#[repr(C)]
pub struct Reference {
    // The per-step state first, the large path last (short load offsets on the M4F).
    /// Time-indexed only: the reference's position along the path (wrapping per lap on a
    /// closed path, held at the end of an open one).
    progress: PathFraction,
    /// Progress per control period at `per_period_rate_hz` (0 until the first sample).
    per_period: PathFraction,
    per_period_rate_hz: u32,
    speed_m_s: f32,
    mode: ReferenceMode,
    /// Path-following only: the robot's last projection, m (None before the first sample).
    projection_m: Option<f32>,
    path: Path,
}

impl Clone for Reference {
    fn clone(&self) -> Self {
        Self {
            progress: self.progress,
            per_period: self.per_period,
            per_period_rate_hz: self.per_period_rate_hz,
            speed_m_s: self.speed_m_s,
            mode: self.mode,
            projection_m: self.projection_m,
            path: self.path.clone(),
        }
    }

    /// In place, field by field: no temporary reference on the stack.
    fn clone_from(&mut self, source: &Self) {
        self.progress = source.progress;
        self.per_period = source.per_period;
        self.per_period_rate_hz = source.per_period_rate_hz;
        self.speed_m_s = source.speed_m_s;
        self.mode = source.mode;
        self.projection_m = source.projection_m;
        self.path.clone_from(&source.path);
    }
}

impl Reference {
    /// A reference moving along `path` at `speed_m_s` (m/s, > 0) in `mode`.
    pub fn new(path: Path, speed_m_s: f32, mode: ReferenceMode) -> Result<Self, ReferenceError> {
        check_motion(speed_m_s, mode)?;
        let mut reference = Self {
            path,
            ..Self::PLACEHOLDER
        };
        reference.start_moving(speed_m_s, mode);
        Ok(reference)
    }

    /// A reference at 1 m/s along [`Path::PLACEHOLDER`], time-indexed from its start: room
    /// that a reference is then built into in place ([`Reference::rebuild`]).
    pub const PLACEHOLDER: Reference = Reference {
        progress: PathFraction::START,
        per_period: PathFraction::START,
        per_period_rate_hz: 0,
        speed_m_s: 1.0,
        mode: ReferenceMode::TimeIndexed {
            start_offset_m: 0.0,
        },
        projection_m: None,
        path: Path::PLACEHOLDER,
    };

    /// Makes this reference the one `Reference::new(Path::from_segments(segments)?,
    /// speed_m_s, mode)` builds, in place (no path or reference on the stack). On an
    /// error the reference is unchanged.
    pub fn rebuild(
        &mut self,
        segments: &[Segment],
        speed_m_s: f32,
        mode: ReferenceMode,
    ) -> Result<(), RebuildError> {
        check_motion(speed_m_s, mode).map_err(RebuildError::Reference)?;
        self.path
            .rebuild_from_segments(segments)
            .map_err(RebuildError::Path)?;
        self.start_moving(speed_m_s, mode);
        Ok(())
    }

    /// Sets the (checked) speed and mode on the path it has, forgets the cached
    /// per-period progress, and goes back to the start.
    fn start_moving(&mut self, speed_m_s: f32, mode: ReferenceMode) {
        self.speed_m_s = speed_m_s;
        self.mode = mode;
        self.per_period = PathFraction::START;
        self.per_period_rate_hz = 0;
        self.restart();
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
        let start = DoubleF32::from_f32(self.path.normalize_m(start_m)) / self.path.length_m();
        self.progress = PathFraction::from_fraction(start);
        self.projection_m = None;
    }

    /// Goes on after a pause (the robot was disarmed, and may have been moved): the
    /// time-indexed reference stays where it stopped, its clock having paused, and path
    /// following forgets its progress, so the next sample projects the robot onto the
    /// whole path from wherever it now is.
    pub fn resume(&mut self) {
        self.projection_m = None;
    }

    /// The reference `elapsed_periods` control periods of `rate` (Hz) after the previous
    /// sample (0 for the first sample after [`Reference::restart`]), for a robot at
    /// `robot` (world frame).
    pub fn sample(
        &mut self,
        elapsed_periods: u32,
        rate: NonZeroU32,
        robot: &Pose,
    ) -> ReferenceState {
        let length = self.path.length_m();
        let (progress_m, finished) = match self.mode {
            ReferenceMode::TimeIndexed { .. } => {
                self.advance(elapsed_periods, rate);
                let finished = !self.path.is_closed() && self.progress == PathFraction::END;
                (self.progress.of_length_m(length), finished)
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

    /// Moves the time-indexed reference on by `periods` control periods of `rate` at the
    /// set speed: wrapped into [0, length) on a closed path, held at the end of an open one.
    fn advance(&mut self, periods: u32, rate: NonZeroU32) {
        if rate.get() != self.per_period_rate_hz {
            // v_r/(rate·length) to 48 bits (a rate is exact in f32 below 2²⁴ Hz).
            let per_period =
                DoubleF32::from_f32(self.speed_m_s) / rate.get() as f32 / self.path.length_m();
            self.per_period = PathFraction::from_fraction(per_period);
            self.per_period_rate_hz = rate.get();
        }
        self.progress = if self.path.is_closed() {
            let moved = self.per_period.times_wrapping(periods);
            self.progress.plus_wrapping(moved)
        } else {
            let moved = self.per_period.times_saturating(periods);
            self.progress.plus_saturating(moved)
        };
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

    #[test]
    fn a_rebuild_error_says_which_part_failed_and_keeps_its_cause() {
        use core::error::Error as _;
        let e = RebuildError::Reference(ReferenceError::NonPositiveSpeed);
        assert!(e.to_string().contains("speed or mode"));
        let cause = e.source().map(std::string::ToString::to_string);
        assert_eq!(cause, Some(ReferenceError::NonPositiveSpeed.to_string()));
    }
    use core::f32::consts::{FRAC_PI_2, PI};

    /// 100 Hz: one period is 0.01 s.
    const HZ_100: NonZeroU32 = NonZeroU32::new(100).unwrap();

    fn circle() -> Path {
        Path::circle(Point::new(0.0, 0.0), 1.25, 0.0, true).unwrap()
    }

    #[test]
    fn a_reference_rebuilt_in_place_is_the_one_new_builds() {
        let square = crate::path::tests::SQUARE_2M;
        let path = Path::polyline(&square, 0.3, true).unwrap();
        let robot = Pose {
            x_m: 0.4,
            y_m: -0.2,
            theta_rad: 0.1,
        };
        for mode in [
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.7,
            },
            ReferenceMode::PathFollowing { lookahead_m: 0.2 },
        ] {
            let mut built = Reference::new(path.clone(), 0.3, mode).unwrap();
            // Rebuilt over a reference with a history (another path, sampled), in place.
            let mut rebuilt = Reference::new(
                circle(),
                1.0,
                ReferenceMode::TimeIndexed {
                    start_offset_m: 0.0,
                },
            )
            .unwrap();
            for _ in 0..37 {
                rebuilt.sample(3, HZ_100, &robot);
            }
            rebuilt.rebuild(path.segments(), 0.3, mode).unwrap();
            assert_eq!(rebuilt.path().segments(), path.segments());
            assert_eq!(
                rebuilt.path().length_m().to_bits(),
                path.length_m().to_bits()
            );
            assert_eq!(rebuilt.path().is_closed(), path.is_closed());
            for k in 0..200 {
                let at = Pose {
                    x_m: robot.x_m + 0.01 * k as f32,
                    ..robot
                };
                assert_eq!(
                    rebuilt.sample(1, HZ_100, &at),
                    built.sample(1, HZ_100, &at),
                    "{mode:?} sample {k}"
                );
            }
        }
    }

    #[test]
    fn a_refused_rebuild_changes_nothing() {
        let mut reference = Reference::new(
            circle(),
            0.25,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap();
        let first = reference.clone().sample(10, HZ_100, &Pose::default());
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 1.0).unwrap();
        let ok = ReferenceMode::TimeIndexed {
            start_offset_m: 0.0,
        };
        assert_eq!(
            reference.rebuild(line.segments(), 0.0, ok),
            Err(RebuildError::Reference(ReferenceError::NonPositiveSpeed))
        );
        let bad_distance = ReferenceMode::PathFollowing { lookahead_m: -1.0 };
        assert_eq!(
            reference.rebuild(line.segments(), 0.25, bad_distance),
            Err(RebuildError::Reference(ReferenceError::BadDistance))
        );
        assert_eq!(
            reference.rebuild(&[], 0.25, ok),
            Err(RebuildError::Path(PathError::NoSegments))
        );
        assert_eq!(reference.path().segments(), circle().segments());
        assert_eq!(reference.speed_m_s(), 0.25);
        assert_eq!(reference.sample(10, HZ_100, &Pose::default()), first);
    }

    #[test]
    fn the_placeholder_is_a_valid_reference() {
        let mut placeholder = Reference::PLACEHOLDER;
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 1.0).unwrap();
        assert_eq!(placeholder.path().segments(), line.segments());
        let mode = ReferenceMode::TimeIndexed {
            start_offset_m: 0.0,
        };
        let mut built = Reference::new(line, 1.0, mode).unwrap();
        let at = Pose::default();
        assert_eq!(
            placeholder.sample(10, HZ_100, &at),
            built.sample(10, HZ_100, &at)
        );
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
        let mut s = r.sample(0, HZ_100, &Pose::default());
        for _ in 0..500 {
            s = r.sample(1, HZ_100, &Pose::default());
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
        let s = r.sample(300, HZ_100, &Pose::default());
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
        let s = r.sample(0, HZ_100, &Pose::new(0.0, 1.6, PI));
        assert!((s.pose.x_m).abs() < 1e-4 && (s.pose.y_m - 1.25).abs() < 1e-4);
        // Time does not move it: only the robot does.
        let s2 = r.sample(1000, HZ_100, &Pose::new(0.0, 1.6, PI));
        assert!((s2.progress_m - s.progress_m).abs() < 1e-5);
    }

    #[test]
    fn look_ahead_places_the_reference_further_on_and_an_open_path_finishes() {
        // A 2 m line along +x; the robot beside it at x = 0.5: the reference is 0.3 m
        // further on, at x = 0.8, moving at the set speed.
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 2.0).unwrap();
        let following = ReferenceMode::PathFollowing { lookahead_m: 0.3 };
        let mut r = Reference::new(line, 0.25, following).unwrap();
        let s = r.sample(0, HZ_100, &Pose::new(0.5, 0.2, 0.0));
        assert!((s.progress_m - 0.8).abs() < 1e-5 && (s.pose.x_m - 0.8).abs() < 1e-5);
        assert!(!s.finished);
        assert_eq!(s.v_m_s, 0.25);
        // Within the look-ahead of the end (the robot gets there in steps the windowed
        // search follows): held at the end, finished, standing still.
        for x in [0.9, 1.3] {
            assert!(!r.sample(1, HZ_100, &Pose::new(x, 0.0, 0.0)).finished);
        }
        let end = r.sample(1, HZ_100, &Pose::new(1.8, 0.0, 0.0));
        assert!(end.finished);
        assert_eq!(end.v_m_s, 0.0);
        assert!((end.progress_m - 2.0).abs() < 1e-6);
        // On a closed path the same look-ahead wraps past the start and never finishes.
        let mut c = Reference::new(circle(), 0.25, following).unwrap();
        let length = c.path().length_m();
        let near_end = c.sample(0, HZ_100, &Pose::new(1.25, -0.1, FRAC_PI_2));
        assert!(!near_end.finished);
        let expected = (length - 1.25 * (0.1f32 / 1.25).atan() + 0.3) - length;
        assert!(
            (near_end.progress_m - expected).abs() < 1e-3,
            "{} vs {expected}",
            near_end.progress_m
        );
    }

    #[test]
    fn errors_say_what_is_wrong() {
        let speed = std::format!("{}", ReferenceError::NonPositiveSpeed);
        assert!(speed.contains("speed") && speed.contains("> 0"), "{speed}");
        let distance = std::format!("{}", ReferenceError::BadDistance);
        assert!(
            distance.contains("look-ahead") && distance.contains("≥ 0"),
            "{distance}"
        );
    }

    #[test]
    fn a_day_on_the_circle_keeps_the_reference_smooth_and_on_time() {
        // 24 h at 0.25 m/s, sampled every 10 periods of 1 kHz (8.64e6 samples): each
        // sample must move the reference by 2.5 mm (±1 µm), as on the first lap, and at
        // the end it must be where s = v_r·t puts it, modulo the lap, to 10 µm. An
        // unwrapped f32 arc length would be 21 600 m at the end and move in 1.95 mm jerks;
        // an f32 sum of v_r·T would be 1 mm late.
        let khz = NonZeroU32::new(1000).unwrap();
        let mut r = Reference::new(
            circle(),
            0.25,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap();
        let length = r.path().length_m();
        let mut previous = r.sample(0, khz, &Pose::default()).progress_m;
        for k in 0..8_640_000u32 {
            let now = r.sample(10, khz, &Pose::default()).progress_m;
            let mut step = now - previous;
            if step < 0.0 {
                step += length;
            }
            if k % 1000 == 0 || k > 8_639_000 {
                assert!((step - 0.0025).abs() < 1e-6, "sample {k}: moved {step} m");
            }
            assert!((0.0..=length).contains(&now));
            previous = now;
        }
        let expected = 21_600.0f64.rem_euclid(f64::from(length));
        assert!(
            (f64::from(previous) - expected).abs() < 1e-5,
            "{previous} vs {expected}"
        );
    }

    #[test]
    fn resuming_keeps_the_clock_and_projects_the_robot_again() {
        // Time-indexed: 2 s along, resumed: the next sample of 0 periods is where it
        // stopped, not at the start offset.
        let indexed = ReferenceMode::TimeIndexed {
            start_offset_m: 0.0,
        };
        let mut r = Reference::new(circle(), 0.25, indexed).unwrap();
        let stopped = r.sample(200, HZ_100, &Pose::default()).progress_m;
        r.resume();
        assert_eq!(r.sample(0, HZ_100, &Pose::default()).progress_m, stopped);
        assert!((stopped - 0.5).abs() < 1e-6);
        // Path following: a robot carried 1.5 m on along a line, beyond the search window
        // ahead of its last projection, is found where it now is.
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 3.0).unwrap();
        let following = ReferenceMode::PathFollowing { lookahead_m: 0.0 };
        let mut r = Reference::new(line, 0.25, following).unwrap();
        assert!(r.sample(0, HZ_100, &Pose::new(0.2, 0.1, 0.0)).progress_m < 0.21);
        r.resume();
        let found = r.sample(0, HZ_100, &Pose::new(1.7, 0.1, 0.0)).progress_m;
        assert!((found - 1.7).abs() < 1e-4, "{found}");
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
        assert!((r.sample(0, HZ_100, &Pose::default()).progress_m - 1.0).abs() < 1e-6);
        r.sample(200, HZ_100, &Pose::default());
        r.restart();
        assert!((r.sample(0, HZ_100, &Pose::default()).progress_m - 1.0).abs() < 1e-6);
        assert_eq!(r.speed_m_s(), 0.25);
    }
}
