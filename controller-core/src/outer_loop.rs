//! The outer loop: the reference, the steering law and the command limits, run once per
//! steering period.
//!
//! The inner loop ([`crate::controller::Controller`]) runs every control period. When the
//! steering law is due it hands over a [`OuterLoopJob`]: the pose estimate of that step
//! and what else the law needs, as a small value. [`OuterLoop::run`] turns it into a
//! [`OuterLoopOutcome`], and the inner loop applies that at its **next** step: it starts
//! the set-point ramp towards the command's wheel speeds there.
//!
//! That one-period hand-over is the design, everywhere: in the simulator, in the tests
//! and on the robot. It lets the outer loop, whose cost is the reference's projection
//! and the law's trigonometry, run anywhere between two control steps, not inside the
//! control interrupt; and the robot still does exactly what the simulator does.
//!
//! Where the outer loop lives is the controller's [`OuterLoopHolder`]. A
//! `Controller<OuterLoop>` owns it and runs each job itself at the start of the next step,
//! from the due step's state (still in place then) straight into its telemetry (the
//! simulator, the tests). A holder that lends it (the firmware's) takes the job as a value
//! and runs it elsewhere, in a lower-priority task, between the two steps; the outcome
//! stays with the outer loop (`OuterLoop::outcome`), and the next step takes the outer
//! loop back and copies the outcome from there into telemetry. Both give the same
//! result.
//!
//! ```text
//!  step k (inner loop)          between k and k+1           step k+1 (inner loop)
//!  odometry ─► pose ─► OuterLoopJob ─► OuterLoop::run ─► OuterLoopOutcome ─► ramp starts
//! ```

use core::num::NonZeroU32;

use crate::kinematics::{tracking_error_with_heading, BodyVelocity, Pose, TrackingError};
use crate::law::{self, LawGains, LawKind, LawOutput};
use crate::limits::{CommandLimiter, LimitFlags};
use crate::params::Params;
use crate::reference::{Reference, ReferenceState};

/// What the inner loop hands to the outer loop at a step where the steering law is due.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OuterLoopJob {
    /// Odometry pose estimate at that step, world frame.
    pub pose: Pose,
    /// (sin θ, cos θ) of that pose's heading, as odometry keeps them.
    pub heading_sin_cos: (f32, f32),
    /// Control periods since the reference was last sampled (0 at the first job of a run).
    pub elapsed_periods: u32,
    /// Rim-speed cap in force at that step, m/s.
    pub rim_speed_cap_m_s: f32,
    /// Whether path following (re)started since the last job, and how the reference
    /// meets that, before this job samples it.
    pub reference_restart: ReferenceRestart,
    /// The wheel loops restarted since the last job, at this body velocity (v m/s,
    /// ω rad/s, robot frame): the command limiter continues from it.
    pub restart_limiter_from: Option<BodyVelocity>,
    /// The inner loop's restart count when it handed the job over (its outcome is stale
    /// after another restart).
    pub epoch: u32,
}

/// What the reference does before a job samples it: path following went on, resumed
/// after a pause, or started afresh. Ordered by how much of the reference's state goes
/// (two entries into path following before a job meet it as the larger of the two).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub enum ReferenceRestart {
    /// Path following went on since the last job: the reference moves on as it does.
    #[default]
    None,
    /// Path following resumed after a pause ([`Reference::resume`]): a time-indexed
    /// reference goes on from where it stopped, path following projects the robot again.
    Resume,
    /// Path following starts afresh ([`Reference::restart`]): the time index at its
    /// start, the projection forgotten (a new path, or the robot put somewhere new).
    Afresh,
}

/// What the outer loop hands back: the steering law's command after its limits, and how
/// it got there (for telemetry).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OuterLoopOutcome {
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
    /// The job's `epoch`.
    pub epoch: u32,
}

/// The outer loop was lent out (it is running a job elsewhere): what needs it must wait
/// for it to be back, one control period at most.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OuterLoopAway;

/// Where a controller's outer loop is (see the module doc).
pub trait OuterLoopHolder {
    /// The outer loop, if it is held.
    fn held(&self) -> Option<&OuterLoop>;
    /// The outer loop, if it is held.
    fn held_mut(&mut self) -> Option<&mut OuterLoop>;
    /// True when `Controller::step` runs a due job itself before it returns; false when
    /// the job waits for `Controller::lend_steering`.
    fn runs_jobs(&self) -> bool;
    /// Lends the outer loop out with `job`, to run elsewhere; false (nothing done) when
    /// this holder does not lend or the outer loop is away.
    fn lend(&mut self, job: &OuterLoopJob) -> bool {
        let _ = job;
        false
    }
    /// Takes the outer loop back if it has come back (with the outcome of the job it ran
    /// in `OuterLoop::outcome`); false when it has not come back (or was never lent).
    fn collect(&mut self) -> bool {
        false
    }
}

/// Owned: always held, and runs each job at once.
impl OuterLoopHolder for OuterLoop {
    fn held(&self) -> Option<&OuterLoop> {
        Some(self)
    }

    fn held_mut(&mut self) -> Option<&mut OuterLoop> {
        Some(self)
    }

    fn runs_jobs(&self) -> bool {
        true
    }
}

/// What the outer loop takes from the parameters, kept with it so that it can run where
/// the parameters are not.
#[derive(Clone, Copy, Debug)]
struct SteeringParams {
    gains: LawGains,
    control_rate: NonZeroU32,
    steering_period_s: f32,
    track_width_m: f32,
}

impl SteeringParams {
    fn of(params: &Params) -> Self {
        Self {
            gains: params.config().law,
            control_rate: params.control_rate(),
            steering_period_s: params.steering_period_s(),
            track_width_m: params.geometry().track_width_m(),
        }
    }
}

/// The outer loop's state: the reference being followed, the law and its gains, the
/// limiter's last command, and the outcome of the last job [`OuterLoop::run`] ran.
#[derive(Clone, Debug)]
pub struct OuterLoop {
    law: LawKind,
    params: SteeringParams,
    limiter: CommandLimiter,
    reference: Reference,
    outcome: OuterLoopOutcome,
}

impl OuterLoop {
    /// The outer loop for `params`, following `reference` with `law`, its limiter at rest.
    pub fn new(params: &Params, reference: Reference, law: LawKind) -> Self {
        Self {
            law,
            params: SteeringParams::of(params),
            limiter: CommandLimiter::new(params.config().limits),
            reference,
            outcome: OuterLoopOutcome::default(),
        }
    }

    /// Restarts in place as [`OuterLoop::new`] would with `params` and `law`, keeping the
    /// reference.
    pub fn restart(&mut self, params: &Params, law: LawKind) {
        self.law = law;
        self.params = SteeringParams::of(params);
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

    /// One steering update for `job`, into `OuterLoop::outcome` (kept here, where a lent
    /// outer loop comes back with it: the 100 bytes are copied once, into the inner loop's
    /// telemetry), with the geometry, rates, gains and limits of the parameters it was
    /// built or restarted with. Never panics; a non-finite input gives a non-finite
    /// command, which the inner loop latches as a fault when it applies it.
    pub fn run(&mut self, job: &OuterLoopJob) {
        let Self {
            law,
            params,
            limiter,
            reference,
            outcome,
        } = self;
        update(
            (*law, params, limiter, reference),
            job,
            (&mut outcome.reference, &mut outcome.error, &mut outcome.law),
            (&mut outcome.command, &mut outcome.limit_flags),
        );
        outcome.rim_speed_cap_m_s = job.rim_speed_cap_m_s;
        outcome.epoch = job.epoch;
    }

    /// The outcome of the last job [`OuterLoop::run`] ran (a job the controller runs
    /// straight into its telemetry is not kept here, so this is for the controller
    /// only: its telemetry is where the outcome in force is).
    pub(crate) const fn outcome(&self) -> &OuterLoopOutcome {
        &self.outcome
    }

    /// [`OuterLoop::run`], writing each part of the outcome where it is wanted (the
    /// controller's telemetry, when it runs its jobs itself: no copy of the outcome).
    pub(crate) fn run_into(
        &mut self,
        job: &OuterLoopJob,
        law_parts: (&mut ReferenceState, &mut TrackingError, &mut LawOutput),
        command_parts: (&mut BodyVelocity, &mut LimitFlags),
    ) {
        update(
            (
                self.law,
                &self.params,
                &mut self.limiter,
                &mut self.reference,
            ),
            job,
            law_parts,
            command_parts,
        );
    }
}

/// One steering update of the outer loop `(law, params, limiter, reference)` for `job`,
/// each part of the outcome written where the caller wants it.
fn update(
    (law_kind, p, limiter, path): (
        LawKind,
        &SteeringParams,
        &mut CommandLimiter,
        &mut Reference,
    ),
    job: &OuterLoopJob,
    (reference, error, law): (&mut ReferenceState, &mut TrackingError, &mut LawOutput),
    (command, limit_flags): (&mut BodyVelocity, &mut LimitFlags),
) {
    match job.reference_restart {
        ReferenceRestart::None => {}
        ReferenceRestart::Resume => path.resume(),
        ReferenceRestart::Afresh => path.restart(),
    }
    if let Some(from) = job.restart_limiter_from {
        limiter.reset(from);
    }
    *reference = path.sample(job.elapsed_periods, p.control_rate, &job.pose);
    *error = tracking_error_with_heading(&job.pose, job.heading_sin_cos, &reference.pose);
    *law = law::steer_with_error(law_kind, &p.gains, &job.pose, reference, *error);
    (*command, *limit_flags) = limiter.apply(
        law.command,
        p.steering_period_s,
        p.track_width_m,
        job.rim_speed_cap_m_s,
    );
}
