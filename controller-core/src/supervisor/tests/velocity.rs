//! The velocity mode under the supervisor: armed by request only, its timeout, its
//! refusals, the button and every fault check in force.

use super::*;

fn arm_velocity() -> ArmRequest {
    ArmRequest {
        mode: RunMode::FollowVelocity,
        ..ArmRequest::follow_path()
    }
}

/// `steps` steps streaming `command` every 50 steps, and a heartbeat every 100 between.
fn stream(r: &mut Rig, command: BodyVelocity, steps: u32) -> Vec<SupervisorOutput> {
    (0..steps)
        .map(|i| {
            if i % 50 == 0 {
                r.command = Some(Command::Velocity(command));
            } else if i % 100 == 25 {
                r.command = Some(Command::Heartbeat);
            }
            r.step()
        })
        .collect()
}

/// `steps` steps with a heartbeat every 100 and no velocity command.
fn heartbeats_only(r: &mut Rig, steps: u32) -> Vec<SupervisorOutput> {
    (0..steps)
        .map(|i| {
            if i % 100 == 0 {
                r.command = Some(Command::Heartbeat);
            }
            r.step()
        })
        .collect()
}

fn velocity_rig() -> Rig {
    let mut c = config();
    c.stall.timeout_steps = u32::MAX;
    Rig::new(c, ResetCause::PowerOn)
}

#[test]
fn the_link_arms_it_and_the_command_reaches_the_wheels_in_its_step() {
    let mut r = velocity_rig();
    let out = r.command(Command::Arm(arm_velocity()));
    assert_eq!(out.event, Some(Event::Armed(RunMode::FollowVelocity)));
    assert_eq!(r.ctl.mode(), Mode::FollowVelocity);
    // No command yet: it holds still.
    for out in r.run(20) {
        assert_eq!(out.state, State::Armed);
    }
    assert_eq!(r.ctl.telemetry().command, BodyVelocity::new(0.0, 0.0));
    let out = r.command(Command::Velocity(BodyVelocity::new(0.3, 0.5)));
    assert_eq!(out.command_result, Some(Ok(())));
    let t = r.ctl.telemetry();
    assert!(
        t.command.v_m_s > 0.0 && t.command.omega_rad_s > 0.0,
        "{t:?}"
    );
    assert_eq!(
        t.law.command,
        BodyVelocity::new(0.3, 0.5),
        "the command in force"
    );
    assert!(
        t.wheel_setpoint.right_rad_s > t.wheel_setpoint.left_rad_s,
        "turning left"
    );
    assert!(out.duty.left > 0.0 && out.duty.right > 0.0);
}

#[test]
fn after_the_timeout_it_ramps_to_a_stop_and_stays_armed() {
    let mut r = velocity_rig();
    r.command(Command::Arm(arm_velocity()));
    let outs = stream(&mut r, BodyVelocity::new(0.3, 0.0), 1001);
    assert!(outs.iter().all(|o| o.state == State::Armed));
    // The last command arrived at the step of index 1000: in force there and for the
    // 499 steps after it.
    let held = heartbeats_only(&mut r, 499);
    assert!(held.iter().all(|o| o.state == State::Armed));
    let at_speed = r.ctl.telemetry().command.v_m_s;
    assert!((at_speed - 0.3).abs() < 1e-4, "{at_speed}");
    // 500 periods after the command arrived, the step ramps.
    assert!(r.ctl.velocity_source().timed_out());
    heartbeats_only(&mut r, 1);
    let ramping = r.ctl.telemetry().command.v_m_s;
    assert!(
        ramping < at_speed && ramping > 0.29,
        "ramps, does not jump: {ramping}"
    );
    let outs = heartbeats_only(&mut r, 2000);
    assert!(outs.iter().all(|o| o.state == State::Armed), "stays armed");
    assert_eq!(r.ctl.telemetry().command, BodyVelocity::new(0.0, 0.0));
    // Without heartbeats the link's own timeout disarms, as in every mode.
    let outs = r.run(600);
    assert!(events(&outs).contains(&Event::Disarmed(DisarmReason::LinkLost)));
}

#[test]
fn commands_are_refused_outside_the_velocity_mode() {
    let mut r = velocity_rig();
    let command = Command::Velocity(BodyVelocity::new(0.2, 0.0));
    let out = r.command(command);
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::WrongState(State::Disarmed)))
    );
    r.command(Command::Arm(ArmRequest::follow_path()));
    let out = r.command(command);
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::WrongMode(RunMode::FollowPath)))
    );
    // Another mode runs: arming the velocity mode is refused too.
    let out = r.command(Command::Arm(arm_velocity()));
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::WrongState(State::Armed)))
    );
    assert_eq!(r.ctl.mode(), Mode::FollowPath);
    r.command(Command::Disarm);
    r.run(100);
    r.command(Command::Arm(arm_velocity()));
    let out = r.command(Command::Velocity(BodyVelocity::new(f32::NAN, 0.0)));
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::NonFiniteVelocity))
    );
    assert_eq!(r.ctl.telemetry().law.command, BodyVelocity::new(0.0, 0.0));
}

#[test]
fn the_button_stops_it_and_never_arms_it() {
    let mut r = velocity_rig();
    r.command(Command::Arm(arm_velocity()));
    stream(&mut r, BodyVelocity::new(0.3, 0.0), 200);
    r.button = true;
    let out = r.run(r.sup.config().debounce_steps + 1);
    assert!(events(&out).contains(&Event::Disarmed(DisarmReason::Button)));
    assert_eq!(r.sup.state(), State::Disarmed);
    assert_eq!(out.last().map(|o| o.duty), Some(MotorCommand::STOP));
    r.button = false;
    r.run(200);
    // A short press after a velocity run arms path following, not the velocity mode.
    let outs = r.press(SHORT);
    assert_eq!(events(&outs), vec![Event::Armed(RunMode::FollowPath)]);
    r.press(SHORT);
    // The mode-select cycle skips it.
    let mut mode = RunMode::FollowVelocity;
    for _ in 0..6 {
        mode = mode.next();
        assert_ne!(mode, RunMode::FollowVelocity);
    }
}

#[test]
fn the_fault_checks_are_in_force() {
    // An encoder jump.
    let mut r = velocity_rig();
    r.command(Command::Arm(arm_velocity()));
    stream(&mut r, BodyVelocity::new(0.3, 0.0), 100);
    let out = r.step_with(TickDeltas {
        left: 10_000,
        right: 0,
    });
    assert_eq!(out.event, Some(Event::Faulted));
    assert_eq!(out.duty, MotorCommand::STOP);
    let out = r.command(Command::Velocity(BodyVelocity::new(0.3, 0.0)));
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::WrongState(State::Faulted)))
    );
    // Wheels that do not turn under a forward command: a stall.
    let mut r = rig();
    r.command(Command::Arm(arm_velocity()));
    let outs = stream(&mut r, BodyVelocity::new(0.3, 0.0), 2000);
    let faulted = outs.iter().find(|o| o.state == State::Faulted);
    assert!(
        faulted.is_some_and(|o| o.faults.has(Fault::StallLeft) || o.faults.has(Fault::StallRight)),
        "a stall"
    );
    // Out of the geofence.
    let mut c = config();
    c.stall.timeout_steps = u32::MAX;
    c.geofence_radius_m = Some(0.01);
    let mut r = Rig::new(c, ResetCause::PowerOn);
    r.moving = true;
    r.command(Command::Arm(ArmRequest {
        initial_motion: Some(BodyVelocity::new(0.1625, 0.0)),
        ..arm_velocity()
    }));
    let outs = stream(&mut r, BodyVelocity::new(0.16, 0.0), 1000);
    assert!(outs.iter().any(|o| o.faults.has(Fault::Geofence)));
}
