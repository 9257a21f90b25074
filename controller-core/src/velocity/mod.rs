//! The velocity mode's command source: body-velocity commands (v, ω) from the link, with
//! the semantics of ros2_control's `diff_drive_controller`.
//!
//! In path following the body command comes from the reference and the steering law (the
//! outer loop, [`crate::outer_loop`]). In [`crate::controller::Mode::FollowVelocity`] it
//! comes from here instead, and everything below it is the same: the rim-speed cap that
//! keeps ω/v, the inverse kinematics, the wheel loops and their limits, the supervisor and
//! every fault check.
//!
//! ```text
//!  link: (v, ω) every ~50 ms ─► VelocitySource::command  (resets the timeout)
//!  every control step:  command in force (0 after cmd_vel_timeout) ─► rim-speed cap
//!      ─► per axis: velocity, acceleration and jerk limits ─► rim-speed cap ─► wheels
//! ```
//!
//! - **Timeout.** A command holds for [`VelocityModeConfig::cmd_vel_timeout_steps`] control
//!   periods after it arrived; then the command in force is zero and the limited command
//!   ramps to a stop within the acceleration and jerk limits. The robot stays armed (the
//!   link's heartbeat, not this timeout, decides that).
//! - **Limits**, per axis (`linear.x`, `angular.z`, named as `diff_drive_controller`'s
//!   parameters, symmetric: the minimum is the negated maximum): the command in force is
//!   clamped to the velocity limit; the limited command's acceleration changes by at most
//!   the jerk limit per second and stays within the acceleration limit; and it is
//!   planned so that it reaches the command without passing it (the acceleration is
//!   brought back to zero in time, at the jerk limit), so a step in the command gives an
//!   S-shaped ramp and no overshoot while the command holds.
//! - **Curvature.** The command in force is first scaled by the rim-speed cap
//!   ([`crate::limits::cap_rim_speed`], which keeps ω/v), so that both axes ramp to a
//!   reachable command; the limited command passes the same cap again, which matters
//!   only when the cap falls during the ramp (a sagging supply): the cap wins over the
//!   acceleration and jerk limits then, and the limiter continues from the capped
//!   command.
//!
//! The source runs in the control step itself, every period, not in the outer loop: it is
//! a few dozen floating-point operations, and handed over like the steering law's job it
//! would reach the wheels up to a steering period later. A command that arrives at a
//! step changes the limited command in that same step.

use crate::kinematics::BodyVelocity;
use crate::limits::{cap_rim_speed, LimitFlags};
use crate::math;
use crate::params::ParamError;

/// One axis's limits, symmetric about zero (`diff_drive_controller`'s `max_velocity`,
/// `max_acceleration`, `max_jerk`; its `min_*` are the negated values). Units are the
/// axis's: for `linear.x` m/s, m/s², m/s³; for `angular.z` rad/s, rad/s², rad/s³. Every
/// value must be finite and > 0.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct AxisLimits {
    /// Largest |velocity| (m/s or rad/s).
    pub max_velocity: f32,
    /// Largest |acceleration| (m/s² or rad/s²).
    pub max_acceleration: f32,
    /// Largest |jerk|, the change of acceleration per second (m/s³ or rad/s³).
    pub max_jerk: f32,
}

/// The velocity mode's settings: the limits of both axes and the command timeout.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct VelocityModeConfig {
    /// Forward speed v, robot frame (`linear.x.*`): m/s, m/s², m/s³.
    pub linear_x: AxisLimits,
    /// Yaw rate ω, counter-clockwise positive (`angular.z.*`): rad/s, rad/s², rad/s³.
    pub angular_z: AxisLimits,
    /// `cmd_vel_timeout` in control periods (≥ 1): a command holds this long after it
    /// arrived, then the command in force is zero.
    pub cmd_vel_timeout_steps: u32,
}

impl VelocityModeConfig {
    /// The defaults at a loop of `control_rate_hz` (Hz): 0.5 s timeout (as
    /// `diff_drive_controller`'s `cmd_vel_timeout`); v within 0.6 m/s, 1.5 m/s²,
    /// 15 m/s³; ω within 4 rad/s, 15 rad/s², 150 rad/s³.
    pub const fn at_rate(control_rate_hz: u32) -> Self {
        let steps = control_rate_hz as u64 / 2;
        Self {
            linear_x: AxisLimits {
                max_velocity: 0.6,
                max_acceleration: 1.5,
                max_jerk: 15.0,
            },
            angular_z: AxisLimits {
                max_velocity: 4.0,
                max_acceleration: 15.0,
                max_jerk: 150.0,
            },
            cmd_vel_timeout_steps: if steps == 0 {
                1
            } else if steps > u32::MAX as u64 {
                u32::MAX
            } else {
                steps as u32
            },
        }
    }
}

impl VelocityModeConfig {
    /// Every limit finite and > 0, the timeout at least one period; the error names the
    /// field (`velocity.linear_x.max_jerk`, …).
    pub(crate) fn validate(&self) -> Result<(), ParamError> {
        let axes = [
            (
                &self.linear_x,
                [
                    "velocity.linear_x.max_velocity",
                    "velocity.linear_x.max_acceleration",
                    "velocity.linear_x.max_jerk",
                ],
            ),
            (
                &self.angular_z,
                [
                    "velocity.angular_z.max_velocity",
                    "velocity.angular_z.max_acceleration",
                    "velocity.angular_z.max_jerk",
                ],
            ),
        ];
        for (axis, names) in axes {
            let values = [axis.max_velocity, axis.max_acceleration, axis.max_jerk];
            for (value, field) in values.into_iter().zip(names) {
                if !(value.is_finite() && value > 0.0) {
                    return Err(ParamError::NonPositive { field, value });
                }
            }
        }
        if self.cmd_vel_timeout_steps == 0 {
            return Err(ParamError::NonPositive {
                field: "velocity.cmd_vel_timeout_steps",
                value: 0.0,
            });
        }
        Ok(())
    }
}

/// One axis of the limited command: its velocity and acceleration (the axis's units).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxisState {
    /// Velocity (m/s or rad/s).
    pub velocity: f32,
    /// Acceleration over the last step (m/s² or rad/s²).
    pub acceleration: f32,
}

impl AxisState {
    /// Moves towards `target` over `dt_s` (s, > 0) within `limits`; true when the limits
    /// held it back (it is not at the target after the step).
    ///
    /// The acceleration chosen is the one that reaches the target without passing it
    /// when brought back to zero at the jerk limit afterwards (the discrete ramp down from
    /// m·J·dt adds J·dt²·m(m+1)/2), never more than lands on the target in this step, and
    /// then within J·dt of the last acceleration and within the acceleration limit.
    pub fn advance(&mut self, target: f32, dt_s: f32, limits: &AxisLimits) -> bool {
        let target = math::clamp(target, -limits.max_velocity, limits.max_velocity);
        let error = target - self.velocity;
        let jerk_step = limits.max_jerk * dt_s;
        let distance = math::abs(error);
        // m with J·dt²·m(m+1)/2 = |e|: the ramp-down steps that cover the error.
        let steps = 0.5 * (math::sqrt(1.0 + 8.0 * distance / (jerk_step * dt_s)) - 1.0);
        let landing = distance / dt_s;
        let towards = if jerk_step * steps < landing {
            jerk_step * steps
        } else {
            landing
        };
        let ideal = if error < 0.0 { -towards } else { towards };
        let acceleration = math::clamp(
            math::clamp(
                ideal,
                self.acceleration - jerk_step,
                self.acceleration + jerk_step,
            ),
            -limits.max_acceleration,
            limits.max_acceleration,
        );
        let velocity = math::clamp(
            self.velocity + acceleration * dt_s,
            -limits.max_velocity,
            limits.max_velocity,
        );
        self.acceleration = (velocity - self.velocity) / dt_s;
        self.velocity = velocity;
        velocity != target
    }
}

/// The velocity mode's command source (see the module doc): the last command, its age,
/// and the limited command of both axes.
#[derive(Clone, Copy, Debug)]
pub struct VelocitySource {
    config: VelocityModeConfig,
    /// The last command received (v m/s, ω rad/s, robot frame).
    received: BodyVelocity,
    /// Control periods since it arrived (saturating; at the timeout: none in force).
    age_steps: u32,
    linear: AxisState,
    angular: AxisState,
}

impl VelocitySource {
    /// A source with `config`, at rest, with no command in force.
    pub const fn new(config: VelocityModeConfig) -> Self {
        Self {
            config,
            received: BodyVelocity::new(0.0, 0.0),
            age_steps: u32::MAX,
            linear: AxisState {
                velocity: 0.0,
                acceleration: 0.0,
            },
            angular: AxisState {
                velocity: 0.0,
                acceleration: 0.0,
            },
        }
    }

    /// The settings in use.
    pub const fn config(&self) -> &VelocityModeConfig {
        &self.config
    }

    /// Restarts from `current` (v m/s, ω rad/s; the measured body velocity), without
    /// acceleration and with no command in force: until a command arrives, the source
    /// brings the robot to rest.
    pub fn restart(&mut self, current: BodyVelocity) {
        self.received = BodyVelocity::new(0.0, 0.0);
        self.age_steps = u32::MAX;
        self.linear = AxisState {
            velocity: current.v_m_s,
            acceleration: 0.0,
        };
        self.angular = AxisState {
            velocity: current.omega_rad_s,
            acceleration: 0.0,
        };
    }

    /// A command arrived (v m/s, ω rad/s, robot frame): it is in force from this step on,
    /// for the timeout.
    pub fn command(&mut self, command: BodyVelocity) {
        self.received = command;
        self.age_steps = 0;
    }

    /// The command in force: the last one received, or zero once it is
    /// `cmd_vel_timeout_steps` old (or none arrived since the restart).
    pub const fn in_force(&self) -> BodyVelocity {
        if self.timed_out() {
            BodyVelocity::new(0.0, 0.0)
        } else {
            self.received
        }
    }

    /// True when no command is in force (the timeout ran out, or none arrived).
    pub const fn timed_out(&self) -> bool {
        self.age_steps >= self.config.cmd_vel_timeout_steps
    }

    /// The limited command of the last step (v m/s, ω rad/s).
    pub const fn limited(&self) -> BodyVelocity {
        BodyVelocity::new(self.linear.velocity, self.angular.velocity)
    }

    /// The limited command's acceleration over the last step (m/s², rad/s²).
    pub const fn acceleration(&self) -> BodyVelocity {
        BodyVelocity::new(self.linear.acceleration, self.angular.acceleration)
    }

    /// One control step of `periods` periods of `period_s` (s) each, on a robot of track
    /// width `track_width_m` (m) with the rim-speed cap `max_rim_speed_m_s` (m/s) in
    /// force: the limited command and what limited it. The command in force is the one
    /// of this step (a command that arrived before this call counts from it; the step
    /// ages it by `periods`).
    pub fn step(
        &mut self,
        periods: u32,
        period_s: f32,
        track_width_m: f32,
        max_rim_speed_m_s: f32,
    ) -> (BodyVelocity, LimitFlags) {
        let (target, target_capped) =
            cap_rim_speed(self.in_force(), track_width_m, max_rim_speed_m_s);
        self.age_steps = self.age_steps.saturating_add(periods);
        let dt_s = period_s * periods as f32;
        let linear_held = self
            .linear
            .advance(target.v_m_s, dt_s, &self.config.linear_x);
        let angular_held = self
            .angular
            .advance(target.omega_rad_s, dt_s, &self.config.angular_z);
        let (command, capped) = cap_rim_speed(self.limited(), track_width_m, max_rim_speed_m_s);
        if capped {
            // The cap fell during the ramp: it wins, and the ramp continues from it.
            self.linear = AxisState {
                velocity: command.v_m_s,
                acceleration: 0.0,
            };
            self.angular = AxisState {
                velocity: command.omega_rad_s,
                acceleration: 0.0,
            };
        }
        (
            command,
            LimitFlags {
                rim_speed_capped: target_capped || capped,
                accel_limited: linear_held || angular_held,
            },
        )
    }
}

#[cfg(test)]
mod tests;
