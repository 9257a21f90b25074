//! The velocity mode through the link, against the virtual robot in this process, in
//! lockstep: armed by request, driven by streamed commands, stopped by its timeout while
//! heartbeats keep it armed, and refused outside the mode.

mod support;

use std::time::Duration;

use host_sim::serve::VirtualRobot;
use link::{ArmMode, NotPermitted, Refusal, Request, Uplink};
use robot_app::Channels;
use robot_files::scenario::Scenario;
use station::client::Client;
use station::transport::Transport;
use station::StationError;
use support::InProcess;

/// The robot's telemetry and ground truth until its step reaches `until`, streaming
/// `command` every 50 steps (`None`: no command) and a heartbeat every 100.
fn drive<T: Transport>(
    client: &mut Client<T>,
    until: u32,
    command: Option<(f32, f32)>,
) -> Vec<(link::TelemetryFrame, Option<link::GroundTruth>)> {
    let mut samples = Vec::new();
    let mut last_command = 0;
    let mut last_heartbeat = 0;
    loop {
        let Some(message) = client.next_message(Duration::from_millis(5)).expect("link") else {
            continue;
        };
        match message {
            Uplink::Telemetry(frame) => {
                let step = frame.step;
                samples.push((frame, None));
                if step >= until {
                    return samples;
                }
                if let Some((v_m_s, omega_rad_s)) = command {
                    if step >= last_command + 50 {
                        last_command = step;
                        client
                            .send_only(Request::Velocity { v_m_s, omega_rad_s })
                            .expect("sent");
                    }
                }
                if step >= last_heartbeat + 100 {
                    last_heartbeat = step;
                    client.send_only(Request::Heartbeat).expect("sent");
                }
            }
            Uplink::GroundTruth(truth) => {
                if let Some(last) = samples.last_mut() {
                    last.1 = Some(truth);
                }
            }
            _ => {}
        }
    }
}

/// The last sample that came with the virtual robot's ground truth.
fn last_with_truth(
    samples: &[(link::TelemetryFrame, Option<link::GroundTruth>)],
) -> (link::TelemetryFrame, link::GroundTruth) {
    samples
        .iter()
        .rev()
        .find_map(|(f, t)| t.map(|t| (*f, t)))
        .expect("the virtual robot sends its ground truth")
}

fn refusal(error: StationError) -> Refusal {
    match error {
        StationError::Refused { refusal, .. } => *refusal,
        other => panic!("not a refusal: {other:?}"),
    }
}

#[test]
fn the_velocity_mode_drives_stops_by_its_timeout_and_stays_armed() {
    let scenario = Scenario::load("paper-line").expect("built in");
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid scenario");
    let mut client = Client::new(InProcess::new(&mut robot));
    let velocity = Request::Velocity {
        v_m_s: 0.3,
        omega_rad_s: 0.0,
    };
    // Disarmed: refused, by name.
    let refused = refusal(client.command(velocity.clone()).expect_err("refused"));
    assert_eq!(
        refused,
        Refusal::NotPermitted(NotPermitted::NotInVelocityMode)
    );
    // Not finite: refused, naming the field.
    client
        .command(Request::SetTelemetryRate { hz: 100 })
        .expect("rate");
    client
        .command(Request::Arm {
            mode: ArmMode::FollowVelocity,
            initial_motion: None,
            run_time_limit_steps: None,
        })
        .expect("arms");
    let refused = refusal(
        client
            .command(Request::Velocity {
                v_m_s: f32::NAN,
                omega_rad_s: 0.0,
            })
            .expect_err("refused"),
    );
    assert!(
        matches!(&refused, Refusal::InvalidArgument(p) if p.field == "v_m_s"),
        "{refused:?}"
    );

    let start_step = drive(&mut client, 0, None)
        .last()
        .map_or(0, |(f, _)| f.step);
    let driving = drive(&mut client, start_step + 2000, Some((0.3, 0.0)));
    let (frame, truth) = last_with_truth(&driving);
    assert_eq!(frame.state, controller_core::supervisor::State::Armed);
    assert_eq!(
        frame.run_mode,
        controller_core::supervisor::RunMode::FollowVelocity
    );
    assert!(
        (truth.velocity.v_m_s - 0.3).abs() < 0.03,
        "drives at the command: {:?}",
        truth.velocity
    );
    // The paper-line start faces +y: the robot moved that way.
    assert!(truth.pose.y_m > -0.5 + 0.3, "{:?}", truth.pose);

    // No more commands, heartbeats only: stopped within the timeout and the ramp, armed.
    let stopping = drive(&mut client, frame.step + 1500, None);
    let (frame, truth) = last_with_truth(&stopping);
    assert_eq!(
        frame.state,
        controller_core::supervisor::State::Armed,
        "stays armed"
    );
    assert!(
        truth.velocity.v_m_s.abs() < 0.01,
        "stopped: {:?}",
        truth.velocity
    );
    // Still moving 0.4 s after the last command: the timeout is 0.5 s.
    let early = stopping
        .iter()
        .find(|(f, t)| f.step >= stopping[0].0.step + 350 && t.is_some())
        .and_then(|(_, t)| *t)
        .expect("a sample");
    assert!(
        early.velocity.v_m_s > 0.2,
        "not before the timeout: {:?}",
        early.velocity
    );

    // Armed in another mode: refused as not the velocity mode.
    client.command(Request::Disarm).expect("disarms");
    drive(&mut client, frame.step + 300, None);
    client
        .command(Request::Arm {
            mode: ArmMode::FollowPath,
            initial_motion: None,
            run_time_limit_steps: None,
        })
        .expect("arms");
    let refused = refusal(client.command(velocity).expect_err("refused"));
    assert_eq!(
        refused,
        Refusal::NotPermitted(NotPermitted::NotInVelocityMode)
    );
}
