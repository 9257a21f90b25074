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

/// How much nearer (m) a later segment's point must be for [`Path::project`] to prefer
/// it: points as near as f32 rounding can tell (1 µm) go to the earlier segment, the one
/// the robot meets first.
const PROJECTION_TIE_M: f32 = 1e-6;

/// A set of a path's segments, bit i for segment i.
type SegmentSet = u32;
const _: () = assert!(MAX_SEGMENTS <= SegmentSet::BITS as usize);

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

    /// The segment's point closest to `p` (world frame): its arc length from the
    /// segment's start, m, and its distance from `p`, m. No trigonometry beyond the
    /// line's direction or the arc's polar angle of `p`: the distance comes from the
    /// same numbers (for an arc's inside point, |p − centre| − radius).
    fn closest(&self, p: Point) -> (f32, f32) {
        match *self {
            Segment::Line {
                start,
                heading_rad,
                length_m,
            } => {
                let (sin_h, cos_h) = math::sin_cos(heading_rad);
                let (dx, dy) = (p.x_m - start.x_m, p.y_m - start.y_m);
                let along = math::clamp(dx * cos_h + dy * sin_h, 0.0, length_m);
                (along, math::hypot(dx - along * cos_h, dy - along * sin_h))
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
                    (
                        travelled * radius_m,
                        math::abs(p.distance_to(center) - radius_m),
                    )
                } else {
                    let end = self.length_m();
                    let to_start = p.distance_to(self.sample(0.0).point);
                    let to_end = p.distance_to(self.sample(end).point);
                    if to_start <= to_end {
                        (0.0, to_start)
                    } else {
                        (end, to_end)
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

impl core::error::Error for PathError {}

/// A path: a chain of [`Segment`]s parameterised by arc length, open or closed.
#[derive(Debug)]
pub struct Path {
    segments: Vec<Segment, MAX_SEGMENTS>,
    /// Arc length at which each segment starts, m.
    starts_m: Vec<f32, MAX_SEGMENTS>,
    length_m: f32,
    closed: bool,
}

/// A path's length and closure, from [`Path::check_segments`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathShape {
    /// Total length, m.
    pub length_m: f32,
    /// The end joins the start.
    pub closed: bool,
}

impl Path {
    /// A 1 m line along +x from the origin (world frame): a valid path that costs no
    /// computation, for room a path is then built into in place
    /// ([`Path::rebuild_from_segments`]).
    pub const PLACEHOLDER: Path = Path {
        segments: Vec::from_array([Segment::Line {
            start: Point::new(0.0, 0.0),
            heading_rad: 0.0,
            length_m: 1.0,
        }]),
        starts_m: Vec::from_array([0.0]),
        length_m: 1.0,
        closed: false,
    };
}

impl Clone for Path {
    fn clone(&self) -> Self {
        Self {
            segments: self.segments.clone(),
            starts_m: self.starts_m.clone(),
            length_m: self.length_m,
            closed: self.closed,
        }
    }

    /// In place, element by element: no temporary path on the stack.
    fn clone_from(&mut self, source: &Self) {
        self.segments.clear();
        self.starts_m.clear();
        // Both vectors have the capacity of the source's: every push succeeds.
        for (segment, start_m) in source.segments.iter().zip(&source.starts_m) {
            let _ = self.segments.push(*segment);
            let _ = self.starts_m.push(*start_m);
        }
        self.length_m = source.length_m;
        self.closed = source.closed;
    }
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
        let mut path = Path::PLACEHOLDER;
        path.refill(segments, closed)?;
        Ok(path)
    }

    /// Empties the path and pushes `segments`; `closed` as given.
    fn refill(&mut self, segments: &[Segment], closed: bool) -> Result<(), PathError> {
        self.segments.clear();
        self.starts_m.clear();
        self.length_m = 0.0;
        self.closed = closed;
        for segment in segments {
            self.push(*segment)?;
        }
        Ok(())
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
        let shape = Self::check_segments(segments)?;
        Self::chain(segments, shape.closed)
    }

    /// What [`Path::from_segments`] would build from `segments`, without building it:
    /// the same checks and errors, and the path's length and closure. For a caller that
    /// must refuse a bad path before it gives up what it holds.
    pub fn check_segments(segments: &[Segment]) -> Result<PathShape, PathError> {
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
        // Summed in the order `push` sums them: the same length to the bit.
        let length_m = segments.iter().fold(0.0, |sum, s| sum + s.length_m());
        Ok(PathShape { length_m, closed })
    }

    /// Makes this path the one [`Path::from_segments`] builds from `segments`, in place
    /// (no path on the stack: for an interrupt's or a link task's small stack). On an
    /// error the path is unchanged.
    pub fn rebuild_from_segments(&mut self, segments: &[Segment]) -> Result<(), PathError> {
        let shape = Self::check_segments(segments)?;
        self.refill(segments, shape.closed)
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
    /// [0, length] ([`Path::normalize_m`]), from the segment that holds it (found by
    /// binary search: the cost does not grow with the path).
    pub fn sample_normalized(&self, s_m: f32) -> PathSample {
        match self.segment_at(self.segment_index(s_m)) {
            // Before the first segment (only for s < 0, which normalising excludes) the
            // segment clamps to its start.
            Some((segment, start)) => segment.sample(s_m - start),
            None => PathSample::default(),
        }
    }

    /// Segment `i` and the arc length at which it starts (m); None past the last.
    fn segment_at(&self, i: usize) -> Option<(&Segment, f32)> {
        self.segments.get(i).zip(self.starts_m.get(i).copied())
    }

    /// Index of the segment that holds arc length `s_m` (m): the last that starts at or
    /// before it (the first for s < 0, the last for NaN). A binary search over the
    /// segments' starts, which never decrease: log₂ [`MAX_SEGMENTS`] steps at most, so
    /// the control step's cost does not grow with the path.
    fn segment_index(&self, s_m: f32) -> usize {
        // "Not before `start`", which a NaN is too: one comparison per step of the search.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let not_before = |start: &f32| !(s_m < *start);
        // The first segment starts at 0: the search is over the others' starts, and the
        // count of those not after s is the index.
        self.starts_m
            .get(1..)
            .map_or(0, |others| others.partition_point(not_before))
    }

    /// Arc length (m) of the point of the path closest to `p`, looked for within
    /// [`hint_m` − `behind_m`, `hint_m` + `ahead_m`] of arc length (wrapping on a closed
    /// path). Pass infinite bounds for a global search. The result is not normalised.
    /// Of points as near as rounding can tell apart (within 1 µm), the earlier segment's.
    pub fn project(&self, p: Point, hint_m: f32, behind_m: f32, ahead_m: f32) -> f32 {
        let mut best_s = hint_m;
        let mut best_d = f32::INFINITY;
        let mut near = self.segments_near(hint_m, behind_m, ahead_m);
        // In the segments' order, as a scan of the whole path would visit them, so a tie
        // goes to the same segment.
        while near != 0 {
            let i = near.trailing_zeros() as usize;
            near &= near - 1;
            let Some((segment, start)) = self.segment_at(i) else {
                break;
            };
            let (s, d) = self.candidate(segment, start, p, hint_m, behind_m, ahead_m);
            if d < best_d - PROJECTION_TIE_M {
                best_d = d;
                best_s = s;
            }
        }
        best_s
    }

    /// What `segment` (starting at arc length `start_m`) offers [`Path::project`] for `p`:
    /// the arc length (m) of its point closest to `p`, brought into the search window,
    /// and that point's distance from `p` (m). Inside the window the point is the
    /// segment's own closest point; beyond it, the path's point at the window's edge.
    fn candidate(
        &self,
        segment: &Segment,
        start_m: f32,
        p: Point,
        hint_m: f32,
        behind_m: f32,
        ahead_m: f32,
    ) -> (f32, f32) {
        let (along_m, distance_m) = segment.closest(p);
        let mut offset = start_m + along_m - hint_m;
        if self.closed && behind_m.is_finite() {
            // Into [−L/2, L/2].
            offset = self.normalize_m(offset + 0.5 * self.length_m) - 0.5 * self.length_m;
        }
        let in_window = math::clamp(offset, -behind_m, ahead_m);
        let s = hint_m + in_window;
        if in_window == offset {
            (s, distance_m)
        } else {
            (s, p.distance_to(self.sample(s).point))
        }
    }

    /// The segments that meet the search window around `hint_m` ([`Path::project`]), as
    /// a set of indices (bit i for segment i). Found by walking from the segment that
    /// holds the window's start ([`Path::segment_index`]) until the segments leave the
    /// window: the few segments near the robot cost, not the whole path (a window that
    /// holds the whole path, as the global search's, visits every segment).
    fn segments_near(&self, hint_m: f32, behind_m: f32, ahead_m: f32) -> SegmentSet {
        let n = self.segments.len();
        let first = self.segment_index(self.normalize_m(hint_m - behind_m));
        // One before: a segment that ends exactly at the window's start meets it too.
        let from = if self.closed {
            (first + n - 1) % n.max(1)
        } else {
            first.saturating_sub(1)
        };
        let mut near: SegmentSet = 0;
        for step in 0..n {
            let i = from + step;
            let i = if i >= n && self.closed { i - n } else { i };
            let Some((segment, start)) = self.segment_at(i) else {
                break;
            };
            if self.overlaps_window(start, start + segment.length_m(), hint_m, behind_m, ahead_m) {
                near |= 1 << i;
            } else if near != 0 {
                // The segments that meet a window are consecutive (modulo a lap): past
                // the last of them, none follows.
                break;
            }
        }
        near
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
pub(crate) mod tests;
