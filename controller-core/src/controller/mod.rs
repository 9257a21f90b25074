//! The fixed-step cascade: encoder ticks and the supply voltage in, bridge duties and
//! telemetry out.
//!
//! ```text
//! ticks ─► odometry ─► pose ─┐                                 every step (inner loop, T)
//!      └─► speed estimate ───┼────────────────────────────────────────────┐
//! reference ─► steering law ─► limits ─► inverse kinematics ─► set-point ramp
//!    every `steering_divider` steps, applied one step later     every step │ set-points
//! supply ─► filter ──────────────────────────────────────────► wheel loops (volts) ─► duty
//! ```
//!
//! The outer loop ([`crate::outer_loop`]) runs on a job the inner loop hands over at a step
//! where the law is due, and its outcome starts the set-point ramp at the next step: a
//! one-period hand-over, so that on the robot the outer loop can run outside the control
//! interrupt and still do exactly what it does here. The first step of path following
//! holds the wheels at their measured speeds while the law runs.
//!
//! [`Controller::step`] is the whole of it: call it once per control period with a
//! [`StepInput`] (the signed tick deltas since the last call, how many periods they span,
//! the measured supply), apply the two duties it returns, and read
//! [`Controller::telemetry`] when you want to log or plot. It never panics and always
//! returns duties in [−1, 1]. Faults (an implausible tick jump, a non-finite value
//! anywhere) latch: both duties are 0 until [`Controller::clear_faults`].
//!
//! Time is the number of control periods that actually elapsed: a step that starts late
//! (the firmware missed a tick) says so in [`StepInput::periods`], and the reference, the
//! speed estimate, the ramp and the PIDs all advance by that much, so a late step neither
//! reads 2 ms of ticks as 1 ms nor leaves the time-indexed reference behind.

use core::num::NonZeroU32;

use crate::drive::{SupplyFilter, WheelDrive, WheelLoopReport, WheelVolts};
use crate::encoder::SpeedEstimator;
use crate::gyro::{GyroReport, GyroSample, HeadingFusion};
use crate::kinematics::{BodyVelocity, Pose, TrackingError, WheelSpeeds};
use crate::law::{LawKind, LawOutput};
use crate::limits::LimitFlags;
use crate::math;
use crate::odometry::Odometry;
use crate::outer_loop::{
    OuterLoop, OuterLoopAway, OuterLoopHolder, OuterLoopJob, ReferenceRestart,
};
use crate::params::Params;
use crate::pid::PidParts;
use crate::reference::{Reference, ReferenceState};
use crate::velocity::VelocitySource;

/// Signed encoder ticks counted during one step, forward positive.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct TickDeltas {
    /// Left wheel ticks this step.
    pub left: i32,
    /// Right wheel ticks this step.
    pub right: i32,
}

/// What the controller reads in one step.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepInput {
    /// Encoder ticks since the previous step.
    pub ticks: TickDeltas,
    /// Control periods since the previous step: 1 on time, more when the step started
    /// late and absorbed missed ticks. Never 0, by type.
    pub periods: NonZeroU32,
    /// The measured motor supply (battery) voltage, V.
    pub supply_v: f32,
    /// The gyro's newest reading, if one arrived since the previous step (`None`: no IMU,
    /// or no new reading).
    pub gyro: Option<GyroSample>,
    /// The robot is still: disarmed, both wheels at rest (the supervisor's judgement).
    /// Only then is the gyro's bias learned.
    pub still: bool,
}

impl StepInput {
    /// A step on time (one period) with `ticks` and a supply of `supply_v` (V), no gyro
    /// reading, not still.
    pub const fn on_time(ticks: TickDeltas, supply_v: f32) -> Self {
        Self {
            ticks,
            periods: NonZeroU32::MIN,
            supply_v,
            gyro: None,
            still: false,
        }
    }
}

/// Motor commands, each a signed fraction of the supply voltage in [−1, 1].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct MotorCommand {
    /// Left motor duty, −1…1 (positive drives the robot forward).
    pub left: f32,
    /// Right motor duty, −1…1 (positive drives the robot forward).
    pub right: f32,
}

impl MotorCommand {
    /// Both motors at 0 (short brake while the bridge is enabled).
    pub const STOP: MotorCommand = MotorCommand {
        left: 0.0,
        right: 0.0,
    };
}

/// What the controller is asked to do.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum Mode {
    /// Motors off; odometry keeps running.
    Idle,
    /// Follow the reference with the selected steering law.
    FollowPath,
    /// Hold these wheel speeds (rad/s) with the wheel loops only (bring-up).
    HoldWheelSpeeds(WheelSpeeds),
    /// Apply these voltages open loop (V, within the voltage cap and the current limit,
    /// no slew limit): identification of the motor constants.
    ApplyVolts(WheelVolts),
    /// Follow the body-velocity commands of [`Controller::command_velocity`] through the
    /// velocity mode's limits and timeout ([`crate::velocity`]) instead of the reference
    /// and the steering law; the rim-speed cap, the wheel loops and their limits as in
    /// path following.
    FollowVelocity,
}

/// Latched fault flags. Any flag set means both motors are commanded to 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct ControllerFaults {
    /// A tick delta implied a wheel speed beyond `max_plausible_wheel_speed_rad_s`.
    pub encoder_jump: bool,
    /// A pose, command or duty became NaN or infinite.
    pub non_finite: bool,
}

impl ControllerFaults {
    /// True when any fault is latched.
    pub const fn any(&self) -> bool {
        self.encoder_jump || self.non_finite
    }
}

/// Everything one step computed, for logs and plots. Frames as in each field's type.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct Telemetry {
    /// Index of this step since the controller was built (counts calls, not periods).
    pub step: u32,
    /// Control periods this step covered (1 on time).
    pub periods: u32,
    /// True when this step applied a steering outcome (the law ran on the previous
    /// step's pose: the one-period hand-over of [`crate::outer_loop`]).
    pub steering_updated: bool,
    /// Odometry pose estimate, world frame.
    pub pose: Pose,
    /// Reference at the last steering update.
    pub reference: ReferenceState,
    /// Tracking error (9) at the last steering update, robot frame (a copy of `law.error`).
    pub error: TrackingError,
    /// The steering law's last output (target before limits, V, V̇, polar error).
    pub law: LawOutput,
    /// Body command after the acceleration limit and the rim-speed cap, at the last
    /// steering update (v m/s, ω rad/s).
    pub command: BodyVelocity,
    /// What the limiter did to it.
    pub limit_flags: LimitFlags,
    /// Rim-speed cap in force: the configured one or less on a weak supply, m/s.
    pub rim_speed_cap_m_s: f32,
    /// Wheel-speed set-points, rad/s: ramped each step towards the command's (before
    /// coordinated saturation).
    pub wheel_setpoint: WheelSpeeds,
    /// Measured wheel speeds, rad/s.
    pub wheel_speed: WheelSpeeds,
    /// The wheel loops: volts, saturation, the set-points they used (the PIDs' parts:
    /// [`Controller::wheel_pid_parts`]).
    pub wheel_loop: WheelLoopReport,
    /// Filtered supply voltage, V.
    pub supply_v: f32,
    /// Motor duties sent, −1…1.
    pub duty: MotorCommand,
    /// Latched faults.
    pub faults: ControllerFaults,
    /// The gyro and the heading fusion (all zero while no gyro has read).
    pub gyro: GyroReport,
}

/// Where path following is in its schedule.
#[derive(Clone, Copy, Debug, Default)]
struct Schedule {
    /// Periods until the steering law runs again (0: this step).
    until_steering: u32,
    /// Periods since the reference was last sampled.
    since_sample: u32,
    /// A step has run since path following (re)started.
    started: bool,
}

/// The whole control stack for one robot (see the module doc).
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Controller<S = OuterLoop> {
    // Laid out by hand: the state every step touches first, the large path last, so the
    // hot fields sit within the M4F's short load offsets (`repr(C)` keeps this order).
    /// Latest telemetry; the state carried between steps (set-points, last law output).
    telemetry: Telemetry,
    odometry: Odometry,
    drive: WheelDrive,
    supply: SupplyFilter,
    ramp: SetpointRamp,
    schedule: Schedule,
    /// Steps since the controller was built.
    steps: u32,
    mode: Mode,
    /// The steering law was due at the last step and has not run: its job is that step's
    /// state, still in place (see [`Controller::steering_job`]).
    job_due: bool,
    /// The due job's time since the reference was last sampled, control periods.
    job_elapsed_periods: u32,
    /// The outcome in telemetry starts a new set-point ramp in this step.
    outcome_in_telemetry: bool,
    /// The outer loop's [`OuterLoop::outcome`] waits to be applied (a lent outer loop's,
    /// or one run aside).
    outcome_ready: bool,
    /// Counts restarts of the loops: an outcome of a job from before the last restart is
    /// stale.
    epoch: u32,
    /// Path following (re)started: how the next job meets the reference.
    reference_restart: ReferenceRestart,
    /// The next entry into path following starts the reference afresh instead of
    /// resuming it (a new controller, a new path, a pose command).
    reference_afresh: bool,
    /// The wheel loops restarted at this body velocity: the next job restarts the
    /// command limiter from it.
    restart_limiter_from: Option<BodyVelocity>,
    /// The velocity mode's command source (the body command in [`Mode::FollowVelocity`]).
    velocity: VelocitySource,
    speed: [SpeedEstimator; 2],
    /// The heading fusion: the gyro's bias, the fused heading, the gyro's health.
    fusion: HeadingFusion,
    params: Params,
    /// The outer loop, or where it is when lent.
    steering: S,
}

impl Controller<OuterLoop> {
    /// A controller for `params`, following `reference` with `law`, believing the robot
    /// starts at `start` (world frame). It starts in [`Mode::Idle`] (motors off). It owns
    /// its outer loop and runs it itself (see [`crate::outer_loop`]).
    pub fn new(params: Params, reference: Reference, law: LawKind, start: Pose) -> Self {
        let steering = OuterLoop::new(&params, reference, law);
        Self::with_holder(params, steering, start)
    }

    /// The steering law in use.
    pub const fn law(&self) -> LawKind {
        self.steering.law()
    }

    /// The reference being followed.
    pub const fn reference(&self) -> &Reference {
        self.steering.reference()
    }
}

impl<S: OuterLoopHolder> Controller<S> {
    /// A controller for `params` whose outer loop is `steering` (built for the same
    /// `params`), believing the robot starts at `start` (world frame), in [`Mode::Idle`].
    pub fn with_holder(params: Params, steering: S, start: Pose) -> Self {
        let steps_per_s = params.control_rate().get() as f32;
        let window = params.config().speed_window_steps as usize;
        let estimator = SpeedEstimator::new(window, params.rad_per_tick(), steps_per_s);
        let odometry = Odometry::new(params.geometry(), params.ticks_per_wheel_rev(), start);
        let fusion =
            HeadingFusion::new(params.config().gyro, params.period_s(), odometry.heading());
        Self {
            fusion,
            speed: [estimator.clone(), estimator],
            drive: WheelDrive::new(&params),
            supply: SupplyFilter::new(params.config().drive.supply_filter_tau_s, params.period_s()),
            steering,
            ramp: SetpointRamp::default(),
            mode: Mode::Idle,
            steps: 0,
            schedule: Schedule::default(),
            job_due: false,
            job_elapsed_periods: 0,
            outcome_in_telemetry: false,
            outcome_ready: false,
            epoch: 0,
            reference_restart: ReferenceRestart::None,
            reference_afresh: true,
            restart_limiter_from: None,
            velocity: VelocitySource::new(params.config().velocity),
            telemetry: Telemetry {
                pose: odometry.pose(),
                rim_speed_cap_m_s: params.config().limits.max_rim_speed_m_s,
                ..Telemetry::default()
            },
            odometry,
            params,
        }
    }

    /// Rebuilds the controller in place as [`Controller::new`] would with `params` and
    /// `law`, keeping its pose (odometry rebuilt for the new geometry at the pose it
    /// holds) and its reference as they are: where the robot is and how far along the path
    /// it was do not change with the parameters. Unlike assigning a new controller, it
    /// moves no whole controller through the stack: it is meant for small stacks (an
    /// interrupt installing a new configuration). The gyro takes the new parameters'
    /// configuration and keeps its bias estimate, which is the sensor's. Refused, with
    /// nothing changed, while the outer loop is lent.
    pub fn rebuild(&mut self, params: &Params, law: LawKind) -> Result<(), OuterLoopAway> {
        self.outer_loop_for_a_change()?.restart(params, law);
        self.params = *params;
        let pose = self.odometry.pose();
        self.odometry = Odometry::new(params.geometry(), params.ticks_per_wheel_rev(), pose);
        self.fusion.set_config(params.config().gyro);
        self.fusion
            .restart(params.period_s(), self.odometry.heading());
        self.restart_from_params();
        Ok(())
    }

    /// Rebuilds the controller in place as [`Controller::new`] would with its parameters,
    /// a copy of `reference` and `law`, keeping its odometry as it is (a new path does
    /// not move the robot; the pose command does, [`Controller::set_pose`]): the next
    /// entry into path following starts the new reference afresh. See
    /// [`Controller::rebuild`].
    pub fn follow(&mut self, reference: &Reference, law: LawKind) -> Result<(), OuterLoopAway> {
        self.outer_loop_for_a_change()?.follow(reference);
        if let Some(steering) = self.steering.held_mut() {
            steering.restart(&self.params, law);
        }
        self.restart_from_params();
        // A new path owes its reference nothing.
        self.schedule.since_sample = 0;
        self.reference_restart = ReferenceRestart::None;
        self.reference_afresh = true;
        Ok(())
    }

    /// Everything but the parameters, the odometry, the outer loop and where the
    /// reference is in its run (how the next entry into path following meets it, and
    /// the periods since it was last sampled) as [`Controller::new`] builds it.
    fn restart_from_params(&mut self) {
        let params = &self.params;
        let steps_per_s = params.control_rate().get() as f32;
        let window = params.config().speed_window_steps as usize;
        for speed in &mut self.speed {
            speed.reconfigure(window, params.rad_per_tick(), steps_per_s);
        }
        self.drive = WheelDrive::new(params);
        self.supply =
            SupplyFilter::new(params.config().drive.supply_filter_tau_s, params.period_s());
        self.telemetry = Telemetry {
            pose: self.odometry.pose(),
            rim_speed_cap_m_s: params.config().limits.max_rim_speed_m_s,
            ..Telemetry::default()
        };
        self.ramp = SetpointRamp::default();
        self.velocity = VelocitySource::new(params.config().velocity);
        self.mode = Mode::Idle;
        self.steps = 0;
        self.schedule = Schedule {
            since_sample: self.schedule.since_sample,
            ..Schedule::default()
        };
        // No job is out: rebuilding needs the outer loop held.
        self.job_due = false;
        self.job_elapsed_periods = 0;
        self.outcome_in_telemetry = false;
        self.outcome_ready = false;
        self.epoch = 0;
        self.restart_limiter_from = None;
    }

    /// The parameters in use.
    pub const fn params(&self) -> &Params {
        &self.params
    }

    /// The current mode.
    pub const fn mode(&self) -> Mode {
        self.mode
    }

    /// The outer loop, unless it is lent.
    pub fn steering(&self) -> Option<&OuterLoop> {
        self.steering.held()
    }

    /// Where the outer loop is.
    pub const fn holder(&self) -> &S {
        &self.steering
    }

    /// Where the outer loop is: to lend it and to take it back.
    pub fn holder_mut(&mut self) -> &mut S {
        &mut self.steering
    }

    /// Lends the outer loop out with the job the last step handed over, when its holder
    /// lends it (see [`crate::outer_loop`]); true if it did. Call it after the step.
    pub fn lend_steering(&mut self) -> bool {
        if !self.job_due {
            return false;
        }
        let job = self.steering_job();
        if !self.steering.lend(&job) {
            return false;
        }
        self.job_taken();
        true
    }

    /// Takes a lent outer loop back if it has come back; its outcome is applied at the
    /// next step, unless the loops restarted since its job (a mode change, cleared
    /// faults: then it is stale and dropped). Call it before the step. False when the
    /// outer loop is still away.
    pub fn collect_steering(&mut self) -> bool {
        let came_back = self.steering.collect();
        let held = self.steering.held();
        if came_back {
            self.outcome_ready = held.is_some_and(|s| s.outcome().epoch == self.epoch);
        }
        held.is_some()
    }

    /// Odometry pose estimate, world frame.
    pub fn pose(&self) -> Pose {
        self.odometry.pose()
    }

    /// Latched faults.
    pub const fn faults(&self) -> ControllerFaults {
        self.telemetry.faults
    }

    /// The telemetry of the last step.
    pub const fn telemetry(&self) -> &Telemetry {
        &self.telemetry
    }

    /// Each wheel PID's last output split into P, I, D and FF, V, [left, right] (see
    /// [`crate::pid`] for how the parts of a velocity-form PID are defined).
    pub fn wheel_pid_parts(&self) -> [PidParts; 2] {
        self.drive.pid_parts()
    }

    /// Switches mode. Entering [`Mode::FollowPath`] resumes the reference where the last
    /// path following left it (a time-indexed reference's clock paused meanwhile; path
    /// following projects the robot again), or starts it afresh after a new controller, a
    /// new path ([`Controller::follow`]) or a pose command ([`Controller::set_pose`]);
    /// any change restarts the wheel loops and the ramp from the measured state, so the
    /// command does not jump.
    pub fn set_mode(&mut self, mode: Mode) {
        if mode == self.mode {
            return;
        }
        // New voltages for an open-loop run are not a new mode: nothing to restart.
        if let (Mode::ApplyVolts(_), Mode::ApplyVolts(_)) = (self.mode, mode) {
            self.mode = mode;
            return;
        }
        // A due job runs with the restarts it was due with, not this one's.
        self.run_due_job_aside();
        // The schedule and the reference only move in path following. A resumed
        // reference is owed the periods it was followed for after its last sample: the
        // first job hands them over, so its clock resumes where it stopped.
        if mode == Mode::FollowPath {
            let (restart, owed) = if self.reference_afresh {
                (ReferenceRestart::Afresh, 0)
            } else {
                (ReferenceRestart::Resume, self.schedule.since_sample)
            };
            self.schedule = Schedule {
                since_sample: owed,
                ..Schedule::default()
            };
            // Two entries before a job meet the reference as the larger restart.
            self.reference_restart = self.reference_restart.max(restart);
            self.reference_afresh = false;
        }
        let was_driving = self.mode != Mode::Idle;
        self.mode = mode;
        self.restart_loops(was_driving);
    }

    /// Selects another steering law (takes effect at the next steering step). Refused
    /// while the outer loop is lent.
    pub fn set_law(&mut self, law: LawKind) -> Result<(), OuterLoopAway> {
        self.outer_loop_for_a_change()?.set_law(law);
        Ok(())
    }

    /// The pose command: the robot is at `pose` (world frame, the path's). Everything
    /// that estimates the pose is set to it: the odometry's position and its fixed-point
    /// heading (a heading fused from a gyro would be set here too, but not the gyro's
    /// bias, which belongs to the sensor and not to where the robot stands). The next
    /// entry into path following starts the reference afresh: a robot put down somewhere
    /// starts its path over. A due steering job keeps the pose it was due with.
    pub fn set_pose(&mut self, pose: Pose) {
        self.run_due_job_aside();
        self.odometry.set_pose(pose);
        self.fusion.set_heading(self.odometry.heading());
        self.telemetry.pose = self.odometry.pose();
        self.reference_afresh = true;
    }

    /// The fused heading, world frame, wrapped to (−π, π], rad (odometry's while no gyro
    /// has read).
    pub fn fused_heading_rad(&self) -> f32 {
        self.fusion.fused_heading_rad()
    }

    /// The heading from the encoders alone, world frame, wrapped to (−π, π], rad.
    pub fn odometry_heading_rad(&self) -> f32 {
        self.fusion.odometry_heading_rad()
    }

    /// Starts the odometry's heading recomputation afresh ([`Odometry::resync_heading`]),
    /// the pose unchanged: a run's estimate then does not depend on how long the robot
    /// stood before it was armed. A due steering job keeps the pose it was due with.
    pub fn resync_heading(&mut self) {
        self.run_due_job_aside();
        self.odometry.resync_heading();
    }

    /// Asserts that the robot is moving at `body` (v m/s, ω rad/s, robot frame) although
    /// the controller has not seen it: the speed estimates are filled with the encoder
    /// ticks that motion would have produced. For a run that starts in motion (the
    /// paper's experiments); call it before entering a driving mode, whose loops then
    /// start from that motion.
    pub fn seed_motion(&mut self, body: BodyVelocity) {
        let wheels = self.params.geometry().inverse(body);
        self.speed[0].seed(wheels.left_rad_s);
        self.speed[1].seed(wheels.right_rad_s);
        self.telemetry.wheel_speed =
            WheelSpeeds::new(self.speed[0].speed_rad_s(), self.speed[1].speed_rad_s());
    }

    /// Clears latched faults. Speed history is dropped and the loops restart from rest.
    pub fn clear_faults(&mut self) {
        self.telemetry.faults = ControllerFaults::default();
        self.fusion.clear_failure();
        for estimator in &mut self.speed {
            estimator.reset();
        }
        self.telemetry.wheel_speed = WheelSpeeds::default();
        self.restart_loops(false);
    }

    /// Restarts the ramp and the wheel loops from the measured state; `was_driving` keeps
    /// each wheel's applied voltage (a switch between driving modes).
    fn restart_loops(&mut self, was_driving: bool) {
        // A command computed before the restart is stale, and so is one still running
        // (its job runs all the same, as a lent one would have: see `run_due_job_aside`).
        self.run_due_job_aside();
        self.job_due = false;
        self.outcome_ready = false;
        self.epoch = self.epoch.wrapping_add(1);
        let measured = self.telemetry.wheel_speed;
        let measured_body = self.params.geometry().forward(measured);
        self.restart_limiter_from = Some(measured_body);
        // The velocity mode starts from the measured motion with no command in force.
        self.velocity.restart(measured_body);
        self.telemetry.wheel_setpoint = match self.mode {
            Mode::HoldWheelSpeeds(speeds) => self.capped_wheel_speeds(speeds),
            // Until the first steering step, hold the wheels where they are; the velocity
            // source's first step moves on from there.
            Mode::FollowPath | Mode::FollowVelocity => measured,
            Mode::Idle | Mode::ApplyVolts(_) => WheelSpeeds::default(),
        };
        // The ramp holds the set-points at its target until the first steering outcome
        // starts a new one, a step after path following starts.
        self.ramp = SetpointRamp {
            target: self.telemetry.wheel_setpoint,
            ..SetpointRamp::default()
        };
        self.drive
            .restart(self.telemetry.wheel_setpoint, measured, was_driving);
    }

    /// The rim-speed cap on the present supply: the configured cap, or less if the motors
    /// cannot reach it (m/s). Before the first supply measurement, the configured cap (no
    /// voltage reaches the motors then anyway).
    fn rim_speed_cap_m_s(&self) -> f32 {
        let configured = self.params.config().limits.max_rim_speed_m_s;
        if self.telemetry.supply_v <= 0.0 {
            return configured;
        }
        let reachable = self.params.geometry().min_wheel_radius_m()
            * self.drive.top_speed_rad_s(self.telemetry.supply_v);
        if reachable < configured {
            reachable
        } else {
            configured
        }
    }

    /// Clamps each wheel to the rim-speed cap.
    fn capped_wheel_speeds(&self, speeds: WheelSpeeds) -> WheelSpeeds {
        let max = self.rim_speed_cap_m_s() / self.params.geometry().min_wheel_radius_m();
        WheelSpeeds::new(
            math::clamp(speeds.left_rad_s, -max, max),
            math::clamp(speeds.right_rad_s, -max, max),
        )
    }

    /// One control step (see the module doc). Returns the duties to apply (in [−1, 1], 0
    /// on any fault). What the step computed is in [`Controller::telemetry`], borrowed
    /// rather than copied out (on a Cortex-M4F the copy cost more than the wheel loop's
    /// arithmetic).
    pub fn step(&mut self, input: StepInput) -> MotorCommand {
        let periods = input.periods;
        let ticks = input.ticks;
        // Telemetry is updated in place: it is the state carried between steps, and copying
        // it costs more than the arithmetic on a Cortex-M4F.
        self.telemetry.step = self.steps;
        self.telemetry.periods = periods.get();
        self.telemetry.steering_updated = false;
        // Before anything of this step overwrites the last one's state: the outer loop's
        // outcome of the job that step handed over goes into telemetry.
        self.outcome_in_telemetry = self.steering_outcome_into_telemetry();
        self.telemetry.supply_v = self.supply.update(input.supply_v);

        // A delta beyond what the fastest plausible wheel turns in the elapsed time.
        let limit = self
            .params
            .max_ticks_per_step()
            .unsigned_abs()
            .saturating_mul(periods.get());
        if ticks.left.unsigned_abs() > limit || ticks.right.unsigned_abs() > limit {
            self.telemetry.faults.encoder_jump = true;
        }

        if !self.telemetry.faults.any() {
            let odometry_turn = self.odometry.turn_of(ticks.left, ticks.right);
            self.telemetry.pose = self.odometry.update(ticks.left, ticks.right);
            let fused_turn =
                self.fusion
                    .step(input.gyro, odometry_turn, periods.get(), input.still);
            if self.fusion.steers() {
                self.telemetry.pose = self.odometry.turn_heading(fused_turn.minus(odometry_turn));
            }
            self.telemetry.gyro = *self.fusion.report();
            self.telemetry.wheel_speed = WheelSpeeds::new(
                self.speed[0].update(ticks.left, periods),
                self.speed[1].update(ticks.right, periods),
            );
            match self.mode {
                Mode::FollowPath => self.follow_path(periods),
                Mode::FollowVelocity => self.follow_velocity(periods),
                Mode::HoldWheelSpeeds(speeds) => {
                    self.telemetry.wheel_setpoint = self.capped_wheel_speeds(speeds);
                }
                Mode::Idle | Mode::ApplyVolts(_) => {
                    self.telemetry.wheel_setpoint = WheelSpeeds::default();
                }
            }
            let t = &mut self.telemetry;
            match self.mode {
                Mode::Idle => {
                    self.drive.stop();
                    t.wheel_loop = WheelLoopReport::default();
                    t.duty = MotorCommand::STOP;
                }
                Mode::ApplyVolts(volts) => {
                    t.duty =
                        self.drive
                            .apply_volts(volts, t.wheel_speed, t.supply_v, &mut t.wheel_loop);
                }
                Mode::FollowPath | Mode::FollowVelocity | Mode::HoldWheelSpeeds(_) => {
                    t.duty = self.drive.step(
                        t.wheel_setpoint,
                        t.wheel_speed,
                        t.supply_v,
                        periods.get() as f32,
                        &mut t.wheel_loop,
                    );
                }
            }
            // One check for all: NaN and ±∞ propagate through a sum (∞ − ∞ is NaN), and a
            // sum that overflows comes from values no robot has.
            let sum = t.pose.x_m
                + t.pose.y_m
                + t.pose.theta_rad
                + t.duty.left
                + t.duty.right
                + t.wheel_setpoint.left_rad_s
                + t.wheel_setpoint.right_rad_s;
            if !sum.is_finite() {
                t.faults.non_finite = true;
            }
        }
        if self.telemetry.faults.any() {
            self.drive.stop();
            self.telemetry.duty = MotorCommand::STOP;
            self.telemetry.wheel_setpoint = WheelSpeeds::default();
        }

        self.steps = self.steps.wrapping_add(1);
        self.telemetry.duty
    }

    /// The inner loop's part of one path-following step: apply the steering outcome
    /// handed over since the last step, hand over a job when the law is due, and move the
    /// wheel set-points along the ramp.
    fn follow_path(&mut self, periods: NonZeroU32) {
        if self.outcome_in_telemetry {
            self.start_ramp();
        }
        let s = &mut self.schedule;
        if s.started {
            s.since_sample = s.since_sample.saturating_add(periods.get());
            s.until_steering = s.until_steering.saturating_sub(periods.get());
        }
        s.started = true;
        if s.until_steering == 0 {
            let elapsed_periods = s.since_sample;
            s.since_sample = 0;
            s.until_steering = self.params.steering_divider().get();
            self.job_elapsed_periods = elapsed_periods;
            self.job_due = true;
        }
        self.ramp
            .advance(periods.get(), &mut self.telemetry.wheel_setpoint);
    }

    /// The inner loop's part of one velocity-mode step: the velocity source's limited
    /// command (after the rim-speed cap) as this step's body command and wheel
    /// set-points. In telemetry, `law.command` is the command in force (before the
    /// limits) and `command` the limited one.
    fn follow_velocity(&mut self, periods: NonZeroU32) {
        let cap = self.rim_speed_cap_m_s();
        let t = &mut self.telemetry;
        t.law.command = self.velocity.in_force();
        (t.command, t.limit_flags) = self.velocity.step(
            periods.get(),
            self.params.period_s(),
            self.params.geometry().track_width_m(),
            cap,
        );
        t.rim_speed_cap_m_s = cap;
        t.wheel_setpoint = self.params.geometry().inverse(t.command);
    }

    /// A body-velocity command (v m/s, ω rad/s, robot frame) for [`Mode::FollowVelocity`]:
    /// in force from this step on, for the velocity mode's timeout (see
    /// [`crate::velocity`]). In other modes it is kept but unused: entering the velocity
    /// mode starts with no command in force.
    pub fn command_velocity(&mut self, command: BodyVelocity) {
        self.velocity.command(command);
    }

    /// The velocity mode's command source: the command in force and the limited command.
    pub const fn velocity_source(&self) -> &VelocitySource {
        &self.velocity
    }

    /// The steering law's job, from the state of the step where it was due (still in
    /// place until the next step begins: nothing else moves the pose, the heading or the
    /// supply, and what could change the job first runs it, see
    /// [`Controller::run_due_job_aside`]).
    fn steering_job(&self) -> OuterLoopJob {
        OuterLoopJob {
            pose: self.telemetry.pose,
            heading_sin_cos: self.odometry.heading_sin_cos(),
            elapsed_periods: self.job_elapsed_periods,
            rim_speed_cap_m_s: self.rim_speed_cap_m_s(),
            reference_restart: self.reference_restart,
            restart_limiter_from: self.restart_limiter_from,
            epoch: self.epoch,
        }
    }

    /// The outer loop, to change it: refused while it is lent; a due job runs first, on
    /// the outer loop as it was (see [`Controller::run_due_job_aside`]).
    fn outer_loop_for_a_change(&mut self) -> Result<&mut OuterLoop, OuterLoopAway> {
        self.steering.held().ok_or(OuterLoopAway)?;
        self.run_due_job_aside();
        self.steering.held_mut().ok_or(OuterLoopAway)
    }

    /// The due job went to the outer loop, with the restarts it carried.
    fn job_taken(&mut self) {
        self.job_due = false;
        self.reference_restart = ReferenceRestart::None;
        self.restart_limiter_from = None;
    }

    /// At the start of a step: the outcome of the last step's job into telemetry, run
    /// here directly into it when this controller runs its jobs, or as a lent outer loop
    /// came back with it. True if there was one.
    fn steering_outcome_into_telemetry(&mut self) -> bool {
        if self.job_due && self.steering.runs_jobs() {
            let job = self.steering_job();
            if let Some(steering) = self.steering.held_mut() {
                let t = &mut self.telemetry;
                steering.run_into(
                    &job,
                    (&mut t.reference, &mut t.error, &mut t.law),
                    (&mut t.command, &mut t.limit_flags),
                );
                t.rim_speed_cap_m_s = job.rim_speed_cap_m_s;
                self.job_taken();
                return true;
            }
        }
        if self.outcome_ready {
            self.outcome_ready = false;
            self.apply_steering();
            return true;
        }
        false
    }

    /// The outcome a lent outer loop came back with (or one run aside), one step after its
    /// job: from the outer loop into telemetry (back, or it ran aside, before
    /// this step).
    fn apply_steering(&mut self) {
        let Some(outcome) = self.steering.held().map(OuterLoop::outcome) else {
            return;
        };
        let t = &mut self.telemetry;
        t.rim_speed_cap_m_s = outcome.rim_speed_cap_m_s;
        t.reference = outcome.reference;
        t.error = outcome.error;
        t.law = outcome.law;
        t.command = outcome.command;
        t.limit_flags = outcome.limit_flags;
    }

    /// A steering outcome is in telemetry: a new set-point ramp from where the set-points
    /// are to its command's wheel speeds, over one steering period.
    fn start_ramp(&mut self) {
        let t = &mut self.telemetry;
        t.steering_updated = true;
        self.ramp.start(
            t.wheel_setpoint,
            self.params.geometry().inverse(t.command),
            self.params.steering_divider(),
        );
    }

    /// Runs a due job that this controller would run at the next step now, into the
    /// hand-over slot, before something changes what it would read (the pose, the law,
    /// the parameters) or the loops restart: as a lent outer loop would have run it in
    /// between. Its outcome is applied at the next step as a lent one's is, unless a
    /// restart drops it.
    fn run_due_job_aside(&mut self) {
        if !(self.job_due && self.steering.runs_jobs()) {
            return;
        }
        let job = self.steering_job();
        if let Some(steering) = self.steering.held_mut() {
            steering.run(&job);
            self.job_taken();
            self.outcome_ready = true;
        }
    }
}

/// Wheel set-points moved in equal steps, once per control period, from where they are
/// to a target over one steering period (instead of jumping at each steering update).
#[derive(Clone, Copy, Debug, Default)]
struct SetpointRamp {
    target: WheelSpeeds,
    /// Change per control period, rad/s.
    per_period: WheelSpeeds,
    /// Control periods until the target is reached.
    periods_left: u32,
}

impl SetpointRamp {
    /// A ramp from `from` to `to` (rad/s) over `periods` control periods.
    fn start(&mut self, from: WheelSpeeds, to: WheelSpeeds, periods: NonZeroU32) {
        let per = 1.0 / periods.get() as f32;
        self.target = to;
        self.per_period = WheelSpeeds::new(
            (to.left_rad_s - from.left_rad_s) * per,
            (to.right_rad_s - from.right_rad_s) * per,
        );
        self.periods_left = periods.get();
    }

    /// Moves `setpoint` on by `periods` control periods (to the target exactly at the
    /// end; it stays there until the next [`SetpointRamp::start`]).
    fn advance(&mut self, periods: u32, setpoint: &mut WheelSpeeds) {
        if periods >= self.periods_left {
            self.periods_left = 0;
            *setpoint = self.target;
        } else {
            self.periods_left -= periods;
            let n = periods as f32;
            setpoint.left_rad_s += self.per_period.left_rad_s * n;
            setpoint.right_rad_s += self.per_period.right_rad_s * n;
        }
    }
}

#[cfg(test)]
pub(crate) mod tests;
