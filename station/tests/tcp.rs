//! The station binary against the virtual robot over TCP, as a user runs them: the same
//! result as `host-sim run`, a killed station, and a corrupted line. The virtual robot
//! runs in a thread of this test at a few times real time; wall-clock time only bounds
//! how long a test waits, it never decides a result.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::thread;
use std::time::Duration;

use controller_core::law::LawKind;
use controller_core::supervisor::{DisarmReason, Event};
use host_sim::serve::{serve, ServeOptions, StepReport, VirtualRobot};
use robot_app::Channels;
use robot_files::scenario::Scenario;

/// Simulated time per wall-clock time: 30 s runs take 7.5 s; the station's heartbeats
/// (every 100 robot steps) have 125 ms of wall-clock time before the 500-step timeout.
const SPEED: f64 = 4.0;

/// A virtual robot of `scenario` serving on a free local port for at most `max_s`
/// simulated seconds; its state changes come through the receiver.
fn virtual_robot(scenario: &str, max_s: f64) -> (String, Receiver<StepReport>) {
    let scenario = Scenario::load(scenario).expect("built in");
    let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
    let address = listener.local_addr().expect("bound").to_string();
    let (events, received) = channel();
    thread::spawn(move || {
        let mut channels = Channels::new();
        let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid");
        let options = ServeOptions {
            speed: SPEED,
            max_steps: Some((max_s * 1000.0) as u64),
        };
        let mut log = |r: &StepReport| {
            let _ = events.send(*r);
        };
        let _ = serve(&mut robot, &listener, options, &mut log);
    });
    (address, received)
}

fn station(args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_station"));
    command.args(args);
    command
}

/// The next state change of the robot, waiting at most `wait_s` wall-clock seconds.
fn next_event(events: &Receiver<StepReport>, wait_s: u64) -> Option<StepReport> {
    events.recv_timeout(Duration::from_secs(wait_s)).ok()
}

fn run_and_check_summary(address: &str, out: &std::path::Path) -> serde_json::Value {
    let output = station(&[
        "--connect",
        address,
        "run",
        "paper-circle",
        "--out",
        out.to_str().expect("utf-8 path"),
    ])
    .output()
    .expect("the station runs");
    assert!(
        output.status.success(),
        "station run failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary written");
    for figure in [
        "fig5_path.svg",
        "fig6_errors.svg",
        "fig7_inputs.svg",
        "trace.csv",
    ] {
        assert!(out.join(figure).exists(), "{figure} written");
    }
    serde_json::from_str(&text).expect("json")
}

fn host_sim_summary() -> serde_json::Value {
    let scenario = Scenario::load("paper-circle").expect("built in");
    let result = host_sim::run_scenario(&scenario, LawKind::Tracking).expect("runs");
    // Through text, as the station's summary.json is read: the same digits parse the same.
    let text = serde_json::to_string(&result.summary).expect("json");
    serde_json::from_str(&text).expect("json")
}

#[test]
fn station_run_over_tcp_matches_host_sim_run() {
    let (address, _events) = virtual_robot("paper-circle", 120.0);
    let out = std::env::temp_dir().join(format!("station-tcp-run-{}", std::process::id()));
    let got = run_and_check_summary(&address, &out);
    let want = host_sim_summary();
    assert_eq!(got["source"], "virtual-robot");
    assert_eq!(got["steps"], want["steps"]);
    // Bit for bit: the same f32 statistics, printed the same way.
    assert_eq!(got["true_error"], want["true_error"]);
    assert_eq!(got["estimated_error"], want["estimated_error"]);
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn a_killed_station_leaves_the_robot_disarmed_within_the_heartbeat_timeout() {
    let (address, events) = virtual_robot("paper-circle", 120.0);
    let out = std::env::temp_dir().join(format!("station-tcp-kill-{}", std::process::id()));
    let mut child: Child = station(&[
        "--connect",
        &address,
        "run",
        "paper-circle",
        "--out",
        out.to_str().expect("utf-8 path"),
    ])
    .stdout(Stdio::null())
    .stderr(Stdio::null())
    .spawn()
    .expect("the station starts");
    let armed = next_event(&events, 30).expect("the robot arms");
    assert_eq!(
        armed.event,
        Some(Event::Armed(
            controller_core::supervisor::RunMode::FollowPath
        ))
    );
    // Let it run a while (robot time passes at SPEED), then kill the station outright.
    thread::sleep(Duration::from_millis(1500));
    child.kill().expect("killed");
    let _ = child.wait();
    let stopped = next_event(&events, 30).expect("the robot stops");
    assert_eq!(stopped.event, Some(Event::Disarmed(DisarmReason::LinkLost)));
    let timeout = Scenario::load("paper-circle")
        .expect("built in")
        .supervisor
        .heartbeat_timeout_steps;
    // The supervisor counts from the step it took the last heartbeat, which is at most
    // one step after the link side received it.
    assert!(
        stopped.steps_since_heartbeat <= timeout + 1,
        "disarmed {} steps after the last heartbeat (timeout {timeout})",
        stopped.steps_since_heartbeat
    );
    assert!(stopped.steps_since_heartbeat >= timeout);
    let _ = std::fs::remove_dir_all(out);
}

/// Forwards bytes between a station and the robot: towards the robot one byte in
/// `flip_every` gets a bit flipped, and towards the station a burst of random bytes goes
/// between reads. Returns the proxy's address.
fn corrupting_proxy(robot: String, flip_every: usize) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
    let address = listener.local_addr().expect("bound").to_string();
    thread::spawn(move || {
        let Ok((station_side, _)) = listener.accept() else {
            return;
        };
        let Ok(robot_side) = TcpStream::connect(&robot) else {
            return;
        };
        let (mut up_in, mut up_out) = (
            station_side.try_clone().expect("clone"),
            robot_side.try_clone().expect("clone"),
        );
        thread::spawn(move || {
            let mut buf = [0u8; 512];
            let mut count = 0usize;
            while let Ok(n) = up_in.read(&mut buf) {
                if n == 0 {
                    break;
                }
                for byte in &mut buf[..n] {
                    count += 1;
                    if count % flip_every == 0 {
                        *byte ^= 1 << (count % 8);
                    }
                }
                if up_out.write_all(&buf[..n]).is_err() {
                    break;
                }
            }
        });
        let (mut down_in, mut down_out) = (robot_side, station_side);
        let mut buf = [0u8; 512];
        let mut seed = 0x2545_f491_u64;
        while let Ok(n) = down_in.read(&mut buf) {
            if n == 0 {
                break;
            }
            if down_out.write_all(&buf[..n]).is_err() {
                break;
            }
            // Random bytes between whole writes of the robot (which end on frame ends).
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            if seed % 8 == 0 {
                let junk: Vec<u8> = (0..(seed % 40) as usize)
                    .map(|i| (seed >> (i % 56)) as u8 | 1)
                    .chain([0])
                    .collect();
                if down_out.write_all(&junk).is_err() {
                    break;
                }
            }
        }
    });
    address
}

#[test]
fn corrupted_and_random_bytes_are_dropped_and_the_run_goes_on() {
    let (robot, _events) = virtual_robot("paper-circle", 120.0);
    let proxy = corrupting_proxy(robot.clone(), 1000);
    let out = std::env::temp_dir().join(format!("station-tcp-noise-{}", std::process::id()));
    let got = run_and_check_summary(&proxy, &out);
    // The run went on to its end and still matches the simulator: requests whose frames
    // were corrupted were sent again, and corrupted heartbeats were made up by the next.
    let want = host_sim_summary();
    assert_eq!(got["steps"], want["steps"]);
    assert_eq!(got["true_error"], want["true_error"]);
    // The robot counted what it dropped.
    let stats = station(&["--connect", &robot, "stats"])
        .output()
        .expect("stats");
    let text = String::from_utf8_lossy(&stats.stdout).to_string();
    let crc: u64 = text
        .split("dropped: ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or(0);
    assert!(crc > 0, "the robot dropped corrupted frames: {text}");
    let _ = std::fs::remove_dir_all(out);
}
