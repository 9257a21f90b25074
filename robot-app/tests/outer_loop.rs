//! The outer loop lent to a lower-priority task (as the firmware runs it) against the
//! outer loop run in the control step (as the virtual robot runs it): the same robot.

mod support;

use controller_core::supervisor::{Event, State};
use link::{ArmMode, Reply, Request};
use robot_app::{Actuation, Channels};
use support::Rig;

const BAUD: u32 = 921_600;

fn follow_path() -> Request {
    Request::Arm {
        mode: ArmMode::FollowPath,
        initial_motion: None,
        run_time_limit_steps: None,
    }
}

#[test]
fn lending_the_outer_loop_changes_nothing_the_robot_does() {
    let mut inline_channels = Channels::new();
    let mut lent_channels = Channels::new();
    let mut inline = Rig::new(&mut inline_channels, BAUD, false);
    let mut lent = Rig::lending(&mut lent_channels, BAUD, false);
    for rig in [&mut inline, &mut lent] {
        rig.heartbeat_every = Some(50);
        rig.send(Request::SetTelemetryRate { hz: 50 });
        rig.send(follow_path());
    }
    let (mut lent_steps, mut steering_updates) = (0, 0);
    for k in 0..3000 {
        let a = inline.step();
        let b = lent.step();
        assert_eq!(
            a,
            Actuation {
                steering_lent: false,
                ..b
            },
            "step {k}"
        );
        assert!(!a.steering_lent, "the inline side lends nothing");
        lent_steps += u32::from(b.steering_lent);
        let t = lent.control.controller().telemetry();
        assert_eq!(inline.control.controller().telemetry(), t, "step {k}");
        steering_updates += u32::from(t.steering_updated);
    }
    assert_eq!(lent.last.map(|a| a.state), Some(State::Armed));
    // Following the path, the law ran every tenth step, each time lent and applied.
    assert!(lent_steps > 250, "{lent_steps}");
    assert_eq!(steering_updates, lent_steps);
    assert!(lent.control.controller().telemetry().pose.x_m > 0.1);
    assert_eq!(inline.telemetry(), lent.telemetry());
    assert!(!lent.telemetry().is_empty());
}

#[test]
fn an_outer_loop_that_overruns_the_period_is_an_overrun() {
    let mut channels = Channels::new();
    let mut rig = Rig::lending(&mut channels, BAUD, false);
    rig.heartbeat_every = Some(50);
    assert_eq!(rig.ask(follow_path()), Ok(Reply::Ack));
    // The next step that lends the outer loop: its job is not run before the next step.
    rig.stall_worker_steps = 1;
    // Following the path, the law is due every tenth step.
    assert!(
        (0..20).any(|_| rig.step().steering_lent),
        "no step lent the outer loop"
    );
    let overruns = rig.last.map_or(0, |a| a.overruns_total);
    // A request waits while the outer loop is away.
    let seq = rig.send(Request::Disarm);
    let late = rig.step();
    assert_eq!(late.overruns_total, overruns + 1);
    assert!(!late.steering_lent);
    assert_eq!(
        rig.reply(seq),
        None,
        "not taken while the outer loop is away"
    );
    assert_eq!(late.state, State::Armed);
    // Back at the next step: the request is taken, and nothing else overran.
    rig.run(2);
    assert_eq!(rig.reply(seq), Some(Ok(Reply::Ack)));
    assert_eq!(rig.last.map(|a| a.overruns_total), Some(overruns + 1));
    assert!(rig.events().iter().any(|e| matches!(e, Event::Disarmed(_))));
    assert_eq!(rig.last.map(|a| a.state), Some(State::Disarmed));
}

#[test]
fn every_step_takes_a_waiting_request_the_ones_that_apply_the_law_too() {
    let mut channels = Channels::new();
    let mut rig = Rig::lending(&mut channels, BAUD, false);
    assert_eq!(rig.ask(follow_path()), Ok(Reply::Ack));
    let mut on_steering_steps = 0;
    for k in 0..40 {
        let seq = rig.send(Request::Heartbeat);
        rig.step();
        assert!(rig.reply(seq).is_some(), "step {k}: answered at once");
        on_steering_steps += u32::from(rig.control.controller().telemetry().steering_updated);
    }
    assert!(
        on_steering_steps >= 3,
        "{on_steering_steps} requests fell on a steering step"
    );
}

#[test]
fn a_job_due_while_the_outer_loop_is_away_waits_to_be_lent_not_run_in_the_control_step() {
    let mut channels = Channels::new();
    let mut rig = Rig::lending(&mut channels, BAUD, false);
    // A robot configured to bear an outer loop late by more than a steering period (the
    // default faults first).
    let mut params = support::default_params();
    params.supervisor.max_consecutive_overruns = 50;
    assert!(matches!(
        rig.ask(Request::SetParams(params)),
        Ok(Reply::ParamsApplied { .. })
    ));
    rig.heartbeat_every = Some(50);
    assert_eq!(rig.ask(follow_path()), Ok(Reply::Ack));
    rig.run(100);
    // Away for more than a steering period (10 steps): the next job falls due meanwhile.
    rig.stall_worker_steps = 15;
    let (mut lent, mut updates) = (0, 0);
    for _ in 0..100 {
        lent += u32::from(rig.step().steering_lent);
        updates += u32::from(rig.control.controller().telemetry().steering_updated);
    }
    assert_eq!(rig.last.map(|a| a.state), Some(State::Armed));
    // Every update the controller applied came back from a lent outer loop.
    assert!(lent >= 8, "{lent}");
    assert_eq!(updates, lent);
}
