//! Why the robot did not do what was asked.

use core::fmt::{self, Write as _};

use controller_core::params::ParamError;
use controller_core::path::PathError;
use controller_core::reference::ReferenceError;
use heapless::String;
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

use super::bounded;

/// Capacity of [`FieldProblem::field`], bytes of UTF-8.
pub const FIELD_CAP: usize = 40;
/// Capacity of [`FieldProblem::problem`], bytes of UTF-8.
pub const PROBLEM_CAP: usize = 48;

/// A refused request. `Display` reads as a sentence for a terminal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub enum Refusal {
    /// Not while the motors are armed: disarm first.
    Armed,
    /// Not while faults are latched: clear them first.
    Faulted,
    /// The robot cannot take this request now (e.g. a flash write is in progress); retry.
    Busy,
    /// [`Request::SetParams`](crate::Request) with a configuration the core rejects.
    InvalidParams(FieldProblem),
    /// A request argument out of its range (e.g. a telemetry rate of 0 Hz).
    InvalidArgument(FieldProblem),
    /// A path upload that cannot become a path.
    InvalidPath(PathProblem),
    /// [`PathCommit`](crate::PathCommit) before every segment arrived. The upload stays
    /// open: send the missing chunks and commit again.
    UploadIncomplete {
        /// The upload.
        upload_id: u16,
        /// The first segment index not received.
        missing_index: u8,
        /// Distinct segments received.
        received: u8,
        /// Segments announced.
        expected: u8,
    },
    /// A chunk or commit for an upload that was never begun here, was replaced by a
    /// newer [`PathBegin`](crate::PathBegin), or was discarded.
    UnknownUpload {
        /// The upload id the request carried.
        upload_id: u16,
    },
    /// Not allowed in the robot's current situation, for the reason given.
    NotPermitted(NotPermitted),
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Armed => f.write_str("refused while armed: disarm first"),
            Refusal::Faulted => f.write_str("refused while faulted: clear the faults first"),
            Refusal::Busy => f.write_str("the robot is busy: try again"),
            Refusal::InvalidParams(p) => write!(f, "invalid parameter: {p}"),
            Refusal::InvalidArgument(p) => write!(f, "invalid argument: {p}"),
            Refusal::InvalidPath(p) => write!(f, "invalid path: {p}"),
            Refusal::UploadIncomplete {
                upload_id,
                missing_index,
                received,
                expected,
            } => write!(
                f,
                "path upload {upload_id} incomplete: {received} of {expected} segments \
                 received, segment {missing_index} missing"
            ),
            Refusal::UnknownUpload { upload_id } => {
                write!(f, "no path upload {upload_id} in progress (begin it again)")
            }
            Refusal::NotPermitted(reason) => write!(f, "not permitted: {reason}"),
        }
    }
}

/// A named field and what is wrong with it, e.g. `robot.wheel_radius_m` / `must be > 0`.
/// Both are cut to their capacity at a character boundary.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub struct FieldProblem {
    /// The field's path, e.g. `robot.limits.max_rim_speed_m_s` or `hz`.
    pub field: String<FIELD_CAP>,
    /// What is wrong or required, e.g. `must be > 0, got -0.03`.
    pub problem: String<PROBLEM_CAP>,
}

impl FieldProblem {
    /// `field` and `problem`, each cut to its capacity. No formatting machinery: cheap on
    /// the target.
    pub fn new(field: &str, problem: &str) -> Self {
        Self {
            field: bounded(field),
            problem: bounded(problem),
        }
    }

    /// `field` and the text `problem` displays (cut to [`PROBLEM_CAP`]). Uses
    /// `core::fmt`, which costs flash on the target when the text formats numbers.
    pub fn from_display(field: &str, problem: &dyn fmt::Display) -> Self {
        let mut text = Truncating::<PROBLEM_CAP>::default();
        // Truncating never reports an error.
        let _ = write!(text, "{problem}");
        Self {
            field: bounded(field),
            problem: text.0,
        }
    }

    /// The core's verdict on a `RobotConfig`: field `robot.<field>` and the requirement it
    /// breaks (`must be > 0`, …), without the value, so no float formatting is pulled in.
    pub fn from_param_error(error: &ParamError) -> Self {
        let mut field = String::<FIELD_CAP>::new();
        for part in ["robot.", error.field()] {
            field.push_str(bounded::<FIELD_CAP>(part).as_str()).ok();
        }
        Self {
            field,
            problem: bounded(error.requirement()),
        }
    }
}

impl fmt::Display for FieldProblem {
    /// `robot.wheel_radius_m must be > 0`
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.field, self.problem)
    }
}

/// A `fmt::Write` into a bounded string that keeps what fits and drops the rest.
#[derive(Default)]
struct Truncating<const N: usize>(String<N>);

impl<const N: usize> fmt::Write for Truncating<N> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for c in s.chars() {
            if self.0.push(c).is_err() {
                break;
            }
        }
        Ok(())
    }
}

/// Why an upload cannot become a path.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub enum PathProblem {
    /// [`PathBegin::segment_count`](crate::PathBegin) was 0 or above the core's
    /// `MAX_SEGMENTS`.
    BadSegmentCount {
        /// The count announced.
        segment_count: u8,
    },
    /// [`PathBegin::speed_m_s`](crate::PathBegin) was ≤ 0 or not finite.
    BadSpeed,
    /// [`PathBegin::start_pose`](crate::PathBegin) had a NaN or infinite field.
    BadStartPose,
    /// A chunk was empty or reached past the announced segment count.
    ChunkOutOfRange {
        /// [`PathChunk::first_index`](crate::PathChunk).
        first_index: u8,
        /// Segments in the chunk.
        segments: u8,
        /// Segments announced.
        segment_count: u8,
    },
    /// A chunk repeated a segment index with different contents (a repeat with the same
    /// contents is accepted). The upload stays open with the first contents.
    ChunkConflict {
        /// The first index whose contents differ.
        index: u8,
    },
    /// [`PathCommit::segment_count`](crate::PathCommit) differs from the begin's.
    CountMismatch {
        /// Announced by the begin.
        begun: u8,
        /// Announced by the commit.
        committed: u8,
    },
    /// The segments received do not give the commit's checksum. The upload is discarded.
    ChecksumMismatch {
        /// The commit's [`checksum`](crate::PathCommit::checksum).
        expected: u32,
        /// [`path_checksum`](crate::path_checksum) of what was received.
        computed: u32,
    },
    /// The core rejected the segments (`Path::from_segments`). The upload is discarded.
    Geometry(PathError),
    /// The core rejected the reference speed or mode (`Reference::new`).
    Reference(ReferenceError),
}

impl fmt::Display for PathProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            PathProblem::BadSegmentCount { segment_count } => write!(
                f,
                "segment_count {segment_count} must be in 1..={}",
                controller_core::path::MAX_SEGMENTS
            ),
            PathProblem::BadSpeed => f.write_str("speed_m_s must be > 0 and finite"),
            PathProblem::BadStartPose => f.write_str("start_pose must be finite"),
            PathProblem::ChunkOutOfRange {
                first_index,
                segments,
                segment_count,
            } => write!(
                f,
                "chunk of {segments} segments at index {first_index} is empty or reaches \
                 past segment_count {segment_count}"
            ),
            PathProblem::ChunkConflict { index } => write!(
                f,
                "segment {index} was already received with other contents"
            ),
            PathProblem::CountMismatch { begun, committed } => write!(
                f,
                "commit announces {committed} segments, the begin announced {begun}"
            ),
            PathProblem::ChecksumMismatch { expected, computed } => write!(
                f,
                "checksum 0x{computed:08x} of the segments received is not the commit's \
                 0x{expected:08x}; upload discarded"
            ),
            PathProblem::Geometry(e) => write!(f, "{e}; upload discarded"),
            PathProblem::Reference(e) => write!(f, "{e}"),
        }
    }
}

/// Why a request is not permitted in the robot's current situation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub enum NotPermitted {
    /// Arming to follow a path before any path was committed.
    NoPath,
    /// Persisting parameters on a robot without persistent storage (e.g. the simulator).
    NoStorage,
    /// The robot does not implement this request (e.g. tuning mode).
    Unsupported,
    /// The robot's button is held: the local stop wins over the link (release it first).
    ButtonHeld,
    /// Writing persistent storage failed (erase, program or read-back check); the
    /// configuration in use is unchanged. Retry, or power-cycle if it keeps failing.
    StorageFailed,
    /// Another host commands this robot; this connection only observes (the virtual
    /// robot's rule: its newest connection commands, see `docs/protocol.md`).
    AnotherHostCommands,
    /// Arming from rest while a wheel still turns: both measured wheel speeds must have
    /// stayed below the core's `REST_SPEED_RAD_S` for `REST_STEPS` control steps (wait,
    /// or assert the motion with the arm request's `initial_motion`).
    WheelsTurning,
    /// Persisting parameters while the chip's brown-out reset is off: the chip would keep
    /// running, and writing its flash, with its supply below the 2.7 V that needs. The
    /// firmware sets the level when it starts; it reports in `Info` which level is in force.
    BrownOutResetOff,
    /// A velocity command ([`Request::Velocity`](crate::Request)) while the robot is not
    /// armed in the velocity mode ([`ArmMode::FollowVelocity`](crate::ArmMode)):
    /// disarmed, or armed in another mode.
    NotInVelocityMode,
    /// A motor pulse without the confirmation that the wheels are lifted
    /// (`MotorTest::confirm` is not [`MOTOR_TEST_CONFIRMATION`](crate::MOTOR_TEST_CONFIRMATION)).
    MotorTestUnconfirmed,
}

impl fmt::Display for NotPermitted {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            NotPermitted::NoPath => "no path has been committed yet",
            NotPermitted::NoStorage => "this robot has no persistent storage",
            NotPermitted::Unsupported => "this robot does not support that request",
            NotPermitted::ButtonHeld => "the robot's button is held (local stop)",
            NotPermitted::StorageFailed => "writing the robot's persistent storage failed",
            NotPermitted::AnotherHostCommands => {
                "another connection commands this robot; this one only observes"
            }
            NotPermitted::WheelsTurning => {
                "the wheels are still turning: arming waits until both stand still"
            }
            NotPermitted::BrownOutResetOff => {
                "the robot's brown-out reset is not at level 3, so its supply could sag \
                 below the 2.7 V a flash write needs (the firmware sets the level at boot: \
                 see its log)"
            }
            NotPermitted::NotInVelocityMode => {
                "velocity commands are taken only while armed in the velocity mode"
            }
            NotPermitted::MotorTestUnconfirmed => {
                "a motor pulse needs the confirmation that the wheels are lifted"
            }
        })
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;

    #[test]
    fn param_errors_name_the_robot_field() {
        let e = ParamError::NonPositive {
            field: "wheel_radius_left_m",
            value: -0.03,
        };
        let p = FieldProblem::from_param_error(&e);
        assert_eq!(p.field.as_str(), "robot.wheel_radius_left_m");
        assert_eq!(p.problem.as_str(), "must be > 0");
        assert_eq!(
            Refusal::InvalidParams(p).to_string(),
            "invalid parameter: robot.wheel_radius_left_m must be > 0"
        );
    }

    #[test]
    fn from_display_keeps_the_value_and_truncates() {
        let e = ParamError::NonPositive {
            field: "wheel_radius_left_m",
            value: -0.03,
        };
        let p = FieldProblem::from_display("robot", &e);
        assert_eq!(
            p.problem.as_str(),
            "wheel_radius_left_m must be > 0, got -0.03"
        );
        let long = "x".repeat(200);
        let p = FieldProblem::from_display(&long, &long);
        assert_eq!(p.field.len(), FIELD_CAP);
        assert_eq!(p.problem.len(), PROBLEM_CAP);
    }

    #[test]
    fn refusals_read_as_sentences() {
        let incomplete = Refusal::UploadIncomplete {
            upload_id: 7,
            missing_index: 3,
            received: 5,
            expected: 6,
        };
        assert_eq!(
            incomplete.to_string(),
            "path upload 7 incomplete: 5 of 6 segments received, segment 3 missing"
        );
        assert_eq!(
            Refusal::InvalidPath(PathProblem::ChecksumMismatch {
                expected: 0xabcd,
                computed: 0x1234
            })
            .to_string(),
            "invalid path: checksum 0x00001234 of the segments received is not the commit's \
             0x0000abcd; upload discarded"
        );
        assert_eq!(
            Refusal::NotPermitted(NotPermitted::NoPath).to_string(),
            "not permitted: no path has been committed yet"
        );
    }
}
