//! The path-upload assembler: lost, repeated and out-of-order chunks; only a whole,
//! checked upload becomes a path.

use controller_core::kinematics::{Point, Pose};
use controller_core::law::LawKind;
use controller_core::path::{Path, PathError, Segment, MAX_SEGMENTS};
use controller_core::reference::ReferenceMode;
use link::upload::chunks;
use link::{
    path_checksum, Commit, PathAssembler, PathBegin, PathChunk, PathCommit, PathProblem, Refusal,
    Reply, SEGMENTS_PER_CHUNK,
};
use proptest::prelude::*;

fn rounded_square() -> Path {
    let corners = [
        Point::new(0.0, 0.0),
        Point::new(2.0, 0.0),
        Point::new(2.0, 2.0),
        Point::new(0.0, 2.0),
    ];
    Path::polyline(&corners, 0.3, true).unwrap()
}

fn begin(upload_id: u16, segments: &[Segment]) -> PathBegin {
    PathBegin {
        upload_id,
        segment_count: segments.len() as u8,
        speed_m_s: 0.25,
        mode: ReferenceMode::PathFollowing { lookahead_m: 0.1 },
        law: LawKind::Tracking,
        start_pose: Pose::new(0.3, 0.0, 0.0),
    }
}

fn commit_of(upload_id: u16, segments: &[Segment]) -> PathCommit {
    PathCommit {
        upload_id,
        segment_count: segments.len() as u8,
        checksum: path_checksum(segments),
    }
}

fn committed(result: Result<Commit, Refusal>) -> link::CommittedPath {
    match result {
        Ok(Commit::New(path)) => path,
        other => panic!("expected a new path, got {other:?}"),
    }
}

#[test]
fn a_whole_upload_in_order_becomes_the_path() {
    let original = rounded_square();
    let segments = original.segments();
    let mut assembler = PathAssembler::new();
    assert_eq!(assembler.begin(&begin(1, segments)), Ok(Reply::Ack));
    let mut last = None;
    for chunk in chunks(1, segments) {
        last = Some(assembler.chunk(&chunk).unwrap());
    }
    assert_eq!(
        last,
        Some(Reply::PathChunkStored {
            upload_id: 1,
            received: 8,
            expected: 8
        })
    );
    let result = committed(assembler.commit(&commit_of(1, segments)));
    assert_eq!(assembler.segments_of(&result), segments);
    assert!(result.summary.closed);
    assert_eq!(result.summary.segment_count, 8);
    assert_eq!(result.begin, begin(1, segments));
    assert_eq!(result.summary.length_m, original.length_m());
    assert_eq!(result.summary.checksum, path_checksum(segments));
    assert_eq!(assembler.progress(), None, "the upload is closed");
}

#[test]
fn an_aborted_upload_is_gone() {
    let segments = rounded_square().segments().to_vec();
    let mut assembler = PathAssembler::new();
    assembler.begin(&begin(3, &segments)).unwrap();
    for chunk in chunks(3, &segments) {
        assembler.chunk(&chunk).unwrap();
    }
    assert!(assembler.progress().is_some());
    assembler.abort();
    assert_eq!(assembler.progress(), None);
    assert!(matches!(
        assembler.commit(&commit_of(3, &segments)),
        Err(Refusal::UnknownUpload { upload_id: 3 })
    ));
}

#[test]
fn a_lost_chunk_is_named_and_can_be_resent() {
    let path = rounded_square();
    let segments = path.segments();
    let all: Vec<PathChunk> = chunks(5, segments).collect();
    let mut assembler = PathAssembler::new();
    assembler.begin(&begin(5, segments)).unwrap();
    // The second chunk (segments 4..8) is lost.
    assembler.chunk(&all[0]).unwrap();
    let refusal = assembler.commit(&commit_of(5, segments)).unwrap_err();
    assert_eq!(
        refusal,
        Refusal::UploadIncomplete {
            upload_id: 5,
            missing_index: SEGMENTS_PER_CHUNK as u8,
            received: 4,
            expected: 8
        }
    );
    // Still open: re-send and commit.
    assembler.chunk(&all[1]).unwrap();
    let result = committed(assembler.commit(&commit_of(5, segments)));
    assert_eq!(assembler.segments_of(&result), segments);
}

#[test]
fn repeated_chunks_are_idempotent_and_conflicts_refused() {
    let path = rounded_square();
    let segments = path.segments();
    let all: Vec<PathChunk> = chunks(2, segments).collect();
    let mut assembler = PathAssembler::new();
    assembler.begin(&begin(2, segments)).unwrap();
    let first = assembler.chunk(&all[0]).unwrap();
    assert_eq!(
        assembler.chunk(&all[0]).unwrap(),
        first,
        "same progress again"
    );

    let mut altered = all[0].clone();
    if let Some(
        Segment::Line { length_m, .. }
        | Segment::Arc {
            radius_m: length_m, ..
        },
    ) = altered.segments.get_mut(2)
    {
        *length_m += 0.01;
    }
    assert_eq!(
        assembler.chunk(&altered),
        Err(Refusal::InvalidPath(PathProblem::ChunkConflict {
            index: 2
        }))
    );
    // A conflicting chunk stores nothing, not even its new segments: overlap one old
    // index (3, altered) with a new one (4).
    let mut overlapping = all[1].clone();
    overlapping.first_index = 3;
    overlapping.segments.truncate(2);
    assert!(assembler.chunk(&overlapping).is_err());
    assert_eq!(assembler.progress().map(|p| p.received), Some(4));

    assembler.chunk(&all[1]).unwrap();
    let result = committed(assembler.commit(&commit_of(2, segments)));
    assert_eq!(assembler.segments_of(&result), segments);
}

#[test]
fn a_repeated_commit_is_answered_again_without_a_new_path() {
    let path = rounded_square();
    let segments = path.segments();
    let mut assembler = PathAssembler::new();
    assembler.begin(&begin(3, segments)).unwrap();
    for chunk in chunks(3, segments) {
        assembler.chunk(&chunk).unwrap();
    }
    let commit = commit_of(3, segments);
    let first = committed(assembler.commit(&commit));
    match assembler.commit(&commit) {
        Ok(again @ Commit::Repeated(summary)) => {
            assert_eq!(summary, first.summary);
            assert_eq!(again.reply(), Reply::PathCommitted(first.summary));
        }
        other => panic!("{other:?}"),
    }
    // Another checksum under the same id is not a repeat.
    let other = PathCommit {
        checksum: commit.checksum ^ 1,
        ..commit
    };
    assert_eq!(
        assembler.commit(&other).unwrap_err(),
        Refusal::UnknownUpload { upload_id: 3 }
    );
}

#[test]
fn unknown_uploads_are_refused() {
    let path = rounded_square();
    let segments = path.segments();
    let mut assembler = PathAssembler::new();
    let chunk = chunks(9, segments).next().unwrap();
    assert_eq!(
        assembler.chunk(&chunk),
        Err(Refusal::UnknownUpload { upload_id: 9 })
    );
    assembler.begin(&begin(10, segments)).unwrap();
    assert_eq!(
        assembler.chunk(&chunk),
        Err(Refusal::UnknownUpload { upload_id: 9 })
    );
    // A new begin replaces the open upload: its chunks no longer count.
    assembler
        .chunk(&chunks(10, segments).next().unwrap())
        .unwrap();
    assembler.begin(&begin(11, segments)).unwrap();
    assert_eq!(
        assembler.commit(&commit_of(10, segments)).unwrap_err(),
        Refusal::UnknownUpload { upload_id: 10 }
    );
    assert_eq!(
        assembler.progress().map(|p| (p.upload_id, p.received)),
        Some((11, 0))
    );
}

#[test]
fn a_resent_begin_keeps_the_chunks() {
    let path = rounded_square();
    let segments = path.segments();
    let mut assembler = PathAssembler::new();
    assembler.begin(&begin(4, segments)).unwrap();
    assembler
        .chunk(&chunks(4, segments).next().unwrap())
        .unwrap();
    assembler.begin(&begin(4, segments)).unwrap();
    assert_eq!(assembler.progress().map(|p| p.received), Some(4));
    // The same id with other settings starts over.
    let mut faster = begin(4, segments);
    faster.speed_m_s = 0.5;
    assembler.begin(&faster).unwrap();
    assert_eq!(assembler.progress().map(|p| p.received), Some(0));
}

#[test]
fn bad_begins_and_chunks_are_refused() {
    let path = rounded_square();
    let segments = path.segments();
    let mut assembler = PathAssembler::new();
    let mut b = begin(1, segments);
    for count in [0u8, MAX_SEGMENTS as u8 + 1, u8::MAX] {
        b.segment_count = count;
        assert_eq!(
            assembler.begin(&b),
            Err(Refusal::InvalidPath(PathProblem::BadSegmentCount {
                segment_count: count
            }))
        );
    }
    for speed in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let mut b = begin(1, segments);
        b.speed_m_s = speed;
        assert_eq!(
            assembler.begin(&b),
            Err(Refusal::InvalidPath(PathProblem::BadSpeed))
        );
    }
    let mut b = begin(1, segments);
    b.start_pose.theta_rad = f32::NAN;
    assert_eq!(
        assembler.begin(&b),
        Err(Refusal::InvalidPath(PathProblem::BadStartPose))
    );
    assert_eq!(assembler.progress(), None, "nothing was opened");
    // The largest count a path can hold is accepted.
    b = begin(1, segments);
    b.segment_count = MAX_SEGMENTS as u8;
    assert_eq!(assembler.begin(&b), Ok(Reply::Ack));
    assembler.abort();

    assembler.begin(&begin(1, segments)).unwrap();
    let mut past_end = chunks(1, segments).last().unwrap();
    past_end.first_index = 6; // 6 + 4 > 8
    assert_eq!(
        assembler.chunk(&past_end),
        Err(Refusal::InvalidPath(PathProblem::ChunkOutOfRange {
            first_index: 6,
            segments: 4,
            segment_count: 8
        }))
    );
    let mut empty = past_end.clone();
    empty.first_index = 0;
    empty.segments.clear();
    assert!(matches!(
        assembler.chunk(&empty),
        Err(Refusal::InvalidPath(PathProblem::ChunkOutOfRange {
            segments: 0,
            ..
        }))
    ));
    past_end.first_index = u8::MAX;
    assert!(assembler.chunk(&past_end).is_err());
}

#[test]
fn checksum_count_and_geometry_errors() {
    let path = rounded_square();
    let segments = path.segments();
    let mut assembler = PathAssembler::new();
    let load = |assembler: &mut PathAssembler, id: u16, segments: &[Segment]| {
        assembler.begin(&begin(id, segments)).unwrap();
        for chunk in chunks(id, segments) {
            assembler.chunk(&chunk).unwrap();
        }
    };

    // Count mismatch: the upload stays open.
    load(&mut assembler, 1, segments);
    let mut wrong_count = commit_of(1, segments);
    wrong_count.segment_count = 7;
    assert_eq!(
        assembler.commit(&wrong_count).unwrap_err(),
        Refusal::InvalidPath(PathProblem::CountMismatch {
            begun: 8,
            committed: 7
        })
    );
    assert!(assembler.progress().is_some());

    // Checksum mismatch: discarded.
    let mut wrong_sum = commit_of(1, segments);
    wrong_sum.checksum ^= 0x8000_0000;
    assert_eq!(
        assembler.commit(&wrong_sum).unwrap_err(),
        Refusal::InvalidPath(PathProblem::ChecksumMismatch {
            expected: wrong_sum.checksum,
            computed: path_checksum(segments)
        })
    );
    assert_eq!(assembler.progress(), None);
    assert_eq!(
        assembler.commit(&commit_of(1, segments)).unwrap_err(),
        Refusal::UnknownUpload { upload_id: 1 }
    );

    // Geometry: a segment moved 5 cm leaves a gap; the core names it. Discarded.
    let mut broken = segments.to_vec();
    if let Segment::Line { start, .. } = &mut broken[2] {
        start.x_m += 0.05;
    } else if let Segment::Arc { center, .. } = &mut broken[2] {
        center.x_m += 0.05;
    }
    load(&mut assembler, 2, &broken);
    assert_eq!(
        assembler.commit(&commit_of(2, &broken)).unwrap_err(),
        Refusal::InvalidPath(PathProblem::Geometry(PathError::Gap { segment: 2 }))
    );
    assert_eq!(assembler.progress(), None);
}

proptest! {
    /// Chunks delivered in any order, with repeats and with some lost the first time:
    /// the commit names a missing index until all arrived, then gives the original path.
    #[test]
    fn any_delivery_order_gives_the_same_path(
        order in Just((0..8usize).collect::<Vec<_>>()).prop_shuffle(),
        repeats in prop::collection::vec(0usize..8, 0..6),
        lost in prop::collection::vec(0usize..8, 0..3),
    ) {
        // A zig-zag of 25 segments: 7 chunks (the last of 1), and an 8th index that
        // does not exist.
        let waypoints: Vec<Point> = (0..14)
            .map(|i| Point::new(i as f32 * 0.5, if i % 2 == 0 { 0.0 } else { 0.4 }))
            .collect();
        let original = Path::polyline(&waypoints, 0.1, false).unwrap();
        let segments = original.segments();
        prop_assert_eq!(segments.len(), 25);
        let all: Vec<PathChunk> = chunks(77, segments).collect();
        let mut assembler = PathAssembler::new();
        assembler.begin(&begin(77, segments)).unwrap();
        let delivered: Vec<usize> = order
            .iter()
            .chain(&repeats)
            .copied()
            .filter(|&i| i < all.len() && !lost.contains(&i))
            .collect();
        for &i in &delivered {
            assembler.chunk(&all[i]).unwrap();
        }
        let commit = commit_of(77, segments);
        let mut missing: Vec<usize> = (0..all.len()).filter(|i| !delivered.contains(i)).collect();
        missing.sort_unstable();
        if let Some(&first) = missing.first() {
            match assembler.commit(&commit) {
                Err(Refusal::UploadIncomplete { missing_index, .. }) => {
                    prop_assert_eq!(usize::from(missing_index), first * SEGMENTS_PER_CHUNK);
                }
                other => prop_assert!(false, "{:?}", other),
            }
            for &i in &missing {
                assembler.chunk(&all[i]).unwrap();
            }
        }
        let result = committed(assembler.commit(&commit));
        prop_assert_eq!(assembler.segments_of(&result), segments);
        prop_assert!(!result.summary.closed);
        let path = Path::from_segments(assembler.segments_of(&result)).unwrap();
        prop_assert_eq!(path.length_m().to_bits(), result.summary.length_m.to_bits());
    }
}
