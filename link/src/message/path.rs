//! The three messages of a path upload (see [`PathAssembler`](crate::PathAssembler)).

use controller_core::kinematics::Pose;
use controller_core::law::LawKind;
use controller_core::path::Segment;
use controller_core::reference::ReferenceMode;
use heapless::Vec;
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Most segments one [`PathChunk`] carries. Four keep a chunk near 90 bytes (about 8 ms
/// at 115 200 baud) and a full 32-segment path to 8 chunks.
pub const SEGMENTS_PER_CHUNK: usize = 4;

/// Starts an upload: announces its segments and how the path will be followed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub struct PathBegin {
    /// Chosen by the host, different for each upload; every chunk and the commit carry it.
    pub upload_id: u16,
    /// Segments the path has, 1…`MAX_SEGMENTS` of the core.
    pub segment_count: u8,
    /// Reference speed along the path, m/s (> 0).
    pub speed_m_s: f32,
    /// How the reference moves along the path.
    pub mode: ReferenceMode,
    /// Steering law to use.
    pub law: LawKind,
    /// The path's start pose (world frame, m and rad): where the robot is put down, the
    /// pose a long press of the button sets (the pose command). Arming does not set it;
    /// a host sets it with [`Request::SetPose`](crate::Request::SetPose).
    pub start_pose: Pose,
}

/// Some consecutive segments of an upload, in order of travel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub struct PathChunk {
    /// The upload ([`PathBegin::upload_id`]).
    pub upload_id: u16,
    /// Index in the path of `segments[0]` (0-based).
    pub first_index: u8,
    /// 1…[`SEGMENTS_PER_CHUNK`] segments, world frame.
    pub segments: Vec<Segment, SEGMENTS_PER_CHUNK>,
}

/// Ends an upload: check it is whole and matches, build the path, make it active.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub struct PathCommit {
    /// The upload ([`PathBegin::upload_id`]).
    pub upload_id: u16,
    /// Must equal [`PathBegin::segment_count`].
    pub segment_count: u8,
    /// [`path_checksum`](crate::path_checksum) of all the segments, in order.
    pub checksum: u32,
}

/// What a commit activated (the payload of [`Reply::PathCommitted`](crate::Reply)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub struct CommitSummary {
    /// The upload.
    pub upload_id: u16,
    /// Segments in the path.
    pub segment_count: u8,
    /// [`path_checksum`](crate::path_checksum) of the segments.
    pub checksum: u32,
    /// Length of the path, m.
    pub length_m: f32,
    /// True when the path's end joins its start (it then loops).
    pub closed: bool,
}
