//! The bring-up's motor pulse: one wheel at a bounded voltage for a bounded time, a short
//! armed mode that every check and the button stop like any run.

use super::*;

fn pulse(wheel: Wheel, volts: f32, steps: u32) -> Command {
    Command::MotorTest(MotorTestRequest {
        wheel,
        volts,
        steps,
    })
}

#[test]
fn a_pulse_drives_one_wheel_for_its_steps_then_disarms() {
    let mut r = rig();
    r.run(200);
    let out = r.command(pulse(Wheel::Right, -2.0, 100));
    assert_eq!(out.command_result, Some(Ok(())));
    assert_eq!(out.event, Some(Event::Armed(RunMode::MotorTest)));
    assert_eq!(out.state, State::Armed);
    let outs = r.run(150);
    let driven: Vec<_> = outs.iter().filter(|o| o.state == State::Armed).collect();
    // The arming step and 99 more: 100 steps armed in all.
    assert_eq!(driven.len(), 99);
    assert!(driven
        .iter()
        .all(|o| o.duty.left == 0.0 && o.duty.right < 0.0));
    assert!(events(&outs).contains(&Event::Disarmed(DisarmReason::Timeout)));
    assert_eq!(r.sup.state(), State::Disarmed);
}

#[test]
fn the_button_stops_a_pulse() {
    let mut r = rig();
    r.run(200);
    r.command(pulse(Wheel::Left, 2.0, 400));
    r.run(10);
    r.button = true;
    let outs = r.run(40);
    assert!(events(&outs).contains(&Event::Disarmed(DisarmReason::Button)));
    assert_eq!(r.sup.state(), State::Disarmed);
}

#[test]
fn a_pulse_out_of_bounds_or_not_from_disarmed_is_refused() {
    let mut r = rig();
    r.run(200);
    for bad in [
        pulse(Wheel::Left, MOTOR_TEST_MAX_VOLTS + 0.1, 100),
        pulse(Wheel::Left, f32::NAN, 100),
        pulse(Wheel::Left, 1.0, 0),
        pulse(Wheel::Left, 1.0, MOTOR_TEST_MAX_MS + 1),
    ] {
        let out = r.command(bad);
        assert_eq!(
            out.command_result,
            Some(Err(CommandRefusal::MotorTestOutOfBounds)),
            "{bad:?}"
        );
        assert_eq!(out.state, State::Disarmed);
    }
    r.command(Command::EmergencyStop);
    let out = r.command(pulse(Wheel::Left, 1.0, 100));
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::WrongState(State::Faulted)))
    );
}

#[test]
fn the_button_never_selects_the_pulse() {
    let mut mode = RunMode::FollowPath;
    for _ in 0..6 {
        mode = mode.next();
        assert_ne!(mode, RunMode::MotorTest);
    }
    assert_eq!(RunMode::MotorTest.next(), RunMode::FollowPath);
}
