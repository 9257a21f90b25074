//! A written run read back with the `mcap` crate: every channel with its schema, the
//! poses at their samples' times, the true pose only where it is known, the events.

use std::collections::{BTreeMap, BTreeSet};

use controller_core::prelude::{Path, Point, Pose};
use controller_core::supervisor::{Fault, Faults, State};
use foxglove::messages::{Log, PoseInFrame};
use prost::Message as _;
use robot_files::trace::{SampleDetail, TraceRow};
use robot_files::truth::TruePose;
use robot_foxglove::{topics, write_run_mcap, RunRecord};

fn row(i: usize) -> TraceRow {
    let t_s = i as f64 * 0.01;
    let known = i != 3;
    let nan = f64::NAN;
    TraceRow {
        t_s,
        true_pose: if known {
            TruePose {
                x_m: 0.1 * i as f64,
                y_m: -0.2,
                theta_rad: 3.0,
            }
        } else {
            TruePose {
                x_m: nan,
                y_m: nan,
                theta_rad: nan,
            }
        },
        est_pose: Pose::new(0.1 * i as f32, 0.25, -3.1),
        reference: Pose::new(1.0, 2.0, 0.5),
        error: Default::default(),
        true_error: (0.0, 0.0),
        true_tracking: [0.0; 3],
        lyapunov: 0.0,
        command: Default::default(),
        true_velocity: (0.0, 0.0),
        setpoint: Default::default(),
        measured: Default::default(),
        true_wheel: [0.0; 2],
        volts: [0.0; 2],
        duty: Default::default(),
        supply_v: 6.0,
        state: if i < 5 { State::Armed } else { State::Faulted },
        detail: SampleDetail {
            faults: if i < 5 {
                Faults::NONE
            } else {
                Faults::NONE.with(Fault::Geofence)
            },
            ..Default::default()
        },
    }
}

/// The yaw of a rotation about z, rad.
fn yaw(p: &PoseInFrame) -> f64 {
    let q = p
        .pose
        .as_ref()
        .and_then(|p| p.orientation.as_ref())
        .expect("a rotation");
    2.0 * q.z.atan2(q.w)
}

#[test]
fn a_run_reads_back_as_it_was_written() {
    let trace: Vec<TraceRow> = (0..8).map(row).collect();
    let path = Path::circle(Point::new(0.0, 0.0), 1.0, 0.0, true).expect("a circle");
    let file =
        std::env::temp_dir().join(format!("robot-foxglove-test-{}.mcap", std::process::id()));
    let written = write_run_mcap(
        &file,
        &RunRecord {
            path: Some(&path),
            trace: &trace,
            end: Some("run ended"),
        },
    )
    .expect("written");
    assert_eq!(written.samples, 8);
    let bytes = std::fs::read(&file).expect("the file");
    let _ = std::fs::remove_file(&file);

    let mut channels = BTreeSet::new();
    let mut poses: BTreeMap<String, Vec<(u64, PoseInFrame)>> = BTreeMap::new();
    let mut events = Vec::new();
    for message in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let message = message.expect("a message");
        let channel = &message.channel;
        let schema = channel.schema.as_ref().expect("every channel has a schema");
        assert_eq!(schema.encoding, "protobuf", "{}", channel.topic);
        channels.insert(channel.topic.clone());
        match channel.topic.as_str() {
            t @ (topics::POSE_ESTIMATE | topics::POSE_TRUE | topics::POSE_REFERENCE) => {
                let pose = PoseInFrame::decode(message.data.as_ref()).expect("a pose");
                poses
                    .entry(t.to_string())
                    .or_default()
                    .push((message.log_time, pose));
            }
            topics::EVENTS => {
                events.push(Log::decode(message.data.as_ref()).expect("a log").message);
            }
            _ => {}
        }
    }
    let all: BTreeSet<String> = topics::ALL.iter().map(|t| t.to_string()).collect();
    assert_eq!(channels, all);

    let estimate = &poses[topics::POSE_ESTIMATE];
    assert_eq!(estimate.len(), 8);
    for (i, (time, pose)) in estimate.iter().enumerate() {
        assert_eq!(*time, i as u64 * 10_000_000, "log time of sample {i}");
        let p = pose
            .pose
            .as_ref()
            .and_then(|p| p.position.as_ref())
            .expect("a position");
        assert_eq!(p.x, f64::from(0.1 * i as f32));
        assert_eq!(p.y, 0.25);
        assert!((yaw(pose) - f64::from(-3.1f32)).abs() < 1e-12);
        assert_eq!(pose.frame_id, topics::WORLD_FRAME);
    }
    // The sample without truth has no true pose.
    let truth = &poses[topics::POSE_TRUE];
    assert_eq!(truth.len(), 7);
    assert!(truth.iter().all(|(t, _)| *t != 30_000_000));
    assert!((yaw(&truth[0].1) - 3.0).abs() < 1e-12);
    assert_eq!(
        events,
        ["first sample: armed", "faulted: geofence", "run ended"]
    );
}
