//! The virtual robot's true account of a path-following run: its true pose against the
//! reference at every steering period from arming, with the robot's own statistics code,
//! exactly as [`crate::run`] measures a simulated run.

use controller_core::kinematics::Pose;
use controller_core::reference::Reference;
use link::{ErrorSummary, TrueRunReport};
use robot_app::metrics::{ErrorSample, ErrorStats};

use robot_files::truth::{true_error, TruePose, TrueReference};

/// The true metrics of the run in progress.
#[derive(Clone, Debug)]
pub struct TrueRun {
    reference: TrueReference,
    stats: ErrorStats,
    /// Control periods per steering update.
    divider: u64,
    /// Control periods since arming.
    periods: u64,
    max_wheel_rad_s: f64,
    distance_m: f64,
    last_position: (f64, f64),
    /// The reference pose of the last sample (world frame).
    last_reference: Pose,
}

impl TrueRun {
    /// A run armed now on `reference`, at `control_rate` periods per second, steering
    /// every `divider` periods, with the robot at `start`.
    pub fn new(
        reference: &Reference,
        control_rate: core::num::NonZeroU32,
        divider: core::num::NonZeroU32,
        start: &TruePose,
    ) -> Self {
        Self {
            reference: TrueReference::of(
                reference.path().clone(),
                reference.speed_m_s(),
                reference.mode(),
                control_rate.get(),
            ),
            stats: ErrorStats::new(control_rate),
            divider: u64::from(divider.get()),
            periods: 0,
            max_wheel_rad_s: 0.0,
            distance_m: 0.0,
            last_position: (start.x_m, start.y_m),
            last_reference: Pose::default(),
        }
    }

    /// One armed control step of `periods` periods, with the true `pose` and wheel speeds
    /// `wheels` (rad/s) read before the step, as the robot's sensors saw them.
    pub fn observe(&mut self, pose: &TruePose, wheels: [f64; 2], periods: u32) {
        let k = self.periods;
        if k.is_multiple_of(self.divider) {
            let reference = self.reference.at(k, pose);
            let (position_m, heading_rad) = true_error(&reference, pose);
            self.stats.push(ErrorSample {
                step: u32::try_from(k).unwrap_or(u32::MAX),
                position_m: position_m as f32,
                heading_rad: heading_rad as f32,
            });
            self.distance_m +=
                (pose.x_m - self.last_position.0).hypot(pose.y_m - self.last_position.1);
            self.last_position = (pose.x_m, pose.y_m);
            self.last_reference = reference;
        }
        self.max_wheel_rad_s = self
            .max_wheel_rad_s
            .max(wheels[0].abs())
            .max(wheels[1].abs());
        self.periods += u64::from(periods);
    }

    /// The reference pose of the latest sample (world frame, m and rad).
    pub const fn reference_pose(&self) -> Pose {
        self.last_reference
    }

    /// The run's report, as the `runs_ended`-th run.
    pub fn report(&self, runs_ended: u16) -> TrueRunReport {
        let error: ErrorSummary = self.stats.summary();
        TrueRunReport {
            runs_ended,
            run_steps: u32::try_from(self.periods).unwrap_or(u32::MAX),
            error,
            max_wheel_speed_rad_s: self.max_wheel_rad_s as f32,
            distance_m: self.distance_m as f32,
        }
    }
}
