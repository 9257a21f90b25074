//! The simulation loop: the controller driven exactly as the firmware drives it, against
//! the plant.
//!
//! Each control step k (t = k·T, T = 1 / control rate, time kept as the integer k):
//!
//! 1. read both encoders at the plant's true wheel angles → [`TickDeltas`] (quantised,
//!    optionally jittered), as the firmware reads its timers;
//! 2. `Controller::step(ticks)` → duties in [−1, 1];
//! 3. the duties are quantised to the PWM resolution, dead-banded, × supply voltage, and
//!    held while the plant integrates one control period with RK4 at the plant rate.
//!
//! ## A start in motion
//!
//! The paper's robot is already moving at t = 0 (v = 0.4 m/s, ω = 0.3 rad/s). The plant's
//! wheels are spun up to match (inverse kinematics with the **true** geometry), and the
//! controller is given the encoder history of that motion: for one speed-estimator window
//! before t = 0 it is stepped in `Mode::Idle` with the ticks the moving wheels would have
//! produced, then its pose is set to the start pose and `Mode::FollowPath` is entered. So
//! at t = 0 its speed estimate, its limiter and its PIDs start from the true motion, as
//! they would on a robot that had been driving — not from a standstill it is not in.
//!
//! ## Errors
//!
//! Every metric is measured on the **true** pose at each steering update, against the
//! reference the controller used at that update. In time-indexed mode the error is the
//! distance to the reference point and θ_r − θ; in path-following mode, where the
//! reference may be placed ahead of the robot on purpose, it is the distance to the
//! closest point of the path and the path's heading there minus θ. The same statistics of
//! the controller's own estimate (odometry) are kept in [`RunResult::estimated`]: the two
//! differ when the true robot does not match what the controller believes (mismatch,
//! slip), which no feedback on odometry alone can see.

use std::time::Instant;

use controller_core::prelude::*;

use crate::encoder::Encoder;
use crate::metrics::{ErrorMetrics, ErrorSample, Summary};
use crate::plant::{Plant, PlantError, PlantParams, TrueGeometry, TruePose};
use crate::rng::Rng;
use crate::scenario::{Scenario, ScenarioError};

/// One row of `trace.csv`. World frame for poses (m, rad); robot frame for x_e, y_e.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceRow {
    /// Time since the start, s.
    pub t_s: f64,
    /// True pose.
    pub true_pose: TruePose,
    /// The controller's odometry estimate.
    pub est_pose: Pose,
    /// Reference pose at the last steering update.
    pub reference: Pose,
    /// The controller's tracking error (9) of its estimate: x_e, y_e (m), θ_e (rad).
    pub error: TrackingError,
    /// Error of the true pose as used by the metrics: position (m), heading (rad).
    pub true_error: ErrorSample,
    /// Tracking error (9) of the true pose against the reference: x_e, y_e (m, robot
    /// frame), θ_e (rad).
    pub true_tracking: [f64; 3],
    /// The steering law's Lyapunov function V.
    pub lyapunov: f32,
    /// Body command after limits: v (m/s), ω (rad/s).
    pub command: BodyVelocity,
    /// True body velocity: v (m/s), ω (rad/s).
    pub true_velocity: (f64, f64),
    /// Wheel-speed set-points, rad/s.
    pub setpoint: WheelSpeeds,
    /// The controller's wheel-speed estimate, rad/s.
    pub measured: WheelSpeeds,
    /// True wheel speeds [left, right], rad/s.
    pub true_wheel: [f64; 2],
    /// Commanded duties, −1…1.
    pub duty: MotorCommand,
}

impl TraceRow {
    /// Column names of [`TraceRow::write_csv`], comma-separated (units in the names).
    pub const CSV_HEADER: &'static str = "t_s,x_m,y_m,theta_rad,x_est_m,y_est_m,theta_est_rad,\
x_ref_m,y_ref_m,theta_ref_rad,x_e_m,y_e_m,theta_e_rad,x_e_true_m,y_e_true_m,theta_e_true_rad,\
pos_err_true_m,heading_err_true_rad,\
lyapunov_v,v_cmd_m_s,omega_cmd_rad_s,v_true_m_s,omega_true_rad_s,\
setpoint_left_rad_s,setpoint_right_rad_s,speed_est_left_rad_s,speed_est_right_rad_s,\
speed_true_left_rad_s,speed_true_right_rad_s,duty_left,duty_right";

    /// Appends this row as CSV (no newline) to `out`.
    pub fn write_csv(&self, out: &mut String) {
        use std::fmt::Write;
        let p = &self.true_pose;
        // Writing to a String cannot fail.
        let _ = write!(
            out,
            "{:.3},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},\
{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.5},{:.5},{:.5},{:.5},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
            self.t_s,
            p.x_m,
            p.y_m,
            p.theta_rad,
            self.est_pose.x_m,
            self.est_pose.y_m,
            self.est_pose.theta_rad,
            self.reference.x_m,
            self.reference.y_m,
            self.reference.theta_rad,
            self.error.x_e_m,
            self.error.y_e_m,
            self.error.theta_e_rad,
            self.true_tracking[0],
            self.true_tracking[1],
            self.true_tracking[2],
            self.true_error.position_m,
            self.true_error.heading_rad,
            self.lyapunov,
            self.command.v_m_s,
            self.command.omega_rad_s,
            self.true_velocity.0,
            self.true_velocity.1,
            self.setpoint.left_rad_s,
            self.setpoint.right_rad_s,
            self.measured.left_rad_s,
            self.measured.right_rad_s,
            self.true_wheel[0],
            self.true_wheel[1],
            self.duty.left,
            self.duty.right,
        );
    }
}

/// Why a run could not start.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The scenario's robot parameters are invalid.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// The plant parameters are invalid.
    #[error(transparent)]
    Plant(#[from] PlantError),
    /// The reference could not be built (speed or distance out of range).
    #[error("reference: {0}")]
    Reference(ReferenceError),
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

/// Options of one run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunOptions {
    /// Record a trace row every this many control steps (0: no trace).
    pub trace_every_steps: u32,
}

impl RunOptions {
    /// A trace row at every steering update of `scenario`'s robot (every
    /// `steering_divider` control steps), so traces and plots sample the law's own rate.
    pub fn at_steering_rate(scenario: &Scenario) -> Self {
        Self {
            trace_every_steps: scenario.robot.steering_divider,
        }
    }
}

/// Everything a run produced.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// The `summary.json` content (true-pose errors).
    pub summary: Summary,
    /// The same error statistics for the controller's own (odometry) estimate.
    pub estimated: ErrorMetrics,
    /// Faults latched by the controller at the end of the run (none in a healthy run).
    pub faults: FaultFlags,
    /// Largest |armature current| of either motor, A.
    pub max_current_a: f64,
    /// Length of the true path driven (sampled at the steering rate), m.
    pub distance_travelled_m: f64,
    /// Trace rows (empty if not requested).
    pub trace: Vec<TraceRow>,
}

/// The plant described by `scenario`: its motor, driver, body and slip, and the true
/// geometry = the controller's belief × the scenario's mismatch.
pub fn plant_params(scenario: &Scenario) -> PlantParams {
    let r = f64::from(scenario.robot.wheel_radius_m);
    let l = f64::from(scenario.robot.track_width_m);
    let m = scenario.plant.mismatch;
    let common = 1.0 + m.wheel_radius_pct / 100.0;
    let split = m.wheel_radius_left_right_pct / 200.0;
    PlantParams {
        motor: scenario.plant.motor,
        driver: scenario.plant.driver,
        gear_ratio: f64::from(scenario.robot.gear_ratio),
        body: scenario.plant.body,
        geometry: TrueGeometry {
            wheel_radius_left_m: r * (common + split),
            wheel_radius_right_m: r * (common - split),
            track_width_m: l * (1.0 + m.track_width_pct / 100.0),
        },
        slip: scenario.plant.slip,
    }
}

/// Runs `scenario` with steering law `law`, recording a trace at every steering update.
pub fn run_scenario(scenario: &Scenario, law: LawKind) -> Result<RunResult, RunError> {
    run_scenario_with(scenario, law, RunOptions::at_steering_rate(scenario))
}

/// Eq. (9) in f64: the reference seen from the true pose, robot frame: [x_e m, y_e m,
/// θ_e rad].
fn tracking_error_f64(pose: &TruePose, reference: &Pose) -> [f64; 3] {
    let dx = f64::from(reference.x_m) - pose.x_m;
    let dy = f64::from(reference.y_m) - pose.y_m;
    let (s, c) = pose.theta_rad.sin_cos();
    [
        c * dx + s * dy,
        -s * dx + c * dy,
        crate::plant::robot::wrap_angle(f64::from(reference.theta_rad) - pose.theta_rad),
    ]
}

/// The true pose's error against `reference` (see the module doc).
fn true_error(
    t_s: f64,
    pose: &TruePose,
    reference: &ReferenceState,
    path: &Path,
    path_following: bool,
) -> ErrorSample {
    let (rx, ry, rth) = if path_following {
        let p = Point::new(pose.x_m as f32, pose.y_m as f32);
        let s = path.project(p, 0.0, f32::INFINITY, f32::INFINITY);
        let sample = path.sample(s);
        (
            f64::from(sample.point.x_m),
            f64::from(sample.point.y_m),
            f64::from(sample.heading_rad),
        )
    } else {
        (
            f64::from(reference.pose.x_m),
            f64::from(reference.pose.y_m),
            f64::from(reference.pose.theta_rad),
        )
    };
    ErrorSample {
        t_s,
        position_m: (rx - pose.x_m).hypot(ry - pose.y_m),
        heading_rad: crate::plant::robot::wrap_angle(rth - pose.theta_rad),
    }
}

/// What both run loops build from a scenario: the controller and the rates and encoder
/// facts of its loop.
struct Setup {
    controller: Controller,
    config: RobotConfig,
    control_hz: u32,
    /// Plant RK4 steps per control step.
    substeps: u32,
    /// Plant step, s.
    dt_s: f64,
    ticks_per_rev: f64,
    /// Encoder edge jitter, ticks RMS.
    noise: f64,
}

impl Setup {
    /// The controller for `scenario` running `law`, believing the robot starts at `start`.
    fn new(scenario: &Scenario, law: LawKind, start: Pose) -> Result<Self, RunError> {
        let params = scenario.params()?;
        let config = *params.config();
        let reference = Reference::new(
            scenario.path.clone(),
            scenario.reference_speed_m_s,
            scenario.reference_mode,
        )
        .map_err(RunError::Reference)?;
        let control_hz = config.control_rate_hz;
        Ok(Self {
            controller: Controller::new(params, reference, law, start),
            config,
            control_hz,
            substeps: scenario.plant_rate_hz / control_hz,
            dt_s: 1.0 / f64::from(scenario.plant_rate_hz),
            ticks_per_rev: f64::from(config.encoder_lines_per_motor_rev)
                * 4.0
                * f64::from(config.gear_ratio),
            noise: scenario.plant.encoder_noise_ticks_rms,
        })
    }
}

/// Runs `scenario` with steering law `law` and `options`.
pub fn run_scenario_with(
    scenario: &Scenario,
    law: LawKind,
    options: RunOptions,
) -> Result<RunResult, RunError> {
    let path_following = matches!(scenario.reference_mode, ReferenceMode::PathFollowing { .. });
    let mut plant = Plant::new(plant_params(scenario))?;
    let s = scenario.start;
    let start_true = TruePose {
        x_m: s.x_m,
        y_m: s.y_m,
        theta_rad: crate::plant::robot::wrap_angle(s.theta_rad),
    };
    let start_speeds = plant.wheel_speeds_for(s.v_m_s, s.omega_rad_s);
    plant.reset(start_true, start_speeds);

    let start_pose = Pose::new(s.x_m as f32, s.y_m as f32, start_true.theta_rad as f32);
    let Setup {
        mut controller,
        config,
        control_hz,
        substeps,
        dt_s,
        ticks_per_rev,
        noise,
    } = Setup::new(scenario, law, start_pose)?;
    let period_s = 1.0 / f64::from(control_hz);
    let mut rng = Rng::new(scenario.seed);

    // Pre-roll: the encoder history of a start in motion (see the module doc). The
    // controller sees the ticks of the window (−(n+1)T, −T]; the main loop's first step then
    // reads (−T, 0] from the same encoders, so no interval is seen twice or skipped.
    let n = if start_speeds == [0.0, 0.0] {
        0
    } else {
        config.speed_window_steps
    };
    let angle_at = |k: u32, i: usize| -f64::from(n + 1 - k) * period_s * start_speeds[i];
    let mut encoders = [
        Encoder::new(ticks_per_rev, noise, angle_at(0, 0)),
        Encoder::new(ticks_per_rev, noise, angle_at(0, 1)),
    ];
    if n > 0 {
        for k in 1..=n {
            let ticks = TickDeltas {
                left: encoders[0].read_delta(angle_at(k, 0), &mut rng),
                right: encoders[1].read_delta(angle_at(k, 1), &mut rng),
            };
            controller.step(ticks);
        }
        controller.set_pose(start_pose);
    }
    controller.set_mode(Mode::FollowPath);

    let total_steps = (scenario.duration_s * f64::from(control_hz)).round() as u64;
    let capacity = if options.trace_every_steps > 0 {
        (total_steps / u64::from(options.trace_every_steps)) as usize + 1
    } else {
        0
    };
    let mut trace = Vec::with_capacity(capacity);
    let samples_cap = (total_steps / u64::from(config.steering_divider.max(1))) as usize + 1;
    let mut true_samples = Vec::with_capacity(samples_cap);
    let mut est_samples = Vec::with_capacity(samples_cap);
    let (mut max_wheel, mut max_duty, mut max_current) = (0.0f64, 0.0f64, 0.0f64);
    let mut travelled = 0.0;
    let mut last_position = (start_true.x_m, start_true.y_m);

    let wall = Instant::now();
    for k in 0..total_steps {
        let t_s = k as f64 / f64::from(control_hz);
        let angles = plant.wheel_angles();
        let ticks = TickDeltas {
            left: encoders[0].read_delta(angles[0], &mut rng),
            right: encoders[1].read_delta(angles[1], &mut rng),
        };
        let duty = controller.step(ticks);
        let tel = controller.telemetry();

        let record = options.trace_every_steps > 0 && k % u64::from(options.trace_every_steps) == 0;
        if tel.steering_updated || record {
            let pose = plant.pose();
            let sample = true_error(t_s, &pose, &tel.reference, &scenario.path, path_following);
            if tel.steering_updated {
                true_samples.push(sample);
                travelled += (pose.x_m - last_position.0).hypot(pose.y_m - last_position.1);
                last_position = (pose.x_m, pose.y_m);
                let est = TruePose {
                    x_m: f64::from(tel.pose.x_m),
                    y_m: f64::from(tel.pose.y_m),
                    theta_rad: f64::from(tel.pose.theta_rad),
                };
                est_samples.push(true_error(
                    t_s,
                    &est,
                    &tel.reference,
                    &scenario.path,
                    path_following,
                ));
            }
            if record {
                trace.push(TraceRow {
                    t_s,
                    true_pose: pose,
                    est_pose: tel.pose,
                    reference: tel.reference.pose,
                    error: tel.error,
                    true_error: sample,
                    true_tracking: tracking_error_f64(&pose, &tel.reference.pose),
                    lyapunov: tel.law.lyapunov,
                    command: tel.command,
                    true_velocity: plant.body_velocity(),
                    setpoint: tel.wheel_setpoint,
                    measured: tel.wheel_speed,
                    true_wheel: plant.wheel_speeds(),
                    duty,
                });
            }
        }

        plant.set_duty(duty.left, duty.right);
        let [il, ir] = plant.currents_a();
        max_current = max_current.max(il.abs()).max(ir.abs());
        max_duty = max_duty
            .max(f64::from(duty.left.abs()))
            .max(f64::from(duty.right.abs()));
        plant.advance(dt_s, substeps);
        let [wl, wr] = plant.wheel_speeds();
        max_wheel = max_wheel.max(wl.abs()).max(wr.abs());
    }
    let wall_time_s = wall.elapsed().as_secs_f64();

    let m = ErrorMetrics::from_samples(&true_samples);
    Ok(RunResult {
        summary: Summary {
            scenario: scenario.name.clone(),
            law: law.name().to_string(),
            settle_time_s: m.settle_time_s,
            final_position_error_m: m.final_position_error_m,
            final_heading_error_rad: m.final_heading_error_rad,
            rms_position_error_m: m.rms_position_error_m,
            max_position_error_m: m.max_position_error_m,
            max_wheel_speed_rad_s: max_wheel,
            max_duty,
            sim_time_s: total_steps as f64 * period_s,
            wall_time_s,
            steps: total_steps,
        },
        estimated: ErrorMetrics::from_samples(&est_samples),
        faults: controller.faults(),
        max_current_a: max_current,
        distance_travelled_m: travelled,
        trace,
    })
}

/// The wheel-speed loop's response to a set-point step, from rest (both wheels).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepResponse {
    /// Set-point, rad/s.
    pub setpoint_rad_s: f64,
    /// Samples every control step: (t s, true left wheel speed rad/s, estimated left wheel
    /// speed rad/s, left duty).
    pub samples: Vec<(f64, f64, f64, f64)>,
    /// 10 → 90 % rise time of the true speed, s (`None` if 90 % is never reached).
    pub rise_time_s: Option<f64>,
    /// Peak overshoot above the set-point, % of the set-point.
    pub overshoot_pct: f64,
    /// Time after which the true speed stays within ±5 % of the set-point, s.
    pub settling_time_s: Option<f64>,
    /// Mean true speed over the last 20 % of the run minus the set-point, rad/s.
    pub steady_state_error_rad_s: f64,
}

/// Holds both wheels at `setpoint_rad_s` (rad/s) from rest with the wheel PIDs only
/// (`Mode::HoldWheelSpeeds`) for `duration_s` (s), on `scenario`'s robot and plant. The
/// robot drives straight; the response is the left wheel's.
pub fn wheel_step_response(
    scenario: &Scenario,
    setpoint_rad_s: f64,
    duration_s: f64,
) -> Result<StepResponse, RunError> {
    let max_s = crate::scenario::MAX_CONTROL_STEPS / f64::from(scenario.robot.control_rate_hz);
    if !(duration_s > 0.0 && duration_s <= max_s.min(crate::scenario::MAX_DURATION_S)) {
        return Err(RunError::Argument {
            name: "duration_s",
            rule: "must be > 0 and within the scenario's step and time limits",
            value: duration_s,
        });
    }
    if !setpoint_rad_s.is_finite() {
        return Err(RunError::Argument {
            name: "setpoint_rad_s",
            rule: "must be finite",
            value: setpoint_rad_s,
        });
    }
    let mut plant = Plant::new(plant_params(scenario))?;
    plant.reset(TruePose::default(), [0.0; 2]);
    let Setup {
        mut controller,
        control_hz,
        substeps,
        dt_s,
        ticks_per_rev,
        noise,
        ..
    } = Setup::new(scenario, LawKind::Tracking, Pose::default())?;
    let sp = setpoint_rad_s as f32;
    controller.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(sp, sp)));
    let mut encoders = [
        Encoder::new(ticks_per_rev, noise, 0.0),
        Encoder::new(ticks_per_rev, noise, 0.0),
    ];
    let mut rng = Rng::new(scenario.seed);
    let steps = (duration_s * f64::from(control_hz)).round() as u64;
    let mut samples = Vec::with_capacity(steps as usize);
    for k in 0..steps {
        let angles = plant.wheel_angles();
        let ticks = TickDeltas {
            left: encoders[0].read_delta(angles[0], &mut rng),
            right: encoders[1].read_delta(angles[1], &mut rng),
        };
        let duty = controller.step(ticks);
        samples.push((
            k as f64 / f64::from(control_hz),
            plant.wheel_speeds()[0],
            f64::from(controller.telemetry().wheel_speed.left_rad_s),
            f64::from(duty.left),
        ));
        plant.set_duty(duty.left, duty.right);
        plant.advance(dt_s, substeps);
    }
    let target = setpoint_rad_s;
    let first_at = |fraction: f64| {
        samples
            .iter()
            .find(|s| s.1 * target.signum() >= fraction * target.abs())
            .map(|s| s.0)
    };
    let rise_time_s = match (first_at(0.1), first_at(0.9)) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    let peak = samples
        .iter()
        .map(|s| s.1 * target.signum())
        .fold(0.0f64, f64::max);
    let band = 0.05 * target.abs();
    let settling_time_s = match samples.iter().rposition(|s| (s.1 - target).abs() > band) {
        None => Some(0.0),
        Some(i) => samples.get(i + 1).map(|s| s.0),
    };
    let tail = &samples[samples.len() * 4 / 5..];
    let mean = tail.iter().map(|s| s.1).sum::<f64>() / tail.len().max(1) as f64;
    Ok(StepResponse {
        setpoint_rad_s,
        rise_time_s,
        overshoot_pct: if target != 0.0 {
            ((peak - target.abs()) / target.abs() * 100.0).max(0.0)
        } else {
            0.0
        },
        settling_time_s,
        steady_state_error_rad_s: mean - target,
        samples,
    })
}
