//! Valid inputs built from the project itself, where each fuzz target starts: frames and
//! bodies of the link's messages, a stored record, the built-in scenarios, robot files.
//! `cargo xtask fuzz` writes them next to the committed corpus before a run (so they
//! follow the messages as they change), and the corpus tests check them too.

use controller_core::kinematics::{BodyVelocity, Pose, WheelSpeeds};
use controller_core::law::LawKind;
use controller_core::params::RobotConfig;
use controller_core::path::Path;
use controller_core::prelude::Point;
use controller_core::reference::ReferenceMode;
use controller_core::supervisor::{Event, SupervisorConfig};
use link::{
    encode, path_checksum, upload, ArmMode, Downlink, FieldProblem, Message, ParamSet, PathBegin,
    PathCommit, ProtocolId, Refusal, Reply, Request, Stats, Uplink, MAX_FRAME_LEN,
};
use robot_app::persist;
use robot_files::robot_file::RobotFile;
use robot_files::scenario::BUILTIN;

use crate::frames::body_of;
use crate::param_record::CONTROL_RATE_HZ;

/// The seeds of the target `name` ([`crate::TARGETS`]), each with a file name; none for
/// an unknown target.
pub fn for_target(name: &str) -> Vec<(String, Vec<u8>)> {
    let named = |prefix: &str, inputs: Vec<Vec<u8>>| {
        inputs
            .into_iter()
            .enumerate()
            .map(|(i, input)| (format!("{prefix}-{i:02}"), input))
            .collect::<Vec<_>>()
    };
    match name {
        "link_frames" => {
            let mut seeds = named("downlink", frames(&downlinks()));
            seeds.extend(named("uplink", frames(&uplinks())));
            seeds.push(("stream".to_string(), stream()));
            seeds
        }
        "link_messages" => {
            let mut seeds = named("downlink", downlinks().iter().map(body_of).collect());
            seeds.extend(named("uplink", uplinks().iter().map(body_of).collect()));
            seeds
        }
        "param_record" => vec![
            ("record".to_string(), record_page()),
            (
                "body".to_string(),
                postcard::to_allocvec(&param_set()).unwrap_or_default(),
            ),
        ],
        "scenario" => BUILTIN
            .iter()
            .map(|(name, text)| (format!("{name}.toml"), text.as_bytes().to_vec()))
            .collect(),
        "robot_file" => named(
            "robot",
            robot_files().into_iter().map(String::into_bytes).collect(),
        ),
        _ => Vec::new(),
    }
}

/// The reference robot's configuration with the supervisor's defaults at the board's
/// rate, as a robot without a stored record runs.
pub fn param_set() -> ParamSet {
    ParamSet {
        robot: RobotConfig::REFERENCE_ROBOT,
        supervisor: SupervisorConfig::at_rate(
            CONTROL_RATE_HZ,
            Pose::new(0.0, 0.0, 0.0),
            WheelSpeeds::new(5.0, 5.0),
        ),
    }
}

/// Robot files: the reference configuration as `params get` writes it, and a short one
/// as a user writes it.
pub fn robot_files() -> Vec<String> {
    let set = param_set();
    vec![
        RobotFile::of(&set.robot, &set.supervisor).to_toml(),
        "[robot]\nwheel_radius_m = 0.033\ntrack_width_m = 0.152\n\n[robot.wheels]\n\
         kp_v_per_rad_s = 0.4\n\n[supervisor]\nrun_time_limit_s = 120.0\n\
         geofence_radius_m = \"off\"\n\n[supervisor.divergence]\nsettle_s = 3.0\n\
         bound_m = 0.5\npersist_s = 1.0\n"
            .to_string(),
    ]
}

/// A page holding the record of [`param_set`].
fn record_page() -> Vec<u8> {
    let mut page = vec![0xFF; persist::MAX_RECORD_LEN + 16];
    let _ = persist::encode(&param_set(), 1, &mut page);
    page
}

/// A path the station would upload: the paper's circle.
fn circle() -> Option<Path> {
    Path::circle(Point::new(0.0, 0.0), 1.25, 0.0, true).ok()
}

/// Requests of every kind the host sends.
fn downlinks() -> Vec<Downlink> {
    let path = circle();
    let segments = path.as_ref().map_or(&[][..], |p| p.segments());
    let count = u8::try_from(segments.len()).unwrap_or(u8::MAX);
    let mut requests = vec![
        Request::Info,
        Request::Ping { nonce: 0xdead_beef },
        Request::GetParams,
        Request::SetParams(param_set()),
        Request::PersistParams,
        Request::PathBegin(PathBegin {
            upload_id: 7,
            segment_count: count,
            speed_m_s: 0.25,
            mode: ReferenceMode::PathFollowing { lookahead_m: 0.1 },
            law: LawKind::Tracking,
            start_pose: Pose::new(-1.0, -1.2, 2.09),
        }),
        Request::PathCommit(PathCommit {
            upload_id: 7,
            segment_count: count,
            checksum: path_checksum(segments),
        }),
        Request::Arm {
            mode: ArmMode::FollowPath,
            initial_motion: Some(BodyVelocity::new(0.4, 0.3)),
            run_time_limit_steps: Some(30_000),
        },
        Request::Arm {
            mode: ArmMode::HoldWheelSpeeds(WheelSpeeds::new(5.0, -5.0)),
            initial_motion: None,
            run_time_limit_steps: None,
        },
        Request::SetPose {
            x_m: -1.0,
            y_m: -1.2,
            theta_rad: 2.09,
        },
        Request::GetPanicRecord,
        Request::ClearPanicRecord,
        Request::MotorTest {
            wheel: link::Wheel::Right,
            volts: -2.5,
            duration_ms: 300,
            confirm: link::MOTOR_TEST_CONFIRMATION,
        },
        Request::Disarm,
        Request::EmergencyStop,
        Request::Heartbeat,
        Request::SetTelemetryRate { hz: 50 },
        Request::GetTuneReport,
        Request::Arm {
            mode: ArmMode::FollowVelocity,
            initial_motion: None,
            run_time_limit_steps: None,
        },
        Request::Velocity {
            v_m_s: 0.3,
            omega_rad_s: -0.5,
        },
    ];
    requests.extend(upload::chunks(7, segments).map(Request::PathChunk));
    requests
        .into_iter()
        .zip(1u16..)
        .map(|(request, seq)| Downlink { seq, request })
        .collect()
}

/// Messages of several kinds the robot sends.
fn uplinks() -> Vec<Uplink> {
    vec![
        Uplink::Reply {
            seq: 1,
            result: Ok(Reply::Pong { nonce: 0xdead_beef }),
        },
        Uplink::Reply {
            seq: 2,
            result: Ok(Reply::Params(param_set())),
        },
        Uplink::Reply {
            seq: 3,
            result: Err(Refusal::InvalidParams(FieldProblem::new(
                "wheel_radius_left_m",
                "must be > 0",
            ))),
        },
        Uplink::Reply {
            seq: 4,
            result: Err(Refusal::Armed),
        },
        Uplink::Event {
            step: 1234,
            event: Event::Faulted,
        },
        Uplink::Stats(Stats::default()),
        Uplink::VersionMismatch {
            received: ProtocolId {
                version: 9,
                schema_hash: 0x1234_5678,
            },
        },
    ]
}

/// Each message's frame.
fn frames<M: Message>(messages: &[M]) -> Vec<Vec<u8>> {
    messages
        .iter()
        .map(|message| {
            let mut wire = [0u8; MAX_FRAME_LEN];
            let len = encode(message, &mut wire).unwrap_or(0);
            wire[..len].to_vec()
        })
        .collect()
}

/// A stream as a line gives it: half a frame, a delimiter, three whole frames.
fn stream() -> Vec<u8> {
    let frames = frames(&downlinks()[..3]);
    let mut bytes = frames[2][3..].to_vec();
    for frame in &frames {
        bytes.extend_from_slice(frame);
    }
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_target_has_seeds_and_they_pass() {
        for target in crate::TARGETS {
            let seeds = for_target(target);
            assert!(!seeds.is_empty(), "{target}");
            for (_, input) in &seeds {
                assert!(crate::check(target, input));
            }
        }
        assert!(for_target("no such target").is_empty());
    }

    #[test]
    fn the_seeds_are_valid_inputs() {
        for (name, page) in for_target("param_record") {
            if name == "record" {
                assert!(persist::decode(&page, CONTROL_RATE_HZ).is_ok());
            }
        }
        assert!(downlinks()
            .iter()
            .any(|d| matches!(d.request, Request::PathChunk(_))));
        for text in robot_files() {
            assert!(RobotFile::from_toml(&text).is_ok(), "{text}");
        }
    }
}
