//! The configurations a user can arm the robot in, and the fault suite run in each:
//! `host-sim faults --matrix`.
//!
//! A configuration is a heading source (odometry alone, or the gyro fused in with its
//! disagreement check set to stop the robot), a mode (path following with a
//! time-indexed or a path-indexed reference, or the velocity mode fed a steady `cmd_vel`
//! stream) and how it is armed (at rest, or in motion). [`Configuration::apply`] turns a
//! base scenario into that configuration; [`Configuration::of`] reads a scenario's own.
//! A cell is one row of [`crate::fault_suite::cases`] in one configuration, where the row
//! applies ([`crate::fault_suite::Case::applies_in`]); its expectation is the row's, as the
//! rows state it for each heading source.

use std::fmt;

use controller_core::gyro::{GyroConfig, HeadingSource};
use controller_core::kinematics::BodyVelocity;
use controller_core::law::LawKind;
use controller_core::reference::ReferenceMode;
use robot_files::scenario::{
    GyroSensor, GyroSetup, GyroSweep, HeadingChoice, Scenario, VelocityEntry, VelocityTimeline,
};
use serde::Serialize;

use crate::fault_suite::{cases, run_case, CaseResult};
use crate::run::RunError;

/// Where the controller's heading comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Heading {
    /// Odometry alone: the robot has no gyro.
    Odometry,
    /// The gyro fused with odometry (the ICM-42688-P model, unless the scenario names
    /// another sensor), its disagreement with odometry set to stop the robot.
    Fused,
}

/// What the armed robot follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// The path, its reference moving with time (the paper's).
    TimeIndexed,
    /// The path, its reference placed at the robot's own projection.
    PathIndexed,
    /// The velocity mode, a `cmd_vel` command every [`VELOCITY_PERIOD_S`].
    Velocity,
}

/// How the robot is armed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Start {
    /// From standstill.
    AtRest,
    /// Already moving (the wheels spun up to match).
    InMotion,
}

/// One configuration of the matrix (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Configuration {
    /// The heading source.
    pub heading: Heading,
    /// The mode.
    pub mode: Mode,
    /// How it is armed.
    pub start: Start,
}

/// The velocity mode's command in the matrix: the paper's circle as a `cmd_vel` stream
/// (v m/s, ω rad/s).
pub const VELOCITY_COMMAND: (f32, f32) = (0.25, 0.2);
/// Time between two of its commands, s (a host's 20 Hz `cmd_vel`).
pub const VELOCITY_PERIOD_S: f64 = 0.05;

impl Configuration {
    /// Every configuration, heading first, then mode, then start.
    pub fn all() -> Vec<Self> {
        let mut all = Vec::new();
        for heading in [Heading::Odometry, Heading::Fused] {
            for mode in [Mode::TimeIndexed, Mode::PathIndexed, Mode::Velocity] {
                for start in [Start::AtRest, Start::InMotion] {
                    all.push(Self {
                        heading,
                        mode,
                        start,
                    });
                }
            }
        }
        all
    }

    /// The configuration `scenario` itself arms in.
    pub fn of(scenario: &Scenario) -> Self {
        let heading = match scenario.gyro.map(|g| g.heading) {
            Some(HeadingChoice::Fused | HeadingChoice::Oracle) => Heading::Fused,
            Some(HeadingChoice::Odometry) | None => Heading::Odometry,
        };
        let mode = match (&scenario.velocity, scenario.reference_mode) {
            (Some(_), _) => Mode::Velocity,
            (None, ReferenceMode::TimeIndexed { .. }) => Mode::TimeIndexed,
            (None, ReferenceMode::PathFollowing { .. }) => Mode::PathIndexed,
        };
        Self {
            heading,
            mode,
            start: if moving(scenario) {
                Start::InMotion
            } else {
                Start::AtRest
            },
        }
    }

    /// `base` armed in this configuration. What the configuration does not name is
    /// `base`'s: its robot, plant, path, start pose, the gyro sensor and rest of a scenario
    /// that has one; a start in motion keeps `base`'s motion if it has one.
    pub fn apply(&self, base: &Scenario) -> Scenario {
        let mut s = base.clone();
        match self.heading {
            Heading::Odometry => {
                s.gyro = None;
                s.robot.gyro = s.robot.gyro.with_heading(HeadingSource::Odometry);
            }
            Heading::Fused => {
                let setup = GyroSetup {
                    heading: HeadingChoice::Fused,
                    ..base.gyro.unwrap_or(GyroSetup {
                        heading: HeadingChoice::Fused,
                        sensor: GyroSensor::ICM42688P,
                        rest_before_arming_s: 0.0,
                        sweep: GyroSweep::default(),
                    })
                };
                s.robot.gyro = GyroConfig {
                    disagreement_stops: true,
                    ..setup.robot_gyro(s.robot.gyro)
                };
                s.gyro = Some(setup);
            }
        }
        let rate = f64::from(s.robot.control_rate_hz);
        s.velocity = None;
        match self.mode {
            Mode::TimeIndexed => {
                if !matches!(s.reference_mode, ReferenceMode::TimeIndexed { .. }) {
                    s.reference_mode = ReferenceMode::TimeIndexed {
                        start_offset_m: 0.0,
                    };
                }
            }
            Mode::PathIndexed => {
                s.reference_mode = ReferenceMode::PathFollowing { lookahead_m: 0.0 };
            }
            Mode::Velocity => {
                let (v_m_s, omega_rad_s) = VELOCITY_COMMAND;
                s.velocity = Some(VelocityTimeline {
                    entries: vec![VelocityEntry {
                        at_step: 0,
                        command: BodyVelocity::new(v_m_s, omega_rad_s),
                    }],
                    command_period_steps: ((VELOCITY_PERIOD_S * rate).round() as u64).max(1),
                    stop_sending_step: None,
                });
            }
        }
        match (self.start, moving(base)) {
            (Start::AtRest, _) => {
                s.start.v_m_s = 0.0;
                s.start.omega_rad_s = 0.0;
            }
            (Start::InMotion, true) => {}
            (Start::InMotion, false) => {
                let (v_m_s, omega_rad_s) = VELOCITY_COMMAND;
                s.start.v_m_s = f64::from(v_m_s);
                s.start.omega_rad_s = f64::from(omega_rad_s);
            }
        }
        s
    }
}

/// Whether `scenario` starts in motion (a forward speed or a yaw rate at t = 0).
fn moving(scenario: &Scenario) -> bool {
    scenario.start.v_m_s != 0.0 || scenario.start.omega_rad_s != 0.0
}

impl fmt::Display for Configuration {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let heading = match self.heading {
            Heading::Odometry => "odometry",
            Heading::Fused => "fused",
        };
        let mode = match self.mode {
            Mode::TimeIndexed => "time-indexed path",
            Mode::PathIndexed => "path-indexed path",
            Mode::Velocity => "velocity",
        };
        let start = match self.start {
            Start::AtRest => "armed at rest",
            Start::InMotion => "armed in motion",
        };
        write!(f, "{heading}, {mode}, {start}")
    }
}

/// One cell's result: the configuration and the row's result in it.
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    /// The configuration.
    pub configuration: Configuration,
    /// Its name ([`Configuration`]'s `Display`).
    pub configuration_name: String,
    /// The row's result.
    pub result: CaseResult,
}

impl Cell {
    /// `configuration: case`, the name the matrix reports a failed cell by.
    pub fn name(&self) -> String {
        format!("{}: {}", self.configuration_name, self.result.case)
    }
}

/// Every row that applies in each of `configurations`, on `base` armed in each, with
/// `law`; cells in configuration order, then row order.
pub fn run_matrix(
    base: &Scenario,
    law: LawKind,
    configurations: &[Configuration],
) -> Result<Vec<Cell>, RunError> {
    use rayon::prelude::*;
    let jobs: Vec<(Configuration, Scenario, crate::fault_suite::Case)> = configurations
        .iter()
        .flat_map(|c| {
            let scenario = c.apply(base);
            cases()
                .into_iter()
                .filter(|case| case.applies_in(c))
                .map(move |case| (*c, scenario.clone(), case))
        })
        .collect();
    jobs.par_iter()
        .map(|(configuration, scenario, case)| {
            Ok(Cell {
                configuration: *configuration,
                configuration_name: configuration.to_string(),
                result: run_case(scenario, law, *case, None)?,
            })
        })
        .collect()
}

/// The matrix's line: `fault matrix: N of M cells as expected`, and the failed cells.
pub fn summary_line(cells: &[Cell]) -> String {
    let failed: Vec<String> = cells
        .iter()
        .filter(|c| !c.result.passed)
        .map(Cell::name)
        .collect();
    let line = format!(
        "fault matrix: {} of {} cells as expected",
        cells.len() - failed.len(),
        cells.len()
    );
    if failed.is_empty() {
        line
    } else {
        format!("{line}; not as expected: {}", failed.join("; "))
    }
}
