//! Re-arming: the pose kept, the wheels at rest, the pose command, a run's own time
//! limit, and one step's two state changes.

use super::*;

/// Arms by the link with `request`, returning the step's output.
fn arm_by_link(r: &mut Rig, request: ArmRequest) -> SupervisorOutput {
    r.command(Command::Arm(request))
}

#[test]
fn arming_waits_for_the_wheels_at_rest_unless_the_motion_is_asserted() {
    let mut r = moving_rig();
    // Turning: refused by the button (its event says why) and by the link.
    r.run(200);
    let outs = r.press(SHORT);
    assert_eq!(
        events(&outs),
        vec![Event::ArmRefused(CommandRefusal::WheelsTurning)]
    );
    let out = arm_by_link(&mut r, ArmRequest::follow_path());
    assert_eq!(out.command_result, Some(Err(CommandRefusal::WheelsTurning)));
    assert_eq!(out.state, State::Disarmed);
    // The wheels stop: still refused until they have stood still for REST_STEPS.
    r.moving = false;
    let out = arm_by_link(&mut r, ArmRequest::follow_path());
    assert_eq!(out.command_result, Some(Err(CommandRefusal::WheelsTurning)));
    // The speed estimate's window empties (64 steps at most), then REST_STEPS at rest.
    r.run(64 + REST_STEPS);
    let out = arm_by_link(&mut r, ArmRequest::follow_path());
    assert_eq!(out.event, Some(Event::Armed(RunMode::FollowPath)));
    // A request that asserts the motion arms while the wheels turn.
    r.command(Command::Disarm);
    r.moving = true;
    r.run(200);
    let mut request = ArmRequest::follow_path();
    request.initial_motion = Some(BodyVelocity::new(0.1625, 0.0));
    let out = arm_by_link(&mut r, request);
    assert_eq!(out.event, Some(Event::Armed(RunMode::FollowPath)));
}

#[test]
fn the_pose_command_is_taken_while_disarmed_and_only_finite() {
    let mut r = rig();
    let there = Pose::new(1.0, 2.0, 0.5);
    let out = r.command(Command::SetPose(there));
    assert_eq!(out.command_result, Some(Ok(())));
    assert_eq!(out.event, Some(Event::PoseSet));
    assert!((r.ctl.pose().x_m - 1.0).abs() < 1e-6 && (r.ctl.pose().y_m - 2.0).abs() < 1e-6);
    let out = r.command(Command::SetPose(Pose::new(0.0, f32::NAN, 0.0)));
    assert_eq!(out.command_result, Some(Err(CommandRefusal::NonFinitePose)));
    assert_eq!(out.event, None);
    // Armed: refused, the pose unchanged.
    r.press(SHORT);
    assert_eq!(r.sup.state(), State::Armed);
    let before = r.ctl.pose();
    let out = r.command(Command::SetPose(Pose::default()));
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::WrongState(State::Armed)))
    );
    assert!((r.ctl.pose().x_m - before.x_m).abs() < 0.01);
    assert_ne!(r.ctl.pose().x_m, 0.0);
}

#[test]
fn an_arm_request_s_time_limit_holds_for_its_run_only() {
    let mut c = config();
    c.max_armed_steps = Some(2000);
    // The rig's world does not turn the wheels: no stall check over a 2 s run.
    c.stall.timeout_steps = u32::MAX;
    let mut r = Rig::new(c, ResetCause::PowerOn);
    let mut request = ArmRequest::follow_path();
    request.max_armed_steps = Some(300);
    assert_eq!(
        arm_by_link(&mut r, request).event,
        Some(Event::Armed(RunMode::FollowPath))
    );
    // The arming step is the first of the 300: 299 more armed, then disarmed.
    let outs: Vec<_> = (0..400).map(|_| r.command(Command::Heartbeat)).collect();
    let at = outs
        .iter()
        .position(|o| o.state == State::Disarmed)
        .unwrap();
    assert_eq!(at, 299);
    assert_eq!(outs[at].event, Some(Event::Disarmed(DisarmReason::Timeout)));
    assert_eq!(
        r.sup.config().max_armed_steps,
        Some(2000),
        "the setting stays"
    );
    // The next run without one: the stored limit.
    r.run(600);
    assert_eq!(
        arm_by_link(&mut r, ArmRequest::follow_path()).event,
        Some(Event::Armed(RunMode::FollowPath))
    );
    let outs: Vec<_> = (0..2100).map(|_| r.command(Command::Heartbeat)).collect();
    let at = outs
        .iter()
        .position(|o| o.state == State::Disarmed)
        .unwrap();
    assert_eq!(at, 1999);
}

#[test]
fn a_link_arm_in_the_step_the_button_clears_the_faults_reports_the_arming() {
    let mut r = rig();
    let out = r.step_with(TickDeltas {
        left: 0,
        right: -10_000,
    });
    assert_eq!(out.state, State::Faulted);
    // The jump leaves the speed estimate; the wheels then stand still.
    r.run(500);
    r.button = true;
    r.run(SHORT);
    r.button = false;
    // The release is debounced: 19 steps, and the 20th clears the faults.
    for out in r.run(19) {
        assert_eq!(out.state, State::Faulted);
    }
    let out = arm_by_link(&mut r, ArmRequest::follow_path());
    assert_eq!(out.command_result, Some(Ok(())));
    assert_eq!(out.state, State::Armed);
    // The step ends armed: its event is the arming, so a host sees the run start.
    assert_eq!(out.event, Some(Event::Armed(RunMode::FollowPath)));
}
