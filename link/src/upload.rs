//! The robot's side of a path upload: chunks in, the segments of a whole path checked
//! as [`Path::from_segments`] checks them out, or nothing. The caller builds the path from
//! them where it will use it (robot-app: in place, with `Reference::rebuild`), so no path
//! crosses the stack.
//!
//! The host sends [`PathBegin`], the segments in [`PathChunk`]s (up to
//! [`SEGMENTS_PER_CHUNK`] each, any order), then [`PathCommit`]. Nothing the assembler
//! holds is active until a commit succeeds, so a half-sent path never becomes active:
//!
//! - a **lost chunk** makes the commit fail with [`Refusal::UploadIncomplete`], naming the
//!   first missing index; the upload stays open, the host re-sends and commits again;
//! - a **repeated chunk** (the host re-sent because a reply was lost) is accepted again
//!   when its contents are the same, and refused ([`PathProblem::ChunkConflict`]) when
//!   they differ;
//! - a **repeated commit** of the upload just committed returns the same summary
//!   ([`Commit::Repeated`]) without rebuilding the path;
//! - a chunk or commit of an upload that is not open gets [`Refusal::UnknownUpload`];
//! - a checksum or geometry error discards the upload.
//!
//! The assembler does not know whether the robot is armed: the robot service refuses
//! begin and commit while armed ([`Refusal::Armed`]) before calling it.

use controller_core::kinematics::Point;
use controller_core::path::{Path, Segment, MAX_SEGMENTS};

use crate::checksum::path_checksum;
use crate::message::{
    CommitSummary, PathBegin, PathChunk, PathCommit, PathProblem, Refusal, Reply,
    SEGMENTS_PER_CHUNK,
};

// One bit per segment in `Pending::received`.
const _: () = assert!(MAX_SEGMENTS <= 64);

/// Builds a path from an upload's chunks; fixed capacity ([`MAX_SEGMENTS`] segments, about
/// 0.8 KiB), no heap. It is an [`UploadState`] with its own [`UploadSegments`]: a robot
/// short of RAM keeps the segments where it has room and uses [`UploadState`] directly
/// (robot-app assembles in the staging area that the committed path then takes).
#[derive(Clone, Debug, Default)]
pub struct PathAssembler {
    state: UploadState,
    segments: UploadSegments,
}

/// Room for an upload's segments (about 0.8 KiB), lent to [`UploadState`]'s calls.
#[derive(Clone, Debug, PartialEq)]
pub struct UploadSegments([Segment; MAX_SEGMENTS]);

impl UploadSegments {
    /// Empty room.
    pub const fn new() -> Self {
        Self([FILLER; MAX_SEGMENTS])
    }

    /// The first `count` segments (all of them for a larger count): a committed path's
    /// with its [`CommitSummary::segment_count`].
    pub fn first(&self, count: u8) -> &[Segment] {
        self.0.get(..usize::from(count)).unwrap_or(&self.0)
    }
}

impl Default for UploadSegments {
    fn default() -> Self {
        Self::new()
    }
}

/// Which upload is open, what of it has arrived, and the last commit; the segments
/// themselves are in an [`UploadSegments`] that the caller lends to each call and must
/// not change while an upload is open (or must [`UploadState::abort`] it).
#[derive(Clone, Debug, Default)]
pub struct UploadState {
    pending: Option<Pending>,
    last_commit: Option<CommitSummary>,
}

/// The upload being received.
#[derive(Clone, Copy, Debug)]
struct Pending {
    begin: PathBegin,
    /// Bit i set: segment i received.
    received: u64,
}

/// An upload that a commit made whole and checked, with how to follow it. Its segments
/// are the first `summary.segment_count` of the [`UploadSegments`] the commit was given
/// ([`UploadSegments::first`]); [`Path::from_segments`] accepts them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CommittedPath {
    /// Speed, reference mode, law and start pose announced by the upload's begin.
    pub begin: PathBegin,
    /// What to report ([`Reply::PathCommitted`]).
    pub summary: CommitSummary,
}

/// The outcome of an accepted commit.
#[derive(Clone, Debug)]
pub enum Commit {
    /// A new path: make it active.
    New(CommittedPath),
    /// The upload committed last, committed again (its reply was lost): nothing to do
    /// but reply.
    Repeated(CommitSummary),
}

impl Commit {
    /// The reply to send.
    pub fn reply(&self) -> Reply {
        Reply::PathCommitted(match self {
            Commit::New(committed) => committed.summary,
            Commit::Repeated(summary) => *summary,
        })
    }
}

/// An upload's progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// The upload.
    pub upload_id: u16,
    /// Distinct segments received.
    pub received: u8,
    /// Segments announced.
    pub expected: u8,
}

const FILLER: Segment = Segment::Line {
    start: Point::new(0.0, 0.0),
    heading_rad: 0.0,
    length_m: 0.0,
};

impl PathAssembler {
    /// An assembler with no upload open.
    pub const fn new() -> Self {
        Self {
            state: UploadState::new(),
            segments: UploadSegments::new(),
        }
    }

    /// [`UploadState::begin`].
    pub fn begin(&mut self, begin: &PathBegin) -> Result<Reply, Refusal> {
        self.state.begin(begin)
    }

    /// [`UploadState::chunk`].
    pub fn chunk(&mut self, chunk: &PathChunk) -> Result<Reply, Refusal> {
        self.state.chunk(chunk, &mut self.segments)
    }

    /// [`UploadState::commit`].
    pub fn commit(&mut self, commit: &PathCommit) -> Result<Commit, Refusal> {
        self.state.commit(commit, &self.segments)
    }

    /// [`UploadState::abort`].
    pub fn abort(&mut self) {
        self.state.abort();
    }

    /// The segments of `committed` (valid until the next chunk is stored).
    pub fn segments_of(&self, committed: &CommittedPath) -> &[Segment] {
        self.segments.first(committed.summary.segment_count)
    }

    /// [`UploadState::progress`].
    pub fn progress(&self) -> Option<Progress> {
        self.state.progress()
    }
}

impl UploadState {
    /// No upload open, none committed.
    pub const fn new() -> Self {
        Self {
            pending: None,
            last_commit: None,
        }
    }

    /// Opens an upload, discarding any other one still open. A begin identical to the
    /// open upload's (a re-send) keeps the chunks already received. Replies
    /// [`Reply::Ack`].
    pub fn begin(&mut self, begin: &PathBegin) -> Result<Reply, Refusal> {
        let count = usize::from(begin.segment_count);
        if count == 0 || count > MAX_SEGMENTS {
            return Err(invalid(PathProblem::BadSegmentCount {
                segment_count: begin.segment_count,
            }));
        }
        if !(begin.speed_m_s.is_finite() && begin.speed_m_s > 0.0) {
            return Err(invalid(PathProblem::BadSpeed));
        }
        if !begin.start_pose.is_finite() {
            return Err(invalid(PathProblem::BadStartPose));
        }
        let resent = self.pending.as_ref().is_some_and(|p| p.begin == *begin);
        if !resent {
            self.pending = Some(Pending {
                begin: *begin,
                received: 0,
            });
        }
        Ok(Reply::Ack)
    }

    /// Stores a chunk of the open upload in `segments` (all its segments or none).
    /// Replies [`Reply::PathChunkStored`].
    pub fn chunk(
        &mut self,
        chunk: &PathChunk,
        segments: &mut UploadSegments,
    ) -> Result<Reply, Refusal> {
        let pending = self.open(chunk.upload_id)?;
        let first = usize::from(chunk.first_index);
        let count = usize::from(pending.begin.segment_count);
        let slots = segments
            .0
            .get_mut(first..first + chunk.segments.len())
            .filter(|slots| !slots.is_empty() && first + slots.len() <= count)
            .ok_or(invalid(PathProblem::ChunkOutOfRange {
                first_index: chunk.first_index,
                segments: chunk.segments.len() as u8,
                segment_count: pending.begin.segment_count,
            }))?;
        for (offset, (slot, segment)) in slots.iter().zip(&chunk.segments).enumerate() {
            let index = first + offset;
            if pending.received & (1 << index) != 0 && slot != segment {
                return Err(invalid(PathProblem::ChunkConflict { index: index as u8 }));
            }
        }
        for (offset, (slot, segment)) in slots.iter_mut().zip(&chunk.segments).enumerate() {
            *slot = *segment;
            pending.received |= 1 << (first + offset);
        }
        let progress = pending.progress();
        Ok(Reply::PathChunkStored {
            upload_id: progress.upload_id,
            received: progress.received,
            expected: progress.expected,
        })
    }

    /// Checks the open upload against `commit` and builds its path from `segments`. On
    /// success the upload is closed and the caller makes the path active; see the module
    /// doc for the failures that keep the upload open and those that discard it.
    pub fn commit(
        &mut self,
        commit: &PathCommit,
        segments: &UploadSegments,
    ) -> Result<Commit, Refusal> {
        let Some(pending) = self
            .pending
            .as_ref()
            .filter(|p| p.begin.upload_id == commit.upload_id)
        else {
            return match self.last_commit {
                Some(last)
                    if last.upload_id == commit.upload_id
                        && last.segment_count == commit.segment_count
                        && last.checksum == commit.checksum =>
                {
                    Ok(Commit::Repeated(last))
                }
                _ => Err(Refusal::UnknownUpload {
                    upload_id: commit.upload_id,
                }),
            };
        };
        let begun = pending.begin.segment_count;
        if commit.segment_count != begun {
            return Err(invalid(PathProblem::CountMismatch {
                begun,
                committed: commit.segment_count,
            }));
        }
        if let Some(missing_index) = pending.first_missing() {
            let progress = pending.progress();
            return Err(Refusal::UploadIncomplete {
                upload_id: progress.upload_id,
                missing_index,
                received: progress.received,
                expected: progress.expected,
            });
        }
        let segments = pending.announced(segments);
        let computed = path_checksum(segments);
        let result = if computed != commit.checksum {
            Err(invalid(PathProblem::ChecksumMismatch {
                expected: commit.checksum,
                computed,
            }))
        } else {
            Path::check_segments(segments)
                .map_err(|e| invalid(PathProblem::Geometry(e)))
                .map(|shape| CommittedPath {
                    begin: pending.begin,
                    summary: CommitSummary {
                        upload_id: commit.upload_id,
                        segment_count: begun,
                        checksum: computed,
                        length_m: shape.length_m,
                        closed: shape.closed,
                    },
                })
        };
        // Whole and checked, or discarded: the upload is over either way.
        self.pending = None;
        let committed = result?;
        self.last_commit = Some(committed.summary);
        Ok(Commit::New(committed))
    }

    /// Discards the open upload, if any.
    pub fn abort(&mut self) {
        self.pending = None;
    }

    /// The open upload's progress, if one is open.
    pub fn progress(&self) -> Option<Progress> {
        self.pending.as_ref().map(Pending::progress)
    }

    /// The open upload with this id, or [`Refusal::UnknownUpload`].
    fn open(&mut self, upload_id: u16) -> Result<&mut Pending, Refusal> {
        self.pending
            .as_mut()
            .filter(|p| p.begin.upload_id == upload_id)
            .ok_or(Refusal::UnknownUpload { upload_id })
    }
}

impl Pending {
    fn progress(&self) -> Progress {
        Progress {
            upload_id: self.begin.upload_id,
            received: self.received.count_ones() as u8,
            expected: self.begin.segment_count,
        }
    }

    /// The lowest announced index not received.
    fn first_missing(&self) -> Option<u8> {
        (0..self.begin.segment_count).find(|&i| self.received & (1 << i) == 0)
    }

    /// The announced segments in `segments` (all received once `first_missing` is
    /// `None`).
    fn announced<'s>(&self, segments: &'s UploadSegments) -> &'s [Segment] {
        segments.first(self.begin.segment_count)
    }
}

fn invalid(problem: PathProblem) -> Refusal {
    Refusal::InvalidPath(problem)
}

/// Splits `segments` into the chunks of upload `upload_id`, [`SEGMENTS_PER_CHUNK`] at a
/// time: what a host sends between [`PathBegin`] and [`PathCommit`].
pub fn chunks(upload_id: u16, segments: &[Segment]) -> impl Iterator<Item = PathChunk> + '_ {
    segments
        .chunks(SEGMENTS_PER_CHUNK)
        .enumerate()
        .map(move |(i, part)| PathChunk {
            upload_id,
            first_index: u8::try_from(i * SEGMENTS_PER_CHUNK).unwrap_or(u8::MAX),
            // `part` has at most SEGMENTS_PER_CHUNK segments: it always fits.
            segments: heapless::Vec::from_slice(part).unwrap_or_default(),
        })
}
