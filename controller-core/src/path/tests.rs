//! Paths against their geometry: every builder's refusals, each segment's samples and
//! projections, the windowed search against a scan of every segment.

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
        Path::polyline(&[o, Point::new(2.0, 0.0), Point::new(1.0, 0.0)], 0.0, true).unwrap_err(),
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
