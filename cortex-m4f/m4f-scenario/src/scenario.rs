//! The scenario: the paper's circle, run by the full controller against the [`Plant`].

use core::f32::consts::PI;
use core::fmt;

use controller_core::controller::{
    Controller, Mode, MotorCommand, StepInput, Telemetry, TickDeltas,
};
use controller_core::kinematics::{Point, Pose};
use controller_core::law::LawKind;
use controller_core::math;
use controller_core::params::{ParamError, Params, RobotConfig};
use controller_core::path::{Path, PathError};
use controller_core::reference::{Reference, ReferenceError, ReferenceMode};

use crate::digest::{pose_bits, Digest, Fnv1a64};
use crate::plant::{Plant, PlantConfig};

/// A stretch of the run driven by one steering law.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Segment {
    /// The law selected at the start of the segment.
    pub law: LawKind,
    /// Control steps in the segment.
    pub steps: u32,
}

/// A closed-loop run: robot, path, reference, start pose, law schedule and plant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scenario {
    /// The controller's configuration.
    pub config: RobotConfig,
    /// Centre of the circular path, world frame, m.
    pub center: Point,
    /// Radius of the circular path, m.
    pub radius_m: f32,
    /// Polar angle (about `center`) where the path and the time-indexed reference start, rad.
    pub start_angle_rad: f32,
    /// Travel direction along the circle.
    pub counter_clockwise: bool,
    /// Reference speed v_r, m/s.
    pub speed_m_s: f32,
    /// True (and believed) start pose of the robot, world frame.
    pub start: Pose,
    /// The laws, in order. A segment of 0 steps is skipped.
    pub segments: [Segment; 3],
    /// The simulated robot.
    pub plant: PlantConfig,
    /// The supply voltage the controller is told, V (the plant's speeds are at it).
    pub supply_v: f32,
}

impl Scenario {
    /// The paper's circle (Jin & Tack 2011, section 4): r = 1.25 m about the origin, CCW,
    /// v_r = 0.25 m/s, the reference starting at polar angle atan2(−1.2, −1) and the
    /// robot at (−1, −1.2, 2π/3). 20 s at 1 kHz: 10 s of the tracking law, then 5 s of
    /// the paper's law and 5 s of Kanayama's, so every law's code runs.
    pub fn paper_circle() -> Self {
        Self {
            config: RobotConfig::REFERENCE_ROBOT,
            center: Point::new(0.0, 0.0),
            radius_m: 1.25,
            start_angle_rad: math::atan2(-1.2, -1.0),
            counter_clockwise: true,
            speed_m_s: 0.25,
            start: Pose::new(-1.0, -1.2, 2.0 * PI / 3.0),
            segments: [
                Segment {
                    law: LawKind::Tracking,
                    steps: 10_000,
                },
                Segment {
                    law: LawKind::Paper,
                    steps: 5_000,
                },
                Segment {
                    law: LawKind::Kanayama,
                    steps: 5_000,
                },
            ],
            plant: PlantConfig::REFERENCE,
            supply_v: 6.0,
        }
    }

    /// Steps over all segments.
    pub fn total_steps(&self) -> u32 {
        self.segments.iter().map(|s| s.steps).sum()
    }

    /// The controller of this scenario, in [`Mode::FollowPath`] with the first segment's
    /// law, plus its validated parameters.
    pub fn controller(&self) -> Result<(Controller, Params), SetupError> {
        let params = Params::new(self.config).map_err(SetupError::Params)?;
        let path = Path::circle(
            self.center,
            self.radius_m,
            self.start_angle_rad,
            self.counter_clockwise,
        )
        .map_err(SetupError::Path)?;
        let reference = Reference::new(
            path,
            self.speed_m_s,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .map_err(SetupError::Reference)?;
        let mut controller = Controller::new(params, reference, self.segments[0].law, self.start);
        controller.set_mode(Mode::FollowPath);
        Ok((controller, params))
    }
}

/// Why a [`Scenario`] could not be set up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SetupError {
    /// The robot configuration was rejected.
    Params(ParamError),
    /// The path was rejected.
    Path(PathError),
    /// The reference was rejected.
    Reference(ReferenceError),
}

impl fmt::Display for SetupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SetupError::Params(_) => "bad robot config",
            SetupError::Path(_) => "bad path",
            SetupError::Reference(_) => "bad reference",
        })
    }
}

impl core::error::Error for SetupError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            SetupError::Params(e) => Some(e),
            SetupError::Path(e) => Some(e),
            SetupError::Reference(e) => Some(e),
        }
    }
}

/// What one step of a run did, for observers of [`run_scenario_with`].
#[derive(Clone, Copy, Debug)]
pub struct StepRecord<'a> {
    /// Index of the step, from 0.
    pub index: u32,
    /// The law selected for this step.
    pub law: LawKind,
    /// The tick deltas the controller was given.
    pub ticks: TickDeltas,
    /// The duties the controller returned.
    pub duty: MotorCommand,
    /// The controller's telemetry of this step.
    pub telemetry: &'a Telemetry,
    /// The plant's true pose when the controller ran (before the duty was applied).
    pub true_pose: Pose,
}

/// Runs `scenario` and returns the digest of its trajectory.
pub fn run_scenario(scenario: &Scenario) -> Result<Digest, SetupError> {
    run_scenario_with(scenario, |_| {})
}

/// Runs `scenario`, calling `observe` after every step, and returns the digest.
///
/// Each step: the controller gets the ticks counted in the previous period, the step's
/// duty, odometry pose and the plant's true pose go into the hash, then the plant runs
/// one period under that duty.
pub fn run_scenario_with(
    scenario: &Scenario,
    mut observe: impl FnMut(&StepRecord<'_>),
) -> Result<Digest, SetupError> {
    let (mut controller, params) = scenario.controller()?;
    let mut plant = Plant::new(scenario.plant, &params, scenario.start);
    let mut hash = Fnv1a64::new();
    let mut ticks = TickDeltas::default();
    let mut index = 0u32;
    for segment in &scenario.segments {
        // An owned outer loop is always held: this cannot be refused.
        let _ = controller.set_law(segment.law);
        for _ in 0..segment.steps {
            let duty = controller.step(StepInput::on_time(ticks, scenario.supply_v));
            hash.write_f32(duty.left);
            hash.write_f32(duty.right);
            hash.write_pose(&controller.telemetry().pose);
            hash.write_pose(&plant.pose());
            observe(&StepRecord {
                index,
                law: segment.law,
                ticks,
                duty,
                telemetry: controller.telemetry(),
                true_pose: plant.pose(),
            });
            ticks = plant.advance(duty);
            index += 1;
        }
    }
    Ok(Digest {
        steps: index,
        hash: hash.finish(),
        pose_bits: pose_bits(&controller.pose()),
        true_pose_bits: pose_bits(&plant.pose()),
    })
}
