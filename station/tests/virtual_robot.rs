//! The station against the virtual robot in this process, in lockstep (deterministic: no
//! wall-clock timing decides anything here).

use std::sync::atomic::AtomicBool;

use controller_core::law::LawKind;
use host_sim::serve::VirtualRobot;
use host_sim::Scenario;
use robot_app::Channels;
use station::client::Client;
use station::record::{self, RunPlan};
use station::transport::InProcess;

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

    let got = &recording.result.summary;
    let want = &expected.summary;
    assert_eq!(got.source, "virtual-robot");
    let settle = got.true_error.and_then(|e| e.settle_time_s);
    assert!(
        settle.is_some_and(|t| t > 1.0 && t < 3.0),
        "the paper circle settles in about 2 s: {got:?}"
    );
    assert_eq!(got.steps, want.steps, "the robot ran the scenario's duration");
    assert_eq!(got.true_error, want.true_error, "true errors, bit for bit");
    assert_eq!(got.estimated_error, want.estimated_error, "estimated errors");
    assert!(got.supervisor.faults.is_empty());
    // The trace: one row per steering period (100 Hz telemetry on a 100 Hz steering loop).
    assert!(
        recording.result.trace.len() as u64 >= want.steps / 10 - 2,
        "{} rows",
        recording.result.trace.len()
    );
    // The robot's time limit was restored after the run.
    assert_eq!(
        station::ops::get_params(&mut client)
            .expect("params")
            .supervisor
            .max_armed_steps,
        scenario.supervisor.max_armed_steps
    );
}
