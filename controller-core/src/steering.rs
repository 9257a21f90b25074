//! The outer loop: the reference, the steering law and the command limits, run once per
//! steering period.
//!
//! The inner loop ([`crate::controller::Controller`]) runs every control period. When the
//! steering law is due it hands over a [`SteeringJob`]: the pose estimate of that step
//! and what else the law needs, as a small value. [`Steering::run`] turns it into a
//! [`SteeringOutcome`], and the inner loop applies that at its **next** step: it starts
//! the set-point ramp towards the command's wheel speeds there.
//!
//! That one-period hand-over is the design, everywhere: in the simulator, in the tests
//! and on the robot. It lets the outer loop, whose cost is the reference's projection
//! and the law's trigonometry, run anywhere between two control steps, not inside the
//! control interrupt; and the robot still does exactly what the simulator does.
//!
//! ```text
//!  step k (inner loop)          between k and k+1           step k+1 (inner loop)
//!  odometry ─► pose ─► SteeringJob ─► Steering::run ─► SteeringOutcome ─► ramp starts
//! ```

use crate::kinematics::{tracking_error_with_heading, BodyVelocity, Pose, TrackingError};
use crate::law::{self, LawKind, LawOutput};
use crate::limits::{CommandLimiter, LimitFlags};
use crate::params::Params;
use crate::reference::{Reference, ReferenceState};

/// What the inner loop hands to the outer loop at a step where the steering law is due.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SteeringJob {
    /// Odometry pose estimate at that step, world frame.
    pub pose: Pose,
    /// (sin θ, cos θ) of that pose's heading, as odometry keeps them.
    pub heading_sin_cos: (f32, f32),
    /// Control periods since the reference was last sampled (0 at the first job of a run).
    pub elapsed_periods: u32,
    /// Rim-speed cap in force at that step, m/s.
    pub rim_speed_cap_m_s: f32,
    /// Path following (re)started since the last job: restart the reference's time index
    /// and progress first.
    pub restart_reference: bool,
    /// The wheel loops restarted since the last job, at this body velocity (v m/s,
    /// ω rad/s, robot frame): the command limiter continues from it.
    pub restart_limiter_from: Option<BodyVelocity>,
}

/// What the outer loop hands back: the steering law's command after its limits, and how
/// it got there (for telemetry).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SteeringOutcome {
    /// The reference sampled for the job's pose.
    pub reference: ReferenceState,
    /// Tracking error (9), robot frame.
    pub error: TrackingError,
    /// The steering law's output (target before limits, V, V̇, polar error).
    pub law: LawOutput,
    /// Body command after the acceleration limit and the rim-speed cap (v m/s, ω rad/s).
    pub command: BodyVelocity,
    /// What the limiter did to it.
    pub limit_flags: LimitFlags,
    /// The rim-speed cap the limiter used, m/s.
    pub rim_speed_cap_m_s: f32,
}

/// The outer loop's state: the reference being followed, the law, the limiter's last
/// command.
#[derive(Clone, Debug)]
pub struct Steering {
    law: LawKind,
    limiter: CommandLimiter,
    reference: Reference,
}

impl Steering {
    /// The outer loop for `params`, following `reference` with `law`, its limiter at rest.
    pub fn new(params: &Params, reference: Reference, law: LawKind) -> Self {
        Self {
            law,
            limiter: CommandLimiter::new(params.config().limits),
            reference,
        }
    }

    /// Restarts in place as [`Steering::new`] would with `params` and `law`, keeping the
    /// reference.
    pub fn restart(&mut self, params: &Params, law: LawKind) {
        self.law = law;
        self.limiter = CommandLimiter::new(params.config().limits);
    }

    /// Follows a copy of `reference` from now on (copied in place, not moved through the
    /// stack).
    pub fn follow(&mut self, reference: &Reference) {
        self.reference.clone_from(reference);
    }

    /// The steering law in use.
    pub const fn law(&self) -> LawKind {
        self.law
    }

    /// Selects another steering law (it takes effect at the next job).
    pub fn set_law(&mut self, law: LawKind) {
        self.law = law;
    }

    /// The reference being followed.
    pub const fn reference(&self) -> &Reference {
        &self.reference
    }

    /// One steering update for `job`, with the geometry, rates, gains and limits of
    /// `params`. Never panics; a non-finite input gives a non-finite command, which the
    /// inner loop latches as a fault when it applies it.
    pub fn run(&mut self, params: &Params, job: &SteeringJob) -> SteeringOutcome {
        if job.restart_reference {
            self.reference.restart();
        }
        if let Some(from) = job.restart_limiter_from {
            self.limiter.reset(from);
        }
        let reference =
            self.reference
                .sample(job.elapsed_periods, params.control_rate(), &job.pose);
        let error = tracking_error_with_heading(&job.pose, job.heading_sin_cos, &reference.pose);
        let law =
            law::steer_with_error(self.law, &params.config().law, &job.pose, &reference, error);
        let (command, limit_flags) = self.limiter.apply(
            law.command,
            params.steering_period_s(),
            params.geometry().track_width_m(),
            job.rim_speed_cap_m_s,
        );
        SteeringOutcome {
            reference,
            error,
            law,
            command,
            limit_flags,
            rim_speed_cap_m_s: job.rim_speed_cap_m_s,
        }
    }
}
