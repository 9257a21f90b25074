//! The path as a line for the 3D panel: each segment's points, arcs tessellated so the
//! line stays within [`CHORD_TOLERANCE_M`] of the arc, as one `SceneUpdate`.

use controller_core::path::{Path, Segment};
use foxglove::messages::{Color, LinePrimitive, Point3, SceneEntity, SceneUpdate};

use crate::convert::timestamp;
use crate::topics::WORLD_FRAME;

/// Most a tessellated arc's chord strays from the arc (its sagitta), m.
pub const CHORD_TOLERANCE_M: f64 = 0.001;

/// Most points one arc is cut into (a huge radius would otherwise ask for many).
const MAX_ARC_POINTS: usize = 2_000;

/// The points of `path` in order of travel, world frame, m: each line's ends, each arc
/// cut into equal steps whose chords stray at most [`CHORD_TOLERANCE_M`] from it (at
/// most 2 000 points an arc). Consecutive segments share their joint once.
pub fn path_points(path: &Path) -> Vec<(f64, f64)> {
    let mut points: Vec<(f64, f64)> = Vec::new();
    for segment in path.segments() {
        let from = if points.is_empty() { 0 } else { 1 };
        match *segment {
            Segment::Line {
                start,
                heading_rad,
                length_m,
            } => {
                let (x, y) = (f64::from(start.x_m), f64::from(start.y_m));
                let (h, l) = (f64::from(heading_rad), f64::from(length_m));
                let ends = [(x, y), (x + l * h.cos(), y + l * h.sin())];
                points.extend_from_slice(&ends[from..]);
            }
            Segment::Arc {
                center,
                radius_m,
                start_angle_rad,
                sweep_rad,
            } => {
                let (cx, cy, r) = (
                    f64::from(center.x_m),
                    f64::from(center.y_m),
                    f64::from(radius_m),
                );
                let (a0, sweep) = (f64::from(start_angle_rad), f64::from(sweep_rad));
                let n = arc_steps(r, sweep.abs());
                for i in from..=n {
                    let a = a0 + sweep * i as f64 / n as f64;
                    points.push((cx + r * a.cos(), cy + r * a.sin()));
                }
            }
        }
    }
    points
}

/// Steps an arc of radius `r` (m) sweeping `sweep` (rad, ≥ 0) is cut into: the fewest
/// whose sagitta r·(1 − cos(step/2)) is within [`CHORD_TOLERANCE_M`], at least 1.
fn arc_steps(r: f64, sweep: f64) -> usize {
    if r <= CHORD_TOLERANCE_M {
        return 1;
    }
    let step = 2.0 * (1.0 - CHORD_TOLERANCE_M / r).acos();
    let n = (sweep / step).ceil();
    if n.is_finite() {
        (n as usize).clamp(1, MAX_ARC_POINTS)
    } else {
        1
    }
}

/// The `/path` message: `path` as one entity `path` in the world frame, a line strip (a
/// loop when the path is closed) 2 cm wide, logged at `t_s` and kept forever.
pub fn path_scene(path: &Path, t_s: f64) -> SceneUpdate {
    let mut points: Vec<Point3> = path_points(path)
        .into_iter()
        .map(|(x, y)| Point3 { x, y, z: 0.0 })
        .collect();
    let r#type = if path.is_closed() {
        // The loop closes itself: drop the end that repeats the start.
        if points.len() > 2 {
            points.pop();
        }
        foxglove::messages::line_primitive::Type::LineLoop
    } else {
        foxglove::messages::line_primitive::Type::LineStrip
    };
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![SceneEntity {
            timestamp: Some(timestamp(t_s)),
            frame_id: WORLD_FRAME.to_string(),
            id: "path".to_string(),
            lifetime: None,
            frame_locked: false,
            lines: vec![LinePrimitive {
                r#type: r#type as i32,
                pose: None,
                thickness: 0.02,
                scale_invariant: false,
                points,
                color: Some(Color {
                    r: 0.2,
                    g: 0.5,
                    b: 1.0,
                    a: 1.0,
                }),
                colors: Vec::new(),
                indices: Vec::new(),
            }],
            ..Default::default()
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::prelude::Point;

    #[test]
    fn a_circle_is_cut_within_the_tolerance_and_closes() {
        let path = Path::circle(
            Point::new(0.0, 1.0),
            1.0,
            -core::f32::consts::FRAC_PI_2,
            true,
        )
        .expect("a circle");
        let points = path_points(&path);
        assert!(points.len() > 20, "{} points", points.len());
        for &(x, y) in &points {
            let r = x.hypot(y - 1.0);
            assert!(
                (r - 1.0).abs() < 1e-6,
                "({x}, {y}) is off the circle: r = {r}"
            );
        }
        for pair in points.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            let mid = ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0);
            let sagitta = 1.0 - mid.0.hypot(mid.1 - 1.0);
            assert!(sagitta <= CHORD_TOLERANCE_M + 1e-9, "sagitta {sagitta}");
        }
        let (first, last) = (points[0], points[points.len() - 1]);
        assert!((first.0 - last.0).hypot(first.1 - last.1) < 1e-5);
        let scene = path_scene(&path, 0.0);
        let line = &scene.entities[0].lines[0];
        assert_eq!(
            line.r#type,
            foxglove::messages::line_primitive::Type::LineLoop as i32
        );
        assert_eq!(line.points.len(), points.len() - 1);
    }

    #[test]
    fn a_line_is_its_two_ends() {
        let path =
            Path::line(Point::new(1.0, 2.0), core::f32::consts::FRAC_PI_2, 3.0).expect("a line");
        let points = path_points(&path);
        assert_eq!(points.len(), 2);
        assert!((points[1].0 - 1.0).abs() < 1e-6 && (points[1].1 - 5.0).abs() < 1e-6);
        let scene = path_scene(&path, 0.0);
        assert_eq!(
            scene.entities[0].lines[0].r#type,
            foxglove::messages::line_primitive::Type::LineStrip as i32
        );
    }
}
