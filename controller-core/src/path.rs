//! Geometric paths in the world frame: chains of straight segments and circular arcs.
//!
//! Every path is parameterised by arc length s (m) from its start. A circle is one arc of
//! 2π, a figure-eight two, and a polyline of waypoints is a chain of straight segments
//! joined by circular fillets of a chosen radius (so that a robot can follow the corners
//! with a finite yaw rate; a zero radius keeps sharp corners). Paths have a fixed maximum
//! size ([`MAX_SEGMENTS`]) and never allocate.

use core::f32::consts::{FRAC_PI_2, PI, TAU};

use heapless::Vec;

use crate::kinematics::Point;
use crate::math;

/// Most segments (lines plus arcs) a [`Path`] can hold. A closed polyline of n waypoints
/// with rounded corners uses 2n.
pub const MAX_SEGMENTS: usize = 32;

/// How far apart (m) the end of one segment and the start of the next may be for
/// [`Path::from_segments`] to accept them as joined: 1 mm, well above the f32 rounding of
/// segments computed on a host and well below anything a robot could follow as a step.
pub const JOINT_TOLERANCE_M: f32 = 1e-3;

/// How far apart (rad) the direction at the end of one segment and at the start of the
/// next may be for [`Path::from_segments`]: 0.01 rad (0.57°).
pub const JOINT_TOLERANCE_RAD: f32 = 1e-2;

/// One piece of a path, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum Segment {
    /// Straight segment from `start`, heading `heading_rad` (rad, world frame) for
    /// `length_m` (m).
    Line {
        /// Start point, world frame, m.
        start: Point,
        /// Direction of travel, rad, world frame.
        heading_rad: f32,
        /// Length, m.
        length_m: f32,
    },
    /// Circular arc about `center` of radius `radius_m` (m), starting at polar angle
    /// `start_angle_rad` (rad, measured at the centre from the world x axis) and sweeping
    /// `sweep_rad` (rad; positive counter-clockwise).
    Arc {
        /// Centre, world frame, m.
        center: Point,
        /// Radius, m.
        radius_m: f32,
        /// Polar angle of the start point about the centre, rad.
        start_angle_rad: f32,
        /// Signed swept angle, rad (+ counter-clockwise, − clockwise).
        sweep_rad: f32,
    },
}

/// A point on a path with its direction of travel and signed curvature.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct PathSample {
    /// Position, world frame, m.
    pub point: Point,
    /// Direction of travel, rad, world frame, in (−π, π].
    pub heading_rad: f32,
    /// Signed curvature, 1/m (+ turning left). The reference yaw rate is ω_r = v_r·κ.
    pub curvature_per_m: f32,
}

impl Segment {
    /// Length of the segment, m.
    pub fn length_m(&self) -> f32 {
        match *self {
            Segment::Line { length_m, .. } => length_m,
            Segment::Arc {
                radius_m,
                sweep_rad,
                ..
            } => radius_m * math::abs(sweep_rad),
        }
    }

    /// The point at arc length `s_m` from the segment's start (clamped to the segment).
    pub fn sample(&self, s_m: f32) -> PathSample {
        let s = math::clamp(s_m, 0.0, self.length_m());
        match *self {
            Segment::Line {
                start, heading_rad, ..
            } => {
                let (sin_h, cos_h) = math::sin_cos(heading_rad);
                PathSample {
                    point: Point::new(start.x_m + s * cos_h, start.y_m + s * sin_h),
                    heading_rad: math::wrap_angle(heading_rad),
                    curvature_per_m: 0.0,
                }
            }
            Segment::Arc {
                center,
                radius_m,
                start_angle_rad,
                sweep_rad,
            } => {
                let direction = if sweep_rad >= 0.0 { 1.0 } else { -1.0 };
                let polar = start_angle_rad + direction * s / radius_m;
                // No wrap needed here: |polar| stays within a few π, where sin_cos is
                // accurate to 2e-7 (see `math`).
                let (sin_p, cos_p) = math::sin_cos(polar);
                PathSample {
                    point: Point::new(center.x_m + radius_m * cos_p, center.y_m + radius_m * sin_p),
                    heading_rad: math::wrap_angle(polar + direction * FRAC_PI_2),
                    curvature_per_m: direction / radius_m,
                }
            }
        }
    }

    /// Checks that every value is finite and the length and radius positive.
    fn check(&self) -> Result<(), PathError> {
        let finite = match *self {
            Segment::Line {
                start,
                heading_rad,
                length_m,
            } => finite_point(start) && heading_rad.is_finite() && length_m.is_finite(),
            Segment::Arc {
                center,
                radius_m,
                start_angle_rad,
                sweep_rad,
            } => {
                finite_point(center)
                    && radius_m.is_finite()
                    && start_angle_rad.is_finite()
                    && sweep_rad.is_finite()
            }
        };
        let length_m = self.length_m();
        if !(finite && length_m.is_finite()) {
            return Err(PathError::NonFinite);
        }
        let radius_ok = match *self {
            Segment::Line { .. } => true,
            Segment::Arc { radius_m, .. } => radius_m > 0.0,
        };
        if !(radius_ok && length_m > 0.0) {
            return Err(PathError::NonPositiveSize);
        }
        Ok(())
    }

    /// Arc length (m, from the segment's start) of the segment's point closest to `p`.
    fn closest_m(&self, p: Point) -> f32 {
        match *self {
            Segment::Line {
                start,
                heading_rad,
                length_m,
            } => {
                let (sin_h, cos_h) = math::sin_cos(heading_rad);
                let along = (p.x_m - start.x_m) * cos_h + (p.y_m - start.y_m) * sin_h;
                math::clamp(along, 0.0, length_m)
            }
            Segment::Arc {
                center,
                radius_m,
                start_angle_rad,
                sweep_rad,
            } => {
                let direction = if sweep_rad >= 0.0 { 1.0 } else { -1.0 };
                let polar = math::atan2(p.y_m - center.y_m, p.x_m - center.x_m);
                // Angle travelled from the start to p's polar angle, in [0, 2π).
                let mut travelled = direction * math::wrap_angle(polar - start_angle_rad);
                if travelled < 0.0 {
                    travelled += TAU;
                }
                let sweep = math::abs(sweep_rad);
                if travelled <= sweep {
                    travelled * radius_m
                } else {
                    let end = self.length_m();
                    let to_start = p.distance_to(self.sample(0.0).point);
                    let to_end = p.distance_to(self.sample(end).point);
                    if to_start <= to_end {
                        0.0
                    } else {
                        end
                    }
                }
            }
        }
    }
}

/// Why a [`Path`] could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum PathError {
    /// A coordinate, length or radius was NaN or infinite.
    NonFinite,
    /// A radius or length was ≤ 0 (a corner radius may be 0, not negative).
    NonPositiveSize,
    /// A polyline needs at least 2 waypoints (3 when closed).
    TooFewPoints,
    /// Two consecutive waypoints coincide.
    DuplicatePoint,
    /// A corner fillet does not fit between its neighbouring waypoints (or the path
    /// turns back on itself).
    CornerTooTight,
    /// The path needs more than [`MAX_SEGMENTS`] segments.
    TooManySegments,
    /// A chain of segments was empty.
    NoSegments,
    /// Segment `segment` does not start where the one before it ends (further apart than
    /// [`JOINT_TOLERANCE_M`]).
    Gap {
        /// Index of the segment in the slice (≥ 1).
        segment: u8,
    },
    /// Segment `segment` does not start in the direction the one before it ends (more
    /// than [`JOINT_TOLERANCE_RAD`] apart): the path would have a corner.
    Kink {
        /// Index of the segment in the slice.
        segment: u8,
    },
}

impl core::fmt::Display for PathError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            PathError::NonFinite => "a coordinate, length or radius is not finite",
            PathError::NonPositiveSize => "a radius or length is ≤ 0 (a corner radius < 0)",
            PathError::TooFewPoints => "a polyline needs at least 2 waypoints (3 when closed)",
            PathError::DuplicatePoint => "two consecutive waypoints coincide",
            PathError::CornerTooTight => {
                "a corner fillet does not fit between its waypoints, or the path turns back"
            }
            PathError::TooManySegments => "the path needs more than 32 segments",
            PathError::NoSegments => "a path needs at least one segment",
            PathError::Gap { segment } => {
                return write!(
                    f,
                    "segment {segment} does not start where segment {} ends (gap > {} m)",
                    segment.saturating_sub(1),
                    JOINT_TOLERANCE_M
                )
            }
            PathError::Kink { segment } => {
                return write!(
                    f,
                    "segment {segment} does not start in the direction segment {} ends \
                     (corner > {} rad)",
                    segment.saturating_sub(1),
                    JOINT_TOLERANCE_RAD
                )
            }
        })
    }
}

/// A path: a chain of [`Segment`]s parameterised by arc length, open or closed.
#[derive(Clone, Debug)]
pub struct Path {
    segments: Vec<Segment, MAX_SEGMENTS>,
    /// Arc length at which each segment starts, m.
    starts_m: Vec<f32, MAX_SEGMENTS>,
    length_m: f32,
    closed: bool,
}

/// How the end of one segment meets the start of the next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Joint {
    /// Same point and direction, within [`JOINT_TOLERANCE_M`] and [`JOINT_TOLERANCE_RAD`].
    Smooth,
    /// The points are further apart.
    Gap,
    /// Same point, different directions.
    Kink,
}

impl Joint {
    fn between(before: &Segment, after: &Segment) -> Joint {
        let end = before.sample(before.length_m());
        let start = after.sample(0.0);
        if end.point.distance_to(start.point) > JOINT_TOLERANCE_M {
            Joint::Gap
        } else if math::abs(math::wrap_angle(start.heading_rad - end.heading_rad))
            > JOINT_TOLERANCE_RAD
        {
            Joint::Kink
        } else {
            Joint::Smooth
        }
    }
}

fn finite_point(p: Point) -> bool {
    p.x_m.is_finite() && p.y_m.is_finite()
}

impl Path {
    /// A path of `segments` taken as they are (no checks), `closed` or not.
    fn chain(segments: &[Segment], closed: bool) -> Result<Self, PathError> {
        let mut path = Path {
            segments: Vec::new(),
            starts_m: Vec::new(),
            length_m: 0.0,
            closed,
        };
        for segment in segments {
            path.push(*segment)?;
        }
        Ok(path)
    }

    fn push(&mut self, segment: Segment) -> Result<(), PathError> {
        self.segments
            .push(segment)
            .map_err(|_| PathError::TooManySegments)?;
        self.starts_m
            .push(self.length_m)
            .map_err(|_| PathError::TooManySegments)?;
        self.length_m += segment.length_m();
        Ok(())
    }

    /// A path through `segments` (world frame), as they are, after checking them:
    ///
    /// - 1 to [`MAX_SEGMENTS`] segments ([`PathError::NoSegments`],
    ///   [`PathError::TooManySegments`]);
    /// - every value finite ([`PathError::NonFinite`]), every length and radius > 0
    ///   ([`PathError::NonPositiveSize`]);
    /// - each segment starts where the one before ends, within [`JOINT_TOLERANCE_M`]
    ///   ([`PathError::Gap`]), and in the direction it ends, within
    ///   [`JOINT_TOLERANCE_RAD`] ([`PathError::Kink`]).
    ///
    /// The path is closed when the last segment ends where the first starts, in its
    /// direction, within the same tolerances. [`Path::segments`] gives the segments back
    /// unchanged, so a host can send any path with it and the robot rebuild it with this.
    pub fn from_segments(segments: &[Segment]) -> Result<Self, PathError> {
        if segments.is_empty() {
            return Err(PathError::NoSegments);
        }
        if segments.len() > MAX_SEGMENTS {
            return Err(PathError::TooManySegments);
        }
        for segment in segments {
            segment.check()?;
        }
        let joints = segments.iter().zip(segments.iter().skip(1));
        for (index, (before, after)) in joints.enumerate() {
            let segment = u8::try_from(index + 1).unwrap_or(u8::MAX);
            match Joint::between(before, after) {
                Joint::Smooth => {}
                Joint::Gap => return Err(PathError::Gap { segment }),
                Joint::Kink => return Err(PathError::Kink { segment }),
            }
        }
        let closed = match (segments.last(), segments.first()) {
            (Some(last), Some(first)) => Joint::between(last, first) == Joint::Smooth,
            _ => false,
        };
        Self::chain(segments, closed)
    }

    /// A closed circle about `center` (m) of `radius_m` (m), starting at the point at polar
    /// angle `start_angle_rad` about the centre, travelled counter-clockwise when
    /// `counter_clockwise` (else clockwise).
    pub fn circle(
        center: Point,
        radius_m: f32,
        start_angle_rad: f32,
        counter_clockwise: bool,
    ) -> Result<Self, PathError> {
        if !(finite_point(center) && radius_m.is_finite() && start_angle_rad.is_finite()) {
            return Err(PathError::NonFinite);
        }
        if radius_m <= 0.0 {
            return Err(PathError::NonPositiveSize);
        }
        let sweep_rad = if counter_clockwise { TAU } else { -TAU };
        Self::chain(
            &[Segment::Arc {
                center,
                radius_m,
                start_angle_rad: math::wrap_angle(start_angle_rad),
                sweep_rad,
            }],
            true,
        )
    }

    /// An open straight line from `start` (m) heading `heading_rad` (rad, world frame) for
    /// `length_m` (m).
    pub fn line(start: Point, heading_rad: f32, length_m: f32) -> Result<Self, PathError> {
        if !(finite_point(start) && heading_rad.is_finite() && length_m.is_finite()) {
            return Err(PathError::NonFinite);
        }
        if length_m <= 0.0 {
            return Err(PathError::NonPositiveSize);
        }
        Self::chain(
            &[Segment::Line {
                start,
                heading_rad: math::wrap_angle(heading_rad),
                length_m,
            }],
            false,
        )
    }

    /// A figure-eight of two circles of `lobe_radius_m` (m) that touch at `center`: first
    /// the right lobe clockwise, then the left lobe counter-clockwise, both leaving
    /// `center` heading +y (north). Closed, length 4π·r.
    pub fn figure_eight(center: Point, lobe_radius_m: f32) -> Result<Self, PathError> {
        if !(finite_point(center) && lobe_radius_m.is_finite()) {
            return Err(PathError::NonFinite);
        }
        if lobe_radius_m <= 0.0 {
            return Err(PathError::NonPositiveSize);
        }
        let right = Segment::Arc {
            center: Point::new(center.x_m + lobe_radius_m, center.y_m),
            radius_m: lobe_radius_m,
            start_angle_rad: PI,
            sweep_rad: -TAU,
        };
        let left = Segment::Arc {
            center: Point::new(center.x_m - lobe_radius_m, center.y_m),
            radius_m: lobe_radius_m,
            start_angle_rad: 0.0,
            sweep_rad: TAU,
        };
        Self::chain(&[right, left], true)
    }

    /// A polyline through `waypoints` (world frame, m) whose corners are rounded with
    /// circular fillets of `corner_radius_m` (m, ≥ 0; 0 keeps sharp corners). When
    /// `closed`, the last waypoint connects back to the first and that corner is rounded
    /// too; the path then starts just after the first waypoint's fillet.
    pub fn polyline(
        waypoints: &[Point],
        corner_radius_m: f32,
        closed: bool,
    ) -> Result<Self, PathError> {
        let n = waypoints.len();
        if n < 2 || (closed && n < 3) {
            return Err(PathError::TooFewPoints);
        }
        if !(waypoints.iter().all(|p| finite_point(*p)) && corner_radius_m.is_finite()) {
            return Err(PathError::NonFinite);
        }
        if corner_radius_m < 0.0 {
            return Err(PathError::NonPositiveSize);
        }
        if n > MAX_SEGMENTS {
            return Err(PathError::TooManySegments);
        }
        let edges = if closed { n } else { n - 1 };
        let vertex = |i: usize| waypoints[i % n];
        // Heading and length of edge i (from waypoint i to waypoint i + 1).
        let mut headings = [0.0f32; MAX_SEGMENTS];
        let mut lengths = [0.0f32; MAX_SEGMENTS];
        for i in 0..edges {
            let (a, b) = (vertex(i), vertex(i + 1));
            lengths[i] = a.distance_to(b);
            if lengths[i] <= 1e-6 {
                return Err(PathError::DuplicatePoint);
            }
            headings[i] = math::atan2(b.y_m - a.y_m, b.x_m - a.x_m);
        }
        // Turn angle and tangent length of the fillet at each waypoint.
        let mut turns = [0.0f32; MAX_SEGMENTS];
        let mut tangents = [0.0f32; MAX_SEGMENTS];
        for i in 0..n {
            let has_corner = closed || (i > 0 && i < n - 1);
            if !has_corner {
                continue;
            }
            let incoming = headings[(i + edges - 1) % edges];
            let outgoing = headings[i % edges];
            let turn = math::wrap_angle(outgoing - incoming);
            if math::abs(turn) > PI - 1e-3 {
                return Err(PathError::CornerTooTight);
            }
            let (sin_half, cos_half) = math::sin_cos(0.5 * math::abs(turn));
            turns[i] = turn;
            tangents[i] = corner_radius_m * sin_half / cos_half;
        }
        let mut path = Path {
            segments: Vec::new(),
            starts_m: Vec::new(),
            length_m: 0.0,
            closed,
        };
        for i in 0..edges {
            let next = (i + 1) % n;
            let straight = lengths[i] - tangents[i] - tangents[next];
            if straight < -1e-6 {
                return Err(PathError::CornerTooTight);
            }
            let (sin_h, cos_h) = math::sin_cos(headings[i]);
            let a = vertex(i);
            if straight > 1e-6 {
                path.push(Segment::Line {
                    start: Point::new(a.x_m + tangents[i] * cos_h, a.y_m + tangents[i] * sin_h),
                    heading_rad: headings[i],
                    length_m: straight,
                })?;
            }
            let turn = turns[next];
            if corner_radius_m > 0.0 && math::abs(turn) > 1e-6 {
                let b = vertex(i + 1);
                let entry = Point::new(
                    b.x_m - tangents[next] * cos_h,
                    b.y_m - tangents[next] * sin_h,
                );
                // Centre on the inside of the turn, one radius from the entry point.
                let side = if turn > 0.0 { 1.0 } else { -1.0 };
                let center = Point::new(
                    entry.x_m - side * corner_radius_m * sin_h,
                    entry.y_m + side * corner_radius_m * cos_h,
                );
                path.push(Segment::Arc {
                    center,
                    radius_m: corner_radius_m,
                    start_angle_rad: math::atan2(entry.y_m - center.y_m, entry.x_m - center.x_m),
                    sweep_rad: turn,
                })?;
            }
        }
        Ok(path)
    }

    /// Total length, m.
    pub const fn length_m(&self) -> f32 {
        self.length_m
    }

    /// True when the end joins the start (arc length then wraps modulo the length).
    pub const fn is_closed(&self) -> bool {
        self.closed
    }

    /// The segments, in order of travel.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Arc length `s_m` brought into [0, length]: wrapped for a closed path, clamped for an
    /// open one.
    pub fn normalize_m(&self, s_m: f32) -> f32 {
        if self.closed {
            let turns = s_m / self.length_m;
            let whole = turns as i32 as f32 - if turns < 0.0 { 1.0 } else { 0.0 };
            let s = s_m - whole * self.length_m;
            math::clamp(s, 0.0, self.length_m)
        } else {
            math::clamp(s_m, 0.0, self.length_m)
        }
    }

    /// The point at arc length `s_m` (m) from the start (see [`Path::normalize_m`]).
    pub fn sample(&self, s_m: f32) -> PathSample {
        self.sample_normalized(self.normalize_m(s_m))
    }

    /// The point at arc length `s_m` (m), which the caller has already brought into
    /// [0, length] ([`Path::normalize_m`]). The segments are searched in order and the
    /// search stops at the first that starts beyond `s_m`; nothing is indexed, so nothing
    /// can panic.
    pub fn sample_normalized(&self, s_m: f32) -> PathSample {
        let mut chosen = None;
        for (segment, &start) in self.segments.iter().zip(self.starts_m.iter()) {
            if s_m < start {
                break;
            }
            chosen = Some((segment, start));
        }
        match chosen {
            Some((segment, start)) => segment.sample(s_m - start),
            // Before the first segment (only for s < 0, which normalising excludes).
            None => match self.segments.first() {
                Some(first) => first.sample(0.0),
                None => PathSample::default(),
            },
        }
    }

    /// Arc length (m) of the point of the path closest to `p`, looked for within
    /// [`hint_m` − `behind_m`, `hint_m` + `ahead_m`] of arc length (wrapping on a closed
    /// path). Pass infinite bounds for a global search. The result is not normalised.
    pub fn project(&self, p: Point, hint_m: f32, behind_m: f32, ahead_m: f32) -> f32 {
        let mut best_s = hint_m;
        let mut best_d = f32::INFINITY;
        for (segment, start) in self.segments.iter().zip(self.starts_m.iter()) {
            if !self.overlaps_window(
                *start,
                start + segment.length_m(),
                hint_m,
                behind_m,
                ahead_m,
            ) {
                continue;
            }
            let candidate = start + segment.closest_m(p);
            let mut offset = candidate - hint_m;
            if self.closed && behind_m.is_finite() {
                offset = self.normalize_m(offset + 0.5 * self.length_m) - 0.5 * self.length_m;
            }
            let offset = math::clamp(offset, -behind_m, ahead_m);
            let s = hint_m + offset;
            let d = p.distance_to(self.sample(s).point);
            if d < best_d {
                best_d = d;
                best_s = s;
            }
        }
        best_s
    }

    /// True when arc lengths [`from_m`, `to_m`] meet the search window around `hint_m`
    /// (also shifted by one length either way on a closed path). Keeps the projection's
    /// cost to the few segments near the robot instead of the whole path.
    fn overlaps_window(
        &self,
        from_m: f32,
        to_m: f32,
        hint_m: f32,
        behind_m: f32,
        ahead_m: f32,
    ) -> bool {
        let (lo, hi) = (hint_m - behind_m, hint_m + ahead_m);
        let meets = |shift: f32| from_m + shift <= hi && to_m + shift >= lo;
        meets(0.0) || (self.closed && (meets(self.length_m) || meets(-self.length_m)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn circle_samples() {
        let c = Path::circle(Point::new(0.0, 0.0), 1.25, 0.0, true).unwrap();
        assert!(close(c.length_m(), TAU * 1.25, 1e-5));
        let q = c.sample(0.25 * c.length_m());
        assert!(close(q.point.x_m, 0.0, 1e-5) && close(q.point.y_m, 1.25, 1e-5));
        assert!(close(q.heading_rad, PI, 1e-5) || close(q.heading_rad, -PI, 1e-5));
        assert!(close(q.curvature_per_m, 0.8, 1e-6));
        // Wraps past the end.
        let w = c.sample(c.length_m() + 0.1);
        let u = c.sample(0.1);
        assert!(close(w.point.x_m, u.point.x_m, 1e-4) && close(w.point.y_m, u.point.y_m, 1e-4));
        let cw = Path::circle(Point::new(0.0, 0.0), 2.0, 0.0, false).unwrap();
        assert!(close(cw.sample(0.0).heading_rad, -FRAC_PI_2, 1e-6));
        assert!(close(cw.sample(0.0).curvature_per_m, -0.5, 1e-6));
    }

    #[test]
    fn bad_paths_are_rejected() {
        let o = Point::new(0.0, 0.0);
        assert_eq!(
            Path::circle(o, 0.0, 0.0, true).unwrap_err(),
            PathError::NonPositiveSize
        );
        assert_eq!(
            Path::circle(o, f32::NAN, 0.0, true).unwrap_err(),
            PathError::NonFinite
        );
        assert_eq!(
            Path::line(o, 0.0, -1.0).unwrap_err(),
            PathError::NonPositiveSize
        );
        assert_eq!(
            Path::polyline(&[o], 0.1, false).unwrap_err(),
            PathError::TooFewPoints
        );
        assert_eq!(
            Path::polyline(&[o, o, Point::new(1.0, 0.0)], 0.1, false).unwrap_err(),
            PathError::DuplicatePoint
        );
        // A 0.5 m fillet cannot fit on 0.4 m edges.
        let tight = [o, Point::new(0.4, 0.0), Point::new(0.4, 0.4)];
        assert_eq!(
            Path::polyline(&tight, 0.5, false).unwrap_err(),
            PathError::CornerTooTight
        );
        // Turning straight back.
        let back = [o, Point::new(1.0, 0.0), Point::new(0.0, 0.0)];
        assert_eq!(
            Path::polyline(&back, 0.0, false).unwrap_err(),
            PathError::CornerTooTight
        );
    }

    #[test]
    fn rounded_square_is_continuous_with_expected_length() {
        let square = [
            Point::new(0.0, 0.0),
            Point::new(2.0, 0.0),
            Point::new(2.0, 2.0),
            Point::new(0.0, 2.0),
        ];
        let r = 0.3;
        let path = Path::polyline(&square, r, true).unwrap();
        assert_eq!(path.segments().len(), 8);
        // 4 sides of 2 m lose 2r each; 4 quarter circles add 2πr.
        let expected = 4.0 * (2.0 - 2.0 * r) + TAU * r;
        assert!(close(path.length_m(), expected, 1e-4));
        // Position and heading are continuous along the whole loop.
        let n = 2000;
        let mut prev = path.sample(0.0);
        for i in 1..=n {
            let s = path.length_m() * i as f32 / n as f32;
            let q = path.sample(s);
            let step = path.length_m() / n as f32;
            assert!(
                prev.point.distance_to(q.point) <= step * 1.01 + 1e-5,
                "jump at s = {s}"
            );
            assert!(math::abs(math::wrap_angle(q.heading_rad - prev.heading_rad)) < 0.05);
            prev = q;
        }
        assert!(prev.point.distance_to(path.sample(0.0).point) < 1e-4);
    }

    #[test]
    fn figure_eight_passes_through_center_twice() {
        let path = Path::figure_eight(Point::new(1.0, 1.0), 0.5).unwrap();
        assert!(close(path.length_m(), 2.0 * TAU * 0.5, 1e-5));
        for s in [0.0, 0.5 * path.length_m()] {
            let q = path.sample(s);
            assert!(q.point.distance_to(Point::new(1.0, 1.0)) < 1e-5);
            assert!(close(q.heading_rad, FRAC_PI_2, 1e-5));
        }
        assert!(path.sample(0.1).curvature_per_m < 0.0);
        assert!(path.sample(0.5 * path.length_m() + 0.1).curvature_per_m > 0.0);
    }

    #[test]
    fn projection_finds_the_nearest_point() {
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 10.0).unwrap();
        let inf = f32::INFINITY;
        assert!(close(
            line.project(Point::new(3.0, 0.7), 0.0, inf, inf),
            3.0,
            1e-5
        ));
        // A window limits how far the projection may jump.
        assert!(close(
            line.project(Point::new(3.0, 0.7), 0.0, 0.1, 0.5),
            0.5,
            1e-5
        ));
        let circle = Path::circle(Point::new(0.0, 0.0), 1.0, 0.0, true).unwrap();
        let s = circle.project(Point::new(0.0, 2.0), 0.0, inf, inf);
        assert!(close(circle.normalize_m(s), FRAC_PI_2, 1e-4));
        // Near the seam of a closed path the windowed search wraps.
        let s = circle.project(Point::new(1.0, -0.05), 0.02, 0.2, 0.5);
        assert!(close(s, -0.05, 2e-3), "s = {s}");
    }

    fn line(x: f32, y: f32, heading_rad: f32, length_m: f32) -> Segment {
        Segment::Line {
            start: Point::new(x, y),
            heading_rad,
            length_m,
        }
    }

    #[test]
    fn from_segments_rebuilds_every_kind_of_path() {
        let square = [
            Point::new(0.0, 0.0),
            Point::new(2.0, 0.0),
            Point::new(2.0, 2.0),
            Point::new(0.0, 2.0),
        ];
        let paths = [
            Path::polyline(&square, 0.3, true).unwrap(),
            Path::polyline(&square, 0.3, false).unwrap(),
            Path::figure_eight(Point::new(1.0, -1.0), 0.75).unwrap(),
            Path::circle(Point::new(3.0, 4.0), 1.25, -2.27, true).unwrap(),
            Path::circle(Point::new(0.0, 0.0), 0.5, 1.0, false).unwrap(),
            Path::line(Point::new(-1.0, 2.0), 0.3, 4.0).unwrap(),
        ];
        for original in &paths {
            let rebuilt = Path::from_segments(original.segments()).unwrap();
            assert_eq!(rebuilt.segments(), original.segments());
            assert_eq!(rebuilt.is_closed(), original.is_closed());
            assert_eq!(rebuilt.length_m(), original.length_m());
        }
    }

    #[test]
    fn from_segments_checks_counts_values_and_sizes() {
        assert_eq!(Path::from_segments(&[]).unwrap_err(), PathError::NoSegments);
        let chain: [Segment; MAX_SEGMENTS + 1] =
            core::array::from_fn(|i| line(i as f32, 0.0, 0.0, 1.0));
        assert!(Path::from_segments(&chain[..MAX_SEGMENTS]).is_ok());
        assert_eq!(
            Path::from_segments(&chain).unwrap_err(),
            PathError::TooManySegments
        );
        for bad in [
            line(f32::NAN, 0.0, 0.0, 1.0),
            line(0.0, 0.0, f32::INFINITY, 1.0),
            line(0.0, 0.0, 0.0, f32::NAN),
            Segment::Arc {
                center: Point::new(0.0, 0.0),
                radius_m: 1.0,
                start_angle_rad: 0.0,
                sweep_rad: f32::NAN,
            },
            Segment::Arc {
                center: Point::new(0.0, 0.0),
                radius_m: f32::MAX,
                start_angle_rad: 0.0,
                sweep_rad: 4.0,
            },
        ] {
            assert_eq!(
                Path::from_segments(&[bad]).unwrap_err(),
                PathError::NonFinite,
                "{bad:?}"
            );
        }
        for bad in [
            line(0.0, 0.0, 0.0, 0.0),
            line(0.0, 0.0, 0.0, -1.0),
            Segment::Arc {
                center: Point::new(0.0, 0.0),
                radius_m: -1.0,
                start_angle_rad: 0.0,
                sweep_rad: -1.0,
            },
            Segment::Arc {
                center: Point::new(0.0, 0.0),
                radius_m: 1.0,
                start_angle_rad: 0.0,
                sweep_rad: 0.0,
            },
        ] {
            assert_eq!(
                Path::from_segments(&[bad]).unwrap_err(),
                PathError::NonPositiveSize,
                "{bad:?}"
            );
        }
    }

    #[test]
    fn from_segments_checks_the_joints_within_the_stated_tolerances() {
        let first = line(0.0, 0.0, 0.0, 1.0);
        // Within tolerance: 0.5 mm off, 0.005 rad turned.
        let near = line(1.0, 0.0005, 0.005, 1.0);
        assert!(Path::from_segments(&[first, near]).is_ok());
        // 2 mm off.
        let second = line(1.0, 0.0, 0.0, 1.0);
        let gap = line(2.0, 0.002, 0.0, 1.0);
        assert_eq!(
            Path::from_segments(&[first, second, gap]).unwrap_err(),
            PathError::Gap { segment: 2 }
        );
        // Right place, turned 0.02 rad.
        let kink = line(1.0, 0.0, 0.02, 1.0);
        assert_eq!(
            Path::from_segments(&[first, kink]).unwrap_err(),
            PathError::Kink { segment: 1 }
        );
        // An arc joined to a line: leaving (1, 0) heading +x, turning left about (1, 1).
        let arc = Segment::Arc {
            center: Point::new(1.0, 1.0),
            radius_m: 1.0,
            start_angle_rad: -FRAC_PI_2,
            sweep_rad: FRAC_PI_2,
        };
        let path = Path::from_segments(&[first, arc]).unwrap();
        assert!(!path.is_closed());
        assert!(close(path.length_m(), 1.0 + FRAC_PI_2, 1e-6));
        // Turning right instead (clockwise about (1, −1)) joins smoothly too...
        let right = Segment::Arc {
            center: Point::new(1.0, -1.0),
            radius_m: 1.0,
            start_angle_rad: FRAC_PI_2,
            sweep_rad: -FRAC_PI_2,
        };
        assert!(Path::from_segments(&[first, right]).is_ok());
        // ...but the same circle counter-clockwise leaves (1, 0) heading −x: a reversal.
        let backwards = Segment::Arc {
            center: Point::new(1.0, -1.0),
            radius_m: 1.0,
            start_angle_rad: FRAC_PI_2,
            sweep_rad: FRAC_PI_2,
        };
        assert_eq!(
            Path::from_segments(&[first, backwards]).unwrap_err(),
            PathError::Kink { segment: 1 }
        );
    }

    #[test]
    fn closed_only_when_the_end_meets_the_start_in_its_direction() {
        // Out and back along a line pair with a U-turn arc: ends where it started but
        // heading the other way.
        let out = line(0.0, 0.0, 0.0, 1.0);
        let turn = Segment::Arc {
            center: Point::new(1.0, 0.5),
            radius_m: 0.5,
            start_angle_rad: -FRAC_PI_2,
            sweep_rad: PI,
        };
        let back = line(1.0, 1.0, PI, 1.0);
        let u = Path::from_segments(&[out, turn, back]).unwrap();
        assert!(!u.is_closed());
        // A second U-turn closes it.
        let home = Segment::Arc {
            center: Point::new(0.0, 0.5),
            radius_m: 0.5,
            start_angle_rad: FRAC_PI_2,
            sweep_rad: PI,
        };
        let stadium = Path::from_segments(&[out, turn, back, home]).unwrap();
        assert!(stadium.is_closed());
        assert!(close(stadium.length_m(), 2.0 + TAU * 0.5, 1e-5));
    }

    #[test]
    fn new_errors_read_well() {
        extern crate std;
        use std::string::ToString;
        assert_eq!(
            PathError::Gap { segment: 3 }.to_string(),
            "segment 3 does not start where segment 2 ends (gap > 0.001 m)"
        );
        assert_eq!(
            PathError::Kink { segment: 1 }.to_string(),
            "segment 1 does not start in the direction segment 0 ends (corner > 0.01 rad)"
        );
        assert_eq!(
            PathError::NoSegments.to_string(),
            "a path needs at least one segment"
        );
    }
}
