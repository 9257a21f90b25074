//! `station ros2 --arm` when the link to the robot drops: the virtual robot goes away
//! (its connection closes, its port is shut), and a new one comes up on the same port a
//! second later. The bridge must connect to the new robot by itself and arm its velocity
//! mode again. No DDS peer takes part: the bridge's node only publishes. Wall-clock time
//! only bounds how long the test waits.

use std::net::TcpListener;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::thread;
use std::time::Duration;

use controller_core::supervisor::{Event, RunMode};
use host_sim::serve::{serve, ServeOptions, VirtualRobot};
use robot_app::Channels;
use robot_files::scenario::Scenario;
use station::ros2::bridge::{run, BridgeOptions};
use station::ros2::connection::RobotAddress;

/// The test's own DDS domain.
const DOMAIN: u16 = 77;

/// Serves one virtual robot of paper-circle at real time on `listener` for `seconds`;
/// whether it was armed in the velocity mode.
fn serve_for(listener: &TcpListener, seconds: f64) -> bool {
    let scenario = Scenario::load("paper-circle").expect("built in");
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid");
    let options = ServeOptions {
        speed: 1.0,
        max_steps: Some((seconds * 1000.0) as u64),
    };
    let mut armed = false;
    let mut log = |report: &host_sim::serve::StepReport| {
        armed |= report.event == Some(Event::Armed(RunMode::FollowVelocity));
    };
    serve(&mut robot, listener, options, &mut log, None).expect("served");
    armed
}

#[test]
fn the_bridge_reconnects_and_rearms_when_the_robot_comes_back() {
    let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
    let address = listener.local_addr().expect("bound");
    let robots = thread::spawn(move || {
        let first = serve_for(&listener, 3.0);
        drop(listener);
        // Down for a while: the bridge's connection attempts are refused.
        thread::sleep(Duration::from_millis(1500));
        let listener = TcpListener::bind(address).expect("the same port again");
        let second = serve_for(&listener, 4.0);
        (first, second)
    });
    let counts = run(BridgeOptions {
        robot: RobotAddress::Tcp(address.to_string()),
        arm: true,
        domain_id: DOMAIN,
        node_name: "station_link_drop_test".to_string(),
        parameters: Vec::new(),
        interrupt: Arc::new(AtomicBool::new(false)),
        duration: Some(Duration::from_secs(8)),
    })
    .expect("the bridge ran");
    let (first_armed, second_armed) = robots.join().expect("the robots' thread");
    assert_eq!(counts.connections, 2, "{counts:?}");
    assert!(first_armed, "the bridge armed the first robot");
    assert!(second_armed, "the bridge armed the robot that came back");
    assert!(counts.odom_published > 0, "{counts:?}");
}
