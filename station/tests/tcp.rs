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
use link::{Reply, Request, Uplink};
use robot_app::Channels;
use robot_files::scenario::Scenario;
use station::client::Client;
use station::transport::Tcp;

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
        let _ = serve(&mut robot, &listener, options, &mut log, None);
    });
    (address, received)
}

/// Held by each test for its whole length: one virtual robot and one station at a time,
/// so that a loaded machine does not starve a station of the time its heartbeats need.
fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static LINE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LINE.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
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

#[cfg(unix)]
/// `station watch` into a pipe, started now; [`stop_watching`] ends it.
fn start_watching(address: &str) -> Child {
    station(&["--connect", address, "watch"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the station starts")
}

#[cfg(unix)]
/// Ctrl-C (SIGINT) to a watch: what it printed, and on stderr.
fn stop_watching(child: Child) -> (String, String) {
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(status.success());
    let output = child.wait_with_output().expect("the station ends");
    (
        String::from_utf8_lossy(&output.stdout).to_string(),
        String::from_utf8_lossy(&output.stderr).to_string(),
    )
}

/// A run beside a watch that connected first: the run commands the robot, the watch
/// observes the whole run, and the run's result is host-sim's, bit for bit.
#[cfg(unix)]
#[test]
fn station_run_over_tcp_matches_host_sim_run() {
    let _one = one_at_a_time();
    let (address, _events) = virtual_robot("paper-circle", 120.0);
    let out = std::env::temp_dir().join(format!("station-tcp-run-{}", std::process::id()));
    let watch = start_watching(&address);
    thread::sleep(Duration::from_millis(1500));
    let got = run_and_check_summary(&address, &out);
    let (watched, watch_errors) = stop_watching(watch);
    assert!(
        watched.contains("state Armed"),
        "the watch saw the run: {watch_errors}"
    );
    let want = host_sim_summary();
    assert_eq!(got["source"], "virtual-robot");
    assert_eq!(got["complete"], true);
    assert_eq!(got["ended_by"], "time_limit");
    assert_eq!(got["steps"], want["steps"]);
    // Bit for bit: the same f32 statistics, printed the same way.
    assert_eq!(got["true_error"], want["true_error"]);
    assert_eq!(got["estimated_error"], want["estimated_error"]);
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn a_station_overtaken_by_a_newer_connection_is_told_it_only_observes() {
    let _one = one_at_a_time();
    let (address, _events) = virtual_robot("paper-circle", 120.0);
    let connect = || Client::new(Tcp::connect(&address).expect("the robot listens"));
    let mut first = connect();
    assert!(matches!(first.request(Request::Info), Ok(Reply::Info(_))));
    let mut second = connect();
    assert!(matches!(second.request(Request::Info), Ok(Reply::Info(_))));
    let refused = first
        .request(Request::Info)
        .expect_err("first only observes");
    assert!(
        refused
            .to_string()
            .contains("another connection commands this robot; this one only observes"),
        "{refused}"
    );
    // The observer still hears the robot.
    second
        .request(Request::SetTelemetryRate { hz: 50 })
        .expect("the newest connection commands");
    let heard = (0..100).find_map(|_| match first.next_message(Duration::from_millis(20)) {
        Ok(Some(Uplink::Telemetry(frame))) => Some(frame),
        _ => None,
    });
    assert!(heard.is_some(), "the observer receives telemetry");
}

#[test]
fn a_killed_station_leaves_the_robot_disarmed_within_the_heartbeat_timeout() {
    let _one = one_at_a_time();
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
    // The station puts the robot at the start, then arms it.
    let placed = next_event(&events, 30).expect("the pose is set");
    assert_eq!(placed.event, Some(Event::PoseSet));
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
                    if count.is_multiple_of(flip_every) {
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
            if seed.is_multiple_of(8) {
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
    let _one = one_at_a_time();
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

/// What a [`cutting_proxy`] does to the link. Heartbeats are counted from the station's
/// last `Arm`.
#[derive(Clone, Copy, Debug, Default)]
struct Cut {
    /// Heartbeats after this many never reach the robot (it disarms on its timeout).
    mute_heartbeats_after: Option<usize>,
    /// The connection is closed after this many heartbeats.
    close_after_heartbeats: Option<usize>,
    /// The connection is closed after this much wall-clock time.
    close_after: Option<Duration>,
}

/// Forwards bytes between a station and the robot at `robot`, cutting the link as `cut`
/// says. Returns the proxy's address.
fn cutting_proxy(robot: String, cut: Cut) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
    let address = listener.local_addr().expect("bound").to_string();
    thread::spawn(move || {
        let Ok((station_side, _)) = listener.accept() else {
            return;
        };
        let Ok(robot_side) = TcpStream::connect(&robot) else {
            return;
        };
        let close = {
            let (a, b) = (
                station_side.try_clone().expect("clone"),
                robot_side.try_clone().expect("clone"),
            );
            std::sync::Arc::new(move || {
                let _ = a.shutdown(std::net::Shutdown::Both);
                let _ = b.shutdown(std::net::Shutdown::Both);
            })
        };
        if let Some(after) = cut.close_after {
            let close = close.clone();
            thread::spawn(move || {
                thread::sleep(after);
                close();
            });
        }
        let (mut up_in, mut up_out) = (
            station_side.try_clone().expect("clone"),
            robot_side.try_clone().expect("clone"),
        );
        let close_up = close.clone();
        thread::spawn(move || {
            let close = close_up;
            let mut buf = [0u8; 512];
            let mut frame = Vec::new();
            let mut heartbeats = 0usize;
            while let Ok(n) = up_in.read(&mut buf) {
                if n == 0 {
                    break;
                }
                for &byte in &buf[..n] {
                    frame.push(byte);
                    if byte != 0 {
                        continue;
                    }
                    let frame = std::mem::take(&mut frame);
                    let request = link::Decoder::new()
                        .feed::<link::Downlink>(&frame)
                        .find_map(|o| match o {
                            Ok(link::Received::Message(d)) => Some(d.request),
                            _ => None,
                        });
                    match request {
                        Some(link::Request::Arm { .. }) => heartbeats = 0,
                        Some(link::Request::Heartbeat) => {
                            heartbeats += 1;
                            if cut.close_after_heartbeats.is_some_and(|n| heartbeats > n) {
                                close();
                                return;
                            }
                            if cut.mute_heartbeats_after.is_some_and(|n| heartbeats > n) {
                                continue;
                            }
                        }
                        _ => {}
                    }
                    if up_out.write_all(&frame).is_err() {
                        return;
                    }
                }
            }
        });
        let (mut down_in, mut down_out) = (robot_side, station_side);
        let mut buf = [0u8; 512];
        while let Ok(n) = down_in.read(&mut buf) {
            if n == 0 || down_out.write_all(&buf[..n]).is_err() {
                break;
            }
        }
    });
    address
}

/// The station with `args` against a virtual robot of `scenario` (run for at most
/// `max_s` s) behind a proxy that cuts the link as `cut` says: its output and its
/// standard error.
fn behind_a_cut(
    scenario: &str,
    max_s: f64,
    cut: Cut,
    args: &[&str],
) -> (std::process::Output, String) {
    let (robot, _events) = virtual_robot(scenario, max_s);
    let proxy = cutting_proxy(robot, cut);
    let mut all = vec!["--connect", proxy.as_str()];
    all.extend_from_slice(args);
    let output = station(&all).output().expect("the station runs");
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    (output, stderr)
}

/// A temporary output directory for the test `name`.
fn out_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("station-tcp-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn summary_of(out: &std::path::Path) -> serde_json::Value {
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary written");
    serde_json::from_str(&text).expect("json")
}

#[test]
fn a_run_the_connection_drops_in_exits_3_and_keeps_what_was_recorded() {
    let _one = one_at_a_time();
    // 30 heartbeats: about 3 s of the 30 s run.
    let out = out_dir("drop");
    let (output, stderr) = behind_a_cut(
        "paper-circle",
        120.0,
        Cut {
            close_after_heartbeats: Some(30),
            ..Cut::default()
        },
        &[
            "run",
            "paper-circle",
            "--out",
            out.to_str().expect("utf-8 path"),
        ],
    );
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains("did not end at its time limit") && stderr.contains("closed"),
        "says why: {stderr}"
    );
    let summary = summary_of(&out);
    assert_eq!(summary["complete"], false);
    assert_eq!(summary["ended_by"], "link_failed");
    let steps = summary["steps"].as_u64().expect("steps");
    assert!(steps > 1000 && steps < 30_000, "recorded {steps} steps");
    let rows = std::fs::read_to_string(out.join("trace.csv"))
        .expect("trace written")
        .lines()
        .count()
        - 1;
    assert!(
        rows as u64 >= steps / 10 - 2,
        "{rows} rows for {steps} steps"
    );
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn a_run_the_robot_ends_on_its_heartbeat_timeout_exits_3_marked_incomplete() {
    let _one = one_at_a_time();
    let out = out_dir("stall");
    let (output, stderr) = behind_a_cut(
        "paper-circle",
        120.0,
        Cut {
            mute_heartbeats_after: Some(30),
            ..Cut::default()
        },
        &[
            "run",
            "paper-circle",
            "--out",
            out.to_str().expect("utf-8 path"),
        ],
    );
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("LinkLost"), "says why: {stderr}");
    let summary = summary_of(&out);
    assert_eq!(summary["complete"], false);
    assert_eq!(summary["ended_by"], "link_lost");
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn a_tune_cut_short_exits_3_and_says_why() {
    let _one = one_at_a_time();
    let (output, stderr) = behind_a_cut(
        "paper-circle",
        120.0,
        Cut {
            mute_heartbeats_after: Some(3),
            ..Cut::default()
        },
        &["tune"],
    );
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains("the tune stopped") && stderr.contains("LinkLost"),
        "{stderr}"
    );
}

#[test]
fn a_recording_cut_short_exits_3_and_keeps_its_rows() {
    let _one = one_at_a_time();
    let out = out_dir("record");
    let (output, stderr) = behind_a_cut(
        "paper-circle",
        120.0,
        Cut {
            close_after: Some(Duration::from_millis(1500)),
            ..Cut::default()
        },
        &[
            "record",
            "--out",
            out.to_str().expect("utf-8 path"),
            "--duration-s",
            "60",
        ],
    );
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("cut short"), "{stderr}");
    let rows = std::fs::read_to_string(out.join("telemetry.csv"))
        .expect("written")
        .lines()
        .count();
    assert!(rows > 10, "{rows} lines");
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn a_calibration_whose_run_is_cut_short_twice_exits_3_naming_the_run() {
    let _one = one_at_a_time();
    let (output, stderr) = behind_a_cut(
        "square-waypoints",
        300.0,
        Cut {
            mute_heartbeats_after: Some(5),
            ..Cut::default()
        },
        &[
            "calibrate",
            "--side-m",
            "0.5",
            "--runs",
            "1",
            "--simulated-noise-m",
            "0.002",
        ],
    );
    assert_eq!(output.status.code(), Some(3), "{stderr}");
    assert!(
        stderr.contains("clockwise square 1/1") && stderr.contains("LinkLost"),
        "{stderr}"
    );
    assert!(stderr.contains("nothing was persisted"), "{stderr}");
    assert!(!String::from_utf8_lossy(&output.stdout).contains("persisted"));
}

#[test]
fn an_error_names_each_cause_once() {
    let _one = one_at_a_time();
    // A port nobody listens on.
    let address = {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
        listener.local_addr().expect("bound").to_string()
    };
    let output = station(&["--connect", &address, "info"])
        .output()
        .expect("the station runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(&format!("cannot connect to {address}")),
        "{stderr}"
    );
    assert_eq!(stderr.matches("refused").count(), 1, "{stderr}");

    // A connection the robot closes mid-run.
    let out = out_dir("closed");
    let (_, stderr) = behind_a_cut(
        "paper-circle",
        120.0,
        Cut {
            close_after_heartbeats: Some(10),
            ..Cut::default()
        },
        &[
            "run",
            "paper-circle",
            "--out",
            out.to_str().expect("utf-8 path"),
        ],
    );
    assert_eq!(
        stderr.matches("the robot closed the connection").count(),
        1,
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(out);

    // A scenario file that is not there (robot-files' error prints its source too).
    let missing = out_dir("missing");
    let scenario = missing.join("scenario.toml");
    let scenario = scenario.to_str().expect("utf-8 path");
    let output = station(&["run", scenario, "--out", missing.to_str().expect("utf-8")])
        .output()
        .expect("the station runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.matches("not found").count(), 1, "{stderr}");
}

#[test]
fn counts_and_sections_print_as_they_are() {
    let _one = one_at_a_time();
    let (address, _events) = virtual_robot("paper-line", 120.0);
    // What the robot's board found, one line each; the virtual robot keeps no failure.
    let output = station(&["--connect", &address, "info"])
        .output()
        .expect("the station runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}");
    for line in [
        "clock        simulated",
        "brown-out    level 3: resets below 2.75–2.88 V",
        "last failure none recorded",
    ] {
        assert!(stdout.lines().any(|l| l == line), "{line:?} in\n{stdout}");
    }
    // One segment is a segment.
    let output = station(&["--connect", &address, "path", "upload", "paper-line"])
        .output()
        .expect("the station runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}");
    assert!(stdout.contains(": 1 segment, 10.000 m"), "{stdout}");
    // No empty section in what `params get` prints.
    let output = station(&["--connect", &address, "params", "get"])
        .output()
        .expect("the station runs");
    let text = String::from_utf8_lossy(&output.stdout).to_string();
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    for (i, line) in lines.iter().enumerate() {
        if line.starts_with('[') {
            assert!(
                lines.get(i + 1).is_some_and(|next| !next.starts_with('[')),
                "section {line} is empty:\n{text}"
            );
        }
    }
    // A second's recording at 100 Hz on a 1 kHz robot: 100 rows, the frame at 1.000 s
    // being the next second's.
    let out = out_dir("one-second");
    let output = station(&[
        "--connect",
        &address,
        "record",
        "--out",
        out.to_str().expect("utf-8 path"),
        "--duration-s",
        "1",
    ])
    .output()
    .expect("the station runs");
    assert!(output.status.success());
    let csv = std::fs::read_to_string(out.join("telemetry.csv")).expect("written");
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(
        rows.len(),
        100,
        "{}",
        String::from_utf8_lossy(&output.stdout)
    );
    assert!(rows[0].split(',').nth(1) == Some("0.000"), "{}", rows[0]);
    assert!(rows[99].split(',').nth(1) == Some("0.990"), "{}", rows[99]);
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn a_short_run_says_what_its_rms_is_over_and_stats_say_what_is_not_measured() {
    let _one = one_at_a_time();
    let (address, _events) = virtual_robot("paper-line", 120.0);
    let out = out_dir("short");
    std::fs::create_dir_all(&out).expect("created");
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../robot-files/scenarios/paper-line.toml"),
    )
    .expect("paper-line");
    let scenario = out.join("short-line.toml");
    std::fs::write(
        &scenario,
        text.replace("duration_s = 30.0", "duration_s = 5.4")
            .replace("name = \"paper-line\"", "name = \"short-line\""),
    )
    .expect("written");
    let output = station(&[
        "--connect",
        &address,
        "run",
        scenario.to_str().expect("utf-8 path"),
        "--out",
        out.to_str().expect("utf-8 path"),
    ])
    .output()
    .expect("the station runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}");
    assert!(!stdout.contains("last 10 s"), "{stdout}");
    assert!(
        stdout.contains("over the whole run (0.0–5.4 s): RMS "),
        "{stdout}"
    );
    let _ = std::fs::remove_dir_all(out);

    // The virtual robot counts no CPU cycles and no stack.
    let output = station(&["--connect", &address, "stats"])
        .output()
        .expect("the station runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("longest step not measured") && stdout.contains("stack not measured"),
        "{stdout}"
    );
    assert!(
        !stdout.contains(" 0 cycles") && !stdout.contains(" 0 B"),
        "{stdout}"
    );
}

/// `station watch` into a pipe for `wait`, then Ctrl-C (SIGINT): what it printed.
#[cfg(unix)]
fn watched(address: &str, wait: Duration) -> String {
    let child = start_watching(address);
    thread::sleep(wait);
    stop_watching(child).0
}

#[cfg(unix)]
#[test]
fn watch_into_a_pipe_writes_plain_lines_and_a_disarmed_robot_s_motors_off() {
    let _one = one_at_a_time();
    let (address, _events) = virtual_robot("paper-circle", 120.0);
    let text = watched(&address, Duration::from_millis(2000));
    let start: String = text.chars().take(800).collect();
    assert!(text.matches("state Disarmed").count() >= 2, "{start}");
    assert!(!text.contains('\u{1b}'), "no escape codes: {start:?}");
    assert!(text.contains("motors            off (Disarmed)"), "{start}");
}

#[test]
fn pose_tells_the_robot_where_it_is_and_refuses_a_field_that_is_not_a_number_by_name() {
    let _one = one_at_a_time();
    let (address, events) = virtual_robot("paper-line", 60.0);
    let output = station(&[
        "--connect",
        &address,
        "pose",
        "--x-m",
        "-0.25",
        "--y-m",
        "1.5",
        "--theta-rad",
        "0.5",
    ])
    .output()
    .expect("the station runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}");
    assert!(
        stdout.contains("pose set: (-0.25 m, 1.5 m, 0.5 rad)"),
        "{stdout}"
    );
    let set =
        std::iter::from_fn(|| next_event(&events, 10)).find(|r| r.event == Some(Event::PoseSet));
    assert!(set.is_some(), "the robot took the pose command");
    let output = station(&[
        "--connect",
        &address,
        "pose",
        "--x-m",
        "0",
        "--y-m",
        "NaN",
        "--theta-rad",
        "0",
    ])
    .output()
    .expect("the station runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("the robot refused SetPose: invalid argument: y_m must be finite"),
        "{stderr}"
    );
}
