//! The exact plant in closed loop against RK4 at the plant rate: the same scenarios, the
//! same firmware logic, two integrators.
//!
//! Bound: the true pose of the two runs stays within 0.1 mm over the whole run, and the
//! summary's true-error figures within 0.1 mm; with a fault, the supervisor ends both
//! runs with the same faults. The bound is the open-loop replay's: in closed loop the two
//! cannot be bit-equal (an encoder tick that flips at a step boundary changes the next
//! duty), but the controller steers either run back to its path, so a difference does
//! not grow.

use controller_core::law::LawKind;
use host_sim::plant::Integration;
use host_sim::{run_scenario_with, RunOptions, RunResult};
use robot_files::scenario::Scenario;

/// Runs within this of each other (true pose and true-error figures), m.
const BOUND_M: f64 = 1e-4;

/// The largest distance between the two runs' true positions at their trace rows, m.
fn true_pose_gap_m(a: &RunResult, b: &RunResult) -> f64 {
    assert_eq!(a.trace.len(), b.trace.len());
    a.trace
        .iter()
        .zip(&b.trace)
        .map(|(p, q)| (p.true_pose.x_m - q.true_pose.x_m).hypot(p.true_pose.y_m - q.true_pose.y_m))
        .fold(0.0, f64::max)
}

/// `scenario` with the exact plant and with RK4 at the plant rate, traced.
fn both(scenario: &Scenario) -> (RunResult, RunResult) {
    let exact = RunOptions::at_steering_rate(scenario);
    let rk4 = RunOptions {
        integration: Integration::Rk4,
        ..exact
    };
    (
        run_scenario_with(scenario, LawKind::Tracking, exact).unwrap(),
        run_scenario_with(scenario, LawKind::Tracking, rk4).unwrap(),
    )
}

#[test]
fn on_the_paper_circle_and_the_figure_eight_the_exact_plant_stays_within_a_tenth_of_a_millimetre_of_rk4(
) {
    for name in ["paper-circle", "figure-eight"] {
        let scenario = Scenario::load(name).unwrap().with_duration_s(30.0).unwrap();
        let (exact, rk4) = both(&scenario);
        assert!(!exact.trace.is_empty());
        let gap = true_pose_gap_m(&exact, &rk4);
        println!("{name}: true poses at most {gap:.2e} m apart");
        assert!(gap < BOUND_M, "{name}: true poses {gap} m apart");
        let (e, r) = (
            exact.summary.true_error.unwrap(),
            rk4.summary.true_error.unwrap(),
        );
        for (what, a, b) in [
            (
                "final position",
                e.final_position_error_m,
                r.final_position_error_m,
            ),
            (
                "RMS position",
                e.rms_position_error_m,
                r.rms_position_error_m,
            ),
            (
                "max position",
                e.max_position_error_m,
                r.max_position_error_m,
            ),
        ] {
            assert!((a - b).abs() < BOUND_M, "{name}: {what} {a} vs {b} m");
        }
        // The two integrators did differ: the test compares two plants, not one twice.
        assert_ne!(exact.digest, rk4.digest, "{name}");
    }
}

#[test]
fn through_faults_that_stop_or_drag_a_wheel_the_exact_plant_stays_with_rk4() {
    let (_, circle) = robot_files::scenario::BUILTIN
        .iter()
        .find(|(name, _)| *name == "paper-circle")
        .unwrap();
    // (the fault, whether it stops the robot)
    for (fault, stops) in [
        (
            "at_s = 5\nkind = \"slip-patch\"\nwheel = \"right\"\nduration_s = 1",
            false,
        ),
        ("at_s = 5\nkind = \"wheel-blocked\"\nwheel = \"left\"", true),
        (
            "at_s = 5\nkind = \"motor-disconnect\"\nwheel = \"right\"",
            true,
        ),
    ] {
        let text = format!("{circle}\n[[faults]]\n{fault}\n");
        let scenario = Scenario::from_toml(&text, "circle-with-a-fault")
            .unwrap()
            .with_duration_s(10.0)
            .unwrap();
        let (exact, rk4) = both(&scenario);
        let gap = true_pose_gap_m(&exact, &rk4);
        let fault = fault.replace('\n', ", ");
        println!("{fault}: true poses at most {gap:.2e} m apart");
        assert!(gap < BOUND_M, "{fault}: true poses {gap} m apart");
        assert_eq!(
            exact.summary.supervisor.faults, rk4.summary.supervisor.faults,
            "{fault}"
        );
        assert_eq!(exact.faulted(), stops, "{fault}");
    }
}
