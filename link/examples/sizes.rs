//! Prints the postcard size and the wire size of each message (max-sized varints and
//! strings where they matter): the figures in the crate doc.

use controller_core::kinematics::{Point, Pose, WheelSpeeds};
use controller_core::law::LawKind;
use controller_core::params::RobotConfig;
use controller_core::path::Segment;
use controller_core::reference::ReferenceMode;
use controller_core::supervisor::{Event, RunMode, SupervisorConfig};
use link::bandwidth::largest_telemetry;
use link::*;

fn main() {
    let params = ParamSet {
        robot: RobotConfig::REFERENCE_ROBOT,
        supervisor: SupervisorConfig::at_rate(
            1000,
            Pose::new(-1.0, -1.2, 2.0),
            WheelSpeeds::new(5.0, 5.0),
        ),
    };
    let arc = Segment::Arc {
        center: Point::new(1.0, 1.0),
        radius_m: 0.3,
        start_angle_rad: 0.0,
        sweep_rad: 1.5,
    };
    let seq = u16::MAX;
    let text = |n: usize| "x".repeat(n);
    let downlinks = [
        ("Info", Request::Info),
        ("Ping", Request::Ping { nonce: u32::MAX }),
        ("SetParams (defaults)", Request::SetParams(params)),
        (
            "PathBegin",
            Request::PathBegin(PathBegin {
                upload_id: u16::MAX,
                segment_count: 32,
                speed_m_s: 0.25,
                mode: ReferenceMode::PathFollowing { lookahead_m: 0.1 },
                law: LawKind::Tracking,
                start_pose: Pose::default(),
            }),
        ),
        (
            "PathChunk (4 arcs)",
            Request::PathChunk(PathChunk {
                upload_id: u16::MAX,
                first_index: 28,
                segments: heapless::Vec::from_slice(&[arc; 4]).unwrap(),
            }),
        ),
        (
            "PathChunk (1 arc)",
            Request::PathChunk(PathChunk {
                upload_id: u16::MAX,
                first_index: 28,
                segments: heapless::Vec::from_slice(&[arc]).unwrap(),
            }),
        ),
        (
            "PathCommit",
            Request::PathCommit(PathCommit {
                upload_id: u16::MAX,
                segment_count: 32,
                checksum: u32::MAX,
            }),
        ),
        (
            "Arm (hold, in motion)",
            Request::Arm {
                mode: ArmMode::HoldWheelSpeeds(WheelSpeeds::new(1.0, 1.0)),
                initial_motion: Some(Default::default()),
                run_time_limit_steps: None,
            },
        ),
        ("Heartbeat", Request::Heartbeat),
    ];
    println!("| downlink | postcard body (B) | wire (B) |");
    for (name, request) in downlinks {
        let message = Downlink { seq, request };
        show(name, &message);
    }
    let info = RobotInfo {
        protocol: ProtocolId::OURS,
        firmware_version: bounded(&text(VERSION_CAP)),
        git_hash: bounded(&text(GIT_HASH_CAP)),
        chip: bounded(&text(NAME_CAP)),
        robot_name: bounded(&text(NAME_CAP)),
        params_hash: u32::MAX,
        bridge: link::BridgeChip::Tb6612fng,
        clock: ClockSource::InternalFallback {
            expected_hz: u32::MAX,
        },
        brown_out_reset: BrownOutReset::Level3,
        reset_cause: ResetCause::Unknown,
    };
    let panic_record = PanicReport {
        kind: FailureKind::Panic,
        file: bounded(&text(PANIC_FILE_CAP)),
        line: u32::MAX,
        pc: u32::MAX,
        message: bounded(&text(PANIC_MESSAGE_CAP)),
    };
    let stats = Stats {
        max_step_cycles: u32::MAX,
        missed_ticks: u32::MAX,
        overruns: u32::MAX,
        stack_high_water_bytes: u32::MAX,
        link: LinkStats {
            received: RxCounters {
                frames_ok: u32::MAX,
                crc_errors: u32::MAX,
                format_errors: u32::MAX,
                overflows: u32::MAX,
                mismatches: u32::MAX,
                decode_errors: u32::MAX,
            },
            frames_sent: u32::MAX,
            telemetry_dropped: u32::MAX,
        },
    };
    let uplinks = [
        (
            "Reply Params (defaults)",
            Uplink::Reply {
                seq,
                result: Ok(Reply::Params(params)),
            },
        ),
        (
            "Reply Info (full strings)",
            Uplink::Reply {
                seq,
                result: Ok(Reply::Info(info)),
            },
        ),
        (
            "Reply PanicRecord (full strings)",
            Uplink::Reply {
                seq,
                result: Ok(Reply::PanicRecord(Some(panic_record))),
            },
        ),
        (
            "Reply Ack",
            Uplink::Reply {
                seq,
                result: Ok(Reply::Ack),
            },
        ),
        (
            "Reply refusal InvalidParams (full)",
            Uplink::Reply {
                seq,
                result: Err(Refusal::InvalidParams(FieldProblem::new(
                    &text(FIELD_CAP),
                    &text(PROBLEM_CAP),
                ))),
            },
        ),
        ("Telemetry (largest)", largest_telemetry()),
        (
            "Event",
            Uplink::Event {
                step: u32::MAX,
                event: Event::Armed(RunMode::FollowPath),
            },
        ),
        (
            "GroundTruth",
            Uplink::GroundTruth(GroundTruth {
                step: u32::MAX,
                ..Default::default()
            }),
        ),
        ("Stats (largest)", Uplink::Stats(stats)),
        (
            "TuneReport (a result)",
            Uplink::TuneReport(TuneReport {
                tunes_ended: u16::MAX,
                outcome: Ok(controller_core::tune::TuneResult {
                    models: [controller_core::tune::WheelModel::default(); 2],
                    loops: [RobotConfig::REFERENCE_ROBOT.left_wheel; 2],
                    warnings: controller_core::tune::TuneWarnings::default(),
                }),
            }),
        ),
    ];
    println!("| uplink | postcard body (B) | wire (B) |");
    for (name, message) in uplinks {
        show(name, &message);
    }
    println!("MAX_BODY_LEN {MAX_BODY_LEN}, MAX_FRAME_LEN {MAX_FRAME_LEN}");
    println!("schema 0x{SCHEMA_HASH:08x}");
    println!(
        "sizes in RAM: Decoder {}, PathAssembler {} (UploadState {}, UploadSegments {}), Downlink {}, Uplink {}, Path {}",
        core::mem::size_of::<Decoder>(),
        core::mem::size_of::<PathAssembler>(),
        core::mem::size_of::<link::UploadState>(),
        core::mem::size_of::<link::UploadSegments>(),
        core::mem::size_of::<Downlink>(),
        core::mem::size_of::<Uplink>(),
        core::mem::size_of::<controller_core::path::Path>()
    );
    for baud in [115_200, 230_400, 460_800, 921_600] {
        println!(
            "{baud}: {} B/s, raw {} Hz, capped {} Hz",
            link::bandwidth::bytes_per_second(baud),
            link::bandwidth::max_frame_rate_hz(baud, link::bandwidth::telemetry_wire_len(), 30),
            max_telemetry_rate_hz(baud, 30)
        );
    }
}

fn show<M: Message>(name: &str, message: &M) {
    let body = postcard::experimental::serialized_size(message).unwrap();
    let mut wire = [0u8; MAX_FRAME_LEN];
    let len = encode(message, &mut wire).unwrap();
    println!("| {name} | {body} | {len} |");
}
