//! A recorded run: what it amounted to, how it ended, and the files it is written to.

use std::path::PathBuf;

use controller_core::kinematics::Pose;
use controller_core::supervisor::{DisarmReason, Event};
use link::{RunReport, TrueRunReport};
use robot_files::metrics::Summary;
use robot_files::output::OutputError;
use robot_files::trace::{trace_csv, TraceRow};
use robot_files::truth::{tracking_error_f64, true_error, TruePose};

use super::*;

/// A recorded run.
#[derive(Clone, Debug)]
pub struct Recording {
    /// What the run amounted to, as `summary.json` says it.
    pub summary: Summary,
    /// One row per telemetry frame of the run (with the same step's ground truth, when the
    /// robot sent it), as `trace.csv` says it.
    pub trace: Vec<TraceRow>,
    /// Length of the path driven, m: the true one when the robot sent ground truth, else
    /// the odometry's between telemetry frames.
    pub distance_travelled_m: f64,
    /// True when the robot sent ground truth (the virtual robot).
    pub has_truth: bool,
    /// The robot's own report (`None` when the run was cut short before it came; the
    /// summary's errors are then empty, `samples` 0).
    pub report: Option<RunReport>,
    /// The virtual robot's true report, if any.
    pub truth: Option<TrueRunReport>,
    /// How the run ended.
    pub ended_by: RunEnd,
    /// The link failed after the robot's report came (the error's text): the recording
    /// is whole, but the robot may not have been disarmed or given its time limit back.
    pub after_run_error: Option<String>,
    /// How much of the telemetry came.
    pub telemetry: TelemetryCount,
    /// The robot's final odometry pose (world frame), from the last telemetry frame.
    pub final_estimate: Option<Pose>,
    /// The true final pose, from the last ground-truth frame.
    pub final_truth: Option<Pose>,
}

impl Recording {
    /// True when the run ended as [`run`] asks, at its time limit: the recording holds
    /// the whole run.
    pub fn complete(&self) -> bool {
        self.ended_by.is_time_limit()
    }

    /// Writes `trace.csv` and `summary.json` into `dir` (created if needed), the summary
    /// with what the station adds to the simulator's: `complete` ([`Recording::complete`]),
    /// `ended_by` ([`RunEnd::name`]), `end_reason` (the same as a sentence) and
    /// `telemetry` ([`TelemetryCount`]). A run cut short is written too, as far as it was
    /// recorded. Returns the files written.
    pub fn write(&self, dir: &std::path::Path) -> Result<Vec<PathBuf>, OutputError> {
        std::fs::create_dir_all(dir).map_err(|source| OutputError::CreateDir {
            dir: dir.to_path_buf(),
            source,
        })?;
        let trace_file = dir.join("trace.csv");
        write_file(&trace_file, trace_csv(&self.trace))?;
        let summary_file = dir.join("summary.json");
        let file = SummaryFile {
            summary: &self.summary,
            complete: self.complete(),
            ended_by: self.ended_by.name(),
            end_reason: self.ended_by.to_string(),
            telemetry: self.telemetry,
        };
        write_file(&summary_file, serde_json::to_string_pretty(&file)? + "\n")?;
        Ok(vec![trace_file, summary_file])
    }
}

impl Recording {
    /// Writes the run as an MCAP file (`robot_foxglove`'s channels): `path`, the trace's
    /// rows at the robot's own time, and how the run ended.
    pub fn write_mcap(
        &self,
        file: &std::path::Path,
        path: &controller_core::path::Path,
    ) -> Result<robot_foxglove::McapWritten, robot_foxglove::McapError> {
        let end = format!("run ended by {}", self.ended_by);
        robot_foxglove::write_run_mcap(
            file,
            &robot_foxglove::RunRecord {
                path: Some(path),
                trace: &self.trace,
                end: Some(&end),
            },
        )
    }
}

/// `summary.json` as the station writes it: the simulator's summary and how the run
/// ended.
#[derive(serde::Serialize)]
struct SummaryFile<'a> {
    #[serde(flatten)]
    summary: &'a Summary,
    complete: bool,
    ended_by: &'static str,
    end_reason: String,
    telemetry: TelemetryCount,
}

fn write_file(file: &std::path::Path, text: String) -> Result<(), OutputError> {
    std::fs::write(file, text).map_err(|source| OutputError::Write {
        file: file.to_path_buf(),
        source,
    })
}

/// The final window of a run of `run_s` seconds, over which its RMS and largest errors
/// are taken ([`robot_files::metrics::FINAL_WINDOW_S`] whole seconds, binned by the whole
/// second of each sample): (start, end), s from arming. A run shorter than the window
/// has it whole.
pub fn final_window(run_s: f64) -> (f64, f64) {
    let run_s = run_s.max(0.0);
    // The whole second of the last sample (one before the run's end).
    let newest = (run_s.ceil() - 1.0).max(0.0);
    let start = (newest - (robot_files::metrics::FINAL_WINDOW_S - 1.0)).max(0.0);
    (start, run_s)
}

/// What [`final_window`] is, for the terminal: `over 20.0–30.0 s`, or `over the whole
/// run (0.0–5.4 s)`.
pub fn final_window_text(run_s: f64) -> String {
    let (start, end) = final_window(run_s);
    if start > 0.0 {
        format!("over {start:.1}–{end:.1} s")
    } else {
        format!("over the whole run (0.0–{end:.1} s)")
    }
}

/// How a recorded run ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RunEnd {
    /// The robot ended it with this event. [`run`] asks for
    /// `Disarmed(Timeout)`, the run's time limit ([`RunEnd::is_time_limit`]); anything
    /// else cut the run short (the heartbeat timeout, a fault, the button). When the
    /// event was lost on the line it is told from the robot's report (a run as long as
    /// its limit ended there) and its telemetry (a fault).
    Robot(Event),
    /// The robot's report came but not its event, and neither the run's length nor the
    /// robot's state tell why it ended.
    Unknown,
    /// The link failed before the robot's report came (the error's text): the recording
    /// stops there, and the robot disarms itself on its heartbeat timeout.
    LinkFailed(String),
    /// Ctrl-C: the station disarmed the robot and stopped recording.
    Interrupted,
}

impl RunEnd {
    /// True when the run ended as [`run`] asks: at its time limit.
    pub fn is_time_limit(&self) -> bool {
        *self == RunEnd::Robot(Event::Disarmed(DisarmReason::Timeout))
    }

    /// The end's name in `summary.json` (`ended_by`): `time_limit`, `link_lost` (the
    /// robot's heartbeat timeout), `fault`, `button`, `disarm_request`, `link_failed`,
    /// `interrupted` or `unknown`.
    pub fn name(&self) -> &'static str {
        match self {
            RunEnd::Robot(Event::Disarmed(DisarmReason::Timeout)) => "time_limit",
            RunEnd::Robot(Event::Disarmed(DisarmReason::LinkLost)) => "link_lost",
            RunEnd::Robot(Event::Disarmed(DisarmReason::Button)) => "button",
            RunEnd::Robot(Event::Disarmed(DisarmReason::Link)) => "disarm_request",
            RunEnd::Robot(Event::Faulted) => "fault",
            RunEnd::LinkFailed(_) => "link_failed",
            RunEnd::Interrupted => "interrupted",
            RunEnd::Robot(_) | RunEnd::Unknown => "unknown",
        }
    }
}

impl std::fmt::Display for RunEnd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RunEnd::Robot(Event::Disarmed(DisarmReason::Timeout)) => {
                f.write_str("the run's time limit (Disarmed(Timeout))")
            }
            RunEnd::Robot(Event::Disarmed(DisarmReason::LinkLost)) => f.write_str(
                "the robot's heartbeat timeout: no heartbeat reached it (Disarmed(LinkLost))",
            ),
            RunEnd::Robot(Event::Disarmed(DisarmReason::Button)) => {
                f.write_str("the robot's button (Disarmed(Button))")
            }
            RunEnd::Robot(Event::Disarmed(DisarmReason::Link)) => {
                f.write_str("a disarm request on the link (Disarmed(Link))")
            }
            RunEnd::Robot(Event::Faulted) => f.write_str("a fault (Faulted)"),
            RunEnd::Robot(event) => write!(f, "{event:?}"),
            RunEnd::Unknown => f.write_str(
                "an event lost on the line, not the time limit (the robot's report came without it)",
            ),
            RunEnd::LinkFailed(error) => write!(f, "a link failure ({error})"),
            RunEnd::Interrupted => f.write_str("Ctrl-C (the station disarmed the robot)"),
        }
    }
}

/// The trace with the estimate in place of the missing truth, for the figures of a run
/// without ground truth (their titles say so).
pub fn estimate_as_truth(trace: &[TraceRow]) -> Vec<TraceRow> {
    trace
        .iter()
        .map(|r| {
            let est = TruePose {
                x_m: f64::from(r.est_pose.x_m),
                y_m: f64::from(r.est_pose.y_m),
                theta_rad: f64::from(r.est_pose.theta_rad),
            };
            TraceRow {
                true_pose: est,
                true_error: true_error(&r.reference, &est),
                true_tracking: tracking_error_f64(&est, &r.reference),
                true_velocity: (f64::from(r.command.v_m_s), f64::from(r.command.omega_rad_s)),
                true_wheel: [
                    f64::from(r.measured.left_rad_s),
                    f64::from(r.measured.right_rad_s),
                ],
                ..*r
            }
        })
        .collect()
}
