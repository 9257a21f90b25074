//! Recording a run: heartbeats paced by the robot's own step counter, telemetry and
//! ground truth joined into trace rows ([`TraceRow`], the simulator's `trace.csv`), and
//! the robot's run report (computed on the robot at the control rate) turned into a
//! [`Summary`] (the simulator's `summary.json`).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use controller_core::kinematics::Pose;
use controller_core::law::LawKind;
use controller_core::params::Params;
use controller_core::supervisor::{DisarmReason, Event, Faults, RunMode, State};
use link::{
    GroundTruth, ParamSet, Reply, Request, RunReport, TelemetryFrame, TrueRunReport, Uplink,
};
use robot_files::metrics::{ErrorReport, Summary, SupervisorReport};
use robot_files::output::OutputError;
use robot_files::scenario::Scenario;
use robot_files::trace::{trace_csv, TraceRow};
use robot_files::truth::{tracking_error_f64, true_error, TruePose, TrueReference};

use crate::client::{Client, StationError};
use crate::ops;
use crate::transport::Transport;

/// What `run` needs besides the link.
pub struct RunPlan<'a> {
    /// The scenario: path, reference, start, duration.
    pub scenario: &'a Scenario,
    /// The steering law.
    pub law: LawKind,
    /// Telemetry rate to ask for, Hz (lower rates are tried when the link refuses).
    pub telemetry_hz: u8,
    /// Set by Ctrl-C: disarm and stop.
    pub interrupt: &'a AtomicBool,
    /// Called with (run steps so far, run steps in all).
    pub progress: &'a mut dyn FnMut(u64, u64),
}

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

/// Past this fraction of missing telemetry frames, the station warns.
pub const MISSING_TELEMETRY_WARNING: f64 = 0.05;

/// How much of a run's telemetry reached the station (`summary.json`'s `telemetry`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TelemetryCount {
    /// The telemetry rate, Hz.
    pub rate_hz: u8,
    /// Control steps between frames: control rate / telemetry rate.
    pub period_steps: u32,
    /// Frames the run should have given: received plus missing.
    pub expected_frames: u64,
    /// Frames of the run received (the trace's rows).
    pub received_frames: u64,
    /// Frames missing, from the gaps in the received frames' step numbers, and before the
    /// first and after the last to the run's ends.
    pub missing_frames: u64,
    /// Telemetry frames the robot could not send for want of room on the link while the
    /// run was recorded (its `telemetry_dropped`); `None` when its statistics did not
    /// come. The rest of the missing frames were lost on the line.
    pub dropped_on_robot: Option<u32>,
}

impl TelemetryCount {
    /// Missing frames over expected ones (0 when none was expected).
    pub fn missing_fraction(&self) -> f64 {
        if self.expected_frames == 0 {
            0.0
        } else {
            self.missing_frames as f64 / self.expected_frames as f64
        }
    }

    /// One line: received of expected, and where the missing ones went.
    pub fn text(&self) -> String {
        if self.missing_frames == 0 {
            return format!(
                "telemetry: {} of {} frames at {} Hz, none missing",
                self.received_frames, self.expected_frames, self.rate_hz
            );
        }
        let mut text = format!(
            "telemetry: {} of {} frames at {} Hz ({} missing, {:.1} %",
            self.received_frames,
            self.expected_frames,
            self.rate_hz,
            self.missing_frames,
            100.0 * self.missing_fraction()
        );
        match self.dropped_on_robot {
            Some(dropped) => {
                let on_line = self.missing_frames.saturating_sub(u64::from(dropped));
                text += &format!(
                    "; {dropped} dropped on the robot for want of link room, {on_line} lost on the line)"
                );
            }
            None => text += "; the robot's count of dropped frames did not come)",
        }
        text
    }

    /// A warning when more than [`MISSING_TELEMETRY_WARNING`] of the frames are missing.
    pub fn warning(&self) -> Option<String> {
        (self.missing_fraction() > MISSING_TELEMETRY_WARNING).then(|| {
            format!(
                "{:.1} % of the telemetry is missing (over {:.0} %): the trace has gaps; a \
lower --hz, or a cleaner line, would keep more",
                100.0 * self.missing_fraction(),
                100.0 * MISSING_TELEMETRY_WARNING
            )
        })
    }
}

/// Counts the frames of a run from their step numbers, one every `period` steps.
#[derive(Clone, Copy, Debug, Default)]
pub struct GapCounter {
    first: Option<u64>,
    last: u64,
    received: u64,
    missing_between: u64,
}

impl GapCounter {
    /// A frame at run step `k` (steps since the run's start, increasing), on a stream
    /// of one frame every `period` steps.
    pub fn push(&mut self, k: u64, period: u32) {
        let period = u64::from(period.max(1));
        if self.first.is_some() {
            let gap = k.saturating_sub(self.last);
            // Rounded: a late control step moves a frame by a step or two.
            let slots = (gap + period / 2) / period;
            self.missing_between += slots.saturating_sub(1);
        } else {
            self.first = Some(k);
        }
        self.last = k;
        self.received += 1;
    }

    /// (received, missing) for a run of `steps` steps (frames due at steps 0 ≤ k <
    /// `steps`, one every `period`).
    pub fn count(&self, steps: u64, period: u32) -> (u64, u64) {
        let period = u64::from(period.max(1));
        let Some(first) = self.first else {
            return (0, steps.div_ceil(period));
        };
        let before = first / period;
        let after = steps.saturating_sub(self.last + 1) / period;
        (self.received, self.missing_between + before + after)
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

/// When to send the next heartbeat: every `every_steps` of the robot's own step counter
/// (read from its telemetry), and by the host's clock only when telemetry stops coming —
/// so a robot (or emulator) slower or faster than real time is never starved nor
/// flooded.
pub struct HeartbeatPacer {
    every_steps: u32,
    last_step: Option<u32>,
    last_wall: Instant,
}

/// The host-clock fallback: a heartbeat at least this often when no telemetry arrives.
const HEARTBEAT_FALLBACK: Duration = Duration::from_millis(100);

impl HeartbeatPacer {
    /// A pacer for a robot whose heartbeat timeout is `timeout_steps` control steps: five
    /// heartbeats per timeout.
    pub fn new(timeout_steps: u32) -> Self {
        Self {
            every_steps: (timeout_steps / 5).max(1),
            last_step: None,
            last_wall: Instant::now(),
        }
    }

    /// True when a heartbeat is due, the robot's latest step being `robot_step` (None
    /// before any telemetry); the caller sends one and the pacer counts from here.
    pub fn due(&mut self, robot_step: Option<u32>) -> bool {
        let by_robot = match (robot_step, self.last_step) {
            (Some(now), Some(then)) => now.wrapping_sub(then) >= self.every_steps,
            (Some(_), None) => true,
            _ => false,
        };
        if by_robot || self.last_wall.elapsed() > HEARTBEAT_FALLBACK {
            self.last_step = robot_step;
            self.last_wall = Instant::now();
            return true;
        }
        false
    }
}

/// Sets the fastest telemetry rate the link accepts, from `hz` down; returns it.
pub fn set_telemetry_rate<T: Transport>(
    client: &mut Client<T>,
    hz: u8,
) -> Result<u8, StationError> {
    let mut rate = hz.clamp(1, 100);
    loop {
        match client.request(Request::SetTelemetryRate { hz: rate }) {
            Ok(_) => return Ok(rate),
            Err(StationError::Refused { .. }) if rate > 1 => rate /= 2,
            Err(e) => return Err(e),
        }
    }
}

/// Uploads `plan.scenario`'s path, arms (in motion when the scenario starts moving), and
/// records until the robot ends the run — at the scenario's duration, which the robot
/// counts itself (`max_armed_steps`, restored afterwards), or earlier (a fault, its
/// heartbeat timeout) — or until the link fails, or Ctrl-C, which disarms first.
/// Returns the recording, however the run ended once the robot was armed
/// ([`Recording::ended_by`]); an error only when it was not armed.
pub fn run<T: Transport>(
    client: &mut Client<T>,
    plan: &mut RunPlan<'_>,
) -> Result<Recording, StationError> {
    let scenario = plan.scenario;
    let original = ops::get_params(client)?;
    let rate_hz = original.robot.control_rate_hz;
    let total = (scenario.duration_s * f64::from(rate_hz)).round() as u64;
    let mut timed = original;
    timed.supervisor.max_armed_steps = Some(u32::try_from(total).unwrap_or(u32::MAX));
    if timed != original {
        ops::set_params(client, timed)?;
    }
    let outcome = upload_arm_record(client, plan, &original, total);
    // Whatever happened: disarmed, and the robot's own time limit back.
    let disarmed = client.command(Request::Disarm);
    let restored = if timed != original {
        ops::set_params(client, original).map(|_| ())
    } else {
        Ok(())
    };
    let mut recording = outcome?;
    if let (Err(e), None) = (disarmed.and(restored), &recording.after_run_error) {
        // After a link failure the run's end already says so.
        if !matches!(recording.ended_by, RunEnd::LinkFailed(_)) {
            recording.after_run_error = Some(format!(
                "{}; the robot may still hold the run's time limit ({total} steps)",
                crate::error_text(&e)
            ));
        }
    }
    Ok(recording)
}

fn upload_arm_record<T: Transport>(
    client: &mut Client<T>,
    plan: &mut RunPlan<'_>,
    params: &ParamSet,
    total: u64,
) -> Result<Recording, StationError> {
    let scenario = plan.scenario;
    let hz = set_telemetry_rate(client, plan.telemetry_hz)?;
    ops::upload_path(
        client,
        scenario,
        plan.law,
        ops::fresh_upload_id(),
        &mut |_, _| {},
    )?;
    let before = match client.request(Request::GetRunReport)? {
        Reply::RunReport(r) => r.runs_ended,
        _ => 0,
    };
    let stats_before = stats(client)?;
    let wall = Instant::now();
    ops::arm(client, ops::initial_motion(scenario))?;
    let mut recorder = Recorder::new(scenario, plan.law, params, before, total, hz);
    let recorded = record_until_end(client, plan, &mut recorder, total);
    let (stats_after, error) = match recorded.and_then(|()| stats(client)) {
        Ok(s) => (s, None),
        Err(e) => (None, Some(e)),
    };
    let dropped = stats_before.zip(stats_after).map(|(b, a)| {
        a.link
            .telemetry_dropped
            .wrapping_sub(b.link.telemetry_dropped)
    });
    Ok(recorder.finish(
        wall.elapsed().as_secs_f64(),
        stats_after.unwrap_or_default(),
        dropped,
        error,
    ))
}

/// The robot's statistics (`None` if it answers with something else).
fn stats<T: Transport>(client: &mut Client<T>) -> Result<Option<link::Stats>, StationError> {
    Ok(match client.request(Request::GetStats)? {
        Reply::Stats(s) => Some(s),
        _ => None,
    })
}

/// Feeds `recorder` with heartbeats going until the robot's report (and the virtual
/// robot's true one) came. `Err(Interrupted)` after Ctrl-C, which disarms the robot.
fn record_until_end<T: Transport>(
    client: &mut Client<T>,
    plan: &mut RunPlan<'_>,
    recorder: &mut Recorder<'_>,
    total: u64,
) -> Result<(), StationError> {
    let mut heartbeat = HeartbeatPacer::new(recorder.heartbeat_timeout_steps);
    while !recorder.done() {
        if plan.interrupt.load(Ordering::Relaxed) {
            let _ = client.command(Request::Disarm);
            return Err(StationError::Interrupted);
        }
        if heartbeat.due(recorder.last_step) {
            client.send_only(Request::Heartbeat)?;
        }
        if let Some(message) = client.next_message(Duration::from_millis(20))? {
            recorder.take(message);
            (plan.progress)(recorder.run_steps(), total);
        }
        // A report lost on the line (a corrupted frame): ask for it once the robot has
        // been out of the run for 200 steps.
        if recorder.report.is_none() && recorder.stopped_for() > 200 {
            if let Reply::RunReport(report) = client.request(Request::GetRunReport)? {
                recorder.take(Uplink::RunReport(report));
            }
        }
        if recorder.report.is_some() {
            // The robot's report is in; the virtual robot's true one follows at once.
            let deadline = Instant::now() + Duration::from_millis(500);
            while recorder.expects_truth() && Instant::now() < deadline {
                if let Some(message) = client.next_message(Duration::from_millis(20))? {
                    recorder.take(message);
                }
            }
            break;
        }
    }
    Ok(())
}

/// Joins telemetry and ground truth into trace rows and keeps the run's reports.
struct Recorder<'a> {
    scenario: &'a Scenario,
    law: LawKind,
    params: Option<Params>,
    reference: TrueReference,
    rate_hz: f64,
    /// `runs_ended` before this run: a report with a higher count is this run's.
    runs_before: u16,
    /// The run's time limit, control steps.
    limit_steps: u64,
    heartbeat_timeout_steps: u32,
    telemetry_hz: u8,
    /// Control steps between telemetry frames.
    telemetry_period: u32,
    frames: GapCounter,
    arm_step: Option<u32>,
    last_step: Option<u32>,
    /// Step of the first telemetry frame after arming that was not armed.
    stopped_step: Option<u32>,
    pending: Option<TelemetryFrame>,
    rows: Vec<TraceRow>,
    report: Option<RunReport>,
    truth: Option<TrueRunReport>,
    saw_truth: bool,
    /// The event that ended the run, as it came.
    ended_by: Option<Event>,
    state: State,
    faults: Faults,
    final_estimate: Option<Pose>,
    final_truth: Option<Pose>,
}

impl<'a> Recorder<'a> {
    fn new(
        scenario: &'a Scenario,
        law: LawKind,
        params: &ParamSet,
        runs_before: u16,
        limit_steps: u64,
        telemetry_hz: u8,
    ) -> Self {
        let rate = params.robot.control_rate_hz;
        Self {
            scenario,
            law,
            params: Params::new(params.robot).ok(),
            reference: TrueReference::of(
                scenario.path.clone(),
                scenario.reference_speed_m_s,
                scenario.reference_mode,
                rate,
            ),
            rate_hz: f64::from(rate),
            runs_before,
            limit_steps,
            heartbeat_timeout_steps: params.supervisor.heartbeat_timeout_steps,
            telemetry_hz,
            // As the robot's telemetry clock: at least one step.
            telemetry_period: (rate / u32::from(telemetry_hz.max(1))).max(1),
            frames: GapCounter::default(),
            arm_step: None,
            last_step: None,
            stopped_step: None,
            pending: None,
            rows: Vec::new(),
            report: None,
            truth: None,
            saw_truth: false,
            ended_by: None,
            state: State::Disarmed,
            faults: Faults::default(),
            final_estimate: None,
            final_truth: None,
        }
    }

    fn done(&self) -> bool {
        self.report.is_some() && !self.expects_truth()
    }

    /// The virtual robot's true report is still to come.
    fn expects_truth(&self) -> bool {
        self.saw_truth && self.truth.is_none()
    }

    /// Steps the robot has been out of the run (0 while it runs).
    fn stopped_for(&self) -> u32 {
        match (self.stopped_step, self.last_step) {
            (Some(stop), Some(now)) => now.wrapping_sub(stop),
            _ => 0,
        }
    }

    fn run_steps(&self) -> u64 {
        match (self.arm_step, self.last_step) {
            (Some(a), Some(now)) => u64::from(now.wrapping_sub(a)),
            _ => 0,
        }
    }

    fn take(&mut self, message: Uplink) {
        match message {
            Uplink::Telemetry(frame) => {
                self.flush(None);
                self.last_step = Some(frame.step);
                self.state = frame.state;
                self.faults = frame.faults;
                self.final_estimate = Some(frame.pose);
                let after_arming = self
                    .arm_step
                    .is_some_and(|a| frame.step.wrapping_sub(a) < u32::MAX / 2);
                if after_arming && frame.state != State::Armed && self.stopped_step.is_none() {
                    self.stopped_step = Some(frame.step);
                }
                self.pending = Some(frame);
            }
            Uplink::GroundTruth(truth) => {
                self.saw_truth = true;
                self.final_truth = Some(truth.pose);
                self.flush(Some(truth));
            }
            Uplink::Event { step, event } => match event {
                Event::Armed(RunMode::FollowPath) if self.arm_step.is_none() => {
                    self.arm_step = Some(step);
                }
                Event::Disarmed(_) | Event::Faulted if self.arm_step.is_some() => {
                    self.ended_by.get_or_insert(event);
                }
                _ => {}
            },
            Uplink::RunReport(report) if report.runs_ended != self.runs_before => {
                self.report = Some(report);
            }
            Uplink::GroundTruthRun(truth) if truth.runs_ended != self.runs_before => {
                self.saw_truth = true;
                self.truth = Some(truth);
            }
            _ => {}
        }
    }

    /// Turns the pending telemetry frame into a row, with `truth` when it is the same
    /// step's.
    fn flush(&mut self, truth: Option<GroundTruth>) {
        let Some(frame) = self.pending.take() else {
            return;
        };
        let truth = truth.filter(|t| t.step == frame.step);
        let (Some(arm), true) = (self.arm_step, frame.state == State::Armed) else {
            return;
        };
        let k = u64::from(frame.step.wrapping_sub(arm));
        self.frames.push(k, self.telemetry_period);
        self.rows.push(self.row(&frame, truth.as_ref(), k));
    }

    fn row(&self, f: &TelemetryFrame, truth: Option<&GroundTruth>, k: u64) -> TraceRow {
        let nan = f64::NAN;
        let true_pose = truth.map_or(
            TruePose {
                x_m: nan,
                y_m: nan,
                theta_rad: nan,
            },
            |t| TruePose {
                x_m: f64::from(t.pose.x_m),
                y_m: f64::from(t.pose.y_m),
                theta_rad: f64::from(t.pose.theta_rad),
            },
        );
        // Where the reference is measured from: the truth when known, else the estimate.
        let seen_from = truth.map_or(
            TruePose {
                x_m: f64::from(f.pose.x_m),
                y_m: f64::from(f.pose.y_m),
                theta_rad: f64::from(f.pose.theta_rad),
            },
            |_| true_pose,
        );
        let reference = self.reference.at(k, &seen_from);
        let command = self
            .params
            .map(|p| p.geometry().forward(f.wheel_setpoint))
            .unwrap_or_default();
        let volts = |p: &link::PidParts| p.p_v + p.i_v + p.d_v + p.ff_v;
        TraceRow {
            t_s: k as f64 / self.rate_hz,
            true_pose,
            est_pose: f.pose,
            reference,
            error: f.tracking_error,
            true_error: truth.map_or((nan, nan), |_| true_error(&reference, &true_pose)),
            true_tracking: truth.map_or([nan; 3], |_| tracking_error_f64(&true_pose, &reference)),
            lyapunov: f.lyapunov,
            command,
            true_velocity: truth.map_or((nan, nan), |t| {
                (
                    f64::from(t.velocity.v_m_s),
                    f64::from(t.velocity.omega_rad_s),
                )
            }),
            setpoint: f.wheel_setpoint,
            measured: f.wheel_speed,
            true_wheel: truth.map_or([nan; 2], |t| {
                [
                    f64::from(t.wheel_speed.left_rad_s),
                    f64::from(t.wheel_speed.right_rad_s),
                ]
            }),
            volts: [volts(&f.pid_left), volts(&f.pid_right)],
            duty: f.duty,
            supply_v: f.supply_v,
            state: f.state,
        }
    }

    /// How the run ended: the event that ended it, else what the report and the last
    /// state say.
    fn end(&self) -> RunEnd {
        if let Some(event) = self.ended_by {
            return RunEnd::Robot(event);
        }
        if self.state == State::Faulted {
            return RunEnd::Robot(Event::Faulted);
        }
        match self.report {
            Some(r) if u64::from(r.run_steps) >= self.limit_steps => {
                RunEnd::Robot(Event::Disarmed(DisarmReason::Timeout))
            }
            _ => RunEnd::Unknown,
        }
    }

    /// The recording, `error` being the link's failure that stopped it, if any.
    /// `stats` are the robot's after the run, `dropped` the telemetry frames it dropped
    /// during it.
    fn finish(
        mut self,
        wall_time_s: f64,
        stats: link::Stats,
        dropped: Option<u32>,
        error: Option<StationError>,
    ) -> Recording {
        self.flush(None);
        let (ended_by, after_run_error) = match (error, self.report) {
            (None, _) => (self.end(), None),
            (Some(StationError::Interrupted), None) => (RunEnd::Interrupted, None),
            (Some(e), None) => (RunEnd::LinkFailed(crate::error_text(&e)), None),
            (Some(e), Some(_)) => (self.end(), Some(crate::error_text(&e))),
        };
        let report = self.report.unwrap_or_default();
        let truth = self.truth;
        // A run cut short: as far as its telemetry went.
        let steps = match self.report {
            Some(r) => u64::from(r.run_steps),
            None => self.run_steps(),
        };
        let summary = Summary {
            scenario: self.scenario.name.clone(),
            law: self.law.name().to_string(),
            source: if self.saw_truth {
                "virtual-robot"
            } else {
                "robot"
            }
            .to_string(),
            true_error: truth.map(|t| ErrorReport::from(t.error)),
            estimated_error: ErrorReport::from(report.estimated),
            hourly_rms_true_position_error_m: Vec::new(),
            max_wheel_speed_rad_s: f64::from(
                truth.map_or(report.max_wheel_speed_rad_s, |t| t.max_wheel_speed_rad_s),
            ),
            max_duty: f64::from(report.max_duty),
            supervisor: SupervisorReport::new(
                final_state(
                    self.state,
                    match ended_by {
                        RunEnd::Robot(event) => Some(event),
                        _ => None,
                    },
                ),
                &self.faults,
                stats.missed_ticks,
                stats.overruns,
            ),
            injected_faults: Vec::new(),
            sim_time_s: steps as f64 / self.rate_hz,
            wall_time_s,
            steps,
        };
        let distance = truth.map_or_else(
            || {
                self.rows
                    .windows(2)
                    .map(|w| {
                        f64::from(w[1].est_pose.x_m - w[0].est_pose.x_m)
                            .hypot(f64::from(w[1].est_pose.y_m - w[0].est_pose.y_m))
                    })
                    .sum()
            },
            |t| f64::from(t.distance_m),
        );
        let (received, missing) = self.frames.count(steps, self.telemetry_period);
        let telemetry = TelemetryCount {
            rate_hz: self.telemetry_hz,
            period_steps: self.telemetry_period,
            expected_frames: received + missing,
            received_frames: received,
            missing_frames: missing,
            dropped_on_robot: dropped,
        };
        Recording {
            summary,
            telemetry,
            trace: self.rows,
            distance_travelled_m: distance,
            has_truth: self.saw_truth,
            report: self.report,
            truth,
            ended_by,
            after_run_error,
            final_estimate: self.final_estimate,
            final_truth: self.final_truth,
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

/// The supervisor's state at the end of a recording: the one the ending event led to (a
/// disarm or a fault reaches the station as an event before, or instead of, a telemetry
/// frame in the new state), else the last state telemetry showed.
fn final_state(last_sampled: State, ended_by: Option<Event>) -> State {
    match ended_by {
        Some(Event::Disarmed(_)) => State::Disarmed,
        Some(Event::Faulted) => State::Faulted,
        _ => last_sampled,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::supervisor::DisarmReason;

    #[test]
    fn gaps_in_the_step_numbers_count_the_missing_frames() {
        // A 100-step run, a frame every 10 steps from step 3: 10 due (3, 13, …, 93).
        let mut all = GapCounter::default();
        for k in (3..100).step_by(10) {
            all.push(k, 10);
        }
        assert_eq!(all.count(100, 10), (10, 0));
        // Without 3 (the first), 43 and 53 (a gap of two), 93 (the last), and one a step
        // late (a late control step).
        let mut some = GapCounter::default();
        for k in [13, 23, 34, 63, 73, 83] {
            some.push(k, 10);
        }
        assert_eq!(some.count(100, 10), (6, 4));
        // Nothing received: every frame is missing.
        assert_eq!(GapCounter::default().count(100, 10), (0, 10));
    }

    #[test]
    fn missing_telemetry_past_five_percent_is_warned_about() {
        let count = |missing| TelemetryCount {
            rate_hz: 100,
            period_steps: 10,
            expected_frames: 1000,
            received_frames: 1000 - missing,
            missing_frames: missing,
            dropped_on_robot: Some(20),
        };
        assert_eq!(count(50).warning(), None);
        assert!(count(51).warning().is_some());
        assert_eq!(
            count(450).text(),
            "telemetry: 550 of 1000 frames at 100 Hz (450 missing, 45.0 %; 20 dropped on the \
robot for want of link room, 430 lost on the line)"
        );
    }

    #[test]
    fn the_final_window_is_the_last_ten_whole_seconds_or_the_whole_run() {
        assert_eq!(final_window(30.0), (20.0, 30.0));
        assert_eq!(final_window(5.4), (0.0, 5.4));
        assert_eq!(final_window(10.0), (0.0, 10.0));
        // The samples of 6 s to 15.5 s: the whole seconds 6 to 15.
        assert_eq!(final_window(15.5), (6.0, 15.5));
        assert_eq!(final_window_text(30.0), "over 20.0–30.0 s");
        assert_eq!(final_window_text(5.4), "over the whole run (0.0–5.4 s)");
    }

    #[test]
    fn the_final_state_is_the_one_the_ending_event_led_to() {
        assert_eq!(
            final_state(State::Armed, Some(Event::Disarmed(DisarmReason::Timeout))),
            State::Disarmed
        );
        assert_eq!(
            final_state(State::Armed, Some(Event::Faulted)),
            State::Faulted
        );
        assert_eq!(final_state(State::Armed, None), State::Armed);
        assert_eq!(final_state(State::Disarmed, None), State::Disarmed);
    }
}
