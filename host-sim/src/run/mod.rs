//! The simulation loop: the firmware's decision path — the
//! [`Supervisor`](controller_core::supervisor::Supervisor) around the [`Controller`] —
//! against the simulated hardware.
//!
//! Each control step (time kept as an integer count of control periods):
//!
//! 1. the hardware says how many periods the step covers (1, or more under a
//!    `late-steps` fault) and what the firmware reads: encoder ticks, the supply
//!    measurement, the button ([`SimHardware`]);
//! 2. `Supervisor::step` steps the controller and decides the duties, the bridge state
//!    (drive, brake, coast) and the watchdog, exactly as on the robot;
//! 3. the hardware applies them and the plant integrates one period.
//!
//! ## Whose logic
//!
//! The loop asks a [`RobotLogic`] for each step's decision. [`run_scenario_with`] gives it
//! the supervisor and controller run right here ([`LocalRobot`]); `host-sim pil` gives it
//! the real firmware on an emulated Cortex-M4F, over the lockstep port ([`crate::pil`]).
//! Everything else — the plant, the faults, the metrics, the digest — is the same code,
//! so the two summaries can be compared field for field.
//!
//! ## The start pose, arming and a start in motion
//!
//! The robot is told it is at the scenario's start with the pose command
//! (`Supervisor::set_pose`, through [`RobotLogic::set_pose_locally`]), the one way a
//! pose is ever set: `station run` and the processor-in-the-loop station send the same
//! command on the link (`SetPose`), and arming keeps the pose. Unless the scenario's
//! `[start]` says `arm = "none"`, the run then arms at step 0 through the supervisor, as
//! an operator at the robot would (no link, so no heartbeat is needed).
//! The paper's experiments start in motion (v = 0.4 m/s, ω = 0.3 rad/s at t = 0): the
//! plant's wheels are spun up to that motion and the arm request asserts it
//! ([`ArmRequest::initial_motion`]), so the controller's speed estimate and ramp start
//! from the motion instead of from rest. The runtime link's `Arm` carries the same
//! assertion, which is how a processor-in-the-loop run reproduces these numbers. Figures
//! from such runs say "armed in motion". A motion the plant's motors could not have given
//! the wheels (faster than the no-load speed on the supply; with slip s a wheel turns
//! 1/(1 − s) times faster than it rolls) is refused before the run, with the keys.
//!
//! ## Errors
//!
//! The true error is measured at every steering period of the run against the scenario's
//! own reference, evaluated here, independently of the controller: in time-indexed mode
//! the reference point at that time and its heading, the time counted while the robot
//! is armed (its own reference holds while it is disarmed or faulted, and a re-arm
//! resumes it where it stopped); in path-following mode, where the
//! controller may aim ahead on purpose, the closest point of the path and the path's
//! heading there. The controller's own estimate is measured against its own reference at
//! its steering updates. See [`robot_files::metrics`].

use std::time::Instant;

use controller_core::prelude::*;
use controller_core::supervisor::{ArmRequest, Event, RunMode, State};
use m4f_scenario::{Digest, Fnv1a64};
use robot_app::metrics::{ErrorSample, ErrorStats};
use robot_files::metrics::{ErrorReport, HourlyRms, Summary, SupervisorReport};
use robot_files::scenario::{Scenario, ScenarioError};
use robot_files::trace::{SampleDetail, TraceRow};
use robot_files::truth::{tracking_error_f64, TrueReference};

use crate::hardware::{Actuation, SimHardware};
use crate::plant::{Integration, PlantError, PlantParams, TrueGeometry};

mod fault_watch;
mod logic;
mod step_response;

pub(crate) use self::logic::Robot;
pub use self::logic::{Decision, Estimate, LocalRobot, RobotLogic};
pub use self::step_response::{wheel_step_response, StepResponse};

use self::fault_watch::FaultWatch;

/// Most trace rows a run keeps: longer runs are decimated to about this many, so memory
/// and file sizes stay flat however long the run.
pub const MAX_TRACE_ROWS: u64 = 30_000;

/// Why a run could not start.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The scenario's robot parameters are invalid.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// The plant parameters are invalid.
    #[error(transparent)]
    Plant(#[from] PlantError),
    /// The scenario's `[start]` motion is beyond what the plant's motors can turn its
    /// wheels at.
    #[error(
        "start.v_m_s = {v_m_s} m/s with start.omega_rad_s = {omega_rad_s} rad/s cannot be \
         the robot's motion: {refused}"
    )]
    StartMotion {
        /// `[start] v_m_s`, m/s.
        v_m_s: f64,
        /// `[start] omega_rad_s`, rad/s.
        omega_rad_s: f64,
        /// What the plant refused (in the message, so not also a `source`).
        refused: PlantError,
    },
    /// The reference could not be built (speed or distance out of range).
    #[error("reference: {0}")]
    Reference(ReferenceError),
    /// The supervisor's settings are invalid.
    #[error("supervisor: {0}")]
    Supervisor(controller_core::supervisor::SupervisorConfigError),
    /// The robot's logic ran elsewhere and failed (e.g. the emulated firmware stopped
    /// answering).
    #[error("robot logic: {0}")]
    Logic(String),
    /// The run's MCAP file (asked for with it) could not be written.
    #[error(transparent)]
    Mcap(#[from] robot_foxglove::McapError),
    /// An argument of a run function is out of range.
    #[error("{name} {rule}, got {value}")]
    Argument {
        /// The argument.
        name: &'static str,
        /// What it must satisfy.
        rule: &'static str,
        /// Its value.
        value: f64,
    },
}

/// Options of one run. The default: no trace, the plant's default integration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunOptions {
    /// Record a trace row every this many control steps (0: no trace). Capped so that a
    /// run keeps at most about [`MAX_TRACE_ROWS`].
    pub trace_every_steps: u32,
    /// How the plant integrates (its default unless a timing comparison asks otherwise).
    pub integration: Integration,
}

impl RunOptions {
    /// A trace row at every steering update of `scenario`'s robot (every
    /// `steering_divider` control steps), so traces and plots sample the law's own rate.
    pub fn at_steering_rate(scenario: &Scenario) -> Self {
        Self::traced_every(scenario.robot.steering_divider)
    }

    /// A trace row every `steps` control steps (0: no trace).
    pub fn traced_every(steps: u32) -> Self {
        Self {
            trace_every_steps: steps,
            ..Self::default()
        }
    }
}

/// Everything a run produced.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// The `summary.json` content.
    pub summary: Summary,
    /// Largest |armature current| of either motor, A.
    pub max_current_a: f64,
    /// Length of the true path driven (sampled at the steering rate), m.
    pub distance_travelled_m: f64,
    /// The controller's heading minus the true heading at the last steering update,
    /// wrapped, rad (`None`: no steering update ran).
    pub final_heading_estimate_error_rad: Option<f64>,
    /// The controller reported its gyro and odometry disagreeing at some step (known only
    /// when the logic runs in this process).
    pub gyro_disagreed: bool,
    /// The largest |gyro − odometry yaw rate| running mean the controller reported while
    /// armed, rad/s (0 without a gyro, or when the logic runs elsewhere).
    pub max_gyro_disagreement_radps: f64,
    /// Trace rows (empty if not requested, or when the logic ran elsewhere).
    pub trace: Vec<TraceRow>,
    /// The trajectory's fingerprint (see [`Digest`]; hashed as [`run_with_logic`] says).
    /// `None` for a result not computed by this loop (e.g. a station's recording).
    pub digest: Option<Digest>,
}

impl RunResult {
    /// True when the supervisor ended the run faulted.
    pub fn faulted(&self) -> bool {
        !self.summary.supervisor.faults.is_empty()
    }
}

/// The plant described by `scenario`: its motor, driver, body and slip, and the true
/// geometry = the controller's belief × the scenario's mismatch.
pub fn plant_params(scenario: &Scenario) -> PlantParams {
    let left = f64::from(scenario.robot.wheel_radius_left_m);
    let right = f64::from(scenario.robot.wheel_radius_right_m);
    let l = f64::from(scenario.robot.track_width_m);
    let m = scenario.plant.mismatch;
    let common = 1.0 + m.wheel_radius_pct / 100.0;
    let split = m.wheel_radius_left_right_pct / 200.0;
    PlantParams {
        motor: scenario.plant.motor,
        motor_mismatch: scenario.plant.motor_mismatch,
        driver: scenario.plant.driver,
        gear_ratio: f64::from(scenario.robot.gear_ratio),
        body: scenario.plant.body,
        geometry: TrueGeometry {
            wheel_radius_left_m: left * (common + split),
            wheel_radius_right_m: right * (common - split),
            track_width_m: l * (1.0 + m.track_width_pct / 100.0),
        },
        slip: scenario.plant.slip,
        load: scenario.plant.load,
    }
}

/// Runs `scenario` with steering law `law` and its own faults, recording a trace at
/// every steering update.
pub fn run_scenario(scenario: &Scenario, law: LawKind) -> Result<RunResult, RunError> {
    run_scenario_with(scenario, law, RunOptions::at_steering_rate(scenario))
}

/// One control step of `logic` against `hardware` (module doc): the periods the step
/// covers, the sensors, the decision, the outputs, one period of the plant.
pub(super) fn step<'a, L: RobotLogic>(
    logic: &'a mut L,
    hardware: &mut SimHardware,
) -> Result<Decision<'a>, RunError> {
    let periods = hardware.periods_until_next_step();
    let sensors = hardware.sense(periods);
    let decision = logic.step(&sensors)?;
    hardware.actuate(Actuation {
        duty: decision.out.duty,
        bridge: decision.out.bridge,
    });
    hardware.advance();
    Ok(decision)
}

/// Runs `scenario` with steering law `law` and `options`.
pub fn run_scenario_with(
    scenario: &Scenario,
    law: LawKind,
    options: RunOptions,
) -> Result<RunResult, RunError> {
    let mut robot = LocalRobot::new(scenario, law)?;
    run_with_logic(scenario, law, options, &mut robot, "simulator")
}

/// Runs `scenario` (its plant, faults and duration) with the decisions of `logic`, which
/// follows the path with `law`; `source` names where the logic ran (`simulator`, `pil`)
/// in the summary.
///
/// The [`Digest`] hashes, at every step, the duties (their bits) and the plant's true
/// pose when the firmware read its sensors, and at every steering update the
/// controller's odometry pose; its final poses are the odometry pose at the last
/// steering update and the plant's true pose at the end. Two runs with equal digests
/// computed the same duties and estimates at every step, bit for bit.
pub fn run_with_logic<L: RobotLogic>(
    scenario: &Scenario,
    law: LawKind,
    options: RunOptions,
    logic: &mut L,
    source: &str,
) -> Result<RunResult, RunError> {
    let mut hardware = SimHardware::new(scenario, &scenario.faults)?;
    hardware.set_integration(options.integration);
    let control_hz = scenario.robot.control_rate_hz;
    let rate = f64::from(control_hz);
    let params = scenario.params()?;
    let divider = u64::from(params.steering_divider().get());
    let truth = TrueReference::new(scenario, control_hz);
    let rate_nz = params.control_rate();
    let mut true_stats = ErrorStats::new(rate_nz);
    let mut est_stats = ErrorStats::new(rate_nz);
    let mut hourly = HourlyRms::default();
    let mut watches: Vec<FaultWatch> = scenario
        .faults
        .iter()
        .map(|f| FaultWatch::new(*f, rate))
        .collect();
    let mut digest = Fnv1a64::new();
    let mut last_estimate_pose = Pose::default();

    // The robot is put at the start and told so (the pose command), then armed at step
    // 0 (in motion if the scenario starts moving), unless told not to.
    let s = scenario.start;
    logic.set_pose_locally(Pose::new(s.x_m as f32, s.y_m as f32, s.theta_rad as f32));
    if s.v_m_s != 0.0 || s.omega_rad_s != 0.0 {
        hardware
            .start_moving(s.v_m_s, s.omega_rad_s)
            .map_err(|refused| RunError::StartMotion {
                v_m_s: s.v_m_s,
                omega_rad_s: s.omega_rad_s,
                refused,
            })?;
    }
    let mut armed_at: Option<u64> = None;
    let motion = (s.v_m_s != 0.0 || s.omega_rad_s != 0.0)
        .then(|| BodyVelocity::new(s.v_m_s as f32, s.omega_rad_s as f32));
    let arm_request = ArmRequest {
        mode: if scenario.velocity.is_some() {
            RunMode::FollowVelocity
        } else {
            RunMode::FollowPath
        },
        hold_speeds: None,
        initial_motion: motion,
        max_armed_steps: None,
    };
    // A robot with a gyro may stand still first, to learn the gyro's bias.
    let rest_steps = scenario
        .gyro
        .map_or(0, |g| (g.rest_before_arming_s * rate).round() as u64);
    if scenario.arm_at_start && rest_steps == 0 && logic.arm_locally(arm_request) {
        armed_at = Some(0);
    }

    let total = (scenario.duration_s * rate).round() as u64;
    let trace_every = match options.trace_every_steps {
        0 => 0,
        n => u64::from(n).max(total / MAX_TRACE_ROWS),
    };
    let mut trace =
        Vec::with_capacity(total.checked_div(trace_every).map_or(0, |n| n as usize + 1));
    let (mut max_wheel, mut max_duty, mut max_current) = (0.0f64, 0.0f64, 0.0f64);
    let mut travelled = 0.0;
    let mut last_position = (s.x_m, s.y_m);
    let mut reference_pose = Pose::default();
    // Control periods since arming in which the robot was not armed.
    let mut paused_periods = 0u64;
    let mut true_sample = (0.0, 0.0);
    let mut last_out = None;

    let wall = Instant::now();
    let mut final_heading_estimate_error_rad = None;
    let mut gyro_disagreed = false;
    let mut max_gyro_disagreement_radps = 0.0f64;
    while hardware.period() < total {
        let period = hardware.period();
        if scenario.arm_at_start
            && rest_steps > 0
            && period == rest_steps
            && logic.arm_locally(arm_request)
        {
            armed_at = Some(period);
        }
        let t_s = period as f64 / rate;
        // The true state when the firmware reads its sensors.
        let pose = hardware.plant().pose();
        let wheels = hardware.plant().wheel_speeds();
        let true_velocity = hardware.plant().body_velocity();
        if let Some(command) = scenario.velocity.as_ref().and_then(|v| v.sent_at(period)) {
            logic.command_velocity(command);
        }
        let decision = step(logic, &mut hardware)?;
        let out = decision.out;
        let step_periods = hardware.period() - period;
        let estimate = decision.estimate;
        if let (Some(t), State::Armed) = (decision.telemetry, out.state) {
            gyro_disagreed |= t.gyro.disagrees;
            max_gyro_disagreement_radps =
                max_gyro_disagreement_radps.max(f64::from(t.gyro.disagreement_radps.abs()));
        }
        digest.write_f32(out.duty.left);
        digest.write_f32(out.duty.right);
        digest.write_pose(&Pose::new(
            pose.x_m as f32,
            pose.y_m as f32,
            pose.theta_rad as f32,
        ));
        if estimate.steering_updated {
            digest.write_pose(&estimate.pose);
            last_estimate_pose = estimate.pose;
            final_heading_estimate_error_rad = Some(robot_files::truth::wrap_angle(
                f64::from(estimate.pose.theta_rad) - pose.theta_rad,
            ));
        }
        if let Some(Event::Armed(RunMode::FollowPath | RunMode::FollowVelocity)) = out.event {
            if armed_at.is_none() {
                armed_at = Some(period);
            }
        }
        let since_arming = armed_at.map(|a| period - a);
        // The robot's reference moves only while it is armed: a pause (a press that
        // disarms, a fault) holds it, and a re-arm resumes it where it stopped.
        if armed_at.is_some() && out.state != State::Armed {
            paused_periods += step_periods;
        }

        // True error every steering period from arming (module doc).
        if let Some(k) = since_arming {
            if k % divider == 0 {
                reference_pose = truth.at(k.saturating_sub(paused_periods), &pose);
                let dx = f64::from(reference_pose.x_m) - pose.x_m;
                let dy = f64::from(reference_pose.y_m) - pose.y_m;
                let heading = robot_files::truth::wrap_angle(
                    f64::from(reference_pose.theta_rad) - pose.theta_rad,
                );
                true_sample = (dx.hypot(dy), heading);
                true_stats.push(ErrorSample {
                    step: k as u32,
                    position_m: true_sample.0 as f32,
                    heading_rad: true_sample.1 as f32,
                });
                hourly.push(k as f64 / rate, true_sample.0);
                travelled += (pose.x_m - last_position.0).hypot(pose.y_m - last_position.1);
                last_position = (pose.x_m, pose.y_m);
            }
        }
        if estimate.steering_updated {
            if let Some(k) = since_arming {
                est_stats.push(ErrorSample {
                    step: k as u32,
                    position_m: estimate.error.position_m(),
                    heading_rad: estimate.error.theta_e_rad,
                });
            }
        }
        for w in &mut watches {
            w.observe(period, t_s, &out, &pose, wheels);
        }
        if let (true, Some(tel)) = (
            trace_every > 0 && period % trace_every == 0,
            decision.telemetry,
        ) {
            trace.push(TraceRow {
                t_s,
                true_pose: pose,
                est_pose: tel.pose,
                reference: reference_pose,
                error: tel.error,
                true_error: true_sample,
                true_tracking: tracking_error_f64(&pose, &reference_pose),
                lyapunov: tel.law.lyapunov,
                command: tel.command,
                true_velocity,
                setpoint: tel.wheel_setpoint,
                measured: tel.wheel_speed,
                true_wheel: wheels,
                volts: [tel.wheel_loop.volts.left_v, tel.wheel_loop.volts.right_v],
                duty: out.duty,
                supply_v: tel.supply_v,
                state: out.state,
                detail: SampleDetail {
                    lyapunov_rate: tel.law.lyapunov_rate,
                    pid: decision.pid_parts.unwrap_or_default(),
                    faults: out.faults,
                },
            });
        }
        let [il, ir] = hardware.plant().currents_a();
        max_current = max_current.max(il.abs()).max(ir.abs());
        max_duty = max_duty
            .max(f64::from(out.duty.left.abs()))
            .max(f64::from(out.duty.right.abs()));
        max_wheel = max_wheel.max(wheels[0].abs()).max(wheels[1].abs());
        last_out = Some(out);
    }
    let wall_time_s = wall.elapsed().as_secs_f64();

    let supervisor = match last_out {
        Some(out) => SupervisorReport::new(
            out.state,
            &out.faults,
            out.missed_ticks_total,
            out.overruns_total,
        ),
        None => SupervisorReport::new(State::Disarmed, &Default::default(), 0, 0),
    };
    Ok(RunResult {
        summary: Summary {
            scenario: scenario.name.clone(),
            law: law.name().to_string(),
            source: source.to_string(),
            true_error: Some(ErrorReport::from(true_stats.summary())),
            estimated_error: ErrorReport::from(est_stats.summary()),
            // The true error is sampled from arming to the end of the run.
            hourly_rms_true_position_error_m: hourly
                .finish(armed_at.map_or(0.0, |a| total.saturating_sub(a) as f64 / rate)),
            max_wheel_speed_rad_s: max_wheel,
            max_duty,
            supervisor,
            injected_faults: watches.into_iter().map(|w| w.report).collect(),
            sim_time_s: total as f64 / rate,
            wall_time_s,
            steps: total,
        },
        max_current_a: max_current,
        distance_travelled_m: travelled,
        final_heading_estimate_error_rad,
        gyro_disagreed,
        max_gyro_disagreement_radps,
        trace,
        digest: Some(Digest {
            steps: u32::try_from(total).unwrap_or(u32::MAX),
            hash: digest.finish(),
            pose_bits: m4f_scenario::digest::pose_bits(&last_estimate_pose),
            true_pose_bits: {
                let p = hardware.plant().pose();
                m4f_scenario::digest::pose_bits(&Pose::new(
                    p.x_m as f32,
                    p.y_m as f32,
                    p.theta_rad as f32,
                ))
            },
        }),
    })
}
