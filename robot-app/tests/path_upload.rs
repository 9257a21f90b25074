//! Path uploads over the link, on the fake board: chunks lost and repeated, the commit,
//! refusals while armed, and the controller following the committed path.

mod support;

use core::f32::consts::FRAC_PI_2;

use controller_core::kinematics::{Point, Pose};
use controller_core::law::LawKind;
use controller_core::path::Segment;
use controller_core::reference::ReferenceMode;
use controller_core::supervisor::{Event, RunMode, State};
use link::upload::chunks;
use link::{path_checksum, ArmMode, CommitSummary, PathBegin, PathCommit, Refusal, Reply, Request};
use robot_app::Channels;
use support::{default_params, Rig};

const BAUD: u32 = 921_600;

/// Six 0.3 m segments along +y from the origin: two chunks (4 + 2).
fn segments() -> Vec<Segment> {
    (0..6)
        .map(|i| Segment::Line {
            start: Point::new(0.0, 0.3 * i as f32),
            heading_rad: FRAC_PI_2,
            length_m: 0.3,
        })
        .collect()
}

fn begin(upload_id: u16) -> PathBegin {
    PathBegin {
        upload_id,
        segment_count: 6,
        speed_m_s: 0.2,
        mode: ReferenceMode::TimeIndexed {
            start_offset_m: 0.0,
        },
        law: LawKind::Kanayama,
        start_pose: Pose::new(0.0, 0.0, FRAC_PI_2),
    }
}

fn commit(upload_id: u16) -> PathCommit {
    PathCommit {
        upload_id,
        segment_count: 6,
        checksum: path_checksum(&segments()),
    }
}

#[test]
fn a_lost_and_a_repeated_chunk_then_a_commit_the_controller_follows() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let parts: Vec<_> = chunks(7, &segments()).collect();
    assert_eq!(parts.len(), 2);

    assert_eq!(rig.ask(Request::PathBegin(begin(7))), Ok(Reply::Ack));
    // The first chunk is lost; the second arrives.
    assert_eq!(
        rig.ask(Request::PathChunk(parts[1].clone())),
        Ok(Reply::PathChunkStored {
            upload_id: 7,
            received: 2,
            expected: 6
        })
    );
    assert_eq!(
        rig.ask(Request::PathCommit(commit(7))),
        Err(Refusal::UploadIncomplete {
            upload_id: 7,
            missing_index: 0,
            received: 2,
            expected: 6
        })
    );
    // A half-sent path never becomes active.
    assert_eq!(rig.active_reference().path().length_m(), 2.0);

    // The missing chunk, twice (the host re-sent it after losing the reply).
    for _ in 0..2 {
        assert_eq!(
            rig.ask(Request::PathChunk(parts[0].clone())),
            Ok(Reply::PathChunkStored {
                upload_id: 7,
                received: 6,
                expected: 6
            })
        );
    }
    let Ok(Reply::PathCommitted(summary)) = rig.ask(Request::PathCommit(commit(7))) else {
        panic!("not committed");
    };
    assert_eq!(summary.segment_count, 6);
    assert!((summary.length_m - 1.8).abs() < 1e-5);
    assert!(!summary.closed);
    // A repeated commit (its reply was lost) gets the same answer, nothing rebuilt.
    assert_eq!(
        rig.ask(Request::PathCommit(commit(7))),
        Ok(Reply::PathCommitted(summary))
    );

    // Path, law and start pose reached the controller and the supervisor together.
    let controller = rig.control.controller();
    assert!((rig.active_reference().path().length_m() - 1.8).abs() < 1e-5);
    // Built in the staging area in place, the very segments uploaded, speed and mode.
    assert_eq!(rig.active_reference().path().segments(), &segments()[..]);
    assert_eq!(rig.active_reference().speed_m_s(), 0.2);
    assert_eq!(rig.active_reference().mode(), begin(7).mode);
    assert_eq!(rig.active_law(), LawKind::Kanayama);
    // The commit does not move the robot's estimate: the pose command does.
    let before = controller.pose();
    assert_ne!(before, Pose::new(0.0, 0.0, FRAC_PI_2));
    let start = rig.control.supervisor().config().start_pose;
    assert_eq!(start, Pose::new(0.0, 0.0, FRAC_PI_2));
    let Ok(Reply::Params(active)) = rig.ask(Request::GetParams) else {
        panic!("no params");
    };
    assert_eq!(active.supervisor.start_pose, start);
    assert_eq!(active.robot, default_params().robot);
    assert_eq!(
        rig.ask(Request::SetPose {
            x_m: start.x_m,
            y_m: start.y_m,
            theta_rad: start.theta_rad,
        }),
        Ok(Reply::Ack)
    );
    assert_eq!(rig.control.controller().pose(), start);

    // Armed, it follows the new path: up +y, where the built-in one went along +x.
    rig.heartbeat_every = Some(100);
    assert_eq!(
        rig.ask(Request::Arm {
            mode: ArmMode::FollowPath,
            initial_motion: None,
            run_time_limit_steps: None,
        }),
        Ok(Reply::Ack)
    );
    rig.run(3000);
    assert_eq!(rig.last.map(|a| a.state), Some(State::Armed));
    let pose = rig.control.controller().pose();
    assert!(pose.y_m > 0.4 && pose.y_m < 0.8, "{pose:?}");
    assert!(pose.x_m.abs() < 0.02, "{pose:?}");
    assert!((pose.theta_rad - FRAC_PI_2).abs() < 0.05, "{pose:?}");
    // The run metrics saw the controller converge on it.
    let run = rig.control.run_summary();
    assert!(run.samples >= 290, "{run:?}");
    assert!(run.final_position_error_m < 0.01, "{run:?}");
    assert!(rig.events().contains(&Event::Armed(RunMode::FollowPath)));
}

#[test]
fn an_upload_is_refused_while_armed_and_completes_after_disarming() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    // Begun while disarmed, all chunks sent.
    assert_eq!(rig.ask(Request::PathBegin(begin(3))), Ok(Reply::Ack));
    for chunk in chunks(3, &segments()) {
        assert!(matches!(
            rig.ask(Request::PathChunk(chunk)),
            Ok(Reply::PathChunkStored { .. })
        ));
    }
    rig.heartbeat_every = Some(100);
    let hold = Request::Arm {
        mode: ArmMode::HoldWheelSpeeds(controller_core::kinematics::WheelSpeeds::new(2.0, 2.0)),
        initial_motion: None,
        run_time_limit_steps: None,
    };
    assert_eq!(rig.ask(hold), Ok(Reply::Ack));
    assert_eq!(rig.ask(Request::PathBegin(begin(4))), Err(Refusal::Armed));
    assert_eq!(rig.ask(Request::PathCommit(commit(3))), Err(Refusal::Armed));
    assert_eq!(rig.active_reference().path().length_m(), 2.0);
    // The refused commit left the upload open.
    assert_eq!(rig.ask(Request::Disarm), Ok(Reply::Ack));
    assert!(matches!(
        rig.ask(Request::PathCommit(commit(3))),
        Ok(Reply::PathCommitted(CommitSummary { upload_id: 3, .. }))
    ));
    assert!((rig.active_reference().path().length_m() - 1.8).abs() < 1e-5);
}

#[test]
fn a_commit_moves_an_enabled_geofence_to_the_new_path() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let mut fenced = default_params();
    fenced.supervisor.geofence_radius_m = Some(3.0);
    assert!(matches!(
        rig.ask(Request::SetParams(fenced)),
        Ok(Reply::ParamsApplied { .. })
    ));
    // The same path 10 m away: the old 3 m fence around the origin would stop the robot.
    let far: Vec<Segment> = segments()
        .into_iter()
        .map(|s| match s {
            Segment::Line {
                start,
                heading_rad,
                length_m,
            } => Segment::Line {
                start: Point::new(start.x_m + 10.0, start.y_m),
                heading_rad,
                length_m,
            },
            arc => arc,
        })
        .collect();
    let mut far_begin = begin(5);
    far_begin.start_pose = Pose::new(10.0, 0.0, FRAC_PI_2);
    assert_eq!(rig.ask(Request::PathBegin(far_begin)), Ok(Reply::Ack));
    for chunk in chunks(5, &far) {
        rig.ask(Request::PathChunk(chunk)).expect("stored");
    }
    let far_commit = PathCommit {
        upload_id: 5,
        segment_count: 6,
        checksum: path_checksum(&far),
    };
    assert!(matches!(
        rig.ask(Request::PathCommit(far_commit)),
        Ok(Reply::PathCommitted(_))
    ));
    // Farthest path point from the start: its end, 1.8 m away; plus 1 m.
    let radius = rig.control.supervisor().config().geofence_radius_m;
    assert!(radius.is_some_and(|r| (r - 2.8).abs() < 1e-4), "{radius:?}");
    // Put at the new path's start and told so.
    let start = far_begin.start_pose;
    let set_pose = Request::SetPose {
        x_m: start.x_m,
        y_m: start.y_m,
        theta_rad: start.theta_rad,
    };
    assert_eq!(rig.ask(set_pose), Ok(Reply::Ack));
    rig.heartbeat_every = Some(100);
    rig.ask(Request::Arm {
        mode: ArmMode::FollowPath,
        initial_motion: None,
        run_time_limit_steps: None,
    })
    .expect("armed");
    rig.run(2000);
    assert_eq!(rig.last.map(|a| a.state), Some(State::Armed), "no fault");
}

/// Begins upload `upload_id` of `segments` and sends all its chunks, not the commit.
fn begin_and_send(rig: &mut Rig<'_>, upload_id: u16, segments: &[Segment]) {
    let begin = PathBegin {
        segment_count: segments.len() as u8,
        ..begin(upload_id)
    };
    assert_eq!(rig.ask(Request::PathBegin(begin)), Ok(Reply::Ack));
    for chunk in chunks(upload_id, segments) {
        assert!(rig.ask(Request::PathChunk(chunk)).is_ok());
    }
}

/// Begins upload `upload_id` of [`segments`] and sends all its chunks, not the commit.
fn begin_and_send_chunks(rig: &mut Rig<'_>, upload_id: u16) {
    begin_and_send(rig, upload_id, &segments());
}

/// Uploads `segments` under `upload_id` and commits them; the commit's reply.
fn upload(rig: &mut Rig<'_>, upload_id: u16, segments: &[Segment]) -> Result<Reply, Refusal> {
    begin_and_send(rig, upload_id, segments);
    rig.ask(Request::PathCommit(PathCommit {
        upload_id,
        segment_count: segments.len() as u8,
        checksum: path_checksum(segments),
    }))
}

#[test]
fn uploads_one_after_another_each_become_active() {
    // Each upload is assembled in the staging area, where the path installed before it
    // was: the second and third must not see the first's segments.
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let six = segments();
    for (id, count) in [(1, 6), (2, 2), (3, 5)] {
        let Ok(Reply::PathCommitted(summary)) = upload(&mut rig, id, &six[..count]) else {
            panic!("upload {id} not committed");
        };
        assert_eq!(summary.segment_count, count as u8);
        let length = rig.active_reference().path().length_m();
        assert!((length - 0.3 * count as f32).abs() < 1e-5, "{id}: {length}");
    }
}

#[test]
fn a_configuration_set_during_an_upload_discards_it() {
    // The configuration is staged in the room the upload's segments are in: the upload
    // ends, and its commit is refused as unknown rather than building a path from what
    // the configuration overwrote. Begun again, it completes.
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let parts: Vec<_> = chunks(9, &segments()).collect();
    assert_eq!(rig.ask(Request::PathBegin(begin(9))), Ok(Reply::Ack));
    assert!(rig.ask(Request::PathChunk(parts[0].clone())).is_ok());
    assert!(matches!(
        rig.ask(Request::SetParams(default_params())),
        Ok(Reply::ParamsApplied { .. })
    ));
    assert_eq!(
        rig.ask(Request::PathChunk(parts[1].clone())),
        Err(Refusal::UnknownUpload { upload_id: 9 })
    );
    assert_eq!(
        rig.ask(Request::PathCommit(commit(9))),
        Err(Refusal::UnknownUpload { upload_id: 9 })
    );
    assert_eq!(rig.active_reference().path().length_m(), 2.0);
    assert!(matches!(
        upload(&mut rig, 9, &segments()),
        Ok(Reply::PathCommitted(_))
    ));
    assert!((rig.active_reference().path().length_m() - 1.8).abs() < 1e-5);
}

#[test]
fn a_configuration_sent_while_a_commit_installs_is_busy_and_the_commit_stays_repeatable() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    begin_and_send_chunks(&mut rig, 4);
    // The commit and a configuration in one go: the commit is staged, and the
    // configuration finds the staging area taken before the control side installs it.
    let commit_seq = rig.send(Request::PathCommit(commit(4)));
    let params_seq = rig.send(Request::SetParams(support::default_params()));
    rig.deliver_at_once();
    assert_eq!(rig.reply(params_seq), Some(Err(Refusal::Busy)));
    rig.run(10);
    let Some(Ok(Reply::PathCommitted(summary))) = rig.reply(commit_seq) else {
        panic!("not committed: {:?}", rig.reply(commit_seq));
    };
    // The host lost the reply and commits again: the same answer.
    assert_eq!(
        rig.ask(Request::PathCommit(commit(4))),
        Ok(Reply::PathCommitted(summary))
    );
    assert_eq!(rig.link.counters().busy, 1);
}

#[test]
fn a_commit_the_control_side_refused_is_not_committed_when_repeated() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    // Faulted: the control side refuses to install anything until faults are cleared.
    assert_eq!(rig.ask(Request::EmergencyStop), Ok(Reply::Ack));
    begin_and_send_chunks(&mut rig, 5);
    let refused = rig.ask(Request::PathCommit(commit(5)));
    assert!(refused.is_err(), "{refused:?}");
    assert_eq!(rig.active_reference().path().length_m(), 2.0);
    // Cleared and repeated: the segments are gone, so the host must upload again.
    assert_eq!(rig.ask(Request::ClearFaults), Ok(Reply::Ack));
    assert_eq!(
        rig.ask(Request::PathCommit(commit(5))),
        Err(Refusal::UnknownUpload { upload_id: 5 })
    );
    assert_eq!(rig.active_reference().path().length_m(), 2.0);
}

#[test]
fn a_configuration_refused_busy_leaves_the_upload_begun_behind_a_staged_commit_open() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    begin_and_send_chunks(&mut rig, 4);
    // In one go: the commit is staged, a new upload begins, and a configuration comes
    // before the control side has installed the path.
    let commit_seq = rig.send(Request::PathCommit(commit(4)));
    let begin_seq = rig.send(Request::PathBegin(begin(6)));
    let params_seq = rig.send(Request::SetParams(support::default_params()));
    rig.deliver_at_once();
    assert_eq!(rig.reply(params_seq), Some(Err(Refusal::Busy)));
    rig.run(10);
    assert!(matches!(
        rig.reply(commit_seq),
        Some(Ok(Reply::PathCommitted(_)))
    ));
    assert_eq!(rig.reply(begin_seq), Some(Ok(Reply::Ack)));
    // The refused configuration left the new upload open: it completes.
    for chunk in chunks(6, &segments()) {
        assert!(rig.ask(Request::PathChunk(chunk)).is_ok());
    }
    assert!(matches!(
        rig.ask(Request::PathCommit(commit(6))),
        Ok(Reply::PathCommitted(_))
    ));
}
