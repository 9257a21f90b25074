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
        // A zero radius gives a zero length, refused just below, so `>=` here is an
        // equivalent mutant (.cargo/mutants.toml).
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
        // Tolerance boundaries: `>=` for either `>` differs only when a distance or an
        // angle equals its tolerance exactly (equivalent mutants, .cargo/mutants.toml).
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
            // Equivalent mutant (`>` → `>=`, .cargo/mutants.toml): it differs only for a
            // turn of exactly π − 10⁻³ rad in f32, a tolerance whose own side is arbitrary.
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
            // Equivalent mutants (`<` → `<=` here, `>` → `>=` on the next test and on the
            // arc's 1e-6 below, .cargo/mutants.toml): each differs only when the value is
            // exactly the 1 µm (or 1 µrad) tolerance in f32, and then by a 1 µm segment.
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
                // Centre on the inside of the turn, one radius from the entry point. (`>` →
                // `>=` is an equivalent mutant, .cargo/mutants.toml: |turn| > 1e-6 here.)
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
            // Into [−L/2, L/2]. (`+` → `-` inside is an equivalent mutant,
            // .cargo/mutants.toml: ±L/2 are the same residue modulo the lap L.)
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
        // Equivalent mutants (`from_m + shift` → `-` or `*`, `to_m + shift` → `-`,
        // .cargo/mutants.toml): they only let more segments through (ones wholly before the
        // window, or a closed path's shifted by a lap), never fewer while the window meets
        // the path. This is a cost filter: an extra segment's candidate is clamped to an
        // edge of the window, a point the segments inside the window already offer, so the
        // projection is unchanged; only its cost grows.
        let meets = |shift: f32| from_m + shift <= hi && to_m + shift >= lo;
        meets(0.0) || (self.closed && (meets(self.length_m) || meets(-self.length_m)))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The corners of a 2 m square from the origin, counter-clockwise (world frame, m).
    pub(crate) const SQUARE_2M: [Point; 4] = [
        Point::new(0.0, 0.0),
        Point::new(2.0, 0.0),
        Point::new(2.0, 2.0),
        Point::new(0.0, 2.0),
    ];

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    /// Arc length of `segment`'s point closest to `p`, after checking the distance
    /// [`Segment::closest`] gives with it against the point that length samples.
    fn closest_m(segment: &Segment, p: Point) -> f32 {
        let (along_m, distance_m) = segment.closest(p);
        let sampled = p.distance_to(segment.sample(along_m).point);
        assert!(
            close(distance_m, sampled, 1e-5),
            "{segment:?} from {p:?}: {distance_m} m, but {sampled} m to the point at {along_m} m"
        );
        along_m
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
        let square = SQUARE_2M;
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
        let square = SQUARE_2M;
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
            // Every field of an arc on its own, including those its length does not
            // depend on (the centre and the start angle).
            Segment::Arc {
                center: Point::new(f32::NAN, 0.0),
                radius_m: 1.0,
                start_angle_rad: 0.0,
                sweep_rad: 1.0,
            },
            Segment::Arc {
                center: Point::new(0.0, f32::INFINITY),
                radius_m: 1.0,
                start_angle_rad: 0.0,
                sweep_rad: 1.0,
            },
            Segment::Arc {
                center: Point::new(0.0, 0.0),
                radius_m: f32::NAN,
                start_angle_rad: 0.0,
                sweep_rad: 1.0,
            },
            Segment::Arc {
                center: Point::new(0.0, 0.0),
                radius_m: 1.0,
                start_angle_rad: f32::NAN,
                sweep_rad: 1.0,
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

    fn close_points(a: Point, b: Point, tol: f32) -> bool {
        a.distance_to(b) <= tol
    }

    /// The point `along_m` ahead of and `left_m` to the left of `start` on heading `h`.
    fn offset(start: Point, h: f32, along_m: f32, left_m: f32) -> Point {
        let (s, c) = (h.sin(), h.cos());
        Point::new(
            start.x_m + along_m * c - left_m * s,
            start.y_m + along_m * s + left_m * c,
        )
    }

    /// The point at polar angle `angle` and distance `radius_m` from `center`.
    fn polar(center: Point, radius_m: f32, angle: f32) -> Point {
        Point::new(
            center.x_m + radius_m * angle.cos(),
            center.y_m + radius_m * angle.sin(),
        )
    }

    #[test]
    fn projection_onto_a_line_runs_along_its_heading_and_stops_at_its_ends() {
        // From (1, 2) heading 3π/4 (up and to the left) for 2 m: both components of the
        // heading matter.
        let start = Point::new(1.0, 2.0);
        let h = 3.0 * core::f32::consts::FRAC_PI_4;
        let line = Segment::Line {
            start,
            heading_rad: h,
            length_m: 2.0,
        };
        for left in [-0.3, 0.0, 0.3] {
            assert!(close(
                closest_m(&line, offset(start, h, 0.8, left)),
                0.8,
                1e-5
            ));
            assert!(close(
                closest_m(&line, offset(start, h, 1.9, left)),
                1.9,
                1e-5
            ));
            // Before the start and past the end: the nearer end.
            assert_eq!(closest_m(&line, offset(start, h, -0.5, left)), 0.0);
            assert_eq!(closest_m(&line, offset(start, h, 2.7, left)), 2.0);
        }
    }

    #[test]
    fn projection_onto_a_counter_clockwise_arc_from_inside_outside_and_past_its_ends() {
        // Radius 2 about (1, −1), from polar angle 0.5 sweeping +2.0 rad: 4 m long.
        let center = Point::new(1.0, -1.0);
        let arc = Segment::Arc {
            center,
            radius_m: 2.0,
            start_angle_rad: 0.5,
            sweep_rad: 2.0,
        };
        assert!(close(arc.length_m(), 4.0, 1e-6));
        // Inside and outside the arc: the arc length to the point's polar angle.
        assert!(close(closest_m(&arc, polar(center, 1.0, 1.2)), 1.4, 1e-5));
        assert!(close(closest_m(&arc, polar(center, 3.5, 2.0)), 3.0, 1e-5));
        assert!(close(closest_m(&arc, polar(center, 0.2, 0.6)), 0.2, 1e-4));
        // Past the end (0.4 rad beyond it) and before the start (0.3 rad before it).
        assert_eq!(closest_m(&arc, polar(center, 2.0, 2.9)), 4.0);
        assert_eq!(closest_m(&arc, polar(center, 2.5, 0.2)), 0.0);
        // Behind the centre, outside the sweep: whichever end is nearer.
        assert_eq!(closest_m(&arc, polar(center, 2.0, -1.3)), 0.0);
        assert_eq!(closest_m(&arc, polar(center, 2.0, 4.2)), 4.0);
        // The sampled point really is the nearest of the arc's points.
        for angle in [-2.0f32, -0.4, 0.3, 0.9, 1.7, 2.4, 3.1, 4.0] {
            for radius in [0.5f32, 2.0, 3.0] {
                let p = polar(center, radius, angle);
                let best = arc.sample(closest_m(&arc, p)).point.distance_to(p);
                for i in 0..=400 {
                    let q = arc.sample(4.0 * i as f32 / 400.0).point;
                    assert!(best <= q.distance_to(p) + 1e-5, "p = {p:?}");
                }
            }
        }
    }

    #[test]
    fn projection_onto_a_clockwise_arc_from_inside_outside_and_past_its_ends() {
        // Radius 1.5 about the origin, from polar angle 1.0 sweeping −2.5 rad to −1.5.
        let center = Point::new(0.0, 0.0);
        let arc = Segment::Arc {
            center,
            radius_m: 1.5,
            start_angle_rad: 1.0,
            sweep_rad: -2.5,
        };
        assert!(close(closest_m(&arc, polar(center, 0.5, 0.0)), 1.5, 1e-5));
        assert!(close(closest_m(&arc, polar(center, 2.0, -1.0)), 3.0, 1e-5));
        assert_eq!(closest_m(&arc, polar(center, 1.5, -1.8)), 3.75);
        assert_eq!(closest_m(&arc, polar(center, 1.5, 1.3)), 0.0);
    }

    #[test]
    fn projection_onto_an_arc_across_the_polar_angle_seam() {
        // From polar angle 3.0 counter-clockwise through ±π to 4.0 (≡ −2.28), radius 1.
        let center = Point::new(-2.0, 0.5);
        let arc = Segment::Arc {
            center,
            radius_m: 1.0,
            start_angle_rad: 3.0,
            sweep_rad: 1.0,
        };
        assert!(close(
            closest_m(&arc, polar(center, 1.2, -2.9)),
            TAU - 5.9,
            1e-5
        ));
        assert!(close(closest_m(&arc, polar(center, 0.8, 3.1)), 0.1, 1e-5));
        // Just before the start: the start, not most of a turn further on.
        assert_eq!(closest_m(&arc, polar(center, 1.0, 2.9)), 0.0);
    }

    #[test]
    fn projection_on_a_path_picks_the_nearer_leg() {
        // A U: along +x for 2 m, up 1 m, back along −x (sharp corners).
        let u = Path::polyline(
            &[
                Point::new(0.0, 0.0),
                Point::new(2.0, 0.0),
                Point::new(2.0, 1.0),
                Point::new(0.0, 1.0),
            ],
            0.0,
            false,
        )
        .unwrap();
        let inf = f32::INFINITY;
        assert!(close(
            u.project(Point::new(0.5, 0.4), 0.0, inf, inf),
            0.5,
            1e-5
        ));
        assert!(close(
            u.project(Point::new(0.5, 0.6), 0.0, inf, inf),
            4.5,
            1e-5
        ));
        assert!(close(
            u.project(Point::new(2.3, 0.5), 0.0, inf, inf),
            2.5,
            1e-5
        ));
        // Past the end of an open path: its end.
        assert!(close(
            u.project(Point::new(-1.0, 1.2), 0.0, inf, inf),
            5.0,
            1e-5
        ));
        // A window around the start cannot reach the top leg.
        assert!(close(
            u.project(Point::new(0.5, 0.6), 0.0, 0.5, 1.0),
            0.5,
            1e-5
        ));
    }

    #[test]
    fn a_segment_whose_nearest_point_is_outside_the_window_offers_the_window_edge() {
        // An L: 1 m along +x, then 1 m along +y. The window [0.9, 2.9] m starts near the
        // end of the first leg. (0.3, 0.45) is 0.45 m from the first leg, but at 0.3 m,
        // outside the window: that leg offers its point at the window's edge, (0.9, 0),
        // 0.75 m away, and the second leg's (1, 0.45), 0.7 m away, wins.
        let l = Path::polyline(
            &[
                Point::new(0.0, 0.0),
                Point::new(1.0, 0.0),
                Point::new(1.0, 1.0),
            ],
            0.0,
            false,
        )
        .unwrap();
        let s = l.project(Point::new(0.3, 0.45), 0.9, 0.0, 2.0);
        assert!(close(s, 1.45, 1e-6), "{s}");
        // Nearer the first leg's edge point, that point wins.
        let s = l.project(Point::new(0.8, 0.1), 0.9, 0.0, 2.0);
        assert!(close(s, 0.9, 1e-6), "{s}");
    }

    #[test]
    fn a_point_as_near_two_legs_projects_onto_the_earlier_one() {
        // An L: 2 m along +x, then 2 m along +y. (1.5, 0.5) is 0.5 m from both legs.
        let l = Path::polyline(
            &[
                Point::new(0.0, 0.0),
                Point::new(2.0, 0.0),
                Point::new(2.0, 2.0),
            ],
            0.0,
            false,
        )
        .unwrap();
        let inf = f32::INFINITY;
        assert_eq!(l.project(Point::new(1.5, 0.5), 0.0, inf, inf), 1.5);
        // Off the bisector the nearer leg wins either way.
        assert!(close(
            l.project(Point::new(1.5, 0.4), 0.0, inf, inf),
            1.5,
            1e-6
        ));
        assert!(close(
            l.project(Point::new(1.6, 0.5), 0.0, inf, inf),
            2.5,
            1e-6
        ));
    }

    #[test]
    fn a_window_that_misses_an_open_path_leaves_the_projection_at_its_hint() {
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 10.0).unwrap();
        let p = Point::new(9.0, 0.5);
        assert_eq!(line.project(p, 15.0, 1.0, 1.0), 15.0);
        assert_eq!(line.project(p, -5.0, 1.0, 1.0), -5.0);
        // A window that reaches the path finds the nearest point within it.
        assert!(close(line.project(p, 10.5, 1.0, 1.0), 9.5, 1e-5));
        assert!(close(
            line.project(Point::new(1.0, 0.5), -0.5, 1.0, 1.0),
            0.5,
            1e-5
        ));
    }

    #[test]
    fn windowed_projection_on_a_closed_path_continues_across_the_seam() {
        let square = SQUARE_2M;
        let path = Path::polyline(&square, 0.3, true).unwrap();
        let length = path.length_m();
        // Hint just before the end of the lap, robot just after the start: the result is
        // a little more than one lap (not normalised), not a jump back by a whole lap.
        let p = path.sample(0.1).point;
        let s = path.project(p, length - 0.05, 0.2, 0.5);
        assert!(close(s, length + 0.1, 1e-4), "s = {s}, length = {length}");
        // And the other way round.
        let p = path.sample(length - 0.1).point;
        let s = path.project(p, 0.05, 0.2, 0.5);
        assert!(close(s, -0.1, 1e-4), "s = {s}");
        // Far from the seam the window stays where it is.
        let p = path.sample(3.0).point;
        assert!(close(path.project(p, 2.9, 0.2, 0.5), 3.0, 1e-4));
        // A global search on every segment finds the sample's own arc length.
        for i in 0..200 {
            let s = length * (i as f32 + 0.5) / 200.0;
            let q = path.sample(s);
            // 5 cm off the path, to its left (inside the square).
            let p = offset(q.point, q.heading_rad, 0.0, 0.05);
            let found = path.project(p, 0.0, f32::INFINITY, f32::INFINITY);
            assert!(
                close(path.normalize_m(found), s, 2e-3),
                "s = {s}, found {found}"
            );
        }
    }

    #[test]
    fn a_window_that_touches_an_end_of_an_open_path_finds_that_end() {
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 10.0).unwrap();
        let p = Point::new(5.0, 1.0);
        // [−2, 0] touches the start, [10, 12] the end.
        assert_eq!(line.project(p, -1.0, 1.0, 1.0), 0.0);
        assert_eq!(line.project(p, 11.0, 1.0, 1.0), 10.0);
    }

    #[test]
    fn a_finite_window_wider_than_an_open_path_finds_what_a_global_search_does() {
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 10.0).unwrap();
        for x in [0.5f32, 3.0, 8.0, 9.5] {
            let p = Point::new(x, -0.4);
            assert!(close(line.project(p, 0.0, 100.0, 100.0), x, 1e-5));
            assert!(close(line.project(p, 10.0, 100.0, 100.0), x, 1e-5));
        }
    }

    #[test]
    fn a_window_past_either_end_of_a_closed_path_wraps_onto_it() {
        let path = Path::figure_eight(Point::new(0.0, 0.0), 1.0).unwrap();
        let length = path.length_m();
        // The window [L + 0.25, L + 0.65] lies wholly in the second lap.
        let p = path.sample(0.5).point;
        assert!(close(
            path.project(p, length + 0.45, 0.2, 0.2),
            length + 0.5,
            1e-4
        ));
        // And [−0.65, −0.25] wholly before the first.
        let p = path.sample(length - 0.5).point;
        assert!(close(path.project(p, -0.45, 0.2, 0.2), -0.5, 1e-4));
    }

    #[test]
    fn a_global_search_does_not_depend_on_the_hint() {
        let path = Path::circle(Point::new(0.0, 0.0), 1.0, 0.0, true).unwrap();
        let inf = f32::INFINITY;
        // The point at three quarters of the lap.
        let p = Point::new(0.0, -1.5);
        for hint in [0.0, 1.0, 5.0, -3.0, 40.0] {
            let s = path.project(p, hint, inf, inf);
            assert!(close(s, 0.75 * path.length_m(), 1e-4), "hint {hint}: {s}");
        }
        // A closed path's start, which is also its end, projects to 0 (as normalize_m
        // writes it), not to one lap, in either direction of travel.
        for ccw in [true, false] {
            let circle = Path::circle(Point::new(0.0, 0.0), 1.0, 0.0, ccw).unwrap();
            assert_eq!(circle.project(Point::new(1.5, 0.0), 2.0, inf, inf), 0.0);
            assert_eq!(circle.normalize_m(circle.length_m()), 0.0);
        }
    }

    #[test]
    fn normalize_wraps_a_closed_path_and_clamps_an_open_one() {
        let circle = Path::circle(Point::new(0.0, 0.0), 1.0, 0.0, true).unwrap();
        let l = circle.length_m();
        // Arc lengths already within a lap are left alone, 0 included.
        for s in [0.0, 0.1, 1.0, 0.5 * l, l - 0.01] {
            assert_eq!(circle.normalize_m(s), s);
        }
        for (s, expected) in [
            (l + 0.2, 0.2),
            (3.0 * l + 0.3, 0.3),
            (-0.1, l - 0.1),
            (-2.0 * l - 0.3, l - 0.3),
        ] {
            let n = circle.normalize_m(s);
            assert!(close(n, expected, 1e-4), "{s} -> {n}, expected {expected}");
        }
        let line = Path::line(Point::new(0.0, 0.0), 0.0, 3.0).unwrap();
        assert_eq!(line.normalize_m(-1.0), 0.0);
        assert_eq!(line.normalize_m(1.5), 1.5);
        assert_eq!(line.normalize_m(4.0), 3.0);
    }

    #[test]
    fn a_sample_at_a_joint_belongs_to_the_segment_that_starts_there() {
        let eight = Path::figure_eight(Point::new(0.0, 0.0), 0.5).unwrap();
        // The left lobe starts at half the length: counter-clockwise, +1/r.
        assert!(close(
            eight.sample(0.5 * eight.length_m()).curvature_per_m,
            2.0,
            1e-6
        ));
        assert!(close(eight.sample(0.0).curvature_per_m, -2.0, 1e-6));
        // A rounded polyline's first fillet starts where its first line ends.
        let path = Path::polyline(
            &[
                Point::new(0.0, 0.0),
                Point::new(2.0, 0.0),
                Point::new(2.0, 2.0),
            ],
            0.5,
            false,
        )
        .unwrap();
        assert!(close(path.sample(1.5).curvature_per_m, 2.0, 1e-6));
        assert_eq!(path.sample(1.4).curvature_per_m, 0.0);
    }

    #[test]
    fn figure_eight_lobes_lie_either_side_of_the_centre() {
        let c = Point::new(1.0, -2.0);
        let r = 0.5;
        let eight = Path::figure_eight(c, r).unwrap();
        assert!(eight.is_closed());
        let quarter = 0.5 * core::f32::consts::PI * r;
        // A quarter of the way round the right lobe (clockwise): its top.
        let q = eight.sample(quarter);
        assert!(close_points(
            q.point,
            Point::new(c.x_m + r, c.y_m + r),
            1e-5
        ));
        assert!(close(q.heading_rad, 0.0, 1e-5));
        // Halfway round the right lobe: its far side, heading −y.
        let q = eight.sample(2.0 * quarter);
        assert!(close_points(
            q.point,
            Point::new(c.x_m + 2.0 * r, c.y_m),
            1e-5
        ));
        assert!(close(q.heading_rad, -FRAC_PI_2, 1e-5));
        // A quarter of the way round the left lobe (counter-clockwise): its top.
        let q = eight.sample(5.0 * quarter);
        assert!(close_points(
            q.point,
            Point::new(c.x_m - r, c.y_m + r),
            1e-5
        ));
        assert!(close(q.heading_rad, PI, 1e-5) || close(q.heading_rad, -PI, 1e-5));
        let q = eight.sample(6.0 * quarter);
        assert!(close_points(
            q.point,
            Point::new(c.x_m - 2.0 * r, c.y_m),
            1e-5
        ));
    }

    #[test]
    fn simple_paths_refuse_each_bad_argument() {
        let o = Point::new(0.0, 0.0);
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let x_bad = Point::new(bad, 0.0);
            let y_bad = Point::new(0.0, bad);
            for p in [x_bad, y_bad] {
                assert_eq!(Path::line(p, 0.0, 1.0).unwrap_err(), PathError::NonFinite);
                assert_eq!(
                    Path::circle(p, 1.0, 0.0, true).unwrap_err(),
                    PathError::NonFinite
                );
                assert_eq!(
                    Path::figure_eight(p, 1.0).unwrap_err(),
                    PathError::NonFinite
                );
            }
            assert_eq!(Path::line(o, bad, 1.0).unwrap_err(), PathError::NonFinite);
            assert_eq!(Path::line(o, 0.0, bad).unwrap_err(), PathError::NonFinite);
            assert_eq!(
                Path::circle(o, 1.0, bad, true).unwrap_err(),
                PathError::NonFinite
            );
            assert_eq!(
                Path::circle(o, bad, 0.0, false).unwrap_err(),
                PathError::NonFinite
            );
            assert_eq!(
                Path::figure_eight(o, bad).unwrap_err(),
                PathError::NonFinite
            );
        }
        for size in [0.0, -0.5] {
            assert_eq!(
                Path::line(o, 0.0, size).unwrap_err(),
                PathError::NonPositiveSize
            );
            assert_eq!(
                Path::circle(o, size, 0.0, true).unwrap_err(),
                PathError::NonPositiveSize
            );
            assert_eq!(
                Path::figure_eight(o, size).unwrap_err(),
                PathError::NonPositiveSize
            );
        }
        // The smallest valid sizes are accepted.
        let line = Path::line(Point::new(1.0, 2.0), 4.0, 1e-3).unwrap();
        assert!(!line.is_closed());
        assert_eq!(line.length_m(), 1e-3);
        // The heading is stored wrapped.
        assert!(close(line.sample(0.0).heading_rad, 4.0 - TAU, 1e-6));
        assert!(Path::circle(o, 1e-3, 0.0, true).unwrap().is_closed());
        assert!(Path::figure_eight(o, 1e-3).is_ok());
    }

    #[test]
    fn polylines_refuse_bad_waypoints_and_radii() {
        let o = Point::new(0.0, 0.0);
        let a = Point::new(1.0, 0.0);
        let b = Point::new(1.0, 1.0);
        assert_eq!(
            Path::polyline(&[], 0.1, false).unwrap_err(),
            PathError::TooFewPoints
        );
        assert_eq!(
            Path::polyline(&[o, a], 0.1, true).unwrap_err(),
            PathError::TooFewPoints
        );
        for bad in [f32::NAN, f32::INFINITY] {
            for p in [Point::new(bad, 1.0), Point::new(1.0, bad)] {
                assert_eq!(
                    Path::polyline(&[o, a, p], 0.1, false).unwrap_err(),
                    PathError::NonFinite
                );
            }
            assert_eq!(
                Path::polyline(&[o, a, b], bad, false).unwrap_err(),
                PathError::NonFinite
            );
        }
        assert_eq!(
            Path::polyline(&[o, a, b], -0.1, false).unwrap_err(),
            PathError::NonPositiveSize
        );
        // A closed polyline whose last waypoint repeats the first.
        assert_eq!(
            Path::polyline(&[o, a, b, o], 0.1, true).unwrap_err(),
            PathError::DuplicatePoint
        );
        assert_eq!(
            Path::polyline(&[o, a, a, b], 0.0, false).unwrap_err(),
            PathError::DuplicatePoint
        );
        // Turning back on itself, sharp or rounded, and on the closing corner.
        let back = [o, Point::new(2.0, 0.0), Point::new(1.0, 0.0)];
        assert_eq!(
            Path::polyline(&back, 0.1, false).unwrap_err(),
            PathError::CornerTooTight
        );
        let spike = [
            o,
            Point::new(2.0, 0.0),
            Point::new(2.0, 1.0),
            Point::new(4.0, 0.0),
        ];
        assert!(Path::polyline(&spike, 0.0, false).is_ok());
        assert_eq!(
            Path::polyline(&[o, Point::new(2.0, 0.0), Point::new(1.0, 0.0)], 0.0, true)
                .unwrap_err(),
            PathError::CornerTooTight
        );
        // A fillet too big for the edge after it (the turn at (2, 0) needs 1 m each side).
        let short = [o, Point::new(2.0, 0.0), Point::new(2.0, 0.9)];
        assert_eq!(
            Path::polyline(&short, 1.0, false).unwrap_err(),
            PathError::CornerTooTight
        );
        // Two fillets that each fit but not together on the edge between them.
        let z = [
            o,
            Point::new(1.0, 0.0),
            Point::new(1.0, 1.5),
            Point::new(2.0, 1.5),
        ];
        assert!(Path::polyline(&z, 0.7, false).is_ok());
        assert_eq!(
            Path::polyline(&z, 0.8, false).unwrap_err(),
            PathError::CornerTooTight
        );
    }

    #[test]
    fn polylines_accept_the_smallest_valid_inputs() {
        let o = Point::new(0.0, 0.0);
        let a = Point::new(1.0, 0.0);
        // Two waypoints: one straight line, whatever the radius.
        let two = Path::polyline(&[o, a], 0.5, false).unwrap();
        assert_eq!(two.segments().len(), 1);
        assert!(close(two.length_m(), 1.0, 1e-6));
        // Three waypoints close into a triangle.
        let triangle = Path::polyline(&[o, a, Point::new(0.0, 1.0)], 0.0, true).unwrap();
        assert_eq!(triangle.segments().len(), 3);
        assert!(close(triangle.length_m(), 2.0 + 2f32.sqrt(), 1e-5));
        // A sharp but not reversed corner (179.4°) is accepted with a zero radius.
        let (s, c) = (PI - 0.01).sin_cos();
        let sharp = [o, a, Point::new(1.0 + c, s)];
        assert!(Path::polyline(&sharp, 0.0, false).is_ok());
        // Waypoints 1 mm apart are distinct.
        assert!(Path::polyline(&[o, Point::new(1e-3, 0.0)], 0.0, false).is_ok());
    }

    #[test]
    fn polyline_size_limits() {
        let zigzag = |n: usize| -> heapless::Vec<Point, 40> {
            (0..n)
                .map(|i| Point::new(i as f32, if i % 2 == 0 { 0.0 } else { 1.0 }))
                .collect()
        };
        // Sharp corners: one line per edge, up to MAX_SEGMENTS waypoints.
        let p = Path::polyline(&zigzag(MAX_SEGMENTS), 0.0, false).unwrap();
        assert_eq!(p.segments().len(), MAX_SEGMENTS - 1);
        assert_eq!(
            Path::polyline(&zigzag(MAX_SEGMENTS + 1), 0.0, false).unwrap_err(),
            PathError::TooManySegments
        );
        // Rounded and closed: two segments per waypoint.
        let ring = |n: usize| -> heapless::Vec<Point, 40> {
            (0..n)
                .map(|i| {
                    let a = TAU * i as f32 / n as f32;
                    Point::new(3.0 * a.cos(), 3.0 * a.sin())
                })
                .collect()
        };
        let p = Path::polyline(&ring(MAX_SEGMENTS / 2), 0.1, true).unwrap();
        assert_eq!(p.segments().len(), MAX_SEGMENTS);
        assert_eq!(
            Path::polyline(&ring(MAX_SEGMENTS / 2 + 1), 0.1, true).unwrap_err(),
            PathError::TooManySegments
        );
    }

    /// Asserts that `path` is continuous in position and heading, and that every sample's
    /// curvature is 0 or ±1/`radius_m`.
    fn assert_smooth(path: &Path, radius_m: f32) {
        let n = 4000;
        let step = path.length_m() / n as f32;
        let mut prev = path.sample(0.0);
        for i in 1..=n {
            let s = path.length_m() * i as f32 / n as f32;
            let q = path.sample(s);
            assert!(
                prev.point.distance_to(q.point) <= step * 1.01 + 1e-5,
                "jump at s = {s}"
            );
            assert!(
                math::abs(math::wrap_angle(q.heading_rad - prev.heading_rad))
                    <= step / radius_m * 1.01 + 1e-4,
                "heading jump at s = {s}"
            );
            let k = q.curvature_per_m;
            assert!(k == 0.0 || close(k.abs(), 1.0 / radius_m, 1e-4), "κ = {k}");
            prev = q;
        }
    }

    #[test]
    fn rounded_polyline_turning_both_ways_has_tangent_fillets() {
        // Left at (2, 0) by atan2(1.5, 1), right at (3, 1.5), right again at (5, 1.5).
        let w = [
            Point::new(0.0, 0.0),
            Point::new(2.0, 0.0),
            Point::new(3.0, 1.5),
            Point::new(5.0, 1.5),
            Point::new(5.5, -1.0),
        ];
        let r = 0.3;
        let path = Path::polyline(&w, r, false).unwrap();
        assert!(!path.is_closed());
        assert_smooth(&path, r);
        // Starts on the first waypoint heading along the first edge, ends on the last one
        // heading along the last edge.
        let first = path.sample(0.0);
        assert!(close_points(first.point, w[0], 1e-6));
        assert!(close(first.heading_rad, 0.0, 1e-6));
        let last = path.sample(path.length_m());
        assert!(close_points(last.point, w[4], 1e-4));
        assert!(close(last.heading_rad, math::atan2(-2.5, 0.5), 1e-5));
        // Each corner: turn angle τ, fillet cuts r·tan(|τ|/2) off both edges, adds r|τ|,
        // and passes r/cos(τ/2) − r from the waypoint, curving towards the turn.
        let mut expected = 0.0;
        for i in 0..4 {
            expected += w[i].distance_to(w[i + 1]);
        }
        for i in 1..4 {
            let incoming = math::atan2(w[i].y_m - w[i - 1].y_m, w[i].x_m - w[i - 1].x_m);
            let outgoing = math::atan2(w[i + 1].y_m - w[i].y_m, w[i + 1].x_m - w[i].x_m);
            let turn = math::wrap_angle(outgoing - incoming);
            let half = 0.5 * turn.abs();
            expected += r * turn.abs() - 2.0 * r * half.tan();
            let s = path.project(w[i], 0.0, f32::INFINITY, f32::INFINITY);
            let q = path.sample(s);
            assert!(close(q.point.distance_to(w[i]), r / half.cos() - r, 1e-4));
            assert!(
                close(q.curvature_per_m, turn.signum() / r, 1e-4),
                "corner {i}"
            );
        }
        assert!(close(path.length_m(), expected, 1e-4));
        // Three line segments' worth of corners: 4 lines and 3 arcs.
        assert_eq!(path.segments().len(), 7);
    }

    #[test]
    fn clockwise_closed_polyline_starts_after_its_first_fillet() {
        // The square of the existing test, travelled clockwise: every turn is right.
        let w = [
            Point::new(0.0, 0.0),
            Point::new(0.0, 2.0),
            Point::new(2.0, 2.0),
            Point::new(2.0, 0.0),
        ];
        let r = 0.4;
        let path = Path::polyline(&w, r, true).unwrap();
        assert!(path.is_closed());
        assert_smooth(&path, r);
        let start = path.sample(0.0);
        assert!(close_points(start.point, Point::new(0.0, r), 1e-5));
        assert!(close(start.heading_rad, FRAC_PI_2, 1e-5));
        assert!(close(
            path.length_m(),
            4.0 * (2.0 - 2.0 * r) + TAU * r,
            1e-4
        ));
        for segment in path.segments() {
            if let Segment::Arc { sweep_rad, .. } = segment {
                assert!(close(*sweep_rad, -FRAC_PI_2, 1e-5));
            }
        }
        // The end of the loop is its start.
        assert!(close_points(
            path.sample(path.length_m()).point,
            start.point,
            1e-4
        ));
    }

    #[test]
    fn fillets_that_use_up_whole_edges_leave_only_arcs() {
        // A 2 m square with 1 m fillets is a circle of radius 1 about its centre.
        let w = [
            Point::new(0.0, 0.0),
            Point::new(2.0, 0.0),
            Point::new(2.0, 2.0),
            Point::new(0.0, 2.0),
        ];
        let path = Path::polyline(&w, 1.0, true).unwrap();
        assert_eq!(path.segments().len(), 4);
        assert!(close(path.length_m(), TAU, 1e-4));
        for i in 0..100 {
            let q = path.sample(path.length_m() * i as f32 / 100.0);
            assert!(close(q.point.distance_to(Point::new(1.0, 1.0)), 1.0, 1e-5));
        }
    }

    #[test]
    fn collinear_waypoints_and_zero_radius_add_no_arcs() {
        let straight = [
            Point::new(0.0, 0.0),
            Point::new(1.0, 1.0),
            Point::new(2.0, 2.0),
            Point::new(3.0, 3.0),
        ];
        let path = Path::polyline(&straight, 0.5, false).unwrap();
        assert_eq!(path.segments().len(), 3);
        assert!(path
            .segments()
            .iter()
            .all(|s| matches!(s, Segment::Line { .. })));
        assert!(close(path.length_m(), 3.0 * 2f32.sqrt(), 1e-5));
        // Sharp corners: the path goes through every waypoint.
        let w = [
            Point::new(0.0, 0.0),
            Point::new(2.0, 0.0),
            Point::new(2.0, 1.0),
        ];
        let sharp = Path::polyline(&w, 0.0, false).unwrap();
        assert_eq!(sharp.segments().len(), 2);
        assert!(close_points(sharp.sample(2.0).point, w[1], 1e-6));
        assert!(close(sharp.sample(2.0).heading_rad, FRAC_PI_2, 1e-6));
        assert!(close(sharp.length_m(), 3.0, 1e-6));
    }

    #[test]
    fn a_path_checked_or_rebuilt_in_place_is_the_one_from_segments_builds() {
        let square = SQUARE_2M;
        let closed = Path::polyline(&square, 0.3, true).unwrap();
        let open = Path::polyline(&square, 0.3, false).unwrap();
        for path in [&closed, &open] {
            let shape = Path::check_segments(path.segments()).unwrap();
            assert_eq!(shape.length_m.to_bits(), path.length_m().to_bits());
            assert_eq!(shape.closed, path.is_closed());
            let mut rebuilt = Path::circle(Point::new(5.0, 5.0), 1.0, 0.0, true).unwrap();
            rebuilt.rebuild_from_segments(path.segments()).unwrap();
            let built = Path::from_segments(path.segments()).unwrap();
            assert_eq!(rebuilt.segments(), built.segments());
            assert_eq!(rebuilt.starts_m, built.starts_m);
            assert_eq!(rebuilt.length_m().to_bits(), built.length_m().to_bits());
            assert_eq!(rebuilt.is_closed(), built.is_closed());
        }
        assert!(closed.is_closed() && !open.is_closed());
        // Refused: unchanged.
        let mut kept = closed.clone();
        let gap = [open.segments()[0], open.segments()[2]];
        assert_eq!(
            kept.rebuild_from_segments(&gap),
            Err(PathError::Gap { segment: 1 })
        );
        assert_eq!(kept.segments(), closed.segments());
        assert_eq!(kept.length_m(), closed.length_m());
        // The placeholder is a path like any other.
        assert_eq!(
            Path::check_segments(Path::PLACEHOLDER.segments()),
            Ok(PathShape {
                length_m: 1.0,
                closed: false
            })
        );
        assert_eq!(Path::PLACEHOLDER.length_m(), 1.0);
    }

    #[test]
    fn every_path_error_has_its_own_message() {
        let all = [
            PathError::NonFinite,
            PathError::NonPositiveSize,
            PathError::TooFewPoints,
            PathError::DuplicatePoint,
            PathError::CornerTooTight,
            PathError::TooManySegments,
        ];
        let keywords = [
            "finite",
            "≤ 0",
            "waypoints",
            "coincide",
            "fillet",
            "32 segments",
        ];
        for (i, (e, keyword)) in all.iter().zip(keywords).enumerate() {
            let text = std::format!("{e}");
            assert!(text.contains(keyword), "{e:?}: {text}");
            for other in &all[i + 1..] {
                assert_ne!(text, std::format!("{other}"));
            }
        }
    }

    /// The projection as a scan of every segment computes it: the oracle for the
    /// windowed search of [`Path::project`] (the same candidates, from every segment).
    fn project_by_scanning_every_segment(
        path: &Path,
        p: Point,
        hint_m: f32,
        behind_m: f32,
        ahead_m: f32,
    ) -> f32 {
        let mut best = (f32::INFINITY, hint_m);
        for (segment, &start) in path.segments.iter().zip(&path.starts_m) {
            if !path.overlaps_window(start, start + segment.length_m(), hint_m, behind_m, ahead_m) {
                continue;
            }
            let (s, d) = path.candidate(segment, start, p, hint_m, behind_m, ahead_m);
            if d < best.0 - PROJECTION_TIE_M {
                best = (d, s);
            }
        }
        best.1
    }

    /// The point at `s_m` as a scan of every segment finds it: the oracle for
    /// [`Path::sample_normalized`]'s binary search.
    fn sample_by_scanning_every_segment(path: &Path, s_m: f32) -> PathSample {
        let mut chosen = (&path.segments[0], 0.0);
        for (segment, &start) in path.segments.iter().zip(&path.starts_m) {
            if s_m >= start {
                chosen = (segment, start);
            }
        }
        chosen.0.sample(s_m - chosen.1)
    }

    /// A polyline of `corners` waypoints on a jittered circle of `radius_m`, corners
    /// rounded by `fillet_m` (falls back to sharp corners where the fillet does not fit).
    fn jittered_polygon(
        corners: usize,
        radius_m: f32,
        jitter: &[f32],
        fillet_m: f32,
        closed: bool,
    ) -> Path {
        let points: std::vec::Vec<Point> = (0..corners)
            .map(|k| {
                let a = TAU * k as f32 / corners as f32;
                let r = radius_m * (1.0 + 0.3 * jitter[k % jitter.len()]);
                Point::new(r * math::cos(a), r * math::sin(a))
            })
            .collect();
        Path::polyline(&points, fillet_m, closed)
            .or_else(|_| Path::polyline(&points, 0.0, closed))
            .unwrap()
    }

    proptest::proptest! {
        #[test]
        fn the_windowed_search_finds_what_a_scan_of_every_segment_finds(
            corners in 3usize..=16,
            radius_m in 0.05f32..3.0,
            jitter in proptest::collection::vec(-1.0f32..1.0, 16),
            fillet_m in 0.0f32..0.4,
            closed in proptest::bool::ANY,
            at in (-4.0f32..4.0, -4.0f32..4.0),
            hint_fraction in -0.2f32..1.2,
            window in (0.0f32..0.6, 0.0f32..1.5),
        ) {
            let path = jittered_polygon(corners, radius_m, &jitter, fillet_m, closed);
            let p = Point::new(at.0, at.1);
            let hint = hint_fraction * path.length_m();
            for (behind, ahead) in [window, (f32::INFINITY, f32::INFINITY), (0.05, 0.5)] {
                let expected = project_by_scanning_every_segment(&path, p, hint, behind, ahead);
                let found = path.project(p, hint, behind, ahead);
                proptest::prop_assert_eq!(found.to_bits(), expected.to_bits(),
                    "window [{} − {}, + {}] on {} segments", hint, behind, ahead, path.segments.len());
            }
            let s = path.normalize_m(hint);
            proptest::prop_assert_eq!(path.sample_normalized(s), sample_by_scanning_every_segment(&path, s));
            // The set itself, also with the window starting exactly where a segment
            // starts (the one before then ends on the window's edge: it meets it too).
            let k = corners % path.segments.len();
            for (hint, behind, ahead) in [(hint, window.0, window.1), (path.starts_m[k], 0.0, window.1)] {
                let expected: u32 = (0..path.segments.len())
                    .filter(|&i| {
                        let start = path.starts_m[i];
                        path.overlaps_window(start, start + path.segments[i].length_m(), hint, behind, ahead)
                    })
                    .map(|i| 1 << i)
                    .sum();
                proptest::prop_assert_eq!(path.segments_near(hint, behind, ahead), expected,
                    "window [{} − {}, + {}]", hint, behind, ahead);
            }
        }
    }

    #[test]
    fn the_search_visits_only_the_segments_near_the_window() {
        // 32 segments, each edge about 0.59 m long: a 0.55 m window meets two or three.
        let path = jittered_polygon(16, 1.5, &[0.0], 0.1, true);
        assert_eq!(path.segments.len(), MAX_SEGMENTS);
        for k in 0..64 {
            let hint = path.length_m() * k as f32 / 64.0;
            let near = path.segments_near(hint, 0.05, 0.5);
            let count = near.count_ones();
            assert!((1..=4).contains(&count), "{count} segments near {hint} m");
            let first = path.segment_index(path.normalize_m(hint - 0.05)) as u32;
            assert!(
                near & (1 << first) != 0,
                "the window's first segment {first} at {hint} m"
            );
        }
        // Past the end of a lap (closed) the window wraps to the first segments.
        let near = path.segments_near(path.length_m() - 0.01, 0.05, 0.5);
        assert!(near & 1 != 0 && near & (1 << 31) != 0, "{near:#034b}");
        // A global search visits every segment; a NaN hint none.
        assert_eq!(
            path.segments_near(0.0, f32::INFINITY, f32::INFINITY),
            u32::MAX
        );
        assert_eq!(path.segments_near(f32::NAN, 0.05, 0.5), 0);
        assert_eq!(path.segment_index(f32::NAN), MAX_SEGMENTS - 1);
        assert_eq!(path.segment_index(-1.0), 0);
    }
}
