//! The station against the virtual robot in this process, in lockstep (deterministic: no
//! wall-clock timing decides anything here).

mod support;

use std::sync::atomic::AtomicBool;

use controller_core::law::LawKind;
use host_sim::serve::VirtualRobot;
use robot_app::Channels;
use robot_files::scenario::Scenario;
use station::client::Client;
use station::record::{self, RunPlan};
use support::{InProcess, LineFaults};

#[test]
fn a_run_through_the_station_matches_host_sim_run_bit_for_bit() {
    let scenario = Scenario::load("paper-circle").expect("built in");
    let expected = host_sim::run_scenario(&scenario, LawKind::Tracking).expect("runs");

    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid scenario");
    let mut client = Client::new(InProcess::new(&mut robot));
    let interrupt = AtomicBool::new(false);
    let mut progress = |_: u64, _: u64| {};
    let recording = record::run(
        &mut client,
        &mut RunPlan {
            scenario: &scenario,
            law: LawKind::Tracking,
            telemetry_hz: 100,
            interrupt: &interrupt,
            progress: &mut progress,
        },
    )
    .expect("the run completes");

    let got = &recording.summary;
    let want = &expected.summary;
    assert_eq!(got.source, "virtual-robot");
    let settle = got.true_error.and_then(|e| e.settle_time_s);
    assert!(
        settle.is_some_and(|t| t > 1.0 && t < 3.0),
        "the paper circle settles in about 2 s: {got:?}"
    );
    assert_eq!(
        got.steps, want.steps,
        "the robot ran the scenario's duration"
    );
    assert_eq!(got.true_error, want.true_error, "true errors, bit for bit");
    assert_eq!(
        got.estimated_error, want.estimated_error,
        "estimated errors"
    );
    assert!(got.supervisor.faults.is_empty());
    // The trace: one row per steering period (100 Hz telemetry on a 100 Hz steering loop).
    assert!(
        recording.trace.len() as u64 >= want.steps / 10 - 2,
        "{} rows",
        recording.trace.len()
    );
    // The run's time limit came with its arm request: the stored one is untouched.
    assert_eq!(
        station::ops::get_params(&mut client)
            .expect("params")
            .supervisor
            .max_armed_steps,
        scenario.supervisor.max_armed_steps
    );
}

#[test]
fn params_and_path_upload_while_armed_are_refused_with_a_clear_message() {
    let scenario = Scenario::load("paper-line").expect("built in");
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid scenario");
    let mut client = Client::new(InProcess::new(&mut robot));
    let params = station::ops::get_params(&mut client).expect("params");
    station::ops::arm(&mut client, None, None).expect("arms");

    let refused = station::ops::set_params(&mut client, params).expect_err("refused");
    assert!(
        matches!(
            &refused,
            station::StationError::Refused { refusal, .. } if **refusal == link::Refusal::Armed
        ),
        "{refused:?}"
    );
    let text = refused.to_string();
    assert!(text.starts_with("the robot refused SetParams: "), "{text}");
    assert!(text.contains("disarm"), "{text}");

    let mut progress = |_: usize, _: usize| {};
    let refused =
        station::ops::upload_path(&mut client, &scenario, LawKind::Tracking, 7, &mut progress)
            .expect_err("refused");
    assert!(
        refused
            .to_string()
            .starts_with("the robot refused PathBegin: "),
        "{refused}"
    );
    // Disarmed, both go through.
    client.command(link::Request::Disarm).expect("disarms");
    station::ops::set_params(&mut client, params).expect("applied");
    station::ops::upload_path(&mut client, &scenario, LawKind::Tracking, 8, &mut progress)
        .expect("committed");
}

#[test]
fn a_robot_file_error_names_the_key() {
    let scenario = Scenario::load("paper-line").expect("built in");
    let current = link::ParamSet {
        robot: scenario.robot,
        supervisor: scenario.supervisor,
    };
    let error =
        station::ops::params_from_toml("[robot]\ntrack_width_m = -0.1\n", "robot.toml", &current)
            .expect_err("invalid");
    let text = error.to_string();
    assert!(
        text.starts_with("robot.toml: robot.track_width_m"),
        "{text}"
    );
    // A partial file keeps the robot's other values.
    let set = station::ops::params_from_toml("[robot]\ntrack_width_m = 0.16\n", "f", &current)
        .expect("valid");
    assert_eq!(set.robot.track_width_m, 0.16);
    assert_eq!(set.robot.gear_ratio, current.robot.gear_ratio);
    // What `params get` writes reads back to the same configuration.
    let text = station::ops::params_to_toml(&current);
    let back = station::ops::params_from_toml(&text, "f", &current).expect("round trip");
    assert_eq!(back, current);
}

#[test]
fn a_tune_through_the_station_identifies_the_simulated_wheels() {
    let scenario = Scenario::load("paper-circle").expect("built in");
    let truth = host_sim::tune::truth(&scenario).expect("linearises");
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid scenario");
    let mut client = Client::new(InProcess::new(&mut robot));
    let timeout = scenario.supervisor.heartbeat_timeout_steps;
    let run = station::ops::tune(&mut client, timeout, std::time::Duration::from_secs(120))
        .expect("the link works");
    let report = run.report.expect("the tune's report");
    assert_eq!(run.finished(), Ok(report), "the tune finished");
    assert_eq!(report.tunes_ended, 1);
    let result = report.outcome.expect("the tune finds a model");
    for m in result.models {
        let kv = f64::from(m.kv_v_per_rad_s);
        let tau = f64::from(m.time_constant_s);
        assert!(
            (kv / truth.kv_v_per_rad_s - 1.0).abs() < 0.1,
            "{m:?} {truth:?}"
        );
        assert!(
            (tau / truth.time_constant_s - 1.0).abs() < 0.1,
            "{m:?} {truth:?}"
        );
    }
    // The text pastes into a robot file and applies.
    let text = station::ops::describe_tune(&report);
    assert!(text.contains("[robot.left_wheel]") && text.contains("kp_v_per_rad_s = "));
    let file = robot_files::robot_file::RobotFile::from_toml(&text).expect("a robot file");
    assert_eq!(
        file.robot.left_wheel.kp_v_per_rad_s,
        Some(result.loops[0].kp_v_per_rad_s)
    );
    assert_eq!(file.robot.right_wheel.ti_s, Some(result.loops[1].ti_s));
}

#[test]
fn a_tune_the_link_cut_short_is_not_taken_for_a_finished_one() {
    let scenario = Scenario::load("paper-circle").expect("built in");
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid scenario");
    let mut pipe = InProcess::new(&mut robot);
    // Heartbeats stop reaching the robot 0.3 s into the tune.
    pipe.faults = LineFaults {
        mute_heartbeats: vec![(1, 300)],
        ..LineFaults::default()
    };
    let mut client = Client::new(pipe);
    let timeout = scenario.supervisor.heartbeat_timeout_steps;
    let run = station::ops::tune(&mut client, timeout, std::time::Duration::from_secs(120))
        .expect("the link works");
    assert_eq!(
        run.ended_by,
        Some(controller_core::supervisor::Event::Disarmed(
            controller_core::supervisor::DisarmReason::LinkLost
        ))
    );
    let why = run.finished().expect_err("not finished");
    assert!(
        why.starts_with("the tune stopped: ") && why.contains("LinkLost"),
        "{why}"
    );
}

/// Runs paper-circle on a virtual robot behind a line with `faults`; `stop_at` (run
/// steps) sets the Ctrl-C flag.
fn faulty_run(faults: LineFaults, stop_at: Option<u64>) -> record::Recording {
    let scenario = Scenario::load("paper-circle").expect("built in");
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid scenario");
    let mut pipe = InProcess::new(&mut robot);
    pipe.faults = faults;
    let mut client = Client::new(pipe);
    let interrupt = AtomicBool::new(false);
    let mut progress = |done: u64, _: u64| {
        if stop_at.is_some_and(|s| done >= s) {
            interrupt.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    };
    record::run(
        &mut client,
        &mut RunPlan {
            scenario: &scenario,
            law: LawKind::Tracking,
            telemetry_hz: 100,
            interrupt: &interrupt,
            progress: &mut progress,
        },
    )
    .expect("armed, so recorded")
}

/// The summary.json `recording` writes.
fn written_summary(recording: &record::Recording, name: &str) -> serde_json::Value {
    let dir = std::env::temp_dir().join(format!("station-vr-{name}-{}", std::process::id()));
    let files = recording.write(&dir).expect("written");
    assert_eq!(files.len(), 2);
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary");
    let _ = std::fs::remove_dir_all(&dir);
    serde_json::from_str(&text).expect("json")
}

#[test]
fn a_run_cut_short_is_recorded_as_far_as_it_went_and_marked_incomplete() {
    // The connection breaks 5 s into the run.
    let broken = faulty_run(
        LineFaults {
            break_after: Some((1, 5000)),
            ..LineFaults::default()
        },
        None,
    );
    assert!(
        matches!(&broken.ended_by, record::RunEnd::LinkFailed(e) if e.contains("closed")),
        "{:?}",
        broken.ended_by
    );
    assert!(!broken.complete());
    assert!(broken.report.is_none());
    assert!(
        (495..=500).contains(&broken.trace.len()),
        "{} rows",
        broken.trace.len()
    );
    assert!((4990..=5000).contains(&broken.summary.steps));
    let summary = written_summary(&broken, "broken");
    assert_eq!(summary["complete"], false);
    assert_eq!(summary["ended_by"], "link_failed");
    assert_eq!(summary["estimated_error"]["samples"], 0);

    // Heartbeats stop reaching the robot 5 s into the run: it disarms 500 steps later.
    let stalled = faulty_run(
        LineFaults {
            mute_heartbeats: vec![(1, 5000)],
            ..LineFaults::default()
        },
        None,
    );
    assert_eq!(
        stalled.ended_by,
        record::RunEnd::Robot(controller_core::supervisor::Event::Disarmed(
            controller_core::supervisor::DisarmReason::LinkLost
        ))
    );
    assert!(!stalled.complete());
    let summary = written_summary(&stalled, "stalled");
    assert_eq!(summary["complete"], false);
    assert_eq!(summary["ended_by"], "link_lost");

    // Ctrl-C 3 s into the run.
    let interrupted = faulty_run(LineFaults::default(), Some(3000));
    assert_eq!(interrupted.ended_by, record::RunEnd::Interrupted);
    assert!(
        interrupted.trace.len() >= 299,
        "{}",
        interrupted.trace.len()
    );
    assert_eq!(
        written_summary(&interrupted, "ctrl-c")["ended_by"],
        "interrupted"
    );
}

#[test]
fn lost_telemetry_is_counted_in_the_summary() {
    // One telemetry frame in ten never reaches the station.
    let lossy = faulty_run(
        LineFaults {
            lose_telemetry_every: 10,
            ..LineFaults::default()
        },
        None,
    );
    let summary = written_summary(&lossy, "lossy");
    let t = &summary["telemetry"];
    assert_eq!(t["expected_frames"], 3000, "{t}");
    assert_eq!(t["period_steps"], 10, "{t}");
    let missing = t["missing_frames"].as_u64().expect("a count");
    assert!((299..=301).contains(&missing), "{t}");
    assert_eq!(
        t["received_frames"].as_u64(),
        Some(3000 - missing),
        "one row per frame received: {t}"
    );
    assert_eq!(lossy.trace.len() as u64, 3000 - missing);
    assert_eq!(
        t["dropped_on_robot"], 0,
        "lost on the line, not on the robot"
    );
    assert!(lossy
        .telemetry
        .warning()
        .is_some_and(|w| w.starts_with("10.0 % of the telemetry is missing")));
    assert!(lossy.telemetry.text().contains("300 lost on the line") || missing != 300);

    let clean = faulty_run(LineFaults::default(), None);
    assert_eq!(clean.telemetry.missing_frames, 0, "{:?}", clean.telemetry);
    assert_eq!(clean.telemetry.expected_frames, 3000);
    assert_eq!(clean.telemetry.warning(), None);
}

#[test]
fn a_run_has_one_trace_row_per_telemetry_period_whatever_the_phase() {
    // 3 s at 1 kHz, telemetry at 100 Hz: 300 rows, at run steps k < 3000, whichever
    // step of its period the telemetry is at when the robot arms.
    let mut scenario = Scenario::load("paper-circle").expect("built in");
    scenario.duration_s = 3.0;
    for phase in 0..10 {
        let mut channels = Channels::new();
        let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid scenario");
        let mut client = Client::new(InProcess::new(&mut robot));
        record::set_telemetry_rate(&mut client, 100).expect("set");
        for _ in 0..phase {
            let _ = client.next_message(std::time::Duration::ZERO);
        }
        let interrupt = AtomicBool::new(false);
        let mut progress = |_: u64, _: u64| {};
        let recording = record::run(
            &mut client,
            &mut RunPlan {
                scenario: &scenario,
                law: LawKind::Tracking,
                telemetry_hz: 100,
                interrupt: &interrupt,
                progress: &mut progress,
            },
        )
        .expect("the run completes");
        assert_eq!(recording.summary.steps, 3000);
        assert_eq!(recording.trace.len(), 300, "phase {phase}");
        let (first, last) = (recording.trace[0].t_s, recording.trace[299].t_s);
        assert!(
            first < 0.01 && last < 3.0,
            "phase {phase}: {first} … {last}"
        );
    }
}

#[test]
fn a_request_that_times_out_says_what_the_station_received() {
    let scenario = Scenario::load("paper-line").expect("built in");
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid scenario");
    let mut pipe = InProcess::new(&mut robot);
    // Every frame towards the station fails its CRC.
    pipe.faults.corrupt_uplink = true;
    let mut client = Client::new(pipe);
    client.reply_timeout = std::time::Duration::from_millis(20);
    client.tries = 2;
    let error = station::ops::info(&mut client).expect_err("no reply");
    let text = error.to_string();
    assert!(
        text.starts_with("no reply to Info from virtual robot (in process) after 2 tries"),
        "{text}"
    );
    assert!(text.contains("failed their CRC"), "{text}");
    assert!(!text.contains("not powered"), "{text}");
}

#[test]
fn a_dropped_run_leaves_the_robot_s_parameters_exactly_as_before() {
    let scenario = Scenario::load("paper-circle").expect("built in");
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid scenario");
    let before = *robot.link().active_params();
    let mut pipe = InProcess::new(&mut robot);
    // The connection breaks 2 s into the run: the station can restore nothing.
    pipe.faults.break_after = Some((1, 2000));
    let mut client = Client::new(pipe);
    let interrupt = AtomicBool::new(false);
    let mut progress = |_: u64, _: u64| {};
    let recording = record::run(
        &mut client,
        &mut RunPlan {
            scenario: &scenario,
            law: LawKind::Tracking,
            telemetry_hz: 100,
            interrupt: &interrupt,
            progress: &mut progress,
        },
    )
    .expect("armed, so recorded");
    assert!(
        matches!(recording.ended_by, record::RunEnd::LinkFailed(_)),
        "{:?}",
        recording.ended_by
    );
    drop(client);
    assert_eq!(
        *robot.link().active_params(),
        before,
        "every setting as it was"
    );
}

/// Steps the in-process robot for `steps` control periods, heartbeating every 100 and
/// returning every message it sent meanwhile.
fn messages_for<T: station::transport::Transport>(
    client: &mut Client<T>,
    steps: u32,
) -> Vec<link::Uplink> {
    let mut out = Vec::new();
    for k in 0..steps {
        if k % 100 == 0 {
            client.send_only(link::Request::Heartbeat).expect("sent");
        }
        if let Some(message) = client
            .next_message(std::time::Duration::from_millis(1))
            .expect("the link works")
        {
            out.push(message);
        }
    }
    out
}

#[test]
fn re_arming_waits_for_rest_and_resumes_from_where_the_robot_really_is() {
    let mut scenario = Scenario::load("paper-circle").expect("built in");
    scenario.duration_s = 4.0;
    let start = station::ops::start_pose(&scenario);
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid scenario");
    let mut client = Client::new(InProcess::new(&mut robot));
    let interrupt = AtomicBool::new(false);
    let mut progress = |_: u64, _: u64| {};
    let first = record::run(
        &mut client,
        &mut RunPlan {
            scenario: &scenario,
            law: LawKind::Tracking,
            telemetry_hz: 100,
            interrupt: &interrupt,
            progress: &mut progress,
        },
    )
    .expect("the run completes");
    assert!(first.complete(), "{:?}", first.ended_by);
    // At once: the wheels still turn, and the refusal says so in words.
    let refused = station::ops::arm(&mut client, None, None).expect_err("refused");
    assert!(
        matches!(
            &refused,
            station::StationError::Refused { refusal, .. }
                if **refusal == link::Refusal::NotPermitted(link::NotPermitted::WheelsTurning)
        ),
        "{refused:?}"
    );
    assert!(
        refused.to_string().contains("the wheels are still turning"),
        "{refused}"
    );
    // A second later they stand still: re-armed, from where the robot is.
    messages_for(&mut client, 1000);
    station::ops::arm(&mut client, None, None).expect("re-arms at rest");
    let after = messages_for(&mut client, 3000);
    let truth: Vec<_> = after
        .iter()
        .filter_map(|m| match m {
            link::Uplink::GroundTruth(g) => Some(*g),
            _ => None,
        })
        .collect();
    let telemetry: Vec<_> = after
        .iter()
        .filter_map(|m| match m {
            link::Uplink::Telemetry(t) => Some(*t),
            _ => None,
        })
        .collect();
    let (t0, g0) = (telemetry[0], truth[0]);
    let apart = |a: controller_core::kinematics::Pose, b: controller_core::kinematics::Pose| {
        (a.x_m - b.x_m).hypot(a.y_m - b.y_m)
    };
    assert!(
        apart(g0.pose, start) > 0.5,
        "the robot is away from the start: {g0:?}"
    );
    assert!(
        apart(t0.pose, g0.pose) < 0.02,
        "its estimate is where it is: {t0:?} {g0:?}"
    );
    // It goes on along the circle: its own error and its true distance from the circle
    // stay small (the reference resumed where it stopped, it did not restart).
    let last = telemetry.last().expect("telemetry");
    assert_eq!(last.state, controller_core::supervisor::State::Armed);
    assert!(
        telemetry
            .iter()
            .all(|t| t.tracking_error.position_m() < 0.05),
        "{last:?}"
    );
    let g = truth.last().expect("truth");
    let at = controller_core::kinematics::Point::new(g.pose.x_m, g.pose.y_m);
    let s_m = scenario.path.project(at, 0.0, f32::INFINITY, f32::INFINITY);
    let on = scenario.path.sample(s_m).point;
    let off = (g.pose.x_m - on.x_m).hypot(g.pose.y_m - on.y_m);
    assert!(off < 0.05, "{off} m off the circle: {g:?}");
}
