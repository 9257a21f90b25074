//! Joining telemetry and ground truth into trace rows, and keeping the run's reports.

use controller_core::kinematics::Pose;
use controller_core::law::LawKind;
use controller_core::params::Params;
use controller_core::supervisor::{DisarmReason, Event, Faults, RunMode, State};
use link::{GroundTruth, ParamSet, RunReport, TelemetryFrame, TrueRunReport, Uplink};
use robot_files::metrics::{ErrorReport, Summary, SupervisorReport};
use robot_files::scenario::Scenario;
use robot_files::trace::{SampleDetail, TraceRow};
use robot_files::truth::{tracking_error_f64, true_error, TruePose, TrueReference};

use crate::client::StationError;

use super::*;

/// Joins telemetry and ground truth into trace rows and keeps the run's reports.
pub(super) struct Recorder<'a> {
    pub(super) scenario: &'a Scenario,
    pub(super) law: LawKind,
    pub(super) params: Option<Params>,
    pub(super) reference: TrueReference,
    pub(super) rate_hz: f64,
    /// `runs_ended` before this run: a report with a higher count is this run's.
    pub(super) runs_before: u16,
    /// The run's time limit, control steps.
    pub(super) limit_steps: u64,
    pub(super) heartbeat_timeout_steps: u32,
    pub(super) telemetry_hz: u8,
    /// Control steps between telemetry frames.
    pub(super) telemetry_period: u32,
    pub(super) frames: GapCounter,
    pub(super) arm_step: Option<u32>,
    pub(super) last_step: Option<u32>,
    /// Step of the first telemetry frame after arming that was not armed.
    pub(super) stopped_step: Option<u32>,
    pub(super) pending: Option<TelemetryFrame>,
    pub(super) rows: Vec<TraceRow>,
    pub(super) report: Option<RunReport>,
    pub(super) truth: Option<TrueRunReport>,
    pub(super) saw_truth: bool,
    /// The event that ended the run, as it came.
    pub(super) ended_by: Option<Event>,
    pub(super) state: State,
    pub(super) faults: Faults,
    pub(super) final_estimate: Option<Pose>,
    pub(super) final_truth: Option<Pose>,
}

impl<'a> Recorder<'a> {
    pub(super) fn new(
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

    pub(super) fn done(&self) -> bool {
        self.report.is_some() && !self.expects_truth()
    }

    /// The virtual robot's true report is still to come.
    pub(super) fn expects_truth(&self) -> bool {
        self.saw_truth && self.truth.is_none()
    }

    /// Steps the robot has been out of the run (0 while it runs).
    pub(super) fn stopped_for(&self) -> u32 {
        match (self.stopped_step, self.last_step) {
            (Some(stop), Some(now)) => now.wrapping_sub(stop),
            _ => 0,
        }
    }

    pub(super) fn run_steps(&self) -> u64 {
        match (self.arm_step, self.last_step) {
            (Some(a), Some(now)) => u64::from(now.wrapping_sub(a)),
            _ => 0,
        }
    }

    pub(super) fn take(&mut self, message: Uplink) {
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
    pub(super) fn flush(&mut self, truth: Option<GroundTruth>) {
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

    pub(super) fn row(&self, f: &TelemetryFrame, truth: Option<&GroundTruth>, k: u64) -> TraceRow {
        // Where the reference is measured from: the truth when known, else the estimate.
        let seen_from = match truth {
            Some(t) => TruePose::from_pose(t.pose),
            None => TruePose::from_pose(f.pose),
        };
        let reference = self.reference.at(k, &seen_from);
        trace_row(
            f,
            truth,
            k as f64 / self.rate_hz,
            Some(reference),
            self.params.as_ref(),
        )
    }

    /// How the run ended: the event that ended it, else what the report and the last
    /// state say.
    pub(super) fn end(&self) -> RunEnd {
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
    pub(super) fn finish(
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

/// The supervisor's state at the end of a recording: the one the ending event led to (a
/// disarm or a fault reaches the station as an event before, or instead of, a telemetry
/// frame in the new state), else the last state telemetry showed.
pub(super) fn final_state(last_sampled: State, ended_by: Option<Event>) -> State {
    match ended_by {
        Some(Event::Disarmed(_)) => State::Disarmed,
        Some(Event::Faulted) => State::Faulted,
        _ => last_sampled,
    }
}

/// The trace row of telemetry frame `f` at `t_s` (s of the run) with the virtual robot's
/// `truth` for the same step (NaN where there is none) and the `reference` pose (NaN
/// when not known, e.g. a recording of whatever the robot does); the body command comes
/// from the set-points through `params`' geometry (zero without them).
pub fn trace_row(
    f: &TelemetryFrame,
    truth: Option<&GroundTruth>,
    t_s: f64,
    reference: Option<Pose>,
    params: Option<&Params>,
) -> TraceRow {
    let nan = f64::NAN;
    let true_pose = truth.map_or(
        TruePose {
            x_m: nan,
            y_m: nan,
            theta_rad: nan,
        },
        |t| TruePose::from_pose(t.pose),
    );
    let known_reference = reference.filter(|_| truth.is_some());
    let reference = reference.unwrap_or(Pose::new(f32::NAN, f32::NAN, f32::NAN));
    let command = params
        .map(|p| p.geometry().forward(f.wheel_setpoint))
        .unwrap_or_default();
    let volts = |p: &link::PidParts| p.p_v + p.i_v + p.d_v + p.ff_v;
    TraceRow {
        t_s,
        true_pose,
        est_pose: f.pose,
        reference,
        error: f.tracking_error,
        true_error: known_reference.map_or((nan, nan), |r| true_error(&r, &true_pose)),
        true_tracking: known_reference.map_or([nan; 3], |r| tracking_error_f64(&true_pose, &r)),
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
        detail: SampleDetail {
            lyapunov_rate: f.lyapunov_rate,
            pid: [pid_parts(&f.pid_left), pid_parts(&f.pid_right)],
            faults: f.faults,
        },
    }
}

/// A wheel PID's parts as the link carries them, in the core's type (V).
fn pid_parts(parts: &link::PidParts) -> controller_core::pid::PidParts {
    controller_core::pid::PidParts {
        p: parts.p_v,
        i: parts.i_v,
        d: parts.d_v,
        ff: parts.ff_v,
    }
}
