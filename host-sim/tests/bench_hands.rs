//! The virtual robot's bench hands (tests only) reach the robot as a real bench's would.

use controller_core::supervisor::{Event, Wheel};
use host_sim::serve::hands::{hands, HandAnswer, HandCommand};
use host_sim::serve::VirtualRobot;
use robot_app::Channels;
use robot_files::scenario::Scenario;

#[test]
fn a_long_press_sets_the_pose_and_a_hand_turn_reaches_the_robot_through_the_wires() {
    let scenario = Scenario::load("paper-circle").expect("built in");
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid");
    robot.miswire(
        "encoders-swapped,left-encoder-inverted"
            .parse()
            .expect("valid"),
    );
    let (remote, bench) = hands();
    robot.attach_hands(bench);
    for _ in 0..100 {
        robot.step();
    }
    remote
        .commands
        .send(HandCommand::Press { ms: 2000 })
        .expect("hands");
    let events: Vec<Event> = (0..2500).filter_map(|_| robot.step().event).collect();
    assert!(events.contains(&Event::PoseSet), "{events:?}");
    assert_eq!(remote.answers.try_recv(), Ok(HandAnswer::Released));
    let before = robot.control().controller().pose().theta_rad;
    remote
        .commands
        .send(HandCommand::Turn {
            wheel: Wheel::Left,
            turns: 1.0,
        })
        .expect("hands");
    for _ in 0..600 {
        robot.step();
    }
    assert!(matches!(
        remote.answers.try_recv(),
        Ok(HandAnswer::Turned { .. })
    ));
    // The left wheel's encoder is on the right input and counts down: the robot, not
    // told, believes its right wheel turned one turn backward.
    let pose = robot.control().controller().pose();
    let track = f64::from(scenario.robot.track_width_m);
    let rim = f64::from(scenario.robot.wheel_radius_right_m) * std::f64::consts::TAU;
    // A right wheel backward alone turns the robot clockwise by rim / track.
    let expected = -(rim / track);
    let turned = f64::from(pose.theta_rad - before);
    let wrapped =
        (expected + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    let off = (turned - wrapped + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
        - std::f64::consts::PI;
    assert!(off.abs() < 0.05, "{turned} rad, expected {wrapped}");
    remote.commands.send(HandCommand::ReadLed).expect("hands");
    robot.step();
    match remote.answers.try_recv() {
        Ok(HandAnswer::Led { on_steps, of_steps }) => {
            assert_eq!(of_steps, 1000);
            assert!((45..=55).contains(&on_steps), "{on_steps}");
        }
        other => panic!("{other:?}"),
    }
}
