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
use crate::kinematics::{BodyVelocity, Pose, TrackingError, WheelSpeeds};
use crate::law::{LawKind, LawOutput};
use crate::limits::LimitFlags;
use crate::math;
use crate::odometry::Odometry;
use crate::outer_loop::{OuterLoop, OuterLoopAway, OuterLoopHolder, OuterLoopJob};
use crate::params::Params;
use crate::pid::PidParts;
use crate::reference::{Reference, ReferenceState};

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
}

impl StepInput {
    /// A step on time (one period) with `ticks` and a supply of `supply_v` (V).
    pub const fn on_time(ticks: TickDeltas, supply_v: f32) -> Self {
        Self {
            ticks,
            periods: NonZeroU32::MIN,
            supply_v,
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
    /// Path following restarted: the next job restarts the reference.
    restart_reference: bool,
    /// The wheel loops restarted at this body velocity: the next job restarts the
    /// command limiter from it.
    restart_limiter_from: Option<BodyVelocity>,
    speed: [SpeedEstimator; 2],
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
        Self::with_seat(params, steering, start)
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
    pub fn with_seat(params: Params, steering: S, start: Pose) -> Self {
        let steps_per_s = params.control_rate().get() as f32;
        let window = params.config().speed_window_steps as usize;
        let estimator = SpeedEstimator::new(window, params.rad_per_tick(), steps_per_s);
        Self {
            odometry: Odometry::new(params.geometry(), params.ticks_per_wheel_rev(), start),
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
            restart_reference: false,
            restart_limiter_from: None,
            telemetry: Telemetry {
                pose: start,
                rim_speed_cap_m_s: params.config().limits.max_rim_speed_m_s,
                ..Telemetry::default()
            },
            params,
        }
    }

    /// Rebuilds the controller in place as [`Controller::new`] would with `params`, `law`
    /// and `start` (world frame), keeping its reference as it is. Unlike assigning a new
    /// controller, it moves no whole controller through the stack: it is meant for small
    /// stacks (an interrupt installing a new configuration). Refused, with nothing
    /// changed, while the outer loop is lent.
    pub fn rebuild(
        &mut self,
        params: &Params,
        law: LawKind,
        start: Pose,
    ) -> Result<(), OuterLoopAway> {
        self.outer_loop_for_a_change()?.restart(params, law);
        self.params = *params;
        self.restart_from_params(start);
        Ok(())
    }

    /// Rebuilds the controller in place as [`Controller::new`] would with its parameters,
    /// a copy of `reference`, `law` and `start` (world frame); see [`Controller::rebuild`].
    pub fn follow(
        &mut self,
        reference: &Reference,
        law: LawKind,
        start: Pose,
    ) -> Result<(), OuterLoopAway> {
        self.outer_loop_for_a_change()?.follow(reference);
        if let Some(steering) = self.steering.seated_mut() {
            steering.restart(&self.params, law);
        }
        self.restart_from_params(start);
        Ok(())
    }

    /// Everything but the parameters and the outer loop as [`Controller::new`] builds it.
    fn restart_from_params(&mut self, start: Pose) {
        let params = &self.params;
        let steps_per_s = params.control_rate().get() as f32;
        let window = params.config().speed_window_steps as usize;
        for speed in &mut self.speed {
            speed.reconfigure(window, params.rad_per_tick(), steps_per_s);
        }
        self.odometry = Odometry::new(params.geometry(), params.ticks_per_wheel_rev(), start);
        self.drive = WheelDrive::new(params);
        self.supply =
            SupplyFilter::new(params.config().drive.supply_filter_tau_s, params.period_s());
        self.telemetry = Telemetry {
            pose: start,
            rim_speed_cap_m_s: params.config().limits.max_rim_speed_m_s,
            ..Telemetry::default()
        };
        self.ramp = SetpointRamp::default();
        self.mode = Mode::Idle;
        self.steps = 0;
        self.schedule = Schedule::default();
        // No job is out: rebuilding needs the outer loop seated.
        self.job_due = false;
        self.job_elapsed_periods = 0;
        self.outcome_in_telemetry = false;
        self.outcome_ready = false;
        self.epoch = 0;
        self.restart_reference = false;
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
        self.steering.seated()
    }

    /// Where the outer loop is.
    pub const fn seat(&self) -> &S {
        &self.steering
    }

    /// Where the outer loop is: to lend it and to seat it again.
    pub fn holder_mut(&mut self) -> &mut S {
        &mut self.steering
    }

    /// Lends the outer loop out with the job the last step handed over, when its seat
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

    /// Seats a lent outer loop again if it has come back; its outcome is applied at the
    /// next step, unless the loops restarted since its job (a mode change, cleared
    /// faults: then it is stale and dropped). Call it before the step. False when the
    /// outer loop is still away.
    pub fn collect_steering(&mut self) -> bool {
        let came_back = self.steering.collect();
        let seated = self.steering.seated();
        if came_back {
            self.outcome_ready = seated.is_some_and(|s| s.outcome().epoch == self.epoch);
        }
        seated.is_some()
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

    /// Switches mode. Entering [`Mode::FollowPath`] restarts the reference's time index
    /// and progress; any change restarts the wheel loops and the ramp from the measured
    /// state, so the command does not jump.
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
        // The schedule and the reference only move in path following, so restarting them
        // on entering every other mode instead (`!=`) would restart them before each use
        // all the same: an equivalent mutant (.cargo/mutants.toml).
        if mode == Mode::FollowPath {
            self.schedule = Schedule::default();
            self.restart_reference = true;
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

    /// Overwrites the odometry pose (world frame), e.g. from an external fix. A due
    /// steering job keeps the pose it was due with.
    pub fn set_pose(&mut self, pose: Pose) {
        self.run_due_job_aside();
        self.odometry.set_pose(pose);
        self.telemetry.pose = self.odometry.pose();
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
        self.restart_limiter_from = Some(self.params.geometry().forward(measured));
        self.telemetry.wheel_setpoint = match self.mode {
            Mode::HoldWheelSpeeds(speeds) => self.capped_wheel_speeds(speeds),
            // Until the first steering step, hold the wheels where they are.
            Mode::FollowPath => measured,
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
        // Equal values give the same cap either way (`<=` is an equivalent mutant).
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
            self.telemetry.pose = self.odometry.update(ticks.left, ticks.right);
            self.telemetry.wheel_speed = WheelSpeeds::new(
                self.speed[0].update(ticks.left, periods),
                self.speed[1].update(ticks.right, periods),
            );
            match self.mode {
                Mode::FollowPath => self.follow_path(periods),
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
                Mode::FollowPath | Mode::HoldWheelSpeeds(_) => {
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
            // sum that overflows comes from values no robot has. `-` or `*` for any `+`
            // keeps that (∞ − ∞ and ∞ · 0 are NaN too) and differs only when finite values
            // overflow: equivalent mutants (.cargo/mutants.toml).
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
            restart_reference: self.restart_reference,
            restart_limiter_from: self.restart_limiter_from,
            epoch: self.epoch,
        }
    }

    /// The outer loop, to change it: refused while it is lent; a due job runs first, on
    /// the outer loop as it was (see [`Controller::run_due_job_aside`]).
    fn outer_loop_for_a_change(&mut self) -> Result<&mut OuterLoop, OuterLoopAway> {
        self.steering.seated().ok_or(OuterLoopAway)?;
        self.run_due_job_aside();
        self.steering.seated_mut().ok_or(OuterLoopAway)
    }

    /// The due job went to the outer loop, with the restarts it carried.
    fn job_taken(&mut self) {
        self.job_due = false;
        self.restart_reference = false;
        self.restart_limiter_from = None;
    }

    /// At the start of a step: the outcome of the last step's job into telemetry, run
    /// here directly into it when this controller runs its jobs, or as a lent outer loop
    /// came back with it. True if there was one.
    fn steering_outcome_into_telemetry(&mut self) -> bool {
        if self.job_due && self.steering.runs_jobs() {
            let job = self.steering_job();
            if let Some(steering) = self.steering.seated_mut() {
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
    /// job: from the outer loop into telemetry (seated again, or it ran aside, before
    /// this step).
    fn apply_steering(&mut self) {
        let Some(outcome) = self.steering.seated().map(OuterLoop::outcome) else {
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
        if let Some(steering) = self.steering.seated_mut() {
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
pub(crate) mod tests {
    use super::*;
    use crate::kinematics::Point;
    use crate::params::RobotConfig;
    use crate::path::Path;
    use crate::reference::ReferenceMode;
    use proptest::prelude::*;

    /// The reference robot with the tracking law on a line along +x of `length_m` (m),
    /// reference at 0.2 m/s, believing it starts at the origin. Shared with the
    /// supervisor's tests.
    pub(crate) fn on_a_line(length_m: f32) -> Controller {
        on_a_line_from(Point::new(0.0, 0.0), length_m)
    }

    /// As [`on_a_line`], with the line and the robot's belief starting at `start` (world
    /// frame, m) instead of the origin.
    pub(crate) fn on_a_line_from(start: Point, length_m: f32) -> Controller {
        let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
        let path = Path::line(start, 0.0, length_m).unwrap();
        let reference = Reference::new(
            path,
            0.2,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap();
        let pose = Pose::new(start.x_m, start.y_m, 0.0);
        Controller::new(params, reference, LawKind::Tracking, pose)
    }

    fn controller() -> Controller {
        on_a_line(5.0)
    }

    /// The supply the tests run on, V.
    const SUPPLY_V: f32 = 6.0;

    /// One on-time step with `ticks` on the test supply.
    fn step<S: OuterLoopHolder>(c: &mut Controller<S>, ticks: TickDeltas) -> MotorCommand {
        c.step(StepInput::on_time(ticks, SUPPLY_V))
    }

    fn ticks(left: i32, right: i32) -> TickDeltas {
        TickDeltas { left, right }
    }

    /// A controller that has driven for a while, then is rebuilt in place, is the one
    /// `Controller::new` builds (every field, as `Debug` shows them).
    #[test]
    fn rebuilding_in_place_equals_building_anew() {
        let mut params_config = RobotConfig::REFERENCE_ROBOT;
        params_config.wheel_radius_left_m *= 1.01;
        params_config.speed_window_steps = 12;
        let other_params = Params::new(params_config).unwrap();
        let other_path = Path::line(Point::new(1.0, 2.0), 0.5, 3.0).unwrap();
        let mut other_reference = Reference::new(
            other_path,
            0.3,
            ReferenceMode::PathFollowing { lookahead_m: 0.1 },
        )
        .unwrap();
        let start = Pose::new(0.5, -0.25, 1.0);
        let _ = other_reference.sample(0, NonZeroU32::MIN, &start);
        let driven = || {
            let mut c = controller();
            c.set_mode(Mode::FollowPath);
            for k in 0..40 {
                step(&mut c, ticks(k % 3, 2));
            }
            c
        };

        let mut rebuilt = driven();
        let reference = rebuilt.reference().clone();
        rebuilt
            .rebuild(&other_params, LawKind::Kanayama, start)
            .expect("owned outer loop");
        let fresh = Controller::new(other_params, reference, LawKind::Kanayama, start);
        assert_eq!(format!("{rebuilt:?}"), format!("{fresh:?}"));

        let mut followed = driven();
        followed
            .follow(&other_reference, LawKind::Kanayama, start)
            .expect("owned outer loop");
        let fresh = Controller::new(
            *controller().params(),
            other_reference.clone(),
            LawKind::Kanayama,
            start,
        );
        assert_eq!(format!("{followed:?}"), format!("{fresh:?}"));
        assert_ne!(format!("{followed:?}"), format!("{:?}", driven()));
    }

    #[test]
    fn idle_commands_nothing() {
        let mut c = controller();
        for _ in 0..100 {
            assert_eq!(step(&mut c, ticks(1, 1)), MotorCommand::STOP);
        }
        // Odometry still runs while idle.
        assert!(c.pose().x_m > 0.0);
    }

    #[test]
    fn follow_path_drives_forward() {
        let mut c = controller();
        c.set_mode(Mode::FollowPath);
        // The first step hands the law its job and holds the wheels where they are (at
        // rest); the next one applies the law's command.
        let duty = step(&mut c, ticks(0, 0));
        assert!(!c.telemetry().steering_updated);
        assert_eq!(c.telemetry().wheel_setpoint, WheelSpeeds::default());
        assert_eq!(duty, MotorCommand::STOP);
        let duty = step(&mut c, ticks(0, 0));
        assert!(c.telemetry().steering_updated);
        assert!(duty.left > 0.0 && duty.right > 0.0);
        assert!(!c.faults().any());
        // The steering law runs every `steering_divider` (10) steps, the PIDs every step.
        let pattern: Vec<bool> = (1..=20)
            .map(|_| {
                step(&mut c, ticks(0, 0));
                c.telemetry().steering_updated
            })
            .collect();
        let expected: Vec<bool> = (1..=20).map(|k| k % 10 == 0).collect();
        assert_eq!(pattern, expected);
    }

    #[test]
    fn the_steering_outcome_of_a_step_is_applied_at_the_next() {
        // The law's job carries this step's pose; its outcome, applied one step later, is
        // exactly what the outer loop computes from that job.
        let mut c = on_a_line(5.0);
        c.set_pose(Pose::new(0.0, 0.05, 0.1));
        c.set_mode(Mode::FollowPath);
        let mut outer = OuterLoop::new(c.params(), c.reference().clone(), c.law());
        step(&mut c, ticks(3, 5));
        let job = OuterLoopJob {
            pose: c.pose(),
            heading_sin_cos: c.odometry.heading_sin_cos(),
            elapsed_periods: 0,
            // 0.85 · 6 V → 30.4 rad/s → 0.987 m/s (see the weak-supply test).
            rim_speed_cap_m_s: 0.987_420_4,
            restart_reference: true,
            restart_limiter_from: Some(BodyVelocity::new(0.0, 0.0)),
            epoch: c.epoch,
        };
        assert_eq!(c.steering_job(), job);
        outer.run(&job);
        let expected = *outer.outcome();
        assert_eq!(expected.epoch, job.epoch);
        let setpoint_before = c.telemetry().wheel_setpoint;
        step(&mut c, ticks(4, 4));
        let t = c.telemetry();
        assert!(t.steering_updated);
        assert_eq!(t.command, expected.command);
        assert_eq!(t.error, expected.error);
        assert_eq!(t.reference, expected.reference);
        // The ramp starts at this step, one tenth of the way to the command's wheels.
        let target = c.params().geometry().inverse(expected.command);
        let tenth =
            setpoint_before.left_rad_s + (target.left_rad_s - setpoint_before.left_rad_s) / 10.0;
        assert!((t.wheel_setpoint.left_rad_s - tenth).abs() < 1e-5, "{t:?}");
    }

    /// A seat that lends its outer loop, and runs what it lent when the test says so (as
    /// the firmware's lower-priority task does).
    #[derive(Clone, Debug)]
    struct Lending {
        home: Option<OuterLoop>,
        /// Lent: the outer loop, its job, and whether it ran.
        away: Option<(OuterLoop, OuterLoopJob, bool)>,
    }

    impl Lending {
        /// Runs the lent job.
        fn run_away(&mut self) {
            let (steering, job, ran) = self.away.as_mut().expect("lent");
            steering.run(job);
            *ran = true;
        }
    }

    impl OuterLoopHolder for Lending {
        fn seated(&self) -> Option<&OuterLoop> {
            self.home.as_ref()
        }

        fn seated_mut(&mut self) -> Option<&mut OuterLoop> {
            self.home.as_mut()
        }

        fn runs_jobs(&self) -> bool {
            false
        }

        fn lend(&mut self, job: &OuterLoopJob) -> bool {
            let Some(steering) = self.home.take() else {
                return false;
            };
            self.away = Some((steering, *job, false));
            true
        }

        fn collect(&mut self) -> bool {
            match self.away.take() {
                Some((steering, _, true)) => {
                    self.home = Some(steering);
                    true
                }
                still_away => {
                    self.away = still_away;
                    false
                }
            }
        }
    }

    /// `owned` as it was built, with a lending seat.
    fn lending(owned: &Controller) -> Controller<Lending> {
        let steering = OuterLoop::new(owned.params(), owned.reference().clone(), owned.law());
        let seat = Lending {
            home: Some(steering),
            away: None,
        };
        Controller::with_seat(*owned.params(), seat, Pose::default())
    }

    #[test]
    fn a_lent_outer_loop_does_what_an_owned_one_does() {
        let mut owned = on_a_line(5.0);
        let mut lent = lending(&owned);
        owned.set_pose(Pose::new(0.0, 0.05, 0.1));
        lent.set_pose(Pose::new(0.0, 0.05, 0.1));
        owned.set_mode(Mode::FollowPath);
        lent.set_mode(Mode::FollowPath);
        let mut jobs = 0;
        for k in 0..300 {
            assert!(lent.collect_steering(), "step {k}: the outer loop is back");
            assert_eq!(lent.steering().map(OuterLoop::law), Some(owned.law()));
            if k == 151 {
                // An external fix between a due step (150) and the next: the job keeps
                // the pose it was due with, as the lent one did.
                owned.set_pose(Pose::new(0.3, 0.04, 0.05));
                lent.set_pose(Pose::new(0.3, 0.04, 0.05));
            }
            let t = ticks(2 + k % 3, 3);
            let duty = step(&mut owned, t);
            assert_eq!(lent.step(StepInput::on_time(t, SUPPLY_V)), duty, "step {k}");
            assert_eq!(lent.telemetry(), owned.telemetry(), "step {k}");
            // The lending seat runs no job itself: each waits to be lent.
            if lent.lend_steering() {
                jobs += 1;
                // Away: what needs the outer loop waits.
                let params = *lent.params();
                assert!(!lent.collect_steering());
                assert!(lent.steering().is_none());
                assert_eq!(lent.set_law(LawKind::Paper), Err(OuterLoopAway));
                assert_eq!(
                    lent.rebuild(&params, LawKind::Paper, Pose::default()),
                    Err(OuterLoopAway)
                );
                lent.holder_mut().run_away();
            }
            assert!(!lent.lend_steering(), "one job per due step");
        }
        // One job every 10 steps.
        assert_eq!(jobs, 30);
        assert!(owned.telemetry().pose.x_m > 0.1);
    }

    #[test]
    fn an_owned_outer_loop_is_never_lent_and_never_collected() {
        // Lending and collecting are for seats that lend: on an owned outer loop they do
        // nothing, and the controller runs its own jobs.
        let mut plain = on_a_line(5.0);
        let mut asked = on_a_line(5.0);
        plain.set_mode(Mode::FollowPath);
        asked.set_mode(Mode::FollowPath);
        for k in 0..50 {
            assert!(asked.collect_steering(), "seated");
            if k == 11 {
                // The job due at step 10 runs aside here; its outcome is applied once.
                plain.set_pose(Pose::new(0.02, 0.01, 0.0));
                asked.set_pose(Pose::new(0.02, 0.01, 0.0));
            }
            step(&mut plain, ticks(3, 3));
            step(&mut asked, ticks(3, 3));
            assert!(!asked.lend_steering(), "step {k}");
            assert_eq!(asked.telemetry(), plain.telemetry(), "step {k}");
        }
        assert!(plain.telemetry().steering_updated || plain.telemetry().command.v_m_s > 0.0);
    }

    #[test]
    fn an_outcome_from_before_a_restart_is_ignored() {
        let mut c = lending(&controller());
        c.set_mode(Mode::FollowPath);
        step(&mut c, ticks(0, 0));
        assert!(c.lend_steering());
        c.holder_mut().run_away();
        // Disarmed and armed again while the job ran.
        c.set_mode(Mode::Idle);
        c.set_mode(Mode::FollowPath);
        assert!(c.collect_steering());
        step(&mut c, ticks(0, 0));
        assert!(!c.telemetry().steering_updated);
        // The new run's own first job is lent, and its outcome applied.
        assert!(c.lend_steering());
        c.holder_mut().run_away();
        assert!(c.collect_steering());
        step(&mut c, ticks(0, 0));
        assert!(c.telemetry().steering_updated);
    }

    #[test]
    fn a_restart_drops_a_steering_outcome_not_yet_applied() {
        // Following, then idle and following again before the outcome of the first step
        // was applied: the new run starts from its own first job, not the stale command.
        let mut c = controller();
        c.set_mode(Mode::FollowPath);
        step(&mut c, ticks(0, 0));
        c.set_mode(Mode::Idle);
        c.set_mode(Mode::FollowPath);
        step(&mut c, ticks(0, 0));
        assert!(!c.telemetry().steering_updated);
        assert_eq!(c.telemetry().wheel_setpoint, WheelSpeeds::default());
        step(&mut c, ticks(0, 0));
        assert!(c.telemetry().steering_updated);
    }

    #[test]
    fn entering_follow_path_restarts_the_reference_and_the_steering_phase() {
        // Idle for 7 steps, then following: the law runs on the first step (its outcome
        // applied on the second) and the reference starts at its beginning, as in a
        // controller that followed at once.
        let mut fresh = controller();
        fresh.set_mode(Mode::FollowPath);
        step(&mut fresh, ticks(0, 0));
        step(&mut fresh, ticks(0, 0));
        let mut late = controller();
        for _ in 0..7 {
            step(&mut late, ticks(0, 0));
        }
        late.set_mode(Mode::FollowPath);
        step(&mut late, ticks(0, 0));
        step(&mut late, ticks(0, 0));
        assert!(late.telemetry().steering_updated);
        assert_eq!(
            late.telemetry().reference.progress_m,
            fresh.telemetry().reference.progress_m
        );
        // Following for 0.5 s, a pause, and following again starts the path over.
        for _ in 0..500 {
            step(&mut late, ticks(0, 0));
        }
        assert!(late.telemetry().reference.progress_m > 0.09);
        late.set_mode(Mode::Idle);
        step(&mut late, ticks(0, 0));
        late.set_mode(Mode::FollowPath);
        step(&mut late, ticks(0, 0));
        step(&mut late, ticks(0, 0));
        assert!(late.telemetry().steering_updated);
        assert_eq!(
            late.telemetry().reference.progress_m,
            fresh.telemetry().reference.progress_m
        );
    }

    #[test]
    fn the_wheel_pid_parts_show_the_drive_pushing_forward() {
        // Following from rest: both set-points are ahead of the measured 0 rad/s, so each
        // wheel's proportional and feed-forward parts push forward.
        let mut c = controller();
        c.set_mode(Mode::FollowPath);
        step(&mut c, ticks(0, 0));
        step(&mut c, ticks(0, 0));
        for part in c.wheel_pid_parts() {
            assert!(part.p > 0.0, "{part:?}");
            assert!(part.ff > 0.0, "{part:?}");
        }
    }

    #[test]
    fn the_set_point_ramp_is_linear_per_wheel_and_stops_at_its_target() {
        let mut ramp = SetpointRamp::default();
        let mut sp = WheelSpeeds::new(2.0, -4.0);
        ramp.start(sp, WheelSpeeds::new(4.0, 6.0), NonZeroU32::new(10).unwrap());
        ramp.advance(5, &mut sp);
        assert!((sp.left_rad_s - 3.0).abs() < 1e-5, "{sp:?}");
        assert!((sp.right_rad_s - 1.0).abs() < 1e-5, "{sp:?}");
        ramp.advance(5, &mut sp);
        assert_eq!(sp, WheelSpeeds::new(4.0, 6.0));
        // It stays there until the next start.
        ramp.advance(1, &mut sp);
        assert_eq!(sp, WheelSpeeds::new(4.0, 6.0));
        // Steps of 2 periods count down 10 periods: after three, 6/10 of the way.
        let mut sp = WheelSpeeds::new(2.0, -4.0);
        ramp.start(sp, WheelSpeeds::new(4.0, 6.0), NonZeroU32::new(10).unwrap());
        for _ in 0..3 {
            ramp.advance(2, &mut sp);
        }
        assert!((sp.left_rad_s - 3.2).abs() < 1e-5, "{sp:?}");
    }

    #[test]
    fn a_delta_of_exactly_the_plausible_maximum_is_no_encoder_jump() {
        // The limit is inclusive, on each wheel.
        let limit = Params::new(RobotConfig::REFERENCE_ROBOT)
            .unwrap()
            .max_ticks_per_step();
        for (left, right) in [(limit, 0), (0, limit), (-limit, -limit)] {
            let mut c = controller();
            step(&mut c, ticks(left, right));
            assert!(!c.faults().any(), "{left} {right}");
        }
        for (left, right) in [(limit + 1, 0), (0, -limit - 1)] {
            let mut c = controller();
            step(&mut c, ticks(left, right));
            assert!(c.faults().encoder_jump, "{left} {right}");
        }
    }

    #[test]
    fn a_late_step_moves_the_set_point_ramp_by_the_periods_it_covered() {
        // After a steering step, three on-time steps and one step covering three periods
        // leave the wheel set-points at the same point of the ramp.
        let mut on_time = controller();
        let mut late = controller();
        for c in [&mut on_time, &mut late] {
            c.set_mode(Mode::FollowPath);
            for _ in 0..25 {
                step(c, ticks(1, 1));
            }
        }
        let before = on_time.telemetry().wheel_setpoint;
        for _ in 0..3 {
            step(&mut on_time, ticks(1, 1));
        }
        late.step(StepInput {
            ticks: ticks(3, 3),
            periods: NonZeroU32::new(3).unwrap(),
            supply_v: SUPPLY_V,
        });
        let (a, b) = (
            on_time.telemetry().wheel_setpoint,
            late.telemetry().wheel_setpoint,
        );
        assert!(
            (a.left_rad_s - before.left_rad_s).abs() > 1e-3,
            "the ramp moves"
        );
        assert!((a.left_rad_s - b.left_rad_s).abs() < 1e-5, "{a:?} {b:?}");
        assert!((a.right_rad_s - b.right_rad_s).abs() < 1e-5, "{a:?} {b:?}");
    }

    #[test]
    fn switching_from_holding_to_following_continues_from_the_measured_speed() {
        // Wheels held at 8.73 rad/s (2 ticks per 1 ms step), then path following with the
        // reference at 0.2 m/s: the acceleration limit starts from the measured 0.28 m/s,
        // so the first set-points stay near the measured speed instead of restarting
        // from 0.
        let mut c = controller();
        let held = 2.0 * core::f32::consts::TAU / 1440.0 * 1000.0;
        c.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(held, held)));
        for _ in 0..300 {
            step(&mut c, ticks(2, 2));
        }
        c.set_mode(Mode::FollowPath);
        step(&mut c, ticks(2, 2));
        let setpoint = c.telemetry().wheel_setpoint;
        assert!(setpoint.left_rad_s > 0.9 * held, "{setpoint:?}");
        assert!(setpoint.right_rad_s > 0.9 * held, "{setpoint:?}");
    }

    #[test]
    fn a_late_step_moves_the_reference_by_the_time_that_passed() {
        // Two controllers, one stepped 21 times on time (steps at 0…20 ms), the other 10
        // times on time (0…9 ms) and then once covering 11 periods (at 20 ms): at that
        // steering step both references must be at 20 ms · 0.2 m/s = 4 mm. The outcome
        // shows one step later.
        let mut on_time = controller();
        let mut late = controller();
        on_time.set_mode(Mode::FollowPath);
        late.set_mode(Mode::FollowPath);
        for _ in 0..20 {
            step(&mut on_time, ticks(0, 0));
        }
        step(&mut on_time, ticks(0, 0));
        for _ in 0..10 {
            step(&mut late, ticks(0, 0));
        }
        late.step(StepInput {
            ticks: ticks(0, 0),
            periods: NonZeroU32::new(11).unwrap(),
            supply_v: SUPPLY_V,
        });
        assert_eq!(late.telemetry().periods, 11);
        step(&mut on_time, ticks(0, 0));
        step(&mut late, ticks(0, 0));
        assert!(on_time.telemetry().steering_updated);
        assert!(late.telemetry().steering_updated);
        let (a, b) = (
            on_time.telemetry().reference.progress_m,
            late.telemetry().reference.progress_m,
        );
        assert!(
            (a - 0.004).abs() < 1e-6 && (b - 0.004).abs() < 1e-6,
            "{a} {b}"
        );
    }

    #[test]
    fn a_late_step_is_not_an_encoder_jump_for_the_time_it_covered() {
        // 45 ticks per period is the limit; 80 ticks over 2 periods is 40 per period.
        let mut c = controller();
        c.step(StepInput {
            ticks: ticks(80, 80),
            periods: NonZeroU32::new(2).unwrap(),
            supply_v: SUPPLY_V,
        });
        assert!(!c.faults().any());
        step(&mut c, ticks(80, 0));
        assert!(c.faults().encoder_jump);
    }

    #[test]
    fn the_wheel_loop_commands_volts_whatever_the_supply() {
        // Holding 10 rad/s with the wheels turning at 10 rad/s: the same volts on 6 and on
        // 12 V, so half the duty.
        let run = |supply_v: f32| {
            let mut c = controller();
            c.seed_motion(BodyVelocity::new(0.325, 0.0));
            c.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(10.0, 10.0)));
            // 10 rad/s is 2.29 ticks per step: whole ticks, the fraction carried.
            let per_step = 10.0 * 1440.0 / (core::f32::consts::TAU * 1000.0);
            let (mut counted, mut duty) = (0.0f32, MotorCommand::STOP);
            for k in 1..=200 {
                let n = (k as f32 * per_step) as i32 - counted as i32;
                counted += n as f32;
                duty = c.step(StepInput::on_time(ticks(n, n), supply_v));
            }
            (duty, c.telemetry().wheel_loop.volts.left_v)
        };
        let (duty6, volts6) = run(6.0);
        let (duty12, volts12) = run(12.0);
        assert!((volts6 - volts12).abs() < 1e-4, "{volts6} vs {volts12}");
        assert!((duty6.left - 2.0 * duty12.left).abs() < 1e-4);
        // About the feed-forward for 10 rad/s, 0.33 + 1.57 V: the PID only trims it.
        assert!((volts6 - 1.9).abs() < 0.15, "{volts6}");
    }

    #[test]
    fn set_points_move_every_step_not_every_steering_period() {
        // From rest the tracking law asks for more than the 3 m/s² allow: the command grows
        // by a·T_s = 30 mm/s per 10 ms steering period, and the wheel set-points follow it
        // in ten equal steps of 0.092 rad/s (3 mm/s at the rim), not in one jump.
        let mut c = on_a_line(5.0);
        c.set_pose(Pose::new(-0.5, 0.0, 0.0));
        c.set_mode(Mode::FollowPath);
        // The first step holds the wheels at rest while the law runs.
        step(&mut c, ticks(0, 0));
        assert_eq!(c.telemetry().wheel_setpoint, WheelSpeeds::default());
        let mut previous = 0.0;
        for k in 0..40 {
            step(&mut c, ticks(0, 0));
            let w = c.telemetry().wheel_setpoint.left_rad_s;
            let change = w - previous;
            assert!(
                (change - 0.003 / 0.0325).abs() < 1e-3,
                "step {k}: {previous} → {w}"
            );
            previous = w;
        }
        assert!(c.telemetry().limit_flags.accel_limited);
        // A late step covers several periods of the ramp at once.
        c.step(StepInput {
            ticks: ticks(0, 0),
            periods: NonZeroU32::new(3).unwrap(),
            supply_v: SUPPLY_V,
        });
        let w = c.telemetry().wheel_setpoint.left_rad_s;
        assert!(
            (w - previous - 3.0 * 0.003 / 0.0325).abs() < 1e-3,
            "{previous} → {w}"
        );
    }

    #[test]
    fn a_weak_supply_lowers_the_rim_speed_cap() {
        let mut c = controller();
        c.set_mode(Mode::FollowPath);
        c.step(StepInput::on_time(ticks(0, 0), 4.8));
        c.step(StepInput::on_time(ticks(0, 0), 4.8));
        // 0.85 · 4.8 V → 23.9 rad/s → 0.776 m/s at 32.5 mm, below the 1 m/s configured.
        let cap = c.telemetry().rim_speed_cap_m_s;
        assert!((cap - 0.7764).abs() < 1e-3, "{cap}");
        let mut strong = controller();
        strong.set_mode(Mode::FollowPath);
        strong.step(StepInput::on_time(ticks(0, 0), 12.0));
        strong.step(StepInput::on_time(ticks(0, 0), 12.0));
        // 0.85 · 6 V (the rated voltage caps a 12 V supply) → 30.4 rad/s → 0.987 m/s.
        let cap = strong.telemetry().rim_speed_cap_m_s;
        assert!((cap - 0.9874).abs() < 1e-3, "{cap}");
    }

    #[test]
    fn seeding_a_motion_fills_the_speed_estimates() {
        let mut c = controller();
        c.seed_motion(BodyVelocity::new(0.4, 0.3));
        let w = c.telemetry().wheel_speed;
        // Inverse kinematics: (0.4 ∓ 0.0225)/0.0325 = 11.62 and 12.98 rad/s, to a tick.
        assert!((w.left_rad_s - 11.615).abs() < 0.22, "{w:?}");
        assert!((w.right_rad_s - 12.998).abs() < 0.22, "{w:?}");
    }

    #[test]
    fn encoder_jump_latches_a_stop_until_cleared() {
        let mut c = controller();
        c.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(5.0, 5.0)));
        assert!(step(&mut c, ticks(0, 0)).left > 0.0);
        let duty = step(&mut c, ticks(10_000, 0));
        assert!(c.faults().encoder_jump);
        assert_eq!(duty, MotorCommand::STOP);
        // Latched, even with sane input.
        assert_eq!(step(&mut c, ticks(0, 0)), MotorCommand::STOP);
        c.clear_faults();
        let duty = step(&mut c, ticks(0, 0));
        assert!(!c.faults().any());
        assert!(duty.left > 0.0);
    }

    #[test]
    fn fault_flags_any() {
        let a = ControllerFaults {
            encoder_jump: true,
            non_finite: false,
        };
        let b = ControllerFaults {
            encoder_jump: false,
            non_finite: true,
        };
        assert!(!ControllerFaults::default().any());
        assert!(a.any() && b.any());
    }

    #[test]
    fn hold_mode_caps_set_points_at_the_rim_speed_limit() {
        let mut c = controller();
        c.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(1000.0, -1000.0)));
        c.step(StepInput::on_time(ticks(0, 0), 12.0));
        // The 6 V motors reach 30.4 rad/s with 15 % of their voltage spare (0.987 m/s at
        // the rim), below the 1 m/s configured cap.
        let max = (0.85 * 6.0 - 0.33) / 0.157;
        assert!((c.telemetry().wheel_setpoint.left_rad_s - max).abs() < 1e-3);
        assert!((c.telemetry().wheel_setpoint.right_rad_s + max).abs() < 1e-3);
    }

    #[test]
    fn open_loop_volts_reach_the_duty_directly() {
        let mut c = controller();
        c.set_mode(Mode::ApplyVolts(WheelVolts {
            left_v: 1.5,
            right_v: -1.5,
        }));
        // 1.5 V on 6 V, at once (no slew, no PID).
        let duty = step(&mut c, ticks(0, 0));
        assert_eq!(
            duty,
            MotorCommand {
                left: 0.25,
                right: -0.25
            }
        );
        c.set_mode(Mode::ApplyVolts(WheelVolts {
            left_v: 3.0,
            right_v: 0.0,
        }));
        assert_eq!(step(&mut c, ticks(0, 0)).left, 0.5);
    }

    #[test]
    fn set_law_and_set_mode_take_effect() {
        let mut c = controller();
        c.set_law(LawKind::Kanayama).expect("owned outer loop");
        assert_eq!(c.law(), LawKind::Kanayama);
        c.set_mode(Mode::FollowPath);
        assert_eq!(c.mode(), Mode::FollowPath);
        step(&mut c, ticks(0, 0));
        step(&mut c, ticks(0, 0));
        // Kanayama's law reports no polar error; the paper's does.
        assert!(c.telemetry().law.polar.is_none());
        c.set_law(LawKind::Paper).expect("owned outer loop");
        for _ in 0..10 {
            step(&mut c, ticks(0, 0));
        }
        assert!(c.telemetry().law.polar.is_some());
        c.set_mode(Mode::Idle);
        assert_eq!(step(&mut c, ticks(0, 0)), MotorCommand::STOP);
    }

    proptest! {
        /// Any tick sequence, late steps and supply reading, however absurd, gives duties
        /// that are finite and in [−1, 1].
        #[test]
        fn any_input_gives_bounded_finite_duty(
            ticks in prop::collection::vec(
                prop_oneof![
                    -50i32..50,
                    Just(i32::MIN), Just(i32::MAX), any::<i32>()
                ],
                1..300,
            ),
            periods in prop::collection::vec(1u32..5, 1..10),
            supply in prop_oneof![
                Just(6.0f32), Just(12.6), Just(4.8), Just(0.0), Just(-3.0),
                Just(f32::NAN), Just(f32::INFINITY), prop::num::f32::ANY
            ],
            law in prop::sample::select(LawKind::ALL.to_vec()),
            pose in prop::option::of((
                prop::num::f32::ANY, prop::num::f32::ANY, prop::num::f32::ANY
            )),
        ) {
            let mut c = controller();
            c.set_law(law).expect("owned outer loop");
            c.set_mode(Mode::FollowPath);
            // Also a pose fix that is NaN, infinite or huge.
            if let Some((x, y, th)) = pose {
                c.set_pose(Pose::new(x, y, th));
            }
            for (k, pair) in ticks.chunks(2).enumerate() {
                let t = TickDeltas { left: pair[0], right: *pair.last().unwrap_or(&0) };
                let n = periods[k % periods.len()];
                let duty = c.step(StepInput {
                    ticks: t,
                    periods: NonZeroU32::new(n).unwrap_or(NonZeroU32::MIN),
                    supply_v: supply,
                });
                for d in [duty.left, duty.right] {
                    prop_assert!(d.is_finite() && (-1.0..=1.0).contains(&d));
                }
                if !c.telemetry().pose.is_finite() {
                    prop_assert!(c.faults().any());
                    prop_assert_eq!(duty, MotorCommand::STOP);
                }
            }
        }
    }
}
