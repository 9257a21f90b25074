//! Run metrics: what a path-following run amounted to, computed on the robot at the
//! control rate (never from decimated telemetry).
//!
//! The robot's control side accumulates the error of its own estimate at every steering
//! update (`robot_app::metrics::ErrorStats`) and, when the run ends (disarm, fault or the
//! supervisor's run timeout), sends a [`RunReport`] unasked ([`Uplink::RunReport`]); a
//! host that lost it asks again with [`Request::GetRunReport`]. The simulator's virtual
//! robot also measures its *true* pose against the reference at every steering period
//! and sends that as [`Uplink::GroundTruthRun`] (simulation only, like
//! [`Uplink::GroundTruth`]).
//!
//! [`Uplink::RunReport`]: crate::Uplink::RunReport
//! [`Uplink::GroundTruthRun`]: crate::Uplink::GroundTruthRun
//! [`Uplink::GroundTruth`]: crate::Uplink::GroundTruth
//! [`Request::GetRunReport`]: crate::Request::GetRunReport

use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// What a run's errors amounted to (definitions in `robot_app::metrics`: settled = below
/// 1 cm and 1° from then to the end; RMS and maximum over the last 10 whole seconds).
/// Errors in m and rad, times in s from arming.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
pub struct ErrorSummary {
    /// Settle time, s; `None` if the run did not end settled (or had no sample).
    pub settle_time_s: Option<f32>,
    /// Position error at the last sample, m.
    pub final_position_error_m: f32,
    /// Heading error θ_r − θ at the last sample, rad (signed).
    pub final_heading_error_rad: f32,
    /// RMS position error over the final window, m.
    pub rms_position_error_m: f32,
    /// Largest position error over the final window, m.
    pub max_position_error_m: f32,
    /// Samples seen.
    pub samples: u32,
}

/// The robot's report of its last path-following run (answer to
/// [`Request::GetRunReport`](crate::Request::GetRunReport), and sent unasked when a run
/// ends). The robot knows only its estimate: `estimated` is its odometry against its own
/// reference.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
pub struct RunReport {
    /// Path-following runs ended since boot (0: none yet, the rest is zero). A host tells
    /// a new report from a repeated one by this count.
    pub runs_ended: u16,
    /// Control periods the run lasted, from the step that armed to the last armed step.
    pub run_steps: u32,
    /// The controller's own error (odometry against its reference) at every steering
    /// update.
    pub estimated: ErrorSummary,
    /// Largest measured (estimated) wheel speed of either wheel while armed, rad/s.
    pub max_wheel_speed_rad_s: f32,
    /// Largest |duty| applied while armed, in [0, 1].
    pub max_duty: f32,
}

/// The virtual robot's true account of the same run (simulation only): its true pose
/// against the reference at every steering period from arming, with the same statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
pub struct TrueRunReport {
    /// [`RunReport::runs_ended`] of the run this describes.
    pub runs_ended: u16,
    /// Control periods the run lasted.
    pub run_steps: u32,
    /// True pose against the reference (in path-following mode: against the path).
    pub error: ErrorSummary,
    /// Largest true wheel speed of either wheel while armed, rad/s.
    pub max_wheel_speed_rad_s: f32,
    /// Length of the true path driven, sampled every steering period, m.
    pub distance_m: f32,
}

/// The outcome of a wheel-loop tune ([`ArmMode::Tune`](crate::ArmMode::Tune)), sent
/// unasked when it ends ([`Uplink::TuneReport`](crate::Uplink::TuneReport)) and in answer
/// to [`Request::GetTuneReport`](crate::Request::GetTuneReport).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
pub struct TuneReport {
    /// Tunes ended since boot (0: none yet, and `outcome` means nothing). A host tells a
    /// new report from a repeated one by this count.
    pub tunes_ended: u16,
    /// Per wheel the identified model and the wheel loop to use (volts, seconds, rad/s),
    /// or why the tune stopped.
    pub outcome: Result<controller_core::tune::TuneResult, controller_core::tune::TuneAbort>,
}

impl TuneReport {
    /// No tune has ended yet.
    pub const NONE: TuneReport = TuneReport {
        tunes_ended: 0,
        outcome: Err(controller_core::tune::TuneAbort::Stopped),
    };
}
