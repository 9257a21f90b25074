//! Recording a run: heartbeats paced by the robot's own step counter, telemetry and
//! ground truth joined into trace rows ([`TraceRow`](robot_files::trace::TraceRow), the
//! simulator's `trace.csv`), and the robot's run report (computed on the robot at the
//! control rate) turned into a [`Summary`](robot_files::metrics::Summary) (the
//! simulator's `summary.json`).
//!
//! | module | what it holds |
//! |---|---|
//! | this one | the run itself: upload, set the start pose, arm, record until the robot ends the run, disarm |
//! | `recording` | a recorded run ([`Recording`]), how it ended ([`RunEnd`]) and its files |
//! | `telemetry` | the frames expected and received ([`TelemetryCount`], [`GapCounter`]) |
//! | `recorder` | telemetry and ground truth joined into trace rows |

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use controller_core::law::LawKind;
use link::{ParamSet, Reply, Request, Uplink};
use robot_files::scenario::Scenario;

use crate::client::{Client, StationError};
use crate::ops;
use crate::transport::Transport;

mod recorder;
mod recording;
mod telemetry;

pub use self::recorder::trace_row;
use self::recorder::Recorder;
pub use self::recording::*;
pub use self::telemetry::*;

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

/// Uploads `plan.scenario`'s path, puts the robot at the scenario's start pose (the pose
/// command, so every run starts from the same estimate), arms (in motion when the
/// scenario starts moving) with the scenario's duration as the run's own time limit
/// (which the robot counts itself; no stored setting changes), and records until the
/// robot ends the run — at that limit, or earlier (a fault, its heartbeat timeout) — or
/// until the link fails, or Ctrl-C, which disarms first. Returns the recording, however
/// the run ended once the robot was armed ([`Recording::ended_by`]); an error only when
/// it was not armed.
pub fn run<T: Transport>(
    client: &mut Client<T>,
    plan: &mut RunPlan<'_>,
) -> Result<Recording, StationError> {
    let scenario = plan.scenario;
    let params = ops::get_params(client)?;
    let rate_hz = params.robot.control_rate_hz;
    let total = (scenario.duration_s * f64::from(rate_hz)).round() as u64;
    let outcome = upload_arm_record(client, plan, &params, total);
    // Whatever happened: disarmed.
    let disarmed = client.command(Request::Disarm);
    let mut recording = outcome?;
    if let (Err(e), None) = (disarmed, &recording.after_run_error) {
        // After a link failure the run's end already says so.
        if !matches!(recording.ended_by, RunEnd::LinkFailed(_)) {
            recording.after_run_error = Some(format!(
                "{}; the robot disarms itself at the run's time limit ({total} steps)",
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
    ops::set_pose(client, ops::start_pose(scenario))?;
    let limit = u32::try_from(total).unwrap_or(u32::MAX);
    arm_once_at_rest(client, ops::initial_motion(scenario), limit)?;
    let wall = Instant::now();
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

/// How long `run` waits for the wheels to stand still before it gives up arming (a run
/// just ended leaves them turning for a few hundred milliseconds), s of the host's clock.
const REST_WAIT: Duration = Duration::from_secs(5);

/// Arms for the run, asking again while the robot refuses because its wheels still turn
/// (the robot's messages meanwhile are not part of the run), for at most [`REST_WAIT`].
fn arm_once_at_rest<T: Transport>(
    client: &mut Client<T>,
    initial_motion: Option<controller_core::kinematics::BodyVelocity>,
    limit_steps: u32,
) -> Result<(), StationError> {
    let give_up = Instant::now() + REST_WAIT;
    loop {
        match ops::arm(client, initial_motion, Some(limit_steps)) {
            Err(StationError::Refused { refusal, .. })
                if *refusal == link::Refusal::NotPermitted(link::NotPermitted::WheelsTurning)
                    && Instant::now() < give_up =>
            {
                for _ in 0..10 {
                    client.next_message(Duration::from_millis(10))?;
                }
            }
            other => return other,
        }
    }
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

#[cfg(test)]
mod tests;
