//! A ROS 2 path (hundreds of poses, as nav2 plans them) made into a path the robot holds:
//! at most [`MAX_WAYPOINTS`] waypoints within a tolerance of the poses (Douglas–Peucker),
//! their corners rounded with fillets ([`Path::polyline`]).
//!
//! The simplification is Douglas–Peucker run in order of deviation: starting from the
//! first and last pose, the pose farthest from the polyline so far becomes a waypoint,
//! until every pose lies within the tolerance of the polyline, or [`MAX_WAYPOINTS`] are
//! used and a pose is still further: then the path is refused, with the deviation that
//! was left. Douglas–Peucker is greedy, not optimal (on a circular arc its chords are
//! unequal), so a refused path may have a fit of 16 waypoints that it does not find; the
//! answer is a looser `path_tolerance` or a shorter path.
//!
//! The tolerance bounds the distance of every pose from the polyline; the fillets then
//! cut each corner by at most `r·(1/cos(θ/2) − 1)` for a turn θ, so a corner radius
//! small against the tolerance keeps the path within it.

use controller_core::kinematics::Point;
use controller_core::path::{Path, PathError, MAX_SEGMENTS};

/// Most waypoints of a simplified path: 16 waypoints make 15 lines and 14 fillets, 29
/// segments of the robot's [`MAX_SEGMENTS`].
pub const MAX_WAYPOINTS: usize = 16;
const _: () = assert!(2 * MAX_WAYPOINTS - 3 <= MAX_SEGMENTS);

/// Poses closer than this to the previous one are dropped before simplifying, m.
const SAME_POINT_M: f64 = 1e-3;

/// Why a path was refused.
#[derive(Clone, Debug, PartialEq)]
pub enum SimplifyError {
    /// Fewer than two distinct positions.
    TooFewPoses,
    /// A coordinate is not finite.
    NonFinite {
        /// Index of the pose in the message.
        index: usize,
    },
    /// [`MAX_WAYPOINTS`] waypoints leave a pose further than the tolerance.
    NotWithinTolerance {
        /// The tolerance, m.
        tolerance_m: f64,
        /// The largest distance of a pose from the best polyline of [`MAX_WAYPOINTS`], m.
        deviation_m: f64,
    },
    /// The waypoints make no path the robot can follow (a turn back on itself).
    Path(PathError),
}

impl core::fmt::Display for SimplifyError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SimplifyError::TooFewPoses => f.write_str("the path has fewer than two distinct poses"),
            SimplifyError::NonFinite { index } => {
                write!(
                    f,
                    "pose {index} of the path has a coordinate that is not finite"
                )
            }
            SimplifyError::NotWithinTolerance {
                tolerance_m,
                deviation_m,
            } => write!(
                f,
                "the path cannot be simplified to {MAX_WAYPOINTS} waypoints within \
                 path_tolerance {tolerance_m} m: a pose is {deviation_m:.3} m off the best \
                 {MAX_WAYPOINTS}"
            ),
            SimplifyError::Path(e) => write!(f, "the simplified path is not followable: {e}"),
        }
    }
}

impl core::error::Error for SimplifyError {}

/// The simplified path: its waypoints and the path through them with fillets.
#[derive(Clone, Debug)]
pub struct Simplified {
    /// The waypoints, world frame (the poses' frame), m.
    pub waypoints: Vec<Point>,
    /// The largest distance of a pose from the waypoints' polyline, m.
    pub deviation_m: f64,
    /// The fillet radius used, m: the one asked for, or less where corners are too
    /// close for it.
    pub corner_radius_m: f32,
    /// The path through the waypoints, corners filleted.
    pub path: Path,
}

/// Simplifies `positions` (x, y in m, in order) to at most [`MAX_WAYPOINTS`] waypoints
/// within `tolerance_m` of every position, and fillets the corners with
/// `corner_radius_m` (m), or the largest radius that fits where that one does not.
pub fn simplify(
    positions: &[(f64, f64)],
    tolerance_m: f64,
    corner_radius_m: f64,
) -> Result<Simplified, SimplifyError> {
    if let Some(index) = positions
        .iter()
        .position(|(x, y)| !(x.is_finite() && y.is_finite()))
    {
        return Err(SimplifyError::NonFinite { index });
    }
    let points = distinct(positions);
    if points.len() < 2 {
        return Err(SimplifyError::TooFewPoses);
    }
    let (kept, deviation_m) = douglas_peucker(&points, tolerance_m, MAX_WAYPOINTS);
    if deviation_m > tolerance_m {
        return Err(SimplifyError::NotWithinTolerance {
            tolerance_m,
            deviation_m,
        });
    }
    let waypoints: Vec<Point> = kept
        .iter()
        .map(|&i| Point::new(points[i].0 as f32, points[i].1 as f32))
        .collect();
    let radius = fitting_radius(&waypoints, corner_radius_m.max(0.0) as f32);
    let path = Path::polyline(&waypoints, radius, false).map_err(SimplifyError::Path)?;
    Ok(Simplified {
        waypoints,
        deviation_m,
        corner_radius_m: radius,
        path,
    })
}

/// `positions` without the ones within [`SAME_POINT_M`] of the one kept before.
fn distinct(positions: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(positions.len());
    for &p in positions {
        match out.last() {
            Some(&q) if distance(p, q) < SAME_POINT_M => {}
            _ => out.push(p),
        }
    }
    out
}

/// The indices of the points kept (sorted, first and last among them) and the largest
/// distance of any point from their polyline: points added worst first until that
/// distance is within `tolerance_m` or `max_kept` are kept.
fn douglas_peucker(points: &[(f64, f64)], tolerance_m: f64, max_kept: usize) -> (Vec<usize>, f64) {
    let last = points.len() - 1;
    let mut kept = vec![0, last];
    loop {
        let worst = kept
            .windows(2)
            .filter_map(|pair| farthest(points, pair[0], pair[1]))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let Some((index, deviation)) = worst else {
            return (kept, 0.0);
        };
        if deviation <= tolerance_m || kept.len() >= max_kept {
            return (kept, deviation);
        }
        let at = kept.partition_point(|&k| k < index);
        kept.insert(at, index);
    }
}

/// The point strictly between `from` and `to` farthest from the segment joining them,
/// and its distance (m); `None` when there is none between.
fn farthest(points: &[(f64, f64)], from: usize, to: usize) -> Option<(usize, f64)> {
    let (a, b) = (points[from], points[to]);
    (from + 1..to)
        .map(|i| (i, distance_to_segment(points[i], a, b)))
        .max_by(|x, y| x.1.total_cmp(&y.1))
}

fn distance(p: (f64, f64), q: (f64, f64)) -> f64 {
    (p.0 - q.0).hypot(p.1 - q.1)
}

/// Distance from `p` to the segment from `a` to `b`, m.
fn distance_to_segment(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let length_sq = dx * dx + dy * dy;
    if length_sq == 0.0 {
        return distance(p, a);
    }
    let t = (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / length_sq).clamp(0.0, 1.0);
    distance(p, (a.0 + t * dx, a.1 + t * dy))
}

/// `wanted` (m), or the largest radius whose fillets fit on every edge of the polyline
/// when that one does not (a fillet of radius r at a turn θ takes r·tan(|θ|/2) of each
/// edge it joins), with 1 % to spare.
fn fitting_radius(waypoints: &[Point], wanted: f32) -> f32 {
    let n = waypoints.len();
    if n < 3 {
        return wanted;
    }
    let heading = |i: usize| {
        let (a, b) = (waypoints[i], waypoints[i + 1]);
        (b.y_m - a.y_m).atan2(b.x_m - a.x_m)
    };
    // tan(|θ|/2) at each interior waypoint (0 at the ends).
    let half_tan = |i: usize| {
        if i == 0 || i == n - 1 {
            return 0.0;
        }
        let turn = controller_core::math::wrap_angle(heading(i) - heading(i - 1));
        (0.5 * turn.abs()).tan()
    };
    let mut radius = wanted;
    for i in 0..n - 1 {
        let taken = half_tan(i) + half_tan(i + 1);
        if taken > 0.0 {
            let length = waypoints[i].distance_to(waypoints[i + 1]);
            radius = radius.min(0.99 * length / taken);
        }
    }
    radius
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `count` poses along a quarter circle of radius 1 m about the origin.
    fn quarter_circle(count: usize) -> Vec<(f64, f64)> {
        (0..count)
            .map(|i| {
                let a = std::f64::consts::FRAC_PI_2 * i as f64 / (count - 1) as f64;
                (a.cos(), a.sin())
            })
            .collect()
    }

    #[test]
    fn a_straight_path_of_many_poses_is_two_waypoints() {
        let poses: Vec<_> = (0..300).map(|i| (0.01 * f64::from(i), 0.5)).collect();
        let s = simplify(&poses, 0.01, 0.1).unwrap();
        assert_eq!(s.waypoints.len(), 2);
        assert_eq!(s.path.segments().len(), 1);
        assert!((s.path.length_m() - 2.99).abs() < 1e-4);
    }

    #[test]
    fn a_corner_is_kept_and_filleted() {
        let mut poses: Vec<_> = (0..=100).map(|i| (0.01 * f64::from(i), 0.0)).collect();
        poses.extend((1..=100).map(|i| (1.0, 0.01 * f64::from(i))));
        let s = simplify(&poses, 0.005, 0.2).unwrap();
        assert_eq!(s.waypoints.len(), 3);
        assert!((s.waypoints[1].x_m - 1.0).abs() < 1e-6 && s.waypoints[1].y_m.abs() < 1e-6);
        // Line, fillet, line; the fillet turns left (counter-clockwise).
        assert_eq!(s.path.segments().len(), 3);
        assert!((s.corner_radius_m - 0.2).abs() < 1e-6);
    }

    #[test]
    fn every_pose_lies_within_the_tolerance_of_the_waypoints() {
        let poses = quarter_circle(500);
        for tolerance in [0.005, 0.01, 0.02] {
            let s = simplify(&poses, tolerance, 0.0).unwrap();
            assert!(s.waypoints.len() <= MAX_WAYPOINTS);
            let points: Vec<(f64, f64)> = s
                .waypoints
                .iter()
                .map(|p| (f64::from(p.x_m), f64::from(p.y_m)))
                .collect();
            for &p in &poses {
                let nearest = points
                    .windows(2)
                    .map(|w| distance_to_segment(p, w[0], w[1]))
                    .fold(f64::INFINITY, f64::min);
                assert!(nearest <= tolerance + 1e-6, "{nearest} > {tolerance}");
            }
            assert!(s.deviation_m <= tolerance);
        }
        // A looser tolerance needs fewer waypoints.
        let coarse = simplify(&poses, 0.02, 0.0).unwrap().waypoints.len();
        let fine = simplify(&poses, 0.005, 0.0).unwrap().waypoints.len();
        assert!(coarse < fine, "{coarse} vs {fine}");
    }

    #[test]
    fn a_path_that_needs_more_waypoints_is_refused_with_what_was_left() {
        // A zigzag of 40 teeth 0.1 m high: 16 waypoints cannot follow it within 1 cm.
        let poses: Vec<_> = (0..=80)
            .map(|i| (0.05 * f64::from(i), if i % 2 == 0 { 0.0 } else { 0.1 }))
            .collect();
        match simplify(&poses, 0.01, 0.0) {
            Err(SimplifyError::NotWithinTolerance {
                tolerance_m,
                deviation_m,
            }) => {
                assert_eq!(tolerance_m, 0.01);
                assert!(deviation_m > 0.05, "{deviation_m}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_poses_are_refused_by_index() {
        assert_eq!(
            simplify(&[(0.0, 0.0)], 0.01, 0.0).unwrap_err(),
            SimplifyError::TooFewPoses
        );
        assert_eq!(
            simplify(&[(0.0, 0.0), (0.0, 0.0005)], 0.01, 0.0).unwrap_err(),
            SimplifyError::TooFewPoses
        );
        assert_eq!(
            simplify(&[(0.0, 0.0), (1.0, f64::NAN)], 0.01, 0.0).unwrap_err(),
            SimplifyError::NonFinite { index: 1 }
        );
    }

    #[test]
    fn fillets_shrink_to_fit_short_edges() {
        // A square of 0.2 m sides: a 0.5 m fillet cannot fit, 0.1 m at most can.
        let poses = [(0.0, 0.0), (0.2, 0.0), (0.2, 0.2), (0.0, 0.2)];
        let s = simplify(&poses, 0.001, 0.5).unwrap();
        assert!(s.corner_radius_m < 0.1 && s.corner_radius_m > 0.09);
        assert!(s.path.length_m() > 0.0);
    }
}
