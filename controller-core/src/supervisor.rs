//! Firmware safety logic: arming, fault handling and watchdog feeding, hardware-free so
//! that host tests exercise it.
//!
//! The firmware's 1 kHz task reads its inputs (encoder ticks, the raw button level, whether
//! the previous step overran, a heartbeat counter of the background work), hands them to
//! [`Supervisor::step`] together with the [`Controller`], and applies what comes back:
//! the duties, the motor driver's enable line and whether to feed the watchdog. Every
//! decision about what the motors get is made here; the firmware only moves numbers
//! between registers and this module.
//!
//! ## States
//!
//! ```text
//!             short press (on release) / auto-arm once after boot
//!   ┌──────────┐ ─────────────────────────────────────► ┌───────┐
//!   │ Disarmed │                                        │ Armed │
//!   └──────────┘ ◄───────────────────────────────────── └───────┘
//!     ▲   │  long press: select the other RunMode   press (on press-down) / run timeout
//!     │   │
//!     │   │ any fault (in any state)         ┌─────────┐
//!     │   └────────────────────────────────► │ Faulted │ ◄── any fault while Armed
//!     └──── short press (on release): ────── └─────────┘
//!           acknowledge, clear all faults
//! ```
//!
//! - **Disarmed** (the state after every reset): duties 0, driver disabled, the controller
//!   in [`Mode::Idle`] (odometry keeps running).
//! - **Armed**: the controller runs the selected [`RunMode`]; its duties go to the motors.
//!   Arming into [`RunMode::FollowPath`] resets the odometry to the configured start pose
//!   and restarts the reference.
//! - **Faulted**: duties 0, driver disabled, the faults latched in [`Faults`] until a short
//!   press acknowledges them (the robot is then Disarmed, not Armed: a second press arms).
//!
//! Faults: the core's latched [`FaultFlags`] (encoder jump, non-finite value), a control
//! loop that overran its period [`SupervisorConfig::max_consecutive_overruns`] times in a
//! row, and a wheel that does not turn the way it is driven (stalled, encoder unplugged or
//! wired with the wrong polarity; see [`StallCheck`]).
//!
//! ## The watchdog-feeding rule
//!
//! The firmware feeds the independent watchdog only from the control task, and only when
//! [`Supervised::feed_watchdog`] says so. It is true unless
//!
//! - the control loop is late: the last [`SupervisorConfig::max_consecutive_overruns`]
//!   steps all overran, or
//! - the background is starved: the heartbeat counter of the lowest-priority work (idle
//!   loop, telemetry) has not changed for [`SupervisorConfig::background_timeout_steps`].
//!
//! A stalled control task does not call [`Supervisor::step`] at all, so it does not feed
//! either. Disarmed and Faulted states keep feeding: a fault is handled by stopping the
//! motors, and the latched flags stay visible in telemetry instead of being wiped by a
//! reset. A watchdog reset is reported as [`ResetCause::Watchdog`] after the reboot, and
//! the robot comes back Disarmed, with auto-arm refused.
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
//! let mut supervisor = Supervisor::new(config, ResetCause::PowerOn).unwrap();
//!
//! let mut input = Inputs::default();
//! let out = supervisor.step(&mut controller, input);
//! assert_eq!(out.state, State::Disarmed);
//! assert_eq!(out.duty, MotorCommand::STOP);
//! assert!(out.feed_watchdog && !out.driver_enabled);
//!
//! // Press the button for 100 ms and release it: the robot arms.
//! input.button_pressed = true;
//! for k in 0..100 {
//!     input.background_heartbeat = k;
//!     supervisor.step(&mut controller, input);
//! }
//! input.button_pressed = false;
//! let mut state = State::Disarmed;
//! for k in 100..200 {
//!     input.background_heartbeat = k;
//!     state = supervisor.step(&mut controller, input).state;
//! }
//! assert_eq!(state, State::Armed);
//! ```

use crate::controller::{Controller, FaultFlags, Mode, MotorCommand, Telemetry, TickDeltas};
use crate::kinematics::{Pose, WheelSpeeds};
use crate::math;

/// What the robot does while armed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum RunMode {
    /// Follow the controller's reference path from [`SupervisorConfig::start_pose`].
    FollowPath,
    /// Hold [`SupervisorConfig::hold_speeds`] with the wheel PIDs only (bring-up).
    HoldWheelSpeeds,
}

impl RunMode {
    /// The other mode (what a long press selects).
    pub const fn other(self) -> RunMode {
        match self {
            RunMode::FollowPath => RunMode::HoldWheelSpeeds,
            RunMode::HoldWheelSpeeds => RunMode::FollowPath,
        }
    }
}

/// The supervisor's state (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum State {
    /// Motors off, driver disabled; waiting for a press (or auto-arm).
    Disarmed,
    /// The controller drives the motors.
    Armed,
    /// Motors off, driver disabled; faults latched until acknowledged by a press.
    Faulted,
}

/// Why the chip last reset, decoded from the reset-flag register (RCC_CSR on an STM32).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum ResetCause {
    /// Power-on or brown-out reset.
    PowerOn,
    /// The reset pin (NRST), e.g. the board's reset button or a debug probe.
    Pin,
    /// The independent or window watchdog: the control loop stalled.
    Watchdog,
    /// A software reset (`SCB::sys_reset`), e.g. after a fault handler.
    Software,
    /// A low-power-management reset.
    LowPower,
    /// No flag set.
    Unknown,
}

/// The raw reset flags of an STM32F4's RCC_CSR, one `bool` per flag.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ResetFlags {
    /// LPWRRSTF: low-power reset.
    pub low_power: bool,
    /// WWDGRSTF: window watchdog reset.
    pub window_watchdog: bool,
    /// IWDGRSTF: independent watchdog reset.
    pub independent_watchdog: bool,
    /// SFTRSTF: software reset.
    pub software: bool,
    /// PORRSTF: power-on / power-down reset.
    pub power_on: bool,
    /// PINRSTF: NRST pin reset (also set by every other reset source, which drives NRST).
    pub pin: bool,
    /// BORRSTF: brown-out reset.
    pub brown_out: bool,
}

impl ResetCause {
    /// The cause that explains `flags`. Every internal reset also pulls NRST low and so
    /// sets the pin flag, so the pin is the cause only when nothing else is set.
    pub const fn from_flags(flags: ResetFlags) -> ResetCause {
        if flags.independent_watchdog || flags.window_watchdog {
            ResetCause::Watchdog
        } else if flags.software {
            ResetCause::Software
        } else if flags.low_power {
            ResetCause::LowPower
        } else if flags.power_on || flags.brown_out {
            ResetCause::PowerOn
        } else if flags.pin {
            ResetCause::Pin
        } else {
            ResetCause::Unknown
        }
    }

    /// True for the resets a person causes on purpose (power-on, reset pin): the only
    /// ones after which [`SupervisorConfig::auto_arm_after_steps`] may arm the motors.
    pub const fn allows_auto_arm(self) -> bool {
        matches!(self, ResetCause::PowerOn | ResetCause::Pin)
    }
}

/// Detects a wheel that does not follow its drive: driven with |duty| ≥ `min_duty` while
/// turning slower than `min_speed_rad_s` in the driven direction, for `timeout_steps`
/// consecutive steps. Catches a stalled or blocked wheel, an unplugged encoder and an
/// encoder or motor wired with the wrong polarity (the PID then runs away to full duty).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct StallCheck {
    /// Smallest |duty| (fraction of supply, 0…1] that must move the wheel.
    pub min_duty: f32,
    /// Slowest wheel speed in the driven direction that counts as moving, rad/s (≥ 0).
    pub min_speed_rad_s: f32,
    /// Consecutive control steps of "driven but not moving" before the fault (≥ 1).
    pub timeout_steps: u32,
}

/// The supervisor's settings. Times are in control steps (1 ms at 1 kHz).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct SupervisorConfig {
    /// Mode the robot is in after a reset (a long press selects the other one).
    pub initial_mode: RunMode,
    /// Pose (world frame, m and rad) the odometry is reset to each time the robot is armed
    /// in [`RunMode::FollowPath`]: where the robot is put down before pressing the button.
    pub start_pose: Pose,
    /// Wheel speeds held in [`RunMode::HoldWheelSpeeds`], rad/s.
    pub hold_speeds: WheelSpeeds,
    /// Steps the button level must be stable before a press or release counts (≥ 1).
    pub debounce_steps: u32,
    /// Steps a press must last to count as long (> `debounce_steps`).
    pub long_press_steps: u32,
    /// Arm by itself this many steps after a power-on or pin reset (`None`: button only).
    /// Happens at most once per boot, never after a watchdog or software reset, and not
    /// once the button has been used.
    pub auto_arm_after_steps: Option<u32>,
    /// Disarm after this many steps armed (`None`: no limit).
    pub max_armed_steps: Option<u32>,
    /// This many overrun steps in a row are a fault and stop the watchdog feeding (≥ 1).
    pub max_consecutive_overruns: u32,
    /// Steps without a change of the background heartbeat before the watchdog is starved
    /// (≥ 1).
    pub background_timeout_steps: u32,
    /// Stall / polarity detection.
    pub stall: StallCheck,
}

impl SupervisorConfig {
    /// Defaults for a loop at `control_rate_hz` (Hz): 20 ms debounce, 1 s long press, no
    /// auto-arm, no run limit, 5 overruns in a row, 500 ms background timeout, and a stall
    /// after 500 ms at ≥ 60 % duty below 1 rad/s. Starts in [`RunMode::FollowPath`] from
    /// `start_pose` (world frame, m and rad); `hold_speeds` in rad/s.
    pub const fn at_rate(control_rate_hz: u32, start_pose: Pose, hold_speeds: WheelSpeeds) -> Self {
        let debounce_steps = ms_to_steps(control_rate_hz, 20);
        let long_press_steps = ms_to_steps(control_rate_hz, 1000);
        Self {
            initial_mode: RunMode::FollowPath,
            start_pose,
            hold_speeds,
            debounce_steps,
            long_press_steps: if long_press_steps > debounce_steps {
                long_press_steps
            } else {
                debounce_steps + 1
            },
            auto_arm_after_steps: None,
            max_armed_steps: None,
            max_consecutive_overruns: 5,
            background_timeout_steps: ms_to_steps(control_rate_hz, 500),
            stall: StallCheck {
                min_duty: 0.6,
                min_speed_rad_s: 1.0,
                timeout_steps: ms_to_steps(control_rate_hz, 500),
            },
        }
    }

    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), SupervisorConfigError> {
        use SupervisorConfigError as E;
        if !self.start_pose.is_finite() {
            return Err(E::NonFiniteStartPose);
        }
        if !(self.hold_speeds.left_rad_s.is_finite() && self.hold_speeds.right_rad_s.is_finite()) {
            return Err(E::NonFiniteHoldSpeeds);
        }
        if self.debounce_steps == 0 || self.long_press_steps <= self.debounce_steps {
            return Err(E::BadButtonTiming);
        }
        if self.max_consecutive_overruns == 0 {
            return Err(E::ZeroOverrunLimit);
        }
        if self.background_timeout_steps == 0 {
            return Err(E::ZeroBackgroundTimeout);
        }
        let s = &self.stall;
        let duty_ok = s.min_duty > 0.0 && s.min_duty <= 1.0;
        let speed_ok = s.min_speed_rad_s >= 0.0 && s.min_speed_rad_s.is_finite();
        if !(duty_ok && speed_ok) || s.timeout_steps == 0 {
            return Err(E::BadStallCheck);
        }
        Ok(())
    }
}

/// Steps of a `rate_hz` loop in `ms` milliseconds, rounded down, at least 1.
const fn ms_to_steps(rate_hz: u32, ms: u32) -> u32 {
    let steps = rate_hz as u64 * ms as u64 / 1000;
    if steps == 0 {
        1
    } else if steps > u32::MAX as u64 {
        u32::MAX
    } else {
        steps as u32
    }
}

/// Why a [`SupervisorConfig`] was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum SupervisorConfigError {
    /// `start_pose` has a NaN or infinite field.
    NonFiniteStartPose,
    /// `hold_speeds` has a NaN or infinite field.
    NonFiniteHoldSpeeds,
    /// `debounce_steps` was 0 or `long_press_steps` ≤ `debounce_steps`.
    BadButtonTiming,
    /// `max_consecutive_overruns` was 0.
    ZeroOverrunLimit,
    /// `background_timeout_steps` was 0.
    ZeroBackgroundTimeout,
    /// `stall.min_duty` outside (0, 1], `stall.min_speed_rad_s` < 0 or not finite, or
    /// `stall.timeout_steps` 0.
    BadStallCheck,
}

/// Faults latched by the supervisor. Any flag set means the robot is [`State::Faulted`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct Faults {
    /// The controller's own latched faults (encoder jump, non-finite value).
    pub core: FaultFlags,
    /// The control loop overran its period too many times in a row.
    pub overrun: bool,
    /// The left wheel did not follow its drive (see [`StallCheck`]).
    pub stall_left: bool,
    /// The right wheel did not follow its drive (see [`StallCheck`]).
    pub stall_right: bool,
}

impl Faults {
    /// True when any fault is latched.
    pub const fn any(&self) -> bool {
        self.core.any() || self.overrun || self.stall_left || self.stall_right
    }
}

/// Why the robot left [`State::Armed`] without a fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum DisarmReason {
    /// The button was pressed.
    Button,
    /// [`SupervisorConfig::max_armed_steps`] ran out.
    Timeout,
}

/// A state change, reported once in the step it happened (for the log).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum Event {
    /// Motors armed in this mode.
    Armed(RunMode),
    /// Motors disarmed.
    Disarmed(DisarmReason),
    /// A fault stopped the motors; the flags are in [`Supervised::faults`].
    Faulted,
    /// A press acknowledged the faults; the robot is Disarmed.
    FaultsCleared,
    /// A long press selected this mode for the next arming.
    ModeSelected(RunMode),
}

/// What the firmware reads each step, besides the controller.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct Inputs {
    /// Encoder ticks since the previous step, forward positive.
    pub ticks: TickDeltas,
    /// Raw (undebounced) button level, true while pressed.
    pub button_pressed: bool,
    /// True when the previous step was still running when this period began.
    pub overrun: bool,
    /// A counter the background work increments (any change proves it runs).
    pub background_heartbeat: u32,
}

/// What the supervisor decided in one step.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct Supervised {
    /// Duties to write now, each in [−1, 1]; exactly 0 unless Armed.
    pub duty: MotorCommand,
    /// Level of the motor driver's enable line (TB6612 STBY, DRV8833 nSLEEP): true only
    /// while Armed.
    pub driver_enabled: bool,
    /// Feed the watchdog in this step (see the module doc for the rule).
    pub feed_watchdog: bool,
    /// State after this step.
    pub state: State,
    /// Mode used when armed.
    pub run_mode: RunMode,
    /// Latched faults.
    pub faults: Faults,
    /// Overrun steps since boot (saturating).
    pub overruns_total: u32,
    /// The state change of this step, if any.
    pub event: Option<Event>,
    /// The controller's duties of this step, before the supervisor zeroed anything (its
    /// telemetry is [`Controller::telemetry`]).
    pub controller_duty: MotorCommand,
}

/// What the debounced button did in one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Press {
    /// A press began (debounced).
    Down,
    /// The press has lasted `long_press_steps`.
    Long,
    /// The press ended (debounced); `long` if it reached `long_press_steps`.
    Up { long: bool },
}

/// Debounces a raw button level sampled once per step.
#[derive(Clone, Copy, Debug)]
struct Debouncer {
    /// Debounced level.
    pressed: bool,
    /// Steps the raw level has differed from `pressed`.
    changing_steps: u32,
    /// Steps the debounced press has lasted.
    held_steps: u32,
}

impl Debouncer {
    const fn new() -> Self {
        Self {
            pressed: false,
            changing_steps: 0,
            held_steps: 0,
        }
    }

    fn update(&mut self, raw: bool, debounce_steps: u32, long_press_steps: u32) -> Option<Press> {
        if raw == self.pressed {
            self.changing_steps = 0;
        } else {
            self.changing_steps += 1;
            if self.changing_steps >= debounce_steps {
                self.changing_steps = 0;
                self.pressed = raw;
                if raw {
                    // The press began `debounce_steps` ago.
                    self.held_steps = debounce_steps;
                    return Some(Press::Down);
                }
                return Some(Press::Up {
                    long: self.held_steps >= long_press_steps,
                });
            }
        }
        if self.pressed {
            let before = self.held_steps;
            self.held_steps = self.held_steps.saturating_add(1);
            if before < long_press_steps && self.held_steps >= long_press_steps {
                return Some(Press::Long);
            }
        }
        None
    }
}

/// The firmware's safety state machine (see the module doc).
#[derive(Clone, Debug)]
pub struct Supervisor {
    config: SupervisorConfig,
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
    consecutive_overruns: u32,
    overruns_total: u32,
    last_heartbeat: Option<u32>,
    steps_since_heartbeat: u32,
    /// Consecutive "driven but not moving" steps, left and right.
    stall_steps: [u32; 2],
}

impl Supervisor {
    /// A supervisor with `config`, after a reset caused by `reset`. It starts
    /// [`State::Disarmed`] whatever the cause.
    pub fn new(config: SupervisorConfig, reset: ResetCause) -> Result<Self, SupervisorConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            state: State::Disarmed,
            run_mode: config.initial_mode,
            faults: Faults::default(),
            button: Debouncer::new(),
            press_consumed: false,
            auto_arm_pending: config.auto_arm_after_steps.is_some() && reset.allows_auto_arm(),
            steps_since_boot: 0,
            armed_steps: 0,
            consecutive_overruns: 0,
            overruns_total: 0,
            last_heartbeat: None,
            steps_since_heartbeat: 0,
            stall_steps: [0; 2],
        })
    }

    /// The settings in use.
    pub const fn config(&self) -> &SupervisorConfig {
        &self.config
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

    /// One control period: processes `input`, sets `controller`'s mode, steps it with
    /// `input.ticks`, checks the result and returns what the motors, the driver's enable
    /// line and the watchdog get.
    pub fn step(&mut self, controller: &mut Controller, input: Inputs) -> Supervised {
        self.steps_since_boot = self.steps_since_boot.saturating_add(1);
        self.track_liveness(input);

        // 1. The operator (button, auto-arm) and the run timeout.
        let mut event = self.handle_button(input.button_pressed, controller);
        if event.is_none() {
            event = self.handle_timers(controller);
        }

        // 2. The controller runs in the mode the state allows.
        let mode = match (self.state, self.run_mode) {
            (State::Armed, RunMode::FollowPath) => Mode::FollowPath,
            (State::Armed, RunMode::HoldWheelSpeeds) => {
                Mode::HoldWheelSpeeds(self.config.hold_speeds)
            }
            (State::Disarmed | State::Faulted, _) => Mode::Idle,
        };
        controller.set_mode(mode);
        let controller_duty = controller.step(input.ticks);

        // 3. Faults, whatever the state.
        self.faults.core = controller.faults();
        let duty_ok = [controller_duty.left, controller_duty.right]
            .iter()
            .all(|d| d.is_finite() && math::abs(*d) <= 1.0);
        if !duty_ok {
            self.faults.core.non_finite = true;
        }
        if self.consecutive_overruns >= self.config.max_consecutive_overruns {
            self.faults.overrun = true;
        }
        if self.state == State::Armed {
            self.check_stall(controller_duty, controller.telemetry());
        } else {
            self.stall_steps = [0; 2];
        }
        if self.faults.any() && self.state != State::Faulted {
            self.state = State::Faulted;
            self.auto_arm_pending = false;
            event = Some(Event::Faulted);
        }

        // 4. Outputs.
        let armed = self.state == State::Armed;
        let duty = if armed {
            controller_duty
        } else {
            MotorCommand::STOP
        };
        Supervised {
            duty,
            driver_enabled: armed,
            feed_watchdog: self.watchdog_may_be_fed(),
            state: self.state,
            run_mode: self.run_mode,
            faults: self.faults,
            overruns_total: self.overruns_total,
            event,
            controller_duty,
        }
    }

    /// The watchdog-feeding rule (module doc): the loop is not late and the background runs.
    fn watchdog_may_be_fed(&self) -> bool {
        self.consecutive_overruns < self.config.max_consecutive_overruns
            && self.steps_since_heartbeat < self.config.background_timeout_steps
    }

    fn track_liveness(&mut self, input: Inputs) {
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

    fn handle_button(&mut self, raw: bool, controller: &mut Controller) -> Option<Event> {
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
            (Press::Long, State::Disarmed) if !self.press_consumed => {
                self.press_consumed = true;
                self.run_mode = self.run_mode.other();
                Some(Event::ModeSelected(self.run_mode))
            }
            (Press::Long, _) => None,
            (Press::Up { .. }, _) if self.press_consumed => {
                self.press_consumed = false;
                None
            }
            (Press::Up { long: false }, State::Disarmed) => Some(self.arm(controller)),
            (Press::Up { long: false }, State::Faulted) => {
                self.faults = Faults::default();
                self.consecutive_overruns = 0;
                controller.clear_faults();
                self.state = State::Disarmed;
                Some(Event::FaultsCleared)
            }
            (Press::Up { .. }, _) => None,
        }
    }

    fn handle_timers(&mut self, controller: &mut Controller) -> Option<Event> {
        match self.state {
            State::Disarmed if self.auto_arm_pending => {
                let due = self.config.auto_arm_after_steps.unwrap_or(u32::MAX);
                if self.steps_since_boot >= due && !self.button.pressed {
                    Some(self.arm(controller))
                } else {
                    None
                }
            }
            State::Armed => {
                self.armed_steps = self.armed_steps.saturating_add(1);
                match self.config.max_armed_steps {
                    Some(max) if self.armed_steps >= max => {
                        self.disarm(controller);
                        Some(Event::Disarmed(DisarmReason::Timeout))
                    }
                    _ => None,
                }
            }
            State::Disarmed | State::Faulted => None,
        }
    }

    fn arm(&mut self, controller: &mut Controller) -> Event {
        self.auto_arm_pending = false;
        self.state = State::Armed;
        self.armed_steps = 0;
        self.stall_steps = [0; 2];
        if self.run_mode == RunMode::FollowPath {
            // The robot has been put down at the start; forget where odometry drifted to
            // while it was carried. Leaving Idle for FollowPath restarts the reference.
            controller.set_pose(self.config.start_pose);
        }
        Event::Armed(self.run_mode)
    }

    fn disarm(&mut self, controller: &mut Controller) {
        self.state = State::Disarmed;
        controller.set_mode(Mode::Idle);
    }

    fn check_stall(&mut self, duty: MotorCommand, telemetry: &Telemetry) {
        let check = self.config.stall;
        let wheels = [
            (duty.left, telemetry.wheel_speed.left_rad_s),
            (duty.right, telemetry.wheel_speed.right_rad_s),
        ];
        for (count, (duty, speed)) in self.stall_steps.iter_mut().zip(wheels) {
            let driven = math::abs(duty) >= check.min_duty;
            let direction = if duty >= 0.0 { 1.0 } else { -1.0 };
            if driven && speed * direction < check.min_speed_rad_s {
                *count = count.saturating_add(1);
            } else {
                *count = 0;
            }
        }
        if self.stall_steps[0] >= check.timeout_steps {
            self.faults.stall_left = true;
        }
        if self.stall_steps[1] >= check.timeout_steps {
            self.faults.stall_right = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOLD: WheelSpeeds = WheelSpeeds {
        left_rad_s: 5.0,
        right_rad_s: 5.0,
    };
    const START: Pose = Pose {
        x_m: 0.0,
        y_m: -0.2,
        theta_rad: 0.0,
    };

    fn controller() -> Controller {
        crate::controller::tests::on_a_line(3.0)
    }

    fn config() -> SupervisorConfig {
        SupervisorConfig::at_rate(1000, START, HOLD)
    }

    /// A supervisor and a controller, with a fake world: each step the heartbeat moves,
    /// and in `moving` the wheels turn at the held speed (5 rad/s ≈ 1.15 ticks/ms).
    struct Rig {
        sup: Supervisor,
        ctl: Controller,
        heartbeat: u32,
        button: bool,
        overrun: bool,
        background_alive: bool,
        moving: bool,
        ticks_acc: f32,
        steps: u32,
    }

    impl Rig {
        fn new(config: SupervisorConfig, reset: ResetCause) -> Self {
            Self {
                sup: Supervisor::new(config, reset).unwrap(),
                ctl: controller(),
                heartbeat: 0,
                button: false,
                overrun: false,
                background_alive: true,
                moving: false,
                ticks_acc: 0.0,
                steps: 0,
            }
        }

        fn step_with(&mut self, ticks: TickDeltas) -> Supervised {
            if self.background_alive {
                self.heartbeat = self.heartbeat.wrapping_add(1);
            }
            self.steps += 1;
            let input = Inputs {
                ticks,
                button_pressed: self.button,
                overrun: self.overrun,
                background_heartbeat: self.heartbeat,
            };
            self.sup.step(&mut self.ctl, input)
        }

        fn step(&mut self) -> Supervised {
            let mut ticks = TickDeltas::default();
            if self.moving {
                // 5 rad/s × 1 ms / (2π / 1440 rad per tick) ≈ 1.146 ticks per step.
                self.ticks_acc += 5.0 * 0.001 * 1440.0 / core::f32::consts::TAU;
                let whole = self.ticks_acc as i32;
                self.ticks_acc -= whole as f32;
                ticks = TickDeltas {
                    left: whole,
                    right: whole,
                };
            }
            self.step_with(ticks)
        }

        /// Runs `n` steps, returning every output.
        fn run(&mut self, n: u32) -> Vec<Supervised> {
            (0..n).map(|_| self.step()).collect()
        }

        /// Presses for `held` steps then releases for 50 steps; returns all outputs.
        fn press(&mut self, held: u32) -> Vec<Supervised> {
            self.button = true;
            let mut out = self.run(held);
            self.button = false;
            out.extend(self.run(50));
            out
        }
    }

    fn events(outs: &[Supervised]) -> Vec<Event> {
        outs.iter().filter_map(|o| o.event).collect()
    }

    fn rig() -> Rig {
        Rig::new(config(), ResetCause::PowerOn)
    }

    #[test]
    fn starts_disarmed_with_motors_off_and_feeds_the_watchdog() {
        let mut r = rig();
        for out in r.run(3000) {
            assert_eq!(out.state, State::Disarmed);
            assert_eq!(out.duty, MotorCommand::STOP);
            assert!(!out.driver_enabled);
            assert!(out.feed_watchdog);
            assert_eq!(out.event, None);
        }
        assert_eq!(r.ctl.mode(), Mode::Idle);
    }

    #[test]
    fn starts_disarmed_after_any_reset_cause() {
        for cause in [
            ResetCause::PowerOn,
            ResetCause::Pin,
            ResetCause::Watchdog,
            ResetCause::Software,
            ResetCause::LowPower,
            ResetCause::Unknown,
        ] {
            let mut c = config();
            c.auto_arm_after_steps = Some(10);
            let sup = Supervisor::new(c, cause).unwrap();
            assert_eq!(sup.state(), State::Disarmed);
        }
    }

    #[test]
    fn short_press_arms_on_release_in_the_initial_mode() {
        let mut r = rig();
        r.button = true;
        // Still disarmed while the button is held.
        for out in r.run(200) {
            assert_eq!(out.state, State::Disarmed);
        }
        r.button = false;
        let outs = r.run(50);
        assert_eq!(events(&outs), vec![Event::Armed(RunMode::FollowPath)]);
        let last = outs.last().unwrap();
        assert_eq!(last.state, State::Armed);
        assert!(last.driver_enabled);
        assert_eq!(r.ctl.mode(), Mode::FollowPath);
        // The line is ahead: the robot drives forward.
        assert!(last.duty.left > 0.0 && last.duty.right > 0.0);
        assert_eq!(last.duty, last.controller_duty);
    }

    #[test]
    fn arming_into_path_following_resets_odometry_to_the_start_pose() {
        let mut r = rig();
        // Odometry drifts while the robot is carried to the start.
        for _ in 0..100 {
            r.step_with(TickDeltas { left: 3, right: 1 });
        }
        assert!(r.ctl.pose().x_m > 0.01);
        r.press(30);
        let pose = r.ctl.pose();
        assert!((pose.y_m - START.y_m).abs() < 0.01, "{pose:?}");
        assert!(pose.x_m.abs() < 0.05, "{pose:?}");
    }

    #[test]
    fn bounces_shorter_than_the_debounce_time_do_nothing() {
        let mut r = rig();
        for _ in 0..50 {
            r.button = true;
            r.run(5);
            r.button = false;
            r.run(5);
        }
        assert_eq!(r.sup.state(), State::Disarmed);
    }

    #[test]
    fn press_disarms_at_once_and_its_release_does_not_rearm() {
        let mut r = rig();
        r.press(30);
        assert_eq!(r.sup.state(), State::Armed);
        r.button = true;
        let outs = r.run(30);
        // Disarmed as soon as the press is debounced (20 steps), with the button still down.
        let at = outs
            .iter()
            .position(|o| o.state == State::Disarmed)
            .unwrap();
        assert_eq!(at, 19);
        assert_eq!(outs[at].event, Some(Event::Disarmed(DisarmReason::Button)));
        assert_eq!(outs[at].duty, MotorCommand::STOP);
        assert!(!outs[at].driver_enabled);
        r.button = false;
        assert!(r.run(200).iter().all(|o| o.state == State::Disarmed));
        assert_eq!(r.ctl.mode(), Mode::Idle);
    }

    #[test]
    fn long_press_while_disarmed_switches_mode_without_arming() {
        let mut r = rig();
        let outs = r.press(1200);
        assert_eq!(
            events(&outs),
            vec![Event::ModeSelected(RunMode::HoldWheelSpeeds)]
        );
        assert_eq!(r.sup.state(), State::Disarmed);
        // A short press now arms into wheel-speed hold.
        let outs = r.press(30);
        assert_eq!(events(&outs), vec![Event::Armed(RunMode::HoldWheelSpeeds)]);
        assert_eq!(r.ctl.mode(), Mode::HoldWheelSpeeds(HOLD));
        assert!(outs.last().unwrap().duty.left > 0.0);
        // Disarm, and a second long press goes back to path following.
        r.press(30);
        let outs = r.press(1200);
        assert_eq!(
            events(&outs),
            vec![Event::ModeSelected(RunMode::FollowPath)]
        );
    }

    #[test]
    fn long_press_while_armed_only_disarms() {
        let mut r = rig();
        r.press(30);
        let outs = r.press(1500);
        assert_eq!(events(&outs), vec![Event::Disarmed(DisarmReason::Button)]);
        assert_eq!(r.sup.run_mode(), RunMode::FollowPath);
    }

    #[test]
    fn core_fault_stops_the_motors_until_acknowledged() {
        let mut r = rig();
        r.press(30);
        assert!(r.step().duty.left > 0.0);
        let out = r.step_with(TickDeltas {
            left: 10_000,
            right: 0,
        });
        assert_eq!(out.event, Some(Event::Faulted));
        assert_eq!(out.state, State::Faulted);
        assert!(out.faults.core.encoder_jump);
        assert_eq!(out.duty, MotorCommand::STOP);
        assert!(!out.driver_enabled);
        // Latched, still fed (the fault is handled; a reset would hide it).
        for out in r.run(500) {
            assert_eq!(out.state, State::Faulted);
            assert_eq!(out.duty, MotorCommand::STOP);
            assert!(out.feed_watchdog);
        }
        // A press acknowledges: Disarmed, not Armed.
        let outs = r.press(30);
        assert_eq!(events(&outs), vec![Event::FaultsCleared]);
        assert_eq!(r.sup.state(), State::Disarmed);
        assert!(!r.sup.faults().any());
        assert!(!r.ctl.faults().any());
        // A second press arms again.
        r.press(30);
        assert_eq!(r.sup.state(), State::Armed);
    }

    #[test]
    fn fault_while_disarmed_is_latched_too() {
        let mut r = rig();
        let out = r.step_with(TickDeltas {
            left: 0,
            right: -10_000,
        });
        assert_eq!(out.state, State::Faulted);
        // A press only acknowledges, it does not arm.
        r.press(30);
        assert_eq!(r.sup.state(), State::Disarmed);
    }

    #[test]
    fn non_finite_pose_is_a_fault() {
        let mut r = rig();
        r.press(30);
        r.ctl.set_pose(Pose {
            x_m: f32::NAN,
            y_m: 0.0,
            theta_rad: 0.0,
        });
        let out = r.step();
        assert_eq!(out.state, State::Faulted);
        assert!(out.faults.core.non_finite);
        assert_eq!(out.duty, MotorCommand::STOP);
    }

    #[test]
    fn sporadic_overruns_are_counted_but_tolerated() {
        let mut r = rig();
        r.press(30);
        for _ in 0..10 {
            r.overrun = true;
            let out = r.step();
            assert!(out.feed_watchdog);
            r.overrun = false;
            r.run(10);
        }
        let out = r.step();
        assert_eq!(out.state, State::Armed);
        assert_eq!(out.overruns_total, 10);
    }

    #[test]
    fn consecutive_overruns_fault_and_starve_the_watchdog() {
        let mut r = rig();
        r.press(30);
        r.overrun = true;
        let outs = r.run(5);
        assert!(outs[..4].iter().all(|o| o.feed_watchdog));
        assert!(outs[..4].iter().all(|o| o.state == State::Armed));
        let last = outs[4];
        assert!(!last.feed_watchdog);
        assert!(last.faults.overrun);
        assert_eq!(last.state, State::Faulted);
        assert_eq!(last.duty, MotorCommand::STOP);
        // The loop recovers: feeding resumes, the fault stays latched.
        r.overrun = false;
        let out = r.step();
        assert!(out.feed_watchdog);
        assert_eq!(out.state, State::Faulted);
    }

    #[test]
    fn starved_background_stops_the_feeding_but_not_the_motors() {
        let mut r = rig();
        // Hold mode, where the fake world turns the wheels at the held speed.
        r.long_press_to_hold();
        r.press(30);
        r.moving = true;
        r.background_alive = false;
        let outs = r.run(600);
        // Heartbeat last changed at step 0 of this run: the 500th unchanged step starves.
        assert!(outs[..499].iter().all(|o| o.feed_watchdog));
        assert!(outs[499..].iter().all(|o| !o.feed_watchdog));
        // The watchdog, not the supervisor, deals with it: the motors still run until reset.
        assert_eq!(outs[599].state, State::Armed, "{:?}", outs[599].faults);
        r.background_alive = true;
        assert!(r.step().feed_watchdog);
    }

    #[test]
    fn a_wheel_that_does_not_turn_is_a_stall_fault() {
        let mut c = config();
        c.stall.min_duty = 0.1;
        let mut r = Rig::new(c, ResetCause::PowerOn);
        r.long_press_to_hold();
        r.press(30);
        assert_eq!(r.sup.state(), State::Armed);
        // Wheels blocked: no ticks while the PID pushes.
        let outs = r.run(1000);
        let at = outs
            .iter()
            .position(|o| o.state == State::Faulted)
            .expect("stall detected");
        assert!(at < 600, "stall at step {at}");
        assert!(outs[at].faults.stall_left && outs[at].faults.stall_right);
        assert_eq!(outs[at].duty, MotorCommand::STOP);
    }

    #[test]
    fn a_wheel_that_turns_is_not_a_stall() {
        let mut c = config();
        c.stall.min_duty = 0.1;
        let mut r = Rig::new(c, ResetCause::PowerOn);
        r.long_press_to_hold();
        r.moving = true;
        r.press(30);
        let outs = r.run(3000);
        assert!(outs.iter().all(|o| o.state == State::Armed));
        assert!(outs.last().unwrap().duty.left >= 0.1);
    }

    impl Rig {
        fn long_press_to_hold(&mut self) {
            self.press(1200);
            assert_eq!(self.sup.run_mode(), RunMode::HoldWheelSpeeds);
        }
    }

    #[test]
    fn auto_arm_after_power_on_only_once() {
        let mut c = config();
        c.auto_arm_after_steps = Some(2000);
        let mut r = Rig::new(c, ResetCause::PowerOn);
        let outs = r.run(2100);
        let at = outs.iter().position(|o| o.state == State::Armed).unwrap();
        assert_eq!(at, 1999);
        assert_eq!(outs[at].event, Some(Event::Armed(RunMode::FollowPath)));
        // Disarmed by the button: stays disarmed.
        r.press(30);
        assert!(r.run(5000).iter().all(|o| o.state == State::Disarmed));
    }

    #[test]
    fn no_auto_arm_after_a_watchdog_or_software_reset() {
        for cause in [ResetCause::Watchdog, ResetCause::Software] {
            let mut c = config();
            c.auto_arm_after_steps = Some(100);
            let mut r = Rig::new(c, cause);
            assert!(r.run(1000).iter().all(|o| o.state == State::Disarmed));
        }
    }

    #[test]
    fn using_the_button_cancels_auto_arm() {
        let mut c = config();
        c.auto_arm_after_steps = Some(2000);
        let mut r = Rig::new(c, ResetCause::Pin);
        r.press(1200); // long press: mode switch only
        assert!(r.run(3000).iter().all(|o| o.state == State::Disarmed));
    }

    #[test]
    fn run_timeout_disarms() {
        let mut c = config();
        c.max_armed_steps = Some(1000);
        // The wheels do not turn in this rig: keep the stall check out of the way.
        c.stall.timeout_steps = u32::MAX;
        let mut r = Rig::new(c, ResetCause::PowerOn);
        let mut outs = r.press(30);
        outs.extend(r.run(1100));
        let armed = outs.iter().filter(|o| o.state == State::Armed).count();
        assert_eq!(armed, 1000);
        assert_eq!(
            events(&outs),
            vec![
                Event::Armed(RunMode::FollowPath),
                Event::Disarmed(DisarmReason::Timeout)
            ]
        );
    }

    #[test]
    fn reset_cause_decoding() {
        let f = |set: fn(&mut ResetFlags)| {
            let mut flags = ResetFlags {
                pin: true,
                ..ResetFlags::default()
            };
            set(&mut flags);
            ResetCause::from_flags(flags)
        };
        assert_eq!(f(|_| {}), ResetCause::Pin);
        assert_eq!(f(|x| x.power_on = true), ResetCause::PowerOn);
        assert_eq!(f(|x| x.brown_out = true), ResetCause::PowerOn);
        assert_eq!(
            f(|x| {
                x.power_on = true;
                x.independent_watchdog = true;
            }),
            ResetCause::Watchdog
        );
        assert_eq!(f(|x| x.window_watchdog = true), ResetCause::Watchdog);
        assert_eq!(f(|x| x.software = true), ResetCause::Software);
        assert_eq!(f(|x| x.low_power = true), ResetCause::LowPower);
        assert_eq!(
            ResetCause::from_flags(ResetFlags::default()),
            ResetCause::Unknown
        );
        assert!(ResetCause::PowerOn.allows_auto_arm() && ResetCause::Pin.allows_auto_arm());
        assert!(!ResetCause::Watchdog.allows_auto_arm());
    }

    #[test]
    fn config_validation_names_the_problem() {
        let bad = |f: fn(&mut SupervisorConfig)| {
            let mut c = config();
            f(&mut c);
            Supervisor::new(c, ResetCause::PowerOn).unwrap_err()
        };
        use SupervisorConfigError as E;
        assert_eq!(bad(|c| c.start_pose.x_m = f32::NAN), E::NonFiniteStartPose);
        assert_eq!(
            bad(|c| c.hold_speeds.left_rad_s = f32::INFINITY),
            E::NonFiniteHoldSpeeds
        );
        assert_eq!(bad(|c| c.debounce_steps = 0), E::BadButtonTiming);
        assert_eq!(bad(|c| c.long_press_steps = 20), E::BadButtonTiming);
        assert_eq!(bad(|c| c.max_consecutive_overruns = 0), E::ZeroOverrunLimit);
        assert_eq!(
            bad(|c| c.background_timeout_steps = 0),
            E::ZeroBackgroundTimeout
        );
        assert_eq!(bad(|c| c.stall.min_duty = 0.0), E::BadStallCheck);
        assert_eq!(bad(|c| c.stall.min_speed_rad_s = -1.0), E::BadStallCheck);
        assert_eq!(bad(|c| c.stall.timeout_steps = 0), E::BadStallCheck);
        assert!(config().validate().is_ok());
    }

    #[test]
    fn defaults_scale_with_the_rate() {
        let c = SupervisorConfig::at_rate(500, START, HOLD);
        assert_eq!(c.debounce_steps, 10);
        assert_eq!(c.long_press_steps, 500);
        // Even at an absurd 1 Hz the defaults are valid.
        assert!(SupervisorConfig::at_rate(1, START, HOLD).validate().is_ok());
    }
}
