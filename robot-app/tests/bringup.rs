//! What a bring-up needs of the robot, on the fake board: the bounded motor pulse, the
//! board's raw encoder counts in telemetry, and the wiring corrections between the board
//! and the wheels.

mod support;

use controller_core::supervisor::{DisarmReason, Event, RunMode, Wheel};
use link::{ArmMode, FieldProblem, NotPermitted, Refusal, Reply, Request, MOTOR_TEST_CONFIRMATION};
use robot_app::Channels;
use support::{default_params, Rig, SUPPLY_V};

const BAUD: u32 = 921_600;

fn pulse(wheel: Wheel, volts: f32, duration_ms: u16) -> Request {
    Request::MotorTest {
        wheel,
        volts,
        duration_ms,
        confirm: MOTOR_TEST_CONFIRMATION,
    }
}

#[test]
fn a_motor_pulse_drives_one_wheel_for_its_time_then_disarms() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    assert_eq!(
        rig.ask(Request::SetTelemetryRate { hz: 100 }),
        Ok(Reply::Ack)
    );
    rig.run(100);
    assert_eq!(rig.ask(pulse(Wheel::Left, 2.0, 200)), Ok(Reply::Ack));
    let mut driven_steps = 0;
    for _ in 0..400 {
        let out = rig.step();
        if out.duty.left > 0.0 {
            driven_steps += 1;
        }
        assert_eq!(out.duty.right, 0.0, "the other wheel stays at 0 V");
    }
    // 200 ms at 1 kHz, give or take the step that took the request.
    assert!((195..=201).contains(&driven_steps), "{driven_steps}");
    let events = rig.events();
    assert!(
        events.contains(&Event::Armed(RunMode::MotorTest)),
        "{events:?}"
    );
    assert!(
        events.contains(&Event::Disarmed(DisarmReason::Timeout)),
        "{events:?}"
    );
    // The encoder's answer, raw, in the telemetry, disarmed as armed.
    let frames = rig.telemetry();
    let last = frames.last().expect("telemetry");
    assert!(last.raw_counts.left > 100, "{:?}", last.raw_counts);
    assert_eq!(last.raw_counts.right, 0);
}

#[test]
fn a_motor_pulse_is_refused_by_name_outside_its_bounds() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    rig.run(100);
    let unconfirmed = Request::MotorTest {
        wheel: Wheel::Left,
        volts: 1.0,
        duration_ms: 100,
        confirm: 0,
    };
    assert_eq!(
        rig.ask(unconfirmed),
        Err(Refusal::NotPermitted(NotPermitted::MotorTestUnconfirmed))
    );
    let field_of = |r: Result<Reply, Refusal>| match r {
        Err(Refusal::InvalidArgument(FieldProblem { field, .. })) => field.to_string(),
        other => format!("{other:?}"),
    };
    assert_eq!(field_of(rig.ask(pulse(Wheel::Right, -3.5, 100))), "volts");
    assert_eq!(
        field_of(rig.ask(pulse(Wheel::Right, f32::NAN, 100))),
        "volts"
    );
    assert_eq!(
        field_of(rig.ask(pulse(Wheel::Right, 1.0, 501))),
        "duration_ms"
    );
    assert_eq!(
        field_of(rig.ask(pulse(Wheel::Right, 1.0, 0))),
        "duration_ms"
    );
    // Only from Disarmed.
    rig.heartbeat_every = Some(50);
    assert_eq!(
        rig.ask(Request::Arm {
            mode: ArmMode::HoldWheelSpeeds(controller_core::kinematics::WheelSpeeds::new(0.0, 0.0)),
            initial_motion: None,
            run_time_limit_steps: None,
        }),
        Ok(Reply::Ack)
    );
    assert_eq!(rig.ask(pulse(Wheel::Left, 1.0, 100)), Err(Refusal::Armed));
}

#[test]
fn the_wiring_sits_between_the_board_and_the_wheels() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let mut params = default_params();
    params.robot.wiring.motors_swapped = true;
    params.robot.wiring.right_motor_inverted = true;
    params.robot.wiring.supply_scale = 1.25;
    assert!(matches!(
        rig.ask(Request::SetParams(params)),
        Ok(Reply::ParamsApplied { .. })
    ));
    assert_eq!(
        rig.ask(Request::SetTelemetryRate { hz: 100 }),
        Ok(Reply::Ack)
    );
    rig.run(200);
    // The left wheel's motor is on the board's right output, and not inverted.
    assert_eq!(rig.ask(pulse(Wheel::Left, 2.0, 100)), Ok(Reply::Ack));
    let outs: Vec<_> = (0..50).map(|_| rig.step()).collect();
    assert!(outs.iter().any(|o| o.duty.right > 0.0));
    assert!(outs.iter().all(|o| o.duty.left == 0.0));
    rig.run(1000);
    // The right wheel's, inverted, on the left output.
    assert_eq!(rig.ask(pulse(Wheel::Right, 2.0, 100)), Ok(Reply::Ack));
    let outs: Vec<_> = (0..50).map(|_| rig.step()).collect();
    assert!(outs.iter().any(|o| o.duty.left < 0.0));
    assert!(outs.iter().all(|o| o.duty.right == 0.0));
    // The supply the robot works with is its board's reading scaled.
    let supply = rig.telemetry().last().expect("telemetry").supply_v;
    assert!((supply - 1.25 * SUPPLY_V).abs() < 0.01, "{supply}");
}

#[test]
fn an_inverted_encoder_is_corrected_but_its_raw_count_is_not() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let mut params = default_params();
    params.robot.wiring.left_encoder_inverted = true;
    assert!(matches!(
        rig.ask(Request::SetParams(params)),
        Ok(Reply::ParamsApplied { .. })
    ));
    assert_eq!(
        rig.ask(Request::SetTelemetryRate { hz: 100 }),
        Ok(Reply::Ack)
    );
    rig.run(200);
    assert_eq!(rig.ask(pulse(Wheel::Left, 2.0, 100)), Ok(Reply::Ack));
    rig.run(60);
    let frame = *rig.telemetry().last().expect("telemetry");
    // The fake board's wheel turns forward: its raw count goes up, the robot reads it
    // backwards as told.
    assert!(frame.raw_counts.left > 0, "{:?}", frame.raw_counts);
    assert!(
        frame.wheel_speed.left_rad_s < 0.0,
        "{:?}",
        frame.wheel_speed
    );
}

#[test]
fn a_pulse_of_the_longest_duration_is_accepted_and_runs_its_time() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    rig.run(100);
    assert_eq!(rig.ask(pulse(Wheel::Left, 1.0, 500)), Ok(Reply::Ack));
    let driven_steps = (0..700).filter(|_| rig.step().duty.left > 0.0).count();
    // 500 ms at 1 kHz, give or take the step that took the request.
    assert!((495..=501).contains(&driven_steps), "{driven_steps}");
    assert!(rig
        .events()
        .contains(&Event::Disarmed(DisarmReason::Timeout)));
}
