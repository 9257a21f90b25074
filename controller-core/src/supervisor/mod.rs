//! The robot's safety logic: arming, fault handling, the bridge's brake/coast decision and
//! watchdog feeding, hardware-free so that host tests and the simulator run exactly what
//! the firmware runs.
//!
//! The firmware's control task reads its inputs (encoder ticks, the periods elapsed since
//! the last step, the supply voltage, the raw button level, whether the previous step
//! overran, a heartbeat counter of the background work, a command from the link), hands
//! them to [`Supervisor::step`] together with the [`Controller`], and applies what comes
//! back: the duties, the bridge state and whether to feed the watchdog. Every decision
//! about what the motors get is made here; the firmware only moves numbers between
//! registers and this module. `host-sim` runs the same [`Supervisor`] around the same
//! [`Controller`], with the same inputs built from its plant.
//!
//! ## States
//!
//! ```text
//!         short press (on release) / link Arm / auto-arm once after boot
//!   ┌──────────┐ ─────────────────────────────────────────► ┌───────┐
//!   │ Disarmed │                                            │ Armed │
//!   └──────────┘ ◄───────────────────────────────────────── └───────┘
//!   ▲  │  ▲  │     press (on press-down) / link Disarm / run limit / link lost
//!   │  │  │  └─ link BeginPersist ──► ┌────────────┐
//!   │  │  └──── link EndPersist ───── │ Persisting │ (flash erase/write, motors off)
//!   │  │                              └────────────┘
//!   │  │ any fault, emergency stop (in any state)   ┌─────────┐
//!   │  └──────────────────────────────────────────► │ Faulted │ ◄── any fault while Armed
//!   └──── short press (on release) / link ClearFaults ─┘
//! ```
//!
//! - **Disarmed** (the state after every reset): duties 0, the controller in
//!   [`Mode::Idle`] (odometry keeps running). The pose command (the link's
//!   [`Command::SetPose`], a long press) is taken here only.
//! - **Armed**: the controller runs the selected [`RunMode`]; its duties go to the motors.
//!   Arming keeps the pose: path following resumes where it stopped (the time-indexed
//!   reference's clock paused while disarmed; path following projects the robot again),
//!   or starts afresh after a new path or a pose command.
//! - **Faulted**: duties 0, the faults latched in [`Faults`] until a short press or the
//!   link's `ClearFaults` acknowledges them (the robot is then Disarmed, not Armed).
//! - **Persisting**: motors off while the firmware erases and writes flash, which stalls
//!   the CPU: missed ticks are expected and are not a fault.
//!
//! Armed, the robot runs one of four [`RunMode`]s: follow the path, hold wheel speeds,
//! tune the wheel loops ([`crate::tune`]: open-loop voltage experiments, every fault
//! check in force; the tune disarms by itself when done, and a fault, the button or the
//! link stops it like any run), or follow the link's velocity commands
//! ([`crate::velocity`]: armed by request only, [`Command::Velocity`] taken in that mode
//! only; after the command timeout the robot ramps to a stop and stays armed; every fault
//! check in force, the geofence too).
//!
//! ## The button
//!
//! | gesture | Disarmed | Armed | Faulted |
//! |---|---|---|---|
//! | press | — | disarm at once (on press-down) | — |
//! | short press (released before [`SupervisorConfig::long_press_steps`]) | arm (on release), if the wheels are at rest | — | clear the faults |
//! | long press (released after it) | set the pose to [`SupervisorConfig::start_pose`]: "I put it at the start" | — | — |
//! | held [`MODE_SELECT_FACTOR`] × as long | select the next [`RunMode`] (while held) | — | — |
//!
//! A press that disarmed does nothing more when it ends.
//!
//! ## Arming
//!
//! The step that arms (a short press, the link's `Arm`, auto-arm) is the run's first
//! driving step: it starts the controller in the new mode (a tune's start, the speed
//! estimates of a run that starts in motion, the loops restarted), steps it, and drives
//! the motors. Arming from rest needs the wheels at rest: both measured speeds below
//! [`REST_SPEED_RAD_S`] for [`REST_STEPS`] steps ([`CommandRefusal::WheelsTurning`]
//! otherwise; a short press reports [`Event::ArmRefused`], auto-arm waits); a request
//! that asserts the motion ([`ArmRequest::initial_motion`], the paper's runs) arms in
//! motion. A request may carry the run's own time limit ([`ArmRequest::max_armed_steps`]),
//! which holds for that run only. [`Supervisor::arm_locally`], called between two steps,
//! starts the controller at once, so the next [`Supervisor::step`] drives.
//!
//! One state change is reported per step ([`SupervisorOutput::event`]): when the button
//! and the link both change the state in one step, the link's, which is the later.
//!
//! ## The bridge: brake, then coast
//!
//! Both supported bridges run slow decay, so duty 0 with the bridge enabled is a short
//! brake (the armature shorted, the back-EMF braking the wheel). On leaving Armed, for
//! whatever reason, the bridge brakes for [`SupervisorConfig::brake_steps`] and then goes
//! to standby ([`Bridge::Coast`]: TB6612 STBY or DRV8833 nSLEEP low, the motor free). The
//! simulator models both states. A panic, a hard fault or a reset cannot brake: the pins
//! go low or float, the STBY pull-down puts the bridge in standby, and the motors coast.
//!
//! ## Faults
//!
//! Latched until acknowledged ([`Faults`]): the core's own (encoder jump, non-finite
//! value), overruns and missed ticks of the control loop, a wheel that does not follow its
//! drive ([`StallCheck`]), a wheel loop stuck at its limits ([`SaturationCheck`]), loss of
//! control ([`DivergenceCheck`]), leaving the geofence, a
//! supply below the battery's fault threshold or above the bridge's maximum, and an
//! emergency stop. Not faults: a low-battery *warning*, and the link going quiet, which
//! disarms a robot the link armed (heartbeat timeout).
//!
//! What odometry cannot see stays unseen: a wrong track width or wheel radius, a wrong
//! start pose, or a wheel whose motor and encoder are *both* inverted leave odometry
//! self-consistent, and the controller converges in its own frame while the robot is
//! elsewhere. Only an independent sensor (a gyro's yaw rate against odometry's, an
//! absolute position fix) would see them: a robot with a gyro reports the running
//! disagreement of the two yaw rates in its telemetry ([`crate::gyro::GyroReport`]).
//! While armed, a disagreement beyond its threshold is a warning ([`Event::GyroDisagrees`],
//! once a spell), or, when the gyro's configuration says
//! ([`crate::gyro::GyroConfig::disagreement_stops`]), the fault
//! [`Fault::HeadingDisagreement`]. A failed gyro is only ever a warning
//! ([`Event::GyroFailed`]): the heading falls back to odometry.
//!
//! ## The watchdog-feeding rule
//!
//! The firmware feeds the independent watchdog only from the control task, and only when
//! [`SupervisorOutput::feed_watchdog`] says so. It is true unless
//!
//! - the control loop is late: the last [`SupervisorConfig::max_consecutive_overruns`]
//!   steps all overran, or
//! - the background is starved: the heartbeat counter of the lowest-priority work has not
//!   changed for [`SupervisorConfig::background_timeout_steps`].
//!
//! A stalled control task does not call [`Supervisor::step`] at all, so it does not feed
//! either. Disarmed and Faulted states keep feeding: a fault is handled by stopping the
//! motors, and the latched flags stay visible instead of being wiped by a reset. After a
//! watchdog, software or brown-out reset the robot comes back Disarmed with auto-arm
//! refused.
//!
//! ## Example
//!
//! ```
//! use controller_core::prelude::*;
//! use controller_core::supervisor::*;
//!
//! let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
//! let line = Path::line(Point::new(0.0, 0.0), 0.0, 2.0).unwrap();
//! let reference =
//!     Reference::new(line, 0.2, ReferenceMode::TimeIndexed { start_offset_m: 0.0 }).unwrap();
//! let mut controller = Controller::new(params, reference, LawKind::Tracking, Pose::default());
//! let config = SupervisorConfig::at_rate(1000, Pose::default(), WheelSpeeds::new(5.0, 5.0));
//! let mut supervisor = Supervisor::new(config, &params, ResetCause::PowerOn).unwrap();
//!
//! let mut input = Inputs::at_supply(6.0);
//! let out = supervisor.step(&mut controller, input);
//! assert_eq!(out.state, State::Disarmed);
//! assert_eq!(out.duty, MotorCommand::STOP);
//! assert!(out.feed_watchdog && out.bridge == Bridge::Coast);
//!
//! // The link arms the robot; it must then send heartbeats. The step that arms drives.
//! input.command = Some(Command::Arm(ArmRequest::follow_path()));
//! let out = supervisor.step(&mut controller, input);
//! assert_eq!(out.state, State::Armed);
//! assert_eq!(out.command_result, Some(Ok(())));
//! assert!(out.bridge == Bridge::Drive);
//!
//! // The steering law's command reaches the wheels one step later.
//! input.command = Some(Command::Heartbeat);
//! let out = supervisor.step(&mut controller, input);
//! assert!(out.duty.left > 0.0 && out.bridge == Bridge::Drive);
//! ```

mod button;
mod checks;
mod config;
mod faults;
mod rest;
mod vocabulary;
mod warning;

pub use button::MODE_SELECT_FACTOR;
pub use config::{
    geofence_radius_m, ms_to_steps, BatteryCheck, DivergenceCheck, MissedTickCheck,
    SaturationCheck, StallCheck, SupervisorConfig, SupervisorConfigError,
};
pub use faults::{Fault, Faults};
pub use rest::{REST_SPEED_RAD_S, REST_STEPS};
pub use vocabulary::{
    ArmRequest, Bridge, Command, CommandRefusal, DisarmReason, Event, Inputs, MotorTestRequest,
    ResetCause, RunMode, State, SupervisorOutput, SupervisorSetError, Wheel, MOTOR_TEST_MAX_MS,
    MOTOR_TEST_MAX_VOLTS,
};

use core::num::NonZeroU32;

use crate::controller::{Controller, Mode, MotorCommand, StepInput};
use crate::drive::WheelVolts;
use crate::gyro::GyroHealth;
use crate::kinematics::{BodyVelocity, Pose};
use crate::math;
use crate::outer_loop::OuterLoopHolder;
use crate::params::Params;
use crate::tune::{TuneAbort, TuneConfig, TuneResult, TuneStep, Tuner};
use warning::OncePerSpell;

use button::{Debouncer, Length, Press};
use checks::{outside_geofence, Divergence, MissedTicks, Saturation, Stall, Supply};
use rest::AtRest;

/// The firmware's safety state machine (see the module doc).
#[derive(Clone, Debug)]
pub struct Supervisor {
    config: SupervisorConfig,
    /// The bridge's maximum supply, V (from the robot's parameters).
    max_supply_v: f32,
    state: State,
    run_mode: RunMode,
    faults: Faults,
    button: Debouncer,
    /// The current press has already acted (disarm, mode switch, arm): its release must not
    /// act again.
    press_consumed: bool,
    /// Auto-arm is still allowed this boot.
    auto_arm_pending: bool,
    /// Steps since boot (saturating), for auto-arm.
    steps_since_boot: u32,
    /// Steps in the current Armed period.
    armed_steps: u32,
    /// The current run's time limit, steps armed (its request's, else the setting's).
    run_limit_steps: Option<u32>,
    /// Whether the wheels have been at rest long enough to arm from rest.
    rest: AtRest,
    /// The link armed the robot: heartbeats are due.
    armed_by_link: bool,
    steps_since_link_heartbeat: u32,
    /// Steps left of braking after leaving Armed.
    brake_steps_left: u32,
    consecutive_overruns: u32,
    overruns_total: u32,
    last_heartbeat: Option<u32>,
    steps_since_heartbeat: u32,
    battery_low: bool,
    /// The warnings: [`Event::BatteryLow`], [`Event::GyroFailed`], [`Event::GyroDisagrees`].
    battery_warning: OncePerSpell,
    gyro_failure_warning: OncePerSpell,
    gyro_disagreement_warning: OncePerSpell,
    missed: MissedTicks,
    stall: Stall,
    saturation: Saturation,
    divergence: Divergence,
    supply: Supply,
    /// The wheel-loop tune, and the voltages it asked for the next step.
    tuner: Tuner,
    tune_volts: WheelVolts,
    /// The voltages of the motor pulse in progress ([`RunMode::MotorTest`]).
    motor_test_volts: WheelVolts,
    /// The control rate, Hz (bounds a motor pulse's length).
    rate_hz: u32,
}

impl Supervisor {
    /// A supervisor with `config` for a robot with `params`, after a reset caused by
    /// `reset`. It starts [`State::Disarmed`] whatever the cause.
    pub fn new(
        config: SupervisorConfig,
        params: &Params,
        reset: ResetCause,
    ) -> Result<Self, SupervisorConfigError> {
        config.validate(params)?;
        Ok(Self {
            config,
            max_supply_v: params.config().drive.max_supply_v,
            state: State::Disarmed,
            run_mode: config.initial_mode,
            faults: Faults::NONE,
            button: Debouncer::new(),
            press_consumed: false,
            auto_arm_pending: config.auto_arm_after_steps.is_some() && reset.allows_auto_arm(),
            steps_since_boot: 0,
            armed_steps: 0,
            run_limit_steps: None,
            rest: AtRest::new(),
            armed_by_link: false,
            steps_since_link_heartbeat: 0,
            brake_steps_left: 0,
            consecutive_overruns: 0,
            overruns_total: 0,
            last_heartbeat: None,
            steps_since_heartbeat: 0,
            battery_low: false,
            battery_warning: OncePerSpell::default(),
            gyro_failure_warning: OncePerSpell::default(),
            gyro_disagreement_warning: OncePerSpell::default(),
            missed: MissedTicks::default(),
            stall: Stall::default(),
            saturation: Saturation::default(),
            divergence: Divergence::default(),
            supply: Supply::default(),
            tuner: Tuner::new(TuneConfig::for_robot(params.config()), params),
            tune_volts: WheelVolts::default(),
            motor_test_volts: WheelVolts::default(),
            rate_hz: params.config().control_rate_hz,
        })
    }

    /// The settings in use.
    pub const fn config(&self) -> &SupervisorConfig {
        &self.config
    }

    /// New settings are taken only while Disarmed.
    fn require_disarmed(&self) -> Result<(), SupervisorSetError> {
        if self.state == State::Disarmed {
            Ok(())
        } else {
            Err(SupervisorSetError::NotDisarmed(self.state))
        }
    }

    /// Replaces the settings (validated against `params`); refused unless Disarmed.
    pub fn set_config(
        &mut self,
        config: SupervisorConfig,
        params: &Params,
    ) -> Result<(), SupervisorSetError> {
        self.require_disarmed()?;
        config
            .validate(params)
            .map_err(SupervisorSetError::Invalid)?;
        self.config = config;
        self.max_supply_v = params.config().drive.max_supply_v;
        self.rate_hz = params.config().control_rate_hz;
        // The robot may have changed: the tune's timing follows, and settings the new robot
        // refuses (e.g. experiment volts above a lower motor rating) give way to its
        // defaults.
        let tune = *self.tuner.config();
        let tune = match tune.validate(params) {
            Ok(()) => tune,
            Err(_) => TuneConfig::for_robot(params.config()),
        };
        self.tuner.set_config(tune, params);
        Ok(())
    }

    /// Replaces the tune's settings (validated against `params`); refused unless Disarmed.
    pub fn set_tune_config(
        &mut self,
        config: TuneConfig,
        params: &Params,
    ) -> Result<(), SupervisorSetError> {
        self.require_disarmed()?;
        config
            .validate(params)
            .map_err(SupervisorSetError::InvalidTune)?;
        self.tuner.set_config(config, params);
        Ok(())
    }

    /// The tune's settings.
    pub const fn tune_config(&self) -> &TuneConfig {
        self.tuner.config()
    }

    /// The last tune's result, or why it stopped (`None`: no tune has ended since start).
    pub const fn tune_outcome(&self) -> Option<Result<TuneResult, TuneAbort>> {
        self.tuner.outcome()
    }

    /// The current state.
    pub const fn state(&self) -> State {
        self.state
    }

    /// The mode used when armed.
    pub const fn run_mode(&self) -> RunMode {
        self.run_mode
    }

    /// Latched faults.
    pub const fn faults(&self) -> Faults {
        self.faults
    }

    /// One control period: processes `input`, sets `controller`'s mode, steps it, checks
    /// the result and returns what the motors, the bridge and the watchdog get.
    pub fn step<S: OuterLoopHolder>(
        &mut self,
        controller: &mut Controller<S>,
        input: Inputs,
    ) -> SupervisorOutput {
        self.steps_since_boot = self.steps_since_boot.saturating_add(1);
        self.track_liveness(&input);

        // 1. The operator (button, link, auto-arm) and the timers.
        let mut event = self.handle_button(input.button_pressed, controller);
        let mut command_result = None;
        if let Some(command) = input.command {
            let (result, command_event) = self.handle_command(command, controller);
            command_result = Some(result);
            // The later change is the one the step ends in (a button that cleared the
            // faults and a link that armed in the same step: the robot is armed, and a
            // run's start must be seen).
            event = command_event.or(event);
        }
        if event.is_none() {
            event = self.handle_timers(controller);
        }

        // 2. The controller runs in the mode the state allows.
        controller.set_mode(self.controller_mode());
        let controller_duty = controller.step(StepInput {
            ticks: input.ticks,
            periods: input.periods,
            supply_v: input.supply_v,
            gyro: input.gyro,
            still: self.state == State::Disarmed && self.rest.at_rest(),
        });
        self.rest.update(controller.telemetry().wheel_speed);

        // 3. Faults, whatever the state. Flags latch: OR, never overwrite.
        self.check_faults(controller, controller_duty, input.periods);
        if self.faults.any() && self.state != State::Faulted {
            if self.state == State::Armed {
                self.start_braking();
            }
            self.state = State::Faulted;
            self.armed_by_link = false;
            self.auto_arm_pending = false;
            self.tuner.abort(TuneAbort::Stopped);
            event = Some(Event::Faulted);
        }
        if self.state == State::Armed && self.run_mode == RunMode::Tune {
            event = self.tune_step(controller, input.periods).or(event);
        }
        // The tune may have ended, disarming.
        let driving = self.state == State::Armed;
        let battery_event = self.battery_event(event.is_none());
        event = event.or(battery_event);
        let gyro_event = self.gyro_event(controller, event.is_none());
        event = event.or(gyro_event);

        // 4. Outputs.
        let bridge = if driving {
            Bridge::Drive
        } else if self.brake_steps_left > 0 {
            self.brake_steps_left -= 1;
            Bridge::Brake
        } else {
            Bridge::Coast
        };
        SupervisorOutput {
            duty: if driving {
                controller_duty
            } else {
                MotorCommand::STOP
            },
            bridge,
            feed_watchdog: self.watchdog_may_be_fed(),
            state: self.state,
            run_mode: self.run_mode,
            faults: self.faults,
            battery_low: self.battery_low,
            overruns_total: self.overruns_total,
            missed_ticks_total: self.missed.total,
            event,
            command_result,
            controller_duty,
        }
    }

    /// One step of the tune while armed in [`RunMode::Tune`]: the voltages for the next
    /// step, or the end (brake and disarm).
    fn tune_step<S: OuterLoopHolder>(
        &mut self,
        controller: &mut Controller<S>,
        periods: NonZeroU32,
    ) -> Option<Event> {
        match self.tuner.step(controller.telemetry(), periods.get()) {
            TuneStep::Drive(volts) => {
                self.tune_volts = volts;
                None
            }
            TuneStep::Finished(_) => {
                self.tune_volts = WheelVolts::default();
                self.disarm(controller);
                Some(Event::Disarmed(DisarmReason::TuneFinished))
            }
        }
    }

    /// Arms at once, at the request of the operator at the robot rather than over the
    /// link (a bench script, the simulator's timeline): like the button, it needs no
    /// heartbeat. Only from Disarmed, not while the button is held, and from rest unless
    /// the request asserts a motion. Call it between two steps: the controller starts at
    /// once, and the next [`Supervisor::step`] drives.
    pub fn arm_locally<S: OuterLoopHolder>(
        &mut self,
        controller: &mut Controller<S>,
        request: ArmRequest,
    ) -> Result<Event, CommandRefusal> {
        if self.state != State::Disarmed {
            return Err(CommandRefusal::WrongState(self.state));
        }
        if self.button.pressed() {
            return Err(CommandRefusal::ButtonHeld);
        }
        self.arm_if_at_rest(controller, request, false)
    }

    /// The pose command: the robot is at `pose` (world frame, the path's), from the link
    /// ([`Command::SetPose`]), a long press (the start pose) or the operator at the robot
    /// (called between two steps). Only while Disarmed ([`CommandRefusal::WrongState`])
    /// and only a finite pose ([`CommandRefusal::NonFinitePose`]). It sets whatever
    /// estimates the pose ([`Controller::set_pose`]: the odometry, and a fused heading
    /// once there is one, never a sensor's bias), and the next path-following run starts
    /// its reference afresh. The pose is set by this command only: arming keeps it.
    pub fn set_pose<S: OuterLoopHolder>(
        &mut self,
        controller: &mut Controller<S>,
        pose: Pose,
    ) -> Result<Event, CommandRefusal> {
        if self.state != State::Disarmed {
            return Err(CommandRefusal::WrongState(self.state));
        }
        if !pose.is_finite() {
            return Err(CommandRefusal::NonFinitePose);
        }
        controller.set_pose(pose);
        Ok(Event::PoseSet)
    }

    /// The watchdog-feeding rule (module doc): the loop is not late and the background runs.
    fn watchdog_may_be_fed(&self) -> bool {
        self.consecutive_overruns < self.config.max_consecutive_overruns
            && self.steps_since_heartbeat < self.config.background_timeout_steps
    }

    fn track_liveness(&mut self, input: &Inputs) {
        // Counted before this step's command: a heartbeat in it restarts from 0.
        self.steps_since_link_heartbeat = self.steps_since_link_heartbeat.saturating_add(1);
        if input.overrun {
            self.consecutive_overruns = self.consecutive_overruns.saturating_add(1);
            self.overruns_total = self.overruns_total.saturating_add(1);
        } else {
            self.consecutive_overruns = 0;
        }
        if self.last_heartbeat == Some(input.background_heartbeat) {
            self.steps_since_heartbeat = self.steps_since_heartbeat.saturating_add(1);
        } else {
            self.last_heartbeat = Some(input.background_heartbeat);
            self.steps_since_heartbeat = 0;
        }
    }

    /// Every check of step 3; sets the latched flags.
    fn check_faults<S: OuterLoopHolder>(
        &mut self,
        controller: &Controller<S>,
        duty: MotorCommand,
        periods: NonZeroU32,
    ) {
        let t = controller.telemetry();
        self.faults.latch_core(controller.faults());
        // A second line of defence: the controller already clamps its duties to [−1, 1].
        let duty_ok = [duty.left, duty.right]
            .iter()
            .all(|d| d.is_finite() && math::abs(*d) <= 1.0);
        if !duty_ok {
            self.faults.set(Fault::NonFinite);
        }
        if self.consecutive_overruns >= self.config.max_consecutive_overruns {
            self.faults.set(Fault::Overrun);
        }
        // A flash erase stalls the CPU on purpose: its missed ticks are not a fault.
        let missed_fault = self.missed.update(periods.get(), &self.config.missed_ticks);
        if missed_fault && self.state != State::Persisting {
            self.faults.set(Fault::MissedTicks);
        }
        if self.state == State::Armed {
            // The tune's breakaway ramp drives wheels that do not turn yet, on purpose, up
            // to a voltage no default can know for a motor not yet identified; the tune
            // bounds it itself (`TuneAbort::NoBreakaway`, 0.5 s at its highest voltage).
            if self.run_mode != RunMode::Tune {
                let [left, right] = self.stall.update(t, &self.config.stall);
                self.faults.set_if(Fault::StallLeft, left);
                self.faults.set_if(Fault::StallRight, right);
            }
            let [left, right] = self
                .saturation
                .update(t, periods.get(), &self.config.saturation);
            self.faults.set_if(Fault::Saturated, left || right);
            if self.run_mode == RunMode::FollowPath {
                if let Some(check) = self.config.divergence {
                    if self.divergence.update(t, periods.get(), &check) {
                        self.faults.set(Fault::Divergence);
                    }
                }
            }
            // The geofence is the operator's, whoever gives the body command, and the
            // heading matters in these modes only.
            if self.follows_a_path_or_velocities() {
                if t.gyro.disagrees && controller.params().config().gyro.disagreement_stops {
                    self.faults.set(Fault::HeadingDisagreement);
                }
                if let Some(radius) = self.config.geofence_radius_m {
                    if outside_geofence(&t.pose, &self.config.start_pose, radius) {
                        self.faults.set(Fault::Geofence);
                    }
                }
            }
        } else {
            self.stall.reset();
            self.saturation.reset();
        }
        let supply = self
            .supply
            .update(t.supply_v, &self.config.battery, self.max_supply_v);
        self.faults.set_if(Fault::SupplyLow, supply.low);
        self.faults.set_if(Fault::SupplyHigh, supply.high);
        self.battery_low = supply.warn;
    }

    /// The low-battery warning's event, once each time the supply falls below the
    /// warning threshold (not while the supply's fault is latched), in the first step
    /// whose event slot is free (`slot_free`; [`OncePerSpell`]).
    fn battery_event(&mut self, slot_free: bool) -> Option<Event> {
        let slot_free = slot_free && !self.faults.has(Fault::SupplyLow);
        self.battery_warning
            .due(self.battery_low, slot_free)
            .then_some(Event::BatteryLow)
    }

    /// The gyro's warnings, once each per spell ([`OncePerSpell`], the event slot
    /// `slot_free`): [`Event::GyroFailed`] when the fusion has given the gyro up (the
    /// heading follows odometry), and, while armed to follow a path or velocities,
    /// [`Event::GyroDisagrees`] when the two yaw rates disagree and the configuration
    /// does not stop the robot for it.
    fn gyro_event<S: OuterLoopHolder>(
        &mut self,
        controller: &Controller<S>,
        slot_free: bool,
    ) -> Option<Event> {
        let report = controller.telemetry().gyro;
        let failure = match report.health {
            GyroHealth::Failed(failure) => Some(failure),
            GyroHealth::None | GyroHealth::Reading => None,
        };
        let warn_disagreement = report.disagrees
            && self.follows_a_path_or_velocities()
            && !controller.params().config().gyro.disagreement_stops;
        let failure_due = self.gyro_failure_warning.due(failure.is_some(), slot_free);
        let disagreement_due = self
            .gyro_disagreement_warning
            .due(warn_disagreement, slot_free && !failure_due);
        match failure {
            Some(failure) if failure_due => Some(Event::GyroFailed(failure)),
            _ => disagreement_due.then_some(Event::GyroDisagrees),
        }
    }

    /// Armed to follow a path or velocity commands: the modes whose heading matters (not
    /// the bench's wheel holds, tunes and motor pulses, which may run with the wheels in
    /// the air).
    fn follows_a_path_or_velocities(&self) -> bool {
        self.state == State::Armed
            && matches!(self.run_mode, RunMode::FollowPath | RunMode::FollowVelocity)
    }

    fn handle_button<S: OuterLoopHolder>(
        &mut self,
        raw: bool,
        controller: &mut Controller<S>,
    ) -> Option<Event> {
        let press = self.button.update(
            raw,
            self.config.debounce_steps,
            self.config.long_press_steps,
        )?;
        // Any use of the button cancels a pending auto-arm: the operator is in charge.
        self.auto_arm_pending = false;
        match (press, self.state) {
            (Press::Down, State::Armed) => {
                // Stop on the press itself, not on its release.
                self.press_consumed = true;
                self.disarm(controller);
                Some(Event::Disarmed(DisarmReason::Button))
            }
            (Press::Down, _) => {
                self.press_consumed = false;
                None
            }
            (Press::ModeSelectHeld, State::Disarmed) if !self.press_consumed => {
                self.press_consumed = true;
                self.run_mode = self.run_mode.next();
                Some(Event::ModeSelected(self.run_mode))
            }
            (Press::ModeSelectHeld, _) => None,
            (Press::Up(_), _) if self.press_consumed => {
                self.press_consumed = false;
                None
            }
            (Press::Up(Length::Short), State::Disarmed) => {
                let request = self.arm_request_for(self.run_mode.in_button_cycle());
                Some(
                    self.arm_if_at_rest(controller, request, false)
                        .unwrap_or_else(Event::ArmRefused),
                )
            }
            (Press::Up(Length::Short), State::Faulted) => Some(self.clear_faults(controller)),
            // The deliberate gesture that says "I put it at the start".
            (Press::Up(Length::Long), State::Disarmed) => {
                self.set_pose(controller, self.config.start_pose).ok()
            }
            (Press::Up(_), _) => None,
        }
    }

    fn handle_command<S: OuterLoopHolder>(
        &mut self,
        command: Command,
        controller: &mut Controller<S>,
    ) -> (Result<(), CommandRefusal>, Option<Event>) {
        let wrong_state = Err(CommandRefusal::WrongState(self.state));
        match (command, self.state) {
            (Command::Heartbeat, _) => {
                self.steps_since_link_heartbeat = 0;
                (Ok(()), None)
            }
            (Command::EmergencyStop, _) => {
                self.faults.set(Fault::EmergencyStop);
                (Ok(()), None)
            }
            (Command::Arm(_), State::Disarmed) if self.button.pressed() => {
                (Err(CommandRefusal::ButtonHeld), None)
            }
            (Command::Arm(request), State::Disarmed) => {
                match self.arm_if_at_rest(controller, request, true) {
                    Ok(event) => (Ok(()), Some(event)),
                    Err(refusal) => (Err(refusal), None),
                }
            }
            (Command::SetPose(pose), _) => match self.set_pose(controller, pose) {
                Ok(event) => (Ok(()), Some(event)),
                Err(refusal) => (Err(refusal), None),
            },
            (Command::Velocity(command), State::Armed) => {
                (self.command_velocity(controller, command), None)
            }
            (Command::MotorTest(_), State::Disarmed) if self.button.pressed() => {
                (Err(CommandRefusal::ButtonHeld), None)
            }
            (Command::MotorTest(test), State::Disarmed) => {
                match self.start_motor_test(controller, test) {
                    Ok(event) => (Ok(()), Some(event)),
                    Err(refusal) => (Err(refusal), None),
                }
            }
            (Command::Disarm, State::Armed) => {
                self.disarm(controller);
                (Ok(()), Some(Event::Disarmed(DisarmReason::Link)))
            }
            // Disarming a robot that is not armed is already done.
            (Command::Disarm, _) => (Ok(()), None),
            (Command::ClearFaults, State::Faulted) => (Ok(()), Some(self.clear_faults(controller))),
            (Command::BeginPersist, State::Disarmed) => {
                self.state = State::Persisting;
                (Ok(()), Some(Event::PersistStarted))
            }
            (Command::EndPersist, State::Persisting) => {
                // The erase's missed ticks must not count against the next window.
                self.missed.restart_window();
                self.state = State::Disarmed;
                (Ok(()), Some(Event::PersistEnded))
            }
            (
                Command::Arm(_)
                | Command::ClearFaults
                | Command::BeginPersist
                | Command::MotorTest(_),
                _,
            )
            | (Command::EndPersist | Command::Velocity(_), _) => (wrong_state, None),
        }
    }

    /// A velocity command while Armed: taken in [`RunMode::FollowVelocity`] only, and only
    /// finite.
    fn command_velocity<S: OuterLoopHolder>(
        &self,
        controller: &mut Controller<S>,
        command: BodyVelocity,
    ) -> Result<(), CommandRefusal> {
        if self.run_mode != RunMode::FollowVelocity {
            return Err(CommandRefusal::WrongMode(self.run_mode));
        }
        if !(command.v_m_s.is_finite() && command.omega_rad_s.is_finite()) {
            return Err(CommandRefusal::NonFiniteVelocity);
        }
        controller.command_velocity(command);
        Ok(())
    }

    fn handle_timers<S: OuterLoopHolder>(
        &mut self,
        controller: &mut Controller<S>,
    ) -> Option<Event> {
        match self.state {
            State::Disarmed if self.auto_arm_pending => {
                let due = self.config.auto_arm_after_steps.unwrap_or(u32::MAX);
                // Tried again at every step until it arms (the wheels may still turn).
                if self.steps_since_boot >= due && !self.button.pressed() {
                    let request = self.arm_request_for(self.run_mode.in_button_cycle());
                    self.arm_if_at_rest(controller, request, false).ok()
                } else {
                    None
                }
            }
            State::Armed => {
                self.armed_steps = self.armed_steps.saturating_add(1);
                if self.armed_by_link
                    && self.steps_since_link_heartbeat >= self.config.heartbeat_timeout_steps
                {
                    self.disarm(controller);
                    return Some(Event::Disarmed(DisarmReason::LinkLost));
                }
                match self.run_limit_steps {
                    Some(max) if self.armed_steps >= max => {
                        self.disarm(controller);
                        Some(Event::Disarmed(DisarmReason::Timeout))
                    }
                    _ => None,
                }
            }
            State::Disarmed | State::Faulted | State::Persisting => None,
        }
    }

    /// Arms for one motor pulse, if `test` is within its bounds and the wheels are at
    /// rest: `test.volts` on its wheel, 0 V on the other, for `test.steps` steps.
    fn start_motor_test<S: OuterLoopHolder>(
        &mut self,
        controller: &mut Controller<S>,
        test: MotorTestRequest,
    ) -> Result<Event, CommandRefusal> {
        test.check(self.rate_hz)?;
        let request = ArmRequest {
            mode: RunMode::MotorTest,
            hold_speeds: None,
            initial_motion: None,
            max_armed_steps: Some(test.steps),
        };
        // No heartbeats are due: the pulse ends by itself within MOTOR_TEST_MAX_MS.
        let event = self.arm_if_at_rest(controller, request, false)?;
        self.motor_test_volts = match test.wheel {
            Wheel::Left => WheelVolts {
                left_v: test.volts,
                right_v: 0.0,
            },
            Wheel::Right => WheelVolts {
                left_v: 0.0,
                right_v: test.volts,
            },
        };
        Ok(event)
    }

    /// The request the button and auto-arm make for `mode`.
    const fn arm_request_for(&self, mode: RunMode) -> ArmRequest {
        ArmRequest {
            mode,
            hold_speeds: None,
            initial_motion: None,
            max_armed_steps: None,
        }
    }

    /// [`Supervisor::arm`], if the wheels are at rest or the request asserts the motion
    /// they have; otherwise refused with [`CommandRefusal::WheelsTurning`] and nothing
    /// changed.
    fn arm_if_at_rest<S: OuterLoopHolder>(
        &mut self,
        controller: &mut Controller<S>,
        request: ArmRequest,
        by_link: bool,
    ) -> Result<Event, CommandRefusal> {
        if request.initial_motion.is_none() && !self.rest.at_rest() {
            return Err(CommandRefusal::WheelsTurning);
        }
        Ok(self.arm(controller, request, by_link))
    }

    /// Arms with `request` (the link's when `by_link`) and prepares `controller` for the
    /// run: a tune's start or the motion a run starts with. The pose is kept (odometry
    /// counted while disarmed); path following resumes its reference, or starts it
    /// afresh after a new path or a pose command. The step then switches the controller
    /// to the run's mode, which restarts its loops.
    fn arm<S: OuterLoopHolder>(
        &mut self,
        controller: &mut Controller<S>,
        request: ArmRequest,
        by_link: bool,
    ) -> Event {
        self.auto_arm_pending = false;
        self.state = State::Armed;
        self.run_mode = request.mode;
        self.run_limit_steps = request.max_armed_steps.or(self.config.max_armed_steps);
        if let Some(speeds) = request.hold_speeds {
            if speeds.left_rad_s.is_finite() && speeds.right_rad_s.is_finite() {
                self.config.hold_speeds = speeds;
            }
        }
        self.armed_steps = 0;
        self.armed_by_link = by_link;
        self.steps_since_link_heartbeat = 0;
        self.brake_steps_left = 0;
        self.stall.reset();
        self.divergence.reset();
        // The estimate of the run does not depend on how long the robot stood before it
        // (the odometry's periodic heading recomputation counts from the arming step).
        controller.resync_heading();
        if self.run_mode == RunMode::Tune {
            // From where the robot stands; the tune checks that it stands still.
            self.tune_volts = WheelVolts::default();
            self.tuner.start(controller.pose());
        } else if let Some(motion) = request.initial_motion {
            controller.seed_motion(motion);
        }
        Event::Armed(self.run_mode)
    }

    /// The controller's mode in the present state: the run mode's while armed, idle
    /// otherwise.
    fn controller_mode(&self) -> Mode {
        match (self.state, self.run_mode) {
            (State::Armed, RunMode::FollowPath) => Mode::FollowPath,
            (State::Armed, RunMode::HoldWheelSpeeds) => {
                Mode::HoldWheelSpeeds(self.config.hold_speeds)
            }
            (State::Armed, RunMode::Tune) => Mode::ApplyVolts(self.tune_volts),
            (State::Armed, RunMode::FollowVelocity) => Mode::FollowVelocity,
            (State::Armed, RunMode::MotorTest) => Mode::ApplyVolts(self.motor_test_volts),
            (State::Disarmed | State::Faulted | State::Persisting, _) => Mode::Idle,
        }
    }

    fn disarm<S: OuterLoopHolder>(&mut self, controller: &mut Controller<S>) {
        self.tuner.abort(TuneAbort::Stopped);
        self.state = State::Disarmed;
        self.armed_by_link = false;
        self.start_braking();
        controller.set_mode(Mode::Idle);
    }

    fn start_braking(&mut self) {
        self.brake_steps_left = self.config.brake_steps;
    }

    fn clear_faults<S: OuterLoopHolder>(&mut self, controller: &mut Controller<S>) -> Event {
        self.faults = Faults::NONE;
        self.consecutive_overruns = 0;
        self.missed.restart_window();
        self.supply = Supply::default();
        controller.clear_faults();
        // The gyro is judged afresh (the controller's fusion too): a new spell warns again.
        self.gyro_failure_warning.restart();
        self.gyro_disagreement_warning.restart();
        self.state = State::Disarmed;
        Event::FaultsCleared
    }
}

#[cfg(test)]
mod tests;
