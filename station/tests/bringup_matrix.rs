//! `station bringup` against miswired virtual robots: the test plays the bench's hands
//! (turning a wheel, pressing the button, looking at the LED) through the virtual robot's
//! test-only hands, and the user's words (a multimeter reading, `done`) through the
//! bring-up's answers; what the bring-up finds comes from the robot's own signals. Each
//! case is then checked: the robot's parameters undo the miswiring, and `station run
//! paper-circle` settles within 5 % of the correctly wired robot's settle time.
//!
//! CI runs a few cases; `cargo xtask bringup-matrix` runs every single miswiring and a
//! few pairs (`the_whole_matrix`, ignored otherwise), and the two steps the matrix leaves
//! out, the tune and the calibration, on a robot whose wheels and track are off
//! (`the_tune_and_the_calibration`, ignored otherwise). The gyro step runs on a robot
//! whose IMU is mounted upside down and reads 3 % high
//! (`the_gyro_step_finds_an_upside_down_imu_and_its_scale`).

use std::io::{BufRead, BufReader, Write};
use std::net::TcpListener;
use std::process::{Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::thread;
use std::time::Duration;

use host_sim::serve::hands::{hands, HandAnswer, HandCommand, HandsRemote};
use host_sim::serve::miswire::Miswiring;
use host_sim::serve::{serve, ServeOptions, VirtualRobot};
use link::ParamSet;
use robot_app::Channels;
use robot_files::scenario::Scenario;
use station::client::Client;
use station::transport::Tcp;

/// Simulated time per wall-clock time (the station's heartbeats, as in `tcp.rs`).
const SPEED: f64 = 4.0;
/// The steps a bring-up runs here: the tune and the calibration change the robot beyond
/// its wiring, so the settle time would not compare with the correctly wired robot's.
const STEPS: [&str; 5] = ["link", "button", "supply", "encoders", "motors"];
/// Largest difference of a corrected robot's settle time from the correctly wired one's.
const SETTLE_TOLERANCE: f64 = 0.05;

/// One at a time: a loaded machine must not starve a station of its heartbeats' time.
fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static LINE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LINE.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A virtual robot of paper-circle miswired as `miswiring`, serving on a free port for at
/// most `max_s` simulated seconds, and the remote of its hands.
fn virtual_robot(miswiring: Miswiring, max_s: f64) -> (String, HandsRemote) {
    served(
        Scenario::load("paper-circle").expect("built in"),
        miswiring,
        max_s,
    )
}

/// A virtual robot of `scenario`, as [`virtual_robot`].
fn served(scenario: Scenario, miswiring: Miswiring, max_s: f64) -> (String, HandsRemote) {
    let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
    let address = listener.local_addr().expect("bound").to_string();
    let (remote, bench_hands) = hands();
    thread::spawn(move || {
        let mut channels = Channels::new();
        let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid");
        robot.miswire(miswiring);
        robot.attach_hands(bench_hands);
        let options = ServeOptions {
            speed: SPEED,
            max_steps: Some((max_s * 1000.0) as u64),
        };
        let _ = serve(&mut robot, &listener, options, &mut |_| {}, None);
    });
    (address, remote)
}

fn wait_for(remote: &HandsRemote) -> HandAnswer {
    remote
        .answers
        .recv_timeout(Duration::from_secs(30))
        .expect("the hands answer")
}

/// Where the robot stands, measured on the floor.
fn tape(remote: &HandsRemote) -> robot_files::truth::TruePose {
    remote
        .commands
        .send(HandCommand::MeasurePose)
        .expect("hands");
    match wait_for(remote) {
        HandAnswer::Pose(p) => p,
        other => panic!("the tape: {other:?}"),
    }
}

/// What the user answers to `question`, doing with the hands what it asks first.
fn answer(question: &str, remote: &HandsRemote, supply_v: f64) -> String {
    let turn = |wheel| {
        remote
            .commands
            .send(HandCommand::Turn { wheel, turns: 1.0 })
            .expect("hands");
        assert!(matches!(wait_for(remote), HandAnswer::Turned { .. }));
        "done".to_string()
    };
    if question.contains("multimeter") {
        format!("{supply_v:.3}")
    } else if question.contains("turn the left wheel forward one turn") {
        turn(controller_core::supervisor::Wheel::Left)
    } else if question.contains("turn the right wheel forward one turn") {
        turn(controller_core::supervisor::Wheel::Right)
    } else if question.contains("press the robot's button") {
        remote
            .commands
            .send(HandCommand::Press { ms: 2000 })
            .expect("hands");
        assert_eq!(wait_for(remote), HandAnswer::Released);
        "done".into()
    } else if question.contains("LED blink") {
        remote.commands.send(HandCommand::ReadLed).expect("hands");
        match wait_for(remote) {
            // 50 ms a second.
            HandAnswer::Led { on_steps, of_steps } if of_steps >= 900 => {
                if (30..=80).contains(&on_steps) {
                    "yes".into()
                } else {
                    "no".into()
                }
            }
            other => panic!("the LED: {other:?}"),
        }
    } else if question.contains("lift the robot") || question.contains("put the robot") {
        // The virtual robot's path upload puts it at the start.
        "done".into()
    } else if question.contains("Measured true end") {
        let p = tape(remote);
        format!("{:.4} {:.4} {:.2}", p.x_m, p.y_m, p.theta_rad.to_degrees())
    } else if question.contains("Distance on the tape") {
        let p = tape(remote);
        format!("{:.4}", p.x_m.hypot(p.y_m))
    } else {
        panic!("a question the bench has no answer for: {question}")
    }
}

/// Reads the station's standard output a line at a time into a channel.
fn lines_of(stream: impl std::io::Read + Send + 'static) -> Receiver<String> {
    let (tx, rx) = channel();
    thread::spawn(move || {
        for line in BufReader::new(stream).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// `station bringup` of the robot at `address` (the matrix's steps), the hands played
/// by `remote`; what it printed.
fn bring_up(address: &str, remote: &HandsRemote, out: &std::path::Path) -> String {
    bring_up_steps(address, remote, out, &STEPS)
}

/// `station bringup STEPS…` of the robot at `address`, as [`bring_up`].
fn bring_up_steps(
    address: &str,
    remote: &HandsRemote,
    out: &std::path::Path,
    steps: &[&str],
) -> String {
    let supply_v = Scenario::load("paper-circle")
        .expect("built in")
        .plant
        .driver
        .supply_v;
    let mut child = Command::new(env!("CARGO_BIN_EXE_station"))
        .args(["--connect", address, "bringup"])
        .args(steps)
        .args(["--answers", "/dev/stdin", "--yes", "--restart", "--out"])
        .arg(out)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the station starts");
    let mut stdin = child.stdin.take().expect("piped");
    let lines = lines_of(child.stdout.take().expect("piped"));
    let mut printed = String::new();
    while let Ok(line) = lines.recv_timeout(Duration::from_secs(300)) {
        printed.push_str(&line);
        printed.push('\n');
        if let Some(question) = line.strip_prefix("> ") {
            let reply = answer(question, remote, supply_v);
            writeln!(stdin, "{reply}").expect("the station reads");
            stdin.flush().expect("flushed");
        } else if line.contains("now turn the robot by hand one full turn on the spot") {
            // The gyro step watches, asking nothing: the hands turn, the station sees it.
            remote
                .commands
                .send(HandCommand::Rotate { turns: 1.0 })
                .expect("hands");
            assert!(matches!(wait_for(remote), HandAnswer::Rotated { .. }));
        }
    }
    drop(stdin);
    let output = child.wait_with_output().expect("the station ends");
    assert!(
        output.status.success(),
        "station bringup failed:\n{printed}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    printed
}

/// `station run paper-circle`'s true settle time, s.
fn settle_time(address: &str, out: &std::path::Path) -> f64 {
    let output = Command::new(env!("CARGO_BIN_EXE_station"))
        .args(["--connect", address, "run", "paper-circle", "--out"])
        .arg(out)
        .output()
        .expect("the station runs");
    assert!(
        output.status.success(),
        "station run failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary written");
    let summary: serde_json::Value = serde_json::from_str(&text).expect("json");
    summary["true_error"]["settle_time_s"]
        .as_f64()
        .expect("the run settles")
}

fn robot_params(address: &str) -> ParamSet {
    let mut client = Client::new(Tcp::connect(address).expect("connects"));
    station::ops::get_params(&mut client).expect("params")
}

/// Why the robot's corrections do not undo `m`, if they do not.
fn undone(m: &Miswiring, set: &ParamSet) -> Result<(), String> {
    let w = &set.robot.wiring;
    let flags = [
        (
            "left motor inverted",
            w.left_motor_inverted,
            m.left_motor_inverted,
        ),
        (
            "right motor inverted",
            w.right_motor_inverted,
            m.right_motor_inverted,
        ),
        ("motors swapped", w.motors_swapped, m.motors_swapped),
        (
            "left encoder inverted",
            w.left_encoder_inverted,
            m.left_encoder_inverted,
        ),
        (
            "right encoder inverted",
            w.right_encoder_inverted,
            m.right_encoder_inverted,
        ),
        ("encoders swapped", w.encoders_swapped, m.encoders_swapped),
    ];
    for (name, robot, truth) in flags {
        if robot != truth {
            return Err(format!(
                "{name}: the robot says {robot}, the wiring is {truth}"
            ));
        }
    }
    let lines = 12.0 * m.cpr_factor;
    if f64::from(set.robot.encoder_lines_per_motor_rev) != lines {
        return Err(format!(
            "encoder lines {} for an encoder of {lines}",
            set.robot.encoder_lines_per_motor_rev
        ));
    }
    let scale = f64::from(w.supply_scale) * m.supply_scale;
    if (scale - 1.0).abs() > 0.01 {
        return Err(format!(
            "supply scale {} for a reading ×{}",
            w.supply_scale, m.supply_scale
        ));
    }
    Ok(())
}

/// The correctly wired robot's settle time, s.
fn reference_settle_time(dir: &std::path::Path) -> f64 {
    let (address, _hands) = virtual_robot(Miswiring::default(), 100.0);
    settle_time(&address, &dir.join("reference"))
}

/// One case: brought up, checked and run; its settle time, or why it failed.
fn case(list: &str, reference_s: f64, dir: &std::path::Path) -> Result<f64, String> {
    let miswiring: Miswiring = list.parse().map_err(|e| format!("{e}"))?;
    let (address, remote) = virtual_robot(miswiring, 200.0);
    let name = list.replace([',', '='], "_");
    let printed = bring_up(&address, &remote, &dir.join(format!("{name}-bringup")));
    undone(&miswiring, &robot_params(&address)).map_err(|e| format!("{e}\n{printed}"))?;
    let settle = settle_time(&address, &dir.join(format!("{name}-run")));
    if (settle / reference_s - 1.0).abs() > SETTLE_TOLERANCE {
        return Err(format!(
            "settles in {settle:.3} s, the correctly wired robot in {reference_s:.3} s"
        ));
    }
    Ok(settle)
}

fn run_cases(cases: &[&str]) -> usize {
    let dir = std::env::temp_dir().join(format!("station-bringup-{}", std::process::id()));
    let reference = reference_settle_time(&dir);
    println!("correctly wired: settles in {reference:.3} s");
    let mut passed = 0;
    let mut failures = Vec::new();
    for list in cases {
        match case(list, reference, &dir) {
            Ok(settle) => {
                passed += 1;
                println!(
                    "{list}: detected and corrected, settles in {settle:.3} s ({:+.1} %)",
                    (settle / reference - 1.0) * 100.0
                );
            }
            Err(why) => {
                println!("{list}: FAILED: {why}");
                failures.push(format!("{list}: {why}"));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "bring-up matrix: {passed} of {} miswirings detected and corrected",
        cases.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    passed
}

#[test]
fn bring_up_detects_and_corrects_a_few_miswirings() {
    let _one = one_at_a_time();
    run_cases(&[
        "left-motor-inverted,right-encoder-inverted,encoders-swapped,motors-swapped,cpr=x2,supply-scale=1.1",
        "right-motor-inverted",
    ]);
}

#[test]
#[ignore = "the whole matrix, about two minutes: cargo xtask bringup-matrix"]
fn the_whole_matrix() {
    let _one = one_at_a_time();
    run_cases(&[
        "left-motor-inverted",
        "right-motor-inverted",
        "left-encoder-inverted",
        "right-encoder-inverted",
        "encoders-swapped",
        "motors-swapped",
        "cpr=x2",
        "supply-scale=1.1",
        "left-motor-inverted,left-encoder-inverted",
        "encoders-swapped,motors-swapped",
        "right-encoder-inverted,motors-swapped",
        "cpr=x2,supply-scale=0.9",
    ]);
}

#[test]
#[ignore = "about three minutes of simulated runs: cargo xtask bringup-matrix"]
fn the_tune_and_the_calibration() {
    let _one = one_at_a_time();
    let mut scenario = Scenario::load("paper-circle").expect("built in");
    scenario.plant.mismatch.wheel_radius_left_right_pct = 1.0;
    scenario.plant.mismatch.track_width_pct = 3.0;
    let truth = host_sim::run::plant_params(&scenario).geometry;
    let (address, remote) = served(scenario, Miswiring::default(), 2000.0);
    let dir = std::env::temp_dir().join(format!("station-tune-calibrate-{}", std::process::id()));
    let before = robot_params(&address);
    let printed = bring_up_steps(&address, &remote, &dir, &["tune", "calibrate"]);
    let after = robot_params(&address);
    let _ = std::fs::remove_dir_all(&dir);
    assert_ne!(
        (after.robot.left_wheel, after.robot.right_wheel),
        (before.robot.left_wheel, before.robot.right_wheel),
        "tuned:\n{printed}"
    );
    let ratio = |r: &controller_core::params::RobotConfig| {
        f64::from(r.wheel_radius_right_m) / f64::from(r.wheel_radius_left_m)
    };
    let true_ratio = truth.wheel_radius_right_m / truth.wheel_radius_left_m;
    let track_error = f64::from(after.robot.track_width_m) / truth.track_width_m - 1.0;
    let ratio_error = ratio(&after.robot) / true_ratio - 1.0;
    println!(
        "tune and calibration: track width {:+.2} % off the plant's (was {:+.2} %), wheel radius ratio {:+.3} % (was {:+.3} %)",
        track_error * 100.0,
        (f64::from(before.robot.track_width_m) / truth.track_width_m - 1.0) * 100.0,
        ratio_error * 100.0,
        (ratio(&before.robot) / true_ratio - 1.0) * 100.0,
    );
    assert!(track_error.abs() < 0.01, "{printed}");
    assert!(ratio_error.abs() < 0.002, "{printed}");
}

#[test]
fn the_gyro_step_finds_an_upside_down_imu_and_its_scale() {
    let _one = one_at_a_time();
    let mut scenario = Scenario::load("paper-circle-gyro").expect("built in");
    let sensor = &mut scenario.gyro.as_mut().expect("a gyro").sensor;
    sensor.scale_error_pct = 3.0;
    sensor.turn_on_bias_rad_s = 0.5_f64.to_radians();
    let (address, remote) = served(scenario, "gyro-inverted".parse().expect("valid"), 200.0);
    let dir = std::env::temp_dir().join(format!("station-bringup-gyro-{}", std::process::id()));
    let before = robot_params(&address).robot.gyro;
    let printed = bring_up_steps(&address, &remote, &dir, &["gyro"]);
    let after = robot_params(&address).robot.gyro;
    let _ = std::fs::remove_dir_all(&dir);
    assert!(!before.axis_inverted && before.scale == 1.0, "{before:?}");
    assert!(after.axis_inverted, "{printed}");
    // The sensor reads 3 % high: the robot's turn per sensor turn is 1/1.03.
    let scale_error = f64::from(after.scale) * 1.03 - 1.0;
    println!(
        "gyro step: axis inverted found, scale {:.5} ({:+.3} % off the true 1/1.03)",
        after.scale,
        scale_error * 100.0
    );
    assert!(scale_error.abs() < 0.001, "{printed}");
    assert!(printed.contains("scale 0.97"), "{printed}");
}

#[test]
fn the_supply_step_tells_to_unplug_a_battery_above_a_drv8833s_rating() {
    let _one = one_at_a_time();
    // A DRV8833 robot on 11.2 V: above the bridge's 10.8 V rating, below its 11.8 V
    // absolute maximum (so the simulated bridge survives it).
    let mut scenario = Scenario::load("paper-circle").expect("built in");
    scenario.plant.driver.kind = robot_files::plant::DriverKind::Drv8833;
    scenario.plant.driver.supply_v = 11.2;
    scenario.robot.drive.max_supply_v = 10.8;
    let (address, _remote) = served(scenario, Miswiring::default(), 60.0);
    let dir = std::env::temp_dir().join(format!("station-bringup-drv-{}", std::process::id()));
    let mut child = Command::new(env!("CARGO_BIN_EXE_station"))
        .args(["--connect", &address, "bringup", "supply"])
        .args(["--answers", "/dev/stdin", "--yes", "--restart", "--out"])
        .arg(&dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the station starts");
    writeln!(child.stdin.take().expect("piped"), "11.2").expect("the station reads");
    let output = child.wait_with_output().expect("the station ends");
    let _ = std::fs::remove_dir_all(&dir);
    let printed = format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    assert_eq!(output.status.code(), Some(3), "{printed}");
    assert!(
        printed.contains(
            "above the DRV8833's 10.8 V rating (11.8 V absolute maximum): unplug the battery now"
        ),
        "{printed}"
    );
    // Nothing was learned: the scale stays as it was.
    assert_eq!(robot_params(&address).robot.wiring.supply_scale, 1.0);
}
