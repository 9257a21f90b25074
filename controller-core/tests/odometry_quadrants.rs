//! Odometry on a quarter circle, starting in each quadrant with each heading, turning left
//! and right, forwards and backwards: the end pose and every pose on the way against the
//! closed-form circle.
//!
//! Geometry: wheel radius R = 0.05 m, track width L = 0.2 m, 1000 ticks per wheel
//! revolution, so one tick is R·2π/1000 = π·10⁻⁴ m of rim travel. The robot drives a
//! quarter circle of radius ρ = 0.3 m about a centre beside it: the inner wheel runs on a
//! circle of ρ − L/2 = 0.2 m (a quarter of it is 0.1π m = 1000 ticks), the outer wheel on
//! ρ + L/2 = 0.4 m (2000 ticks), in 100 equal steps of 10 and 20 ticks.
//!
//! In the robot's starting frame (x ahead, y left) a left turn forwards ends at (ρ, ρ)
//! heading +π/2, a right turn forwards at (ρ, −ρ) heading −π/2, and driving the same
//! wheel ratios backwards ends at (−ρ, ρ) heading −π/2 (left-hand circle) or (−ρ, −ρ)
//! heading +π/2 (right-hand circle). Together with the four starting headings these arcs
//! cover every quadrant of the world frame, so a wrong sign in either position update or
//! in the heading update shows up in at least one of them.

use core::f32::consts::{FRAC_PI_2, PI, TAU};

use controller_core::kinematics::{DiffDrive, Pose};
use controller_core::odometry::Odometry;

const WHEEL_RADIUS_M: f32 = 0.05;
const TRACK_WIDTH_M: f32 = 0.2;
const TICKS_PER_REV: f32 = 1000.0;
/// Radius of the robot's centre's circle, m.
const RHO_M: f32 = 0.3;
const STEPS: usize = 100;

/// Which way the robot turns and drives.
#[derive(Clone, Copy, Debug)]
enum Manoeuvre {
    LeftForwards,
    RightForwards,
    LeftBackwards,
    RightBackwards,
}

impl Manoeuvre {
    const ALL: [Manoeuvre; 4] = [
        Manoeuvre::LeftForwards,
        Manoeuvre::RightForwards,
        Manoeuvre::LeftBackwards,
        Manoeuvre::RightBackwards,
    ];

    /// Tick deltas per step (left, right).
    fn ticks(self) -> (i32, i32) {
        match self {
            Manoeuvre::LeftForwards => (10, 20),
            Manoeuvre::RightForwards => (20, 10),
            Manoeuvre::LeftBackwards => (-10, -20),
            Manoeuvre::RightBackwards => (-20, -10),
        }
    }

    /// +1 when the circle's centre is on the robot's left, −1 on its right.
    fn side(self) -> f32 {
        match self {
            Manoeuvre::LeftForwards | Manoeuvre::LeftBackwards => 1.0,
            Manoeuvre::RightForwards | Manoeuvre::RightBackwards => -1.0,
        }
    }

    /// End point and heading change in the starting robot frame (m, m, rad).
    fn end_in_start_frame(self) -> (f32, f32, f32) {
        match self {
            Manoeuvre::LeftForwards => (RHO_M, RHO_M, FRAC_PI_2),
            Manoeuvre::RightForwards => (RHO_M, -RHO_M, -FRAC_PI_2),
            Manoeuvre::LeftBackwards => (-RHO_M, RHO_M, -FRAC_PI_2),
            Manoeuvre::RightBackwards => (-RHO_M, -RHO_M, FRAC_PI_2),
        }
    }
}

/// Starts in each quadrant of the world frame, with headings along ±x and ±y.
const STARTS: [(f32, f32, f32); 4] = [
    (1.0, 1.0, 0.0),
    (-1.0, 1.0, FRAC_PI_2),
    (-1.0, -1.0, PI),
    (1.0, -1.0, -FRAC_PI_2),
];

fn angle_between(a: f32, b: f32) -> f32 {
    let d = (a - b).rem_euclid(TAU);
    d.min(TAU - d)
}

#[test]
fn quarter_circles_in_every_quadrant_end_where_the_circle_does() {
    let geometry = DiffDrive::new(WHEEL_RADIUS_M, TRACK_WIDTH_M).unwrap();
    for (x0, y0, th0) in STARTS {
        for m in Manoeuvre::ALL {
            let start = Pose::new(x0, y0, th0);
            let mut odometry = Odometry::new(geometry, TICKS_PER_REV, start);
            let (sin0, cos0) = th0.sin_cos();
            // The circle's centre: ρ to the robot's left (or right) of the start.
            let center = (x0 - m.side() * RHO_M * sin0, y0 + m.side() * RHO_M * cos0);
            let (left, right) = m.ticks();
            for step in 1..=STEPS {
                let p = odometry.update(left, right);
                let radius = (p.x_m - center.0).hypot(p.y_m - center.1);
                assert!(
                    (radius - RHO_M).abs() < 1e-5,
                    "{m:?} from {start:?}, step {step}: {p:?} is {radius} m from the centre"
                );
                // The heading is the tangent: perpendicular to the radius, turned by the
                // fraction of the quarter driven so far.
                let (_, _, turn) = m.end_in_start_frame();
                let expected = th0 + turn * step as f32 / STEPS as f32;
                assert!(
                    angle_between(p.theta_rad, expected) < 1e-5,
                    "{m:?} from {start:?}, step {step}: heading {} vs {expected}",
                    p.theta_rad
                );
                assert!(p.theta_rad > -PI && p.theta_rad <= PI);
            }
            let (ex, ey, turn) = m.end_in_start_frame();
            let end = Pose::new(
                x0 + ex * cos0 - ey * sin0,
                y0 + ex * sin0 + ey * cos0,
                th0 + turn,
            );
            let p = odometry.pose();
            assert!(
                (p.x_m - end.x_m).abs() < 1e-5 && (p.y_m - end.y_m).abs() < 1e-5,
                "{m:?} from {start:?}: ended at {p:?}, expected {end:?}"
            );
            assert!(angle_between(p.theta_rad, end.theta_rad) < 1e-5);
        }
    }
}
