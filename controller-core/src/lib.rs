//! # controller-core
//!
//! The control stack of Jin & Tack (2011), "Path Following Control of Mobile Robot Using
//! Lyapunov Techniques and PID Controller", as a `no_std`, `f32`, fixed-step library with
//! no heap and no panics. The same code runs on an STM32 (crate `firmware`) and against a
//! simulated robot (crate `host-sim`).
//!
//! ## The stack, top to bottom
//!
//! 1. [`params`] — one validated struct for geometry (each wheel's radius, the track),
//!    encoder, rates, limits, the motor, the bridge, the wheel loops and the law gains.
//!    Build [`params::Params`] from a [`params::RobotConfig`]; bad values get a
//!    [`params::ParamError`] naming the field.
//! 2. [`encoder`] — wrap-safe tick deltas from 16/32-bit timer counters, and a windowed
//!    wheel-speed estimate that copes with one tick per several steps and with late steps.
//! 3. [`kinematics`] — eqs. (1)–(8): wheel speeds ⇄ body velocity (v, ω), the unicycle
//!    model, and the tracking error of eqs. (9)–(10) in the robot frame.
//! 4. [`odometry`] — pose from ticks, integrated exactly along a constant-curvature arc,
//!    with [`compensated`] sums so a day-long run does not drift.
//! 5. [`path`] and [`mod@reference`] — circles, lines, rounded polylines and a figure-eight;
//!    a reference point moved either by time (the paper's virtual robot) or by the robot's
//!    own progress along the path (true path following).
//! 6. [`law`] — the steering laws behind [`law::steer`]:
//!    [`law::paper`] (eqs. (27)–(35), exactly as published), [`law::tracking`] (the
//!    paper's Lyapunov design redone so the error reaches zero on a moving reference) and
//!    [`law::kanayama`] (the 1990 baseline). Each reports its Lyapunov V and V̇.
//! 7. [`limits`] — the acceleration ramp (at the wheel-loop rate) and a rim-speed cap that
//!    keeps curvature and follows the battery. In the velocity mode the body command
//!    comes from [`velocity`] instead of steps 5–6: the link's (v, ω) with
//!    `diff_drive_controller`'s timeout and velocity, acceleration and jerk limits.
//! 8. [`drive`] — the wheel loops in volts: feed-forward, the incremental PID of
//!    [`pid`] (eqs. (36)–(38), (38)'s typo fixed), voltage, current and slew limits,
//!    reversal through zero, coordinated saturation, and duty = volts / supply.
//! 9. [`controller`] — the cascade that composes all of the above: call
//!    [`controller::Controller::step`] once per period with a
//!    [`controller::StepInput`], apply the two duties it returns, read
//!    [`controller::Controller::telemetry`] to log or plot.
//!
//! [`tune`] identifies each wheel (feed-forward from a voltage ramp, a first-order model
//! from a voltage step) and sets its PI by the SIMC rule, in the supervisor's tune mode.
//!
//! [`supervisor`] holds the safety logic around the controller (arming, the link's
//! commands, faults, brake and coast, watchdog feeding): the firmware and the simulator
//! both run it, so host tests and simulations exercise exactly what the robot runs.
//!
//! ## Conventions
//!
//! - SI units, named in every field: m, m/s, rad, rad/s, s, Hz, V, A, Ω. The wheel loops
//!   compute volts; a duty is a fraction of the measured supply in [−1, 1].
//! - World frame: x, y fixed; θ counter-clockwise from x. Robot frame: x ahead, y left.
//!   Angles are wrapped to (−π, π] ([`math::wrap_angle`]).
//! - Time is an integer count of control periods ([`time::StepClock`],
//!   [`controller::StepInput::periods`]), never an accumulated `f32`.
//! - All transcendental math goes through [`math`], so host and target compute the same
//!   bits.
//!
//! ## Example: one step of the paper's circle
//!
//! ```
//! use controller_core::prelude::*;
//!
//! let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
//! let circle = Path::circle(Point::new(0.0, 0.0), 1.25, 0.0, true).unwrap();
//! let reference =
//!     Reference::new(circle, 0.25, ReferenceMode::TimeIndexed { start_offset_m: 0.0 })
//!         .unwrap();
//! let mut controller =
//!     Controller::new(params, reference, LawKind::Tracking, Pose::new(1.25, 0.0, 1.57));
//! controller.set_mode(Mode::FollowPath);
//! // No ticks yet, on time, on a 6 V supply. The first step hands the steering law its
//! // job and holds the wheels where they are; the next applies the law's command.
//! let input = StepInput::on_time(TickDeltas { left: 0, right: 0 }, 6.0);
//! assert_eq!(controller.step(input), MotorCommand::STOP);
//! let duty = controller.step(input);
//! assert!(duty.left > 0.0 && duty.right > 0.0);
//! assert!(!controller.telemetry().faults.any());
//! ```

#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![forbid(unsafe_op_in_unsafe_fn)]

pub mod compensated;
pub mod controller;
pub mod drive;
pub mod encoder;
pub mod fixed;
pub mod gyro;
pub mod kinematics;
pub mod law;
pub mod limits;
pub mod math;
pub mod odometry;
pub mod outer_loop;
pub mod params;
pub mod path;
pub mod pid;
pub mod reference;
pub mod supervisor;
pub mod time;
pub mod tune;
pub mod velocity;
pub mod wiring;

/// The types needed to build and run a controller.
pub mod prelude {
    pub use crate::controller::{
        Controller, ControllerFaults, Mode, MotorCommand, StepInput, Telemetry, TickDeltas,
    };
    pub use crate::kinematics::{BodyVelocity, DiffDrive, Point, Pose, TrackingError, WheelSpeeds};
    pub use crate::law::{LawGains, LawKind};
    pub use crate::params::{ParamError, Params, RobotConfig};
    pub use crate::path::{Path, PathError};
    pub use crate::reference::{Reference, ReferenceError, ReferenceMode, ReferenceState};
}
