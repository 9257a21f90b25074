//! The fixed-step cascade: encoder ticks in, motor commands and telemetry out.
//!
//! ```text
//! ticks ─► odometry ─► pose ─┐                        every step (inner loop, T)
//!      └─► speed estimate ───┼──────────────┐
//! reference ─► steering law ─► limits ─► inverse kinematics ─► set-points
//!                            every `steering_divider` steps     │
//!                                         incremental PID × 2 ◄─┘ ─► duty in [−1, 1]
//! ```
//!
//! [`Controller::step`] is the whole of it: call it once per period T with the signed tick
//! deltas of that period, apply the duties it returns, and read [`Controller::telemetry`]
//! when you want to log or plot. It never panics and always returns duties in [−1, 1]. Faults
//! (an implausible tick jump, a non-finite value anywhere) latch: both duties are 0 until
//! [`Controller::clear_faults`].

use crate::encoder::SpeedEstimator;
use crate::kinematics::{BodyVelocity, Pose, TrackingError, WheelSpeeds};
use crate::law::{self, LawKind, LawOutput};
use crate::limits::{CommandLimiter, LimitFlags};
use crate::math;
use crate::odometry::Odometry;
use crate::params::Params;
use crate::pid::IncrementalPid;
use crate::reference::{Reference, ReferenceState};
use crate::time::StepClock;

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

/// Motor commands, each a signed fraction of full supply voltage in [−1, 1].
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
    /// Both motors off.
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
    /// Hold these wheel speeds (rad/s) with the wheel PIDs only (bring-up).
    HoldWheelSpeeds(WheelSpeeds),
}

/// Latched fault flags. Any flag set means both motors are commanded to 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct FaultFlags {
    /// A tick delta implied a wheel speed beyond `max_plausible_wheel_speed_rad_s`.
    pub encoder_jump: bool,
    /// A pose, command or duty became NaN or infinite.
    pub non_finite: bool,
}

impl FaultFlags {
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
    /// Index of this step since the controller was built.
    pub step: u32,
    /// True when the steering law ran in this step.
    pub steering_updated: bool,
    /// Odometry pose estimate, world frame.
    pub pose: Pose,
    /// Reference at the last steering update.
    pub reference: ReferenceState,
    /// Tracking error (9) at the last steering update, robot frame (a copy of `law.error`).
    pub error: TrackingError,
    /// The steering law's last output (command before limits, V, V̇, polar error).
    pub law: LawOutput,
    /// Body command after limits (v m/s, ω rad/s).
    pub command: BodyVelocity,
    /// What the limiter did to it.
    pub limit_flags: LimitFlags,
    /// Wheel-speed set-points, rad/s.
    pub wheel_setpoint: WheelSpeeds,
    /// Measured wheel speeds, rad/s.
    pub wheel_speed: WheelSpeeds,
    /// Motor duties sent, −1…1.
    pub duty: MotorCommand,
    /// Latched faults.
    pub faults: FaultFlags,
}

/// The whole control stack for one robot (see the module doc).
#[derive(Clone, Debug)]
pub struct Controller {
    params: Params,
    odometry: Odometry,
    speed: [SpeedEstimator; 2],
    pid: [IncrementalPid; 2],
    limiter: CommandLimiter,
    reference: Reference,
    law: LawKind,
    mode: Mode,
    /// Steps since the controller was built.
    steps: u32,
    /// Steps since path following (re)started: the time index of the reference.
    path_clock: StepClock,
    /// Latest telemetry; the state carried between steps (set-points, last law output).
    telemetry: Telemetry,
}

impl Controller {
    /// A controller for `params`, following `reference` with `law`, believing the robot
    /// starts at `start` (world frame). It starts in [`Mode::Idle`] (motors off).
    pub fn new(params: Params, reference: Reference, law: LawKind, start: Pose) -> Self {
        let steps_per_s = params.config().control_rate_hz as f32;
        let window = params.config().speed_window_steps as usize;
        let estimator = SpeedEstimator::new(window, params.rad_per_tick(), steps_per_s);
        let pid = IncrementalPid::new(params.wheel_pid(), 1.0);
        Self {
            odometry: Odometry::new(params.geometry(), params.rad_per_tick(), start),
            speed: [estimator.clone(), estimator],
            pid: [pid, pid],
            limiter: CommandLimiter::new(params.config().limits),
            reference,
            law,
            mode: Mode::Idle,
            steps: 0,
            path_clock: StepClock::new(params.config().control_rate_hz),
            telemetry: Telemetry {
                pose: start,
                ..Telemetry::default()
            },
            params,
        }
    }

    /// The parameters in use.
    pub const fn params(&self) -> &Params {
        &self.params
    }

    /// The current mode.
    pub const fn mode(&self) -> Mode {
        self.mode
    }

    /// The steering law in use.
    pub const fn law(&self) -> LawKind {
        self.law
    }

    /// The reference being followed.
    pub const fn reference(&self) -> &Reference {
        &self.reference
    }

    /// Odometry pose estimate, world frame.
    pub const fn pose(&self) -> Pose {
        self.odometry.pose()
    }

    /// Latched faults.
    pub const fn faults(&self) -> FaultFlags {
        self.telemetry.faults
    }

    /// The telemetry of the last step.
    pub const fn telemetry(&self) -> &Telemetry {
        &self.telemetry
    }

    /// Switches mode. Entering [`Mode::FollowPath`] restarts the reference's time index
    /// and progress; any change restarts the PIDs and the limiter from the measured state,
    /// so the command does not jump.
    pub fn set_mode(&mut self, mode: Mode) {
        if mode == self.mode {
            return;
        }
        if mode == Mode::FollowPath {
            self.path_clock = StepClock::new(self.params.config().control_rate_hz);
            self.reference.restart();
        }
        self.mode = mode;
        self.restart_loops();
    }

    /// Selects another steering law (takes effect at the next steering step).
    pub fn set_law(&mut self, law: LawKind) {
        self.law = law;
    }

    /// Overwrites the odometry pose (world frame), e.g. from an external fix.
    pub fn set_pose(&mut self, pose: Pose) {
        self.odometry.set_pose(pose);
    }

    /// Clears latched faults. Speed history is dropped and the loops restart from rest.
    pub fn clear_faults(&mut self) {
        self.telemetry.faults = FaultFlags::default();
        for estimator in &mut self.speed {
            estimator.reset();
        }
        self.restart_loops();
    }

    fn restart_loops(&mut self) {
        let measured = self.telemetry.wheel_speed;
        for pid in &mut self.pid {
            pid.reset(0.0);
        }
        self.limiter.reset(self.params.geometry().forward(measured));
        self.telemetry.wheel_setpoint = match self.mode {
            Mode::HoldWheelSpeeds(speeds) => self.capped_wheel_speeds(speeds),
            // Until the first steering step, hold the wheels where they are.
            Mode::FollowPath => measured,
            Mode::Idle => WheelSpeeds::default(),
        };
        self.pid[0].prime(
            self.telemetry.wheel_setpoint.left_rad_s,
            measured.left_rad_s,
        );
        self.pid[1].prime(
            self.telemetry.wheel_setpoint.right_rad_s,
            measured.right_rad_s,
        );
    }

    /// Clamps each wheel to the rim-speed cap.
    fn capped_wheel_speeds(&self, speeds: WheelSpeeds) -> WheelSpeeds {
        let max =
            self.params.config().limits.max_rim_speed_m_s / self.params.geometry().wheel_radius_m();
        WheelSpeeds::new(
            math::clamp(speeds.left_rad_s, -max, max),
            math::clamp(speeds.right_rad_s, -max, max),
        )
    }

    /// One control period: `ticks` counted since the last call. Returns the duties to
    /// apply (in [−1, 1], 0 on any fault). What the step computed is in
    /// [`Controller::telemetry`], borrowed rather than copied out (on a Cortex-M4F the copy
    /// cost more than the wheel loop's arithmetic).
    pub fn step(&mut self, ticks: TickDeltas) -> MotorCommand {
        // Phase the steering loop on the path clock, so the law runs on the very first step
        // after path following (re)starts.
        let steering_due = self.path_clock.steps() % self.params.config().steering_divider == 0;
        // Telemetry is updated in place: it is the state carried between steps, and copying
        // it costs more than the arithmetic on a Cortex-M4F.
        let t = &mut self.telemetry;
        t.step = self.steps;
        t.steering_updated = false;

        let limit = self.params.max_ticks_per_step().unsigned_abs();
        if ticks.left.unsigned_abs() > limit || ticks.right.unsigned_abs() > limit {
            t.faults.encoder_jump = true;
        }

        if !t.faults.any() {
            t.pose = self.odometry.update(ticks.left, ticks.right);
            t.wheel_speed = WheelSpeeds::new(
                self.speed[0].update(ticks.left),
                self.speed[1].update(ticks.right),
            );
            if self.mode == Mode::FollowPath && steering_due {
                // The outer loop: reference, law, limits, inverse kinematics → set-points.
                let geometry = self.params.geometry();
                t.steering_updated = true;
                t.reference = self.reference.sample(&self.path_clock, &t.pose);
                t.law = law::steer(self.law, &self.params.config().law, &t.pose, &t.reference);
                t.error = t.law.error;
                let (command, flags) = self.limiter.apply(
                    t.law.command,
                    self.params.steering_period_s(),
                    geometry.track_width_m(),
                );
                t.command = command;
                t.limit_flags = flags;
                t.wheel_setpoint = geometry.inverse(command);
            }
            t.duty = match self.mode {
                Mode::Idle => MotorCommand::STOP,
                Mode::FollowPath | Mode::HoldWheelSpeeds(_) => MotorCommand {
                    left: self.pid[0].step(t.wheel_setpoint.left_rad_s, t.wheel_speed.left_rad_s),
                    right: self.pid[1]
                        .step(t.wheel_setpoint.right_rad_s, t.wheel_speed.right_rad_s),
                },
            };
            let finite = t.pose.is_finite()
                && t.duty.left.is_finite()
                && t.duty.right.is_finite()
                && t.wheel_setpoint.left_rad_s.is_finite()
                && t.wheel_setpoint.right_rad_s.is_finite();
            if !finite {
                t.faults.non_finite = true;
            }
        }
        if t.faults.any() {
            t.duty = MotorCommand::STOP;
            t.wheel_setpoint = WheelSpeeds::default();
        }

        self.steps = self.steps.wrapping_add(1);
        if self.mode == Mode::FollowPath {
            self.path_clock.tick();
        }
        self.telemetry.duty
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
        let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
        let path = Path::line(Point::new(0.0, 0.0), 0.0, length_m).unwrap();
        let reference = Reference::new(
            path,
            0.2,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap();
        Controller::new(params, reference, LawKind::Tracking, Pose::default())
    }

    fn controller() -> Controller {
        on_a_line(5.0)
    }

    #[test]
    fn idle_commands_nothing() {
        let mut c = controller();
        for _ in 0..100 {
            assert_eq!(c.step(TickDeltas { left: 1, right: 1 }), MotorCommand::STOP);
        }
        // Odometry still runs while idle.
        assert!(c.pose().x_m > 0.0);
    }

    #[test]
    fn follow_path_drives_forward() {
        let mut c = controller();
        c.set_mode(Mode::FollowPath);
        let duty = c.step(TickDeltas::default());
        assert!(c.telemetry().steering_updated);
        assert!(duty.left > 0.0 && duty.right > 0.0);
        assert!(!c.faults().any());
        // The steering law runs every `steering_divider` (10) steps, the PIDs every step.
        let pattern: Vec<bool> = (1..=20)
            .map(|_| {
                c.step(TickDeltas::default());
                c.telemetry().steering_updated
            })
            .collect();
        let expected: Vec<bool> = (1..=20).map(|k| k % 10 == 0).collect();
        assert_eq!(pattern, expected);
    }

    #[test]
    fn encoder_jump_latches_a_stop_until_cleared() {
        let mut c = controller();
        c.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(5.0, 5.0)));
        assert!(c.step(TickDeltas::default()).left > 0.0);
        let duty = c.step(TickDeltas {
            left: 10_000,
            right: 0,
        });
        assert!(c.faults().encoder_jump);
        assert_eq!(duty, MotorCommand::STOP);
        // Latched, even with sane input.
        assert_eq!(c.step(TickDeltas::default()), MotorCommand::STOP);
        c.clear_faults();
        let duty = c.step(TickDeltas::default());
        assert!(!c.faults().any());
        assert!(duty.left > 0.0);
    }

    #[test]
    fn hold_mode_caps_set_points_at_the_rim_speed_limit() {
        let mut c = controller();
        c.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(1000.0, -1000.0)));
        c.step(TickDeltas::default());
        let max = 1.0 / 0.0325;
        assert!((c.telemetry().wheel_setpoint.left_rad_s - max).abs() < 1e-3);
        assert!((c.telemetry().wheel_setpoint.right_rad_s + max).abs() < 1e-3);
    }

    proptest! {
        /// Any tick sequence, however absurd, gives duties that are finite and in [−1, 1].
        #[test]
        fn any_input_gives_bounded_finite_duty(
            ticks in prop::collection::vec(
                prop_oneof![
                    -50i32..50,
                    Just(i32::MIN), Just(i32::MAX), any::<i32>()
                ],
                1..300,
            ),
            law in prop::sample::select(LawKind::ALL.to_vec()),
            pose in prop::option::of((
                prop::num::f32::ANY, prop::num::f32::ANY, prop::num::f32::ANY
            )),
        ) {
            let mut c = controller();
            c.set_law(law);
            c.set_mode(Mode::FollowPath);
            // Also a pose fix that is NaN, infinite or huge.
            if let Some((x, y, th)) = pose {
                c.set_pose(Pose::new(x, y, th));
            }
            for pair in ticks.chunks(2) {
                let t = TickDeltas { left: pair[0], right: *pair.last().unwrap_or(&0) };
                let duty = c.step(t);
                for d in [duty.left, duty.right] {
                    prop_assert!(d.is_finite() && (-1.0..=1.0).contains(&d));
                }
                if !c.telemetry().pose.is_finite() {
                    prop_assert!(c.faults().non_finite);
                    prop_assert_eq!(duty, MotorCommand::STOP);
                }
            }
        }
    }
}
