//! The virtual robot's own requests (what `serve --foxglove` sends for a parameter
//! change) and its samples as trace rows.

use controller_core::supervisor::State;
use host_sim::serve::VirtualRobot;
use link::{Reply, Request};
use robot_files::scenario::Scenario;

#[test]
fn a_local_request_is_answered_to_the_robot_itself_and_to_no_host() {
    let scenario = Scenario::load("paper-circle").expect("built in");
    let mut channels = robot_app::Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid");
    assert!(robot.trace_row().is_none(), "no step yet");
    robot.step();
    let mut set = robot.active_params();
    let before = set.robot.limits.max_linear_accel_m_s2;
    set.robot.limits.max_linear_accel_m_s2 = before - 0.5;
    assert!(robot.request_locally(Request::SetParams(set)));
    let mut reply = None;
    for _ in 0..20 {
        robot.step();
        assert!(
            robot.outgoing().is_empty(),
            "nothing is sent to the hosts (no telemetry asked, the reply kept)"
        );
        if let Some(r) = robot.take_local_reply() {
            reply = Some(r);
            break;
        }
    }
    assert!(
        matches!(reply, Some(Ok(Reply::ParamsApplied { .. }))),
        "{reply:?}"
    );
    assert_eq!(
        robot.active_params().robot.limits.max_linear_accel_m_s2,
        before - 0.5
    );
    // A sample: the truth at the start pose, disarmed, no reference yet.
    let row = robot.trace_row().expect("a step ran");
    assert_eq!(row.state, State::Disarmed);
    assert!((row.true_pose.x_m - scenario.start.x_m).abs() < 1e-9);
    assert!(row.reference.x_m.is_nan());
    assert!(row.t_s > 0.0);
}
