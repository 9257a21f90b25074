//! # controller-core
//!
//! The control stack of Jin & Tack (2011), "Path Following Control of Mobile Robot Using
//! Lyapunov Techniques and PID Controller", as a `no_std`, `f32`, fixed-step library with
//! no heap and no panics. The same code runs on an STM32 (crate `firmware`) and against a
//! simulated robot (crate `host-sim`).
//!
//! ## The stack, top to bottom
//!
//! 1. [`params`] — one validated struct for geometry, encoder, rates, limits and gains.
//!    Build [`params::Params`] from a [`params::RobotConfig`]; bad values get a
//!    [`params::ParamError`] naming the field.
//! 2. [`encoder`] — wrap-safe tick deltas from 16/32-bit timer counters, and a windowed
//!    wheel-speed estimate that copes with one tick per several steps.
//! 3. [`kinematics`] — eqs. (1)–(8): wheel speeds ⇄ body velocity (v, ω), the unicycle
//!    model, and the tracking error of eqs. (9)–(10) in the robot frame.
//! 4. [`odometry`] — pose from ticks, integrated exactly along a constant-curvature arc.
//! 5. [`path`] and [`reference`] — circles, lines, rounded polylines and a figure-eight;
//!    a reference point moved either by time (the paper's virtual robot) or by the robot's
//!    own progress along the path (true path following).
//! 6. [`law`] — the steering laws behind [`law::steer`]:
//!    [`law::paper`] (eqs. (27)–(35), exactly as published), [`law::tracking`] (the
//!    paper's Lyapunov design redone so the error reaches zero on a moving reference) and
//!    [`law::kanayama`] (the 1990 baseline). Each reports its Lyapunov V and V̇.
//! 7. [`limits`] — rim-speed cap that keeps curvature, and acceleration limits.
//! 8. [`pid`] — the incremental PID of eqs. (36)–(38), with (38)'s typo fixed (v₂ = K_d),
//!    output clamp with anti-windup, feed-forward and a D filter.
//! 9. [`controller`] — the cascade that composes all of the above: call
//!    [`controller::Controller::step`] once per period with the tick deltas, apply the two
//!    duties it returns, read [`controller::Controller::telemetry`] to log or plot.
//!
//! [`supervisor`] holds the firmware's safety logic (arming, faults, watchdog feeding)
//! so that host tests can exercise it.
//!
//! ## Conventions
//!
//! - SI units, named in every field: m, m/s, rad, rad/s, s, Hz. Duty is a fraction of
//!   the supply voltage in [−1, 1].
//! - World frame: x, y fixed; θ counter-clockwise from x. Robot frame: x ahead, y left.
//!   Angles are wrapped to (−π, π] ([`math::wrap_angle`]).
//! - Time is an integer count of steps ([`time::StepClock`]), never an accumulated `f32`.
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
//! let duty = controller.step(TickDeltas { left: 0, right: 0 });
//! assert!(duty.left > 0.0 && duty.right > 0.0);
//! assert!(!controller.telemetry().faults.any());
//! ```

#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![forbid(unsafe_op_in_unsafe_fn)]

pub mod controller;
pub mod encoder;
pub mod kinematics;
pub mod law;
pub mod limits;
pub mod math;
pub mod odometry;
pub mod params;
pub mod path;
pub mod pid;
pub mod reference;
pub mod supervisor;
pub mod time;

/// The types needed to build and run a controller.
pub mod prelude {
    pub use crate::controller::{
        Controller, FaultFlags, Mode, MotorCommand, Telemetry, TickDeltas,
    };
    pub use crate::kinematics::{BodyVelocity, DiffDrive, Point, Pose, TrackingError, WheelSpeeds};
    pub use crate::law::{LawGains, LawKind};
    pub use crate::params::{ParamError, Params, RobotConfig};
    pub use crate::path::{Path, PathError};
    pub use crate::reference::{Reference, ReferenceError, ReferenceMode, ReferenceState};
}
