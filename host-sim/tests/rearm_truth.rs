//! The true reference pauses with the robot's: after a double press of the button (a
//! disarm, then a re-arm once the wheels are still) the robot resumes its own time-indexed
//! reference where it stopped, and the simulator's true error measures it against the
//! same point, so a run with a pause ends as close to its path as one without.

use controller_core::law::LawKind;
use host_sim::run_scenario;
use robot_files::faults::{Fault, FaultKind};
use robot_files::scenario::Scenario;

/// The final true position error, m, of `paper-circle` with the button pressed at 10 s
/// and again `pause_s` later (none: no press).
fn final_error_m(pause_s: Option<f64>) -> (f64, String) {
    let mut s = Scenario::load("paper-circle").unwrap();
    let rate = f64::from(s.robot.control_rate_hz);
    let press = |at_s: f64| Fault {
        kind: FaultKind::ButtonPress,
        at_step: (at_s * rate).round() as u64,
        duration_steps: Some((0.03 * rate).round() as u64),
    };
    if let Some(pause_s) = pause_s {
        s.faults = vec![press(10.0), press(10.0 + pause_s)];
    }
    let run = run_scenario(&s, LawKind::Tracking).unwrap();
    let error = run.summary.true_error.unwrap().final_position_error_m;
    (error, run.summary.supervisor.final_state)
}

#[test]
fn a_pause_and_a_re_arm_end_on_the_path_as_a_run_without_them() {
    let (without, _) = final_error_m(None);
    for pause_s in [0.6, 3.0] {
        let (with, state) = final_error_m(Some(pause_s));
        assert_eq!(state, "Armed", "re-armed after {pause_s} s");
        assert!(
            (with - without).abs() <= 0.001,
            "a {pause_s} s pause: final true error {with} m, without it {without} m"
        );
    }
}
