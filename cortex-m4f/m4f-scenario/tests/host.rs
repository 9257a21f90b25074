//! The scenario on the host.
//!
//! `cargo xtask ci` runs the same scenario on an emulated Cortex-M4F and demands the same
//! digest, bit for bit. These tests make sure the scenario is worth comparing: it is
//! deterministic, it closes the loop (the robot really follows the circle, with no fault),
//! every law runs, and the digest notices a one-ulp change.

use controller_core::law::LawKind;
use controller_core::math;
use m4f_scenario::{run_scenario, run_scenario_with, Digest, Scenario};

fn paper_circle() -> Scenario {
    Scenario::paper_circle()
}

#[test]
fn digest_is_deterministic() {
    let a = run_scenario(&paper_circle()).unwrap();
    let b = run_scenario(&paper_circle()).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.steps, 20_000);
    assert_eq!(Digest::parse_line(&a.to_string()), Some(a));
}

#[test]
fn scenario_covers_at_least_ten_seconds_and_three_laws() {
    let s = paper_circle();
    let rate = s.config.control_rate_hz;
    assert!(s.total_steps() >= 10 * rate);
    let laws: Vec<LawKind> = s.segments.iter().map(|seg| seg.law).collect();
    assert_eq!(laws, [LawKind::Tracking, LawKind::Paper, LawKind::Kanayama]);
}

/// Distance of a point from the circle of the scenario, m.
fn off_circle_m(s: &Scenario, x: f32, y: f32) -> f32 {
    math::abs(math::hypot(x - s.center.x_m, y - s.center.y_m) - s.radius_m)
}

#[test]
fn the_loop_closes_without_faults() {
    let s = paper_circle();
    let mut worst_late_tracking_error = 0.0f32;
    let mut worst_late_off_circle = 0.0f32;
    let mut worst_odometry_drift = 0.0f32;
    let mut steering_steps = [0u32; 3];
    run_scenario_with(&s, |r| {
        let t = r.telemetry;
        assert!(!t.faults.any(), "fault at step {}: {:?}", r.index, t.faults);
        for duty in [r.duty.left, r.duty.right] {
            assert!(duty.is_finite() && (-1.0..=1.0).contains(&duty));
        }
        if t.steering_updated {
            let law = LawKind::ALL.iter().position(|&l| l == r.law).unwrap();
            steering_steps[law] += 1;
        }
        // After 6 s of the tracking law the robot rides on the moving reference.
        if r.law == LawKind::Tracking && r.index >= 6_000 {
            worst_late_tracking_error = worst_late_tracking_error.max(t.error.position_m());
        }
        // Every law keeps it on the circle once converged.
        if r.index >= 6_000 {
            worst_late_off_circle =
                worst_late_off_circle.max(off_circle_m(&s, r.true_pose.x_m, r.true_pose.y_m));
        }
        let drift = math::hypot(t.pose.x_m - r.true_pose.x_m, t.pose.y_m - r.true_pose.y_m);
        worst_odometry_drift = worst_odometry_drift.max(drift);
    })
    .unwrap();
    assert!(
        worst_late_tracking_error < 0.02,
        "tracking error {worst_late_tracking_error} m"
    );
    assert!(
        worst_late_off_circle < 0.05,
        "off the circle by {worst_late_off_circle} m"
    );
    // Odometry and truth differ only by encoder quantisation.
    assert!(
        worst_odometry_drift < 0.005,
        "odometry drift {worst_odometry_drift} m"
    );
    // Every law ran its steering step (100 Hz).
    for (law, count) in LawKind::ALL.iter().zip(steering_steps) {
        assert!(count >= 500, "{law:?} steered {count} times");
    }
}

#[test]
fn digest_notices_a_one_ulp_change() {
    let base = run_scenario(&paper_circle()).unwrap();
    let mut nudged = paper_circle();
    nudged.start.x_m = f32::from_bits(nudged.start.x_m.to_bits() + 1);
    let other = run_scenario(&nudged).unwrap();
    assert_ne!(base.hash, other.hash);
}
