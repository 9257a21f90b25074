//! Scenarios: a TOML file that says what to follow, where the robot starts, what the
//! controller believes about the robot and what the robot really is.
//!
//! Every quantity is in SI units named in its key (`_m`, `_m_s`, `_rad`, `_rad_s`, `_s`,
//! `_hz`, `_v`, `_ohm`, …); percentages end in `_pct`. Positions are within ±1 km of the
//! origin and lengths at most 1 km ([`MAX_POSITION_M`]). Only `[path]`, `[reference]` and
//! `[start]` are required; everything else has a documented default. The built-in
//! scenarios in `robot-files/scenarios/` are commented examples of every section:
//!
//! ```toml
//! name = "my-run"
//! description = "free text"
//!
//! [sim]
//! duration_s = 30.0          # simulated time, s
//! plant_rate_hz = 10000      # RK4 rate of the plant; a multiple of, and ≥ 10 ×, the control rate
//! seed = 1                   # noise seed
//!
//! [path]
//! kind = "circle"            # circle | line | polyline | figure-eight
//! center_m = [0.0, 0.0]      # circle, figure-eight
//! radius_m = 1.25            # circle
//! start_angle_rad = 0.0      # circle: polar angle of the path's start about the centre
//! counter_clockwise = true   # circle
//! # start_m, heading_rad, length_m           (line)
//! # waypoints_m = [[x, y], …], corner_radius_m, closed   (polyline)
//! # lobe_radius_m                             (figure-eight)
//!
//! [reference]
//! speed_m_s = 0.25           # v_r
//! mode = "time-indexed"      # or "path-following"
//! start_offset_m = 0.0       # time-indexed: arc length of the reference at t = 0
//! lookahead_m = 0.0          # path-following: reference this far ahead of the projection
//!
//! [start]                    # the TRUE initial state (the controller is told the same pose)
//! x_m = -1.0
//! y_m = -1.2
//! theta_rad = 2.0943951
//! v_m_s = 0.4                # already moving: wheels spun up accordingly
//! omega_rad_s = 0.3
//!
//! [robot]                    # overrides of controller_core's RobotConfig::REFERENCE_ROBOT
//! wheel_radius_m = 0.0325    # … every field, same names, nested tables for
//!                            # [robot.limits], [robot.wheel_pid], [robot.law.paper|tracking|kanayama]
//!
//! [plant]                    # the simulated robot (defaults: see `plant`)
//! driver = "tb6612"          # or "drv8833": bridge on-resistance and supply limit
//! supply_v = 6.0             # ≤ the driver's absolute maximum (15 V, 11.8 V)
//! pwm_levels = 5000          # compare value of 100 % (TIM3: 100 MHz / 20 kHz)
//! dead_band_duty = 0.02      # |duty| below this brakes (u = 0)
//! encoder_noise_ticks_rms = 0.0 # edge jitter, ticks RMS, ≤ 0.5
//! load = "ground"            # or "lifted": on a stand, wheels in the air (no chassis)
//! [plant.motor]              # resistance_ohm, torque_constant_nm_per_a, …
//! [plant.body]               # mass_kg, yaw_inertia_kg_m2 (about the axle midpoint),
//!                            # wheel_inertia_kg_m2, com_ahead_of_axle_m (default 0)
//! [plant.mismatch]           # wheel_radius_pct, wheel_radius_left_right_pct, track_width_pct
//! [plant.motor_mismatch]     # left − right motor, % of nominal: resistance_left_right_pct,
//!                            # torque_constant_left_right_pct (K_t and K_e),
//!                            # viscous_friction_left_right_pct, coulomb_friction_left_right_pct
//! [plant.slip]               # left, right (slip ratios in [0, 1))
//!
//! [sweep]                    # Monte-Carlo spreads for `host-sim sweep` (see SweepSpec)
//!
//! [gyro]                     # the robot has a gyro (see `GyroSetup`; none without it)
//! heading = "fused"          # fused | odometry | oracle
//! [velocity]                 # a run in the velocity mode instead of path following
//! commands = [[0.5, 0.3, 0.0], [2.5, 0.3, 1.5]]   # [t_s, v_m_s, omega_rad_s], streamed
//! command_period_s = 0.05    # every this long from each entry on
//! stop_sending_s = 6.5       # then silence: the robot's timeout stops it
//! ```
//!
//! The plant's bridge runs in slow decay like the firmware's (duty 0 = short brake; coasting
//! only when the driver is disabled or a motor disconnected), and the chassis' yaw inertia
//! is about the axle midpoint with the centre of mass `com_ahead_of_axle_m` ahead of the
//! axle (0 = on it); the parameters are [`crate::plant`]'s, the model that uses them is
//! host-sim's `plant`.
//!
//! A bad file gets an error naming the key and the problem, e.g.
//! `robot.wheel_radius_m must be > 0, got -0.03`; an array key of the wrong length, e.g.
//! `path.center_m must have exactly 2 numbers, got 3`; text nested past
//! [`MAX_NESTING`](crate::toml_text::MAX_NESTING) gets its line and what is too deep, e.g.
//! ``line 3: the key `a.a.a.…` has 200 parts; a key may have at most 16``. Nothing in here
//! panics on input.

//!
//! | file | what it holds |
//! |---|---|
//! | this one | the validated [`Scenario`] and its parts, [`ScenarioError`], the built-in scenarios |
//! | `schema.rs` | the file as serde reads it (unknown keys refused) |
//! | `raw_value.rs` | fixed-length number arrays, read as any TOML value and checked with their key |
//! | `checks.rs` | the rules values are checked against, each error naming its key |
//! | `build.rs` | the file as read → the validated scenario |

mod build;
mod checks;
mod gyro;
mod raw_value;
mod schema;
mod velocity;

use std::fmt;
use std::path::Path as FsPath;

use controller_core::params::{Params, RobotConfig};
use controller_core::path::Path;
use controller_core::reference::ReferenceMode;
use controller_core::supervisor::SupervisorConfig;

use crate::faults::Fault;
use crate::plant::{BodyParams, DriverParams, Load, MotorMismatch, MotorParams};
use crate::robot_file::{param_error, SectionError};
pub use gyro::{GyroSensor, GyroSetup, GyroSweep, HeadingChoice};
use schema::ScenarioFile;

pub use velocity::{VelocityEntry, VelocityTimeline};

/// The built-in scenarios: (name, TOML text).
pub const BUILTIN: [(&str, &str); 7] = [
    (
        "paper-circle",
        include_str!("../../scenarios/paper-circle.toml"),
    ),
    (
        "paper-line",
        include_str!("../../scenarios/paper-line.toml"),
    ),
    (
        "square-waypoints",
        include_str!("../../scenarios/square-waypoints.toml"),
    ),
    (
        "figure-eight",
        include_str!("../../scenarios/figure-eight.toml"),
    ),
    (
        "longest-path",
        include_str!("../../scenarios/longest-path.toml"),
    ),
    (
        "paper-circle-gyro",
        include_str!("../../scenarios/paper-circle-gyro.toml"),
    ),
    (
        "velocity-steps",
        include_str!("../../scenarios/velocity-steps.toml"),
    ),
];

/// Why a scenario could not be loaded. [`fmt::Display`] gives a one-line message that
/// names the key, for example `robot.wheel_radius_m must be > 0, got -0.03`.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The text is not valid TOML, nests deeper than
    /// [`MAX_NESTING`](crate::toml_text::MAX_NESTING), or a key is unknown or of the
    /// wrong type (the message names the line, and the key where there is one).
    #[error("{origin}: {message}")]
    Syntax {
        /// File name or built-in name.
        origin: String,
        /// The parser's message.
        message: String,
    },
    /// A value is out of range.
    #[error("{key} {problem}")]
    Invalid {
        /// Dotted TOML key, e.g. `robot.wheel_radius_m`.
        key: String,
        /// What is wrong with it, with the value, e.g. `must be > 0, got -0.03`.
        problem: String,
    },
    /// The `[robot]` or `[supervisor]` section is invalid.
    #[error(transparent)]
    Section(#[from] SectionError),
    /// Neither a file nor a built-in scenario.
    #[error("no scenario file or built-in scenario named `{0}` (built in: paper-circle, paper-line, square-waypoints, figure-eight, longest-path, paper-circle-gyro, velocity-steps)")]
    Unknown(String),
}

impl ScenarioError {
    fn invalid(key: impl Into<String>, problem: impl Into<String>) -> Self {
        ScenarioError::Invalid {
            key: key.into(),
            problem: problem.into(),
        }
    }
}

/// The robot's true initial state, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartState {
    /// x, m.
    pub x_m: f64,
    /// y, m.
    pub y_m: f64,
    /// Heading θ, rad (counter-clockwise from x).
    pub theta_rad: f64,
    /// Forward speed at t = 0, m/s.
    pub v_m_s: f64,
    /// Yaw rate at t = 0, rad/s.
    pub omega_rad_s: f64,
}

/// How the true robot differs from the controller's [`RobotConfig`], in percent.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mismatch {
    /// Both true wheel radii are (1 + p/100) × the believed radius, %.
    pub wheel_radius_pct: f64,
    /// Left wheel a further +p/200, right −p/200 of the believed radius, % (unequal wheels
    /// make a robot that believes it drives straight curve).
    pub wheel_radius_left_right_pct: f64,
    /// True track width is (1 + p/100) × the believed one, %.
    pub track_width_pct: f64,
}

/// The simulated robot's own parameters (what the controller does not see).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantSpec {
    /// Motor and gearbox of each wheel.
    pub motor: MotorParams,
    /// H-bridge and supply.
    pub driver: DriverParams,
    /// Chassis mass properties.
    pub body: BodyParams,
    /// True geometry against believed geometry.
    pub mismatch: Mismatch,
    /// The left and right motors' difference about [`PlantSpec::motor`].
    pub motor_mismatch: MotorMismatch,
    /// Longitudinal slip ratios [left, right], in [0, 1).
    pub slip: [f64; 2],
    /// Encoder edge jitter, ticks RMS (0 = ideal), in [0, [`MAX_EDGE_JITTER_TICKS_RMS`]]:
    /// each edge sits off its true place by a fixed offset of its own.
    pub encoder_noise_ticks_rms: f64,
    /// On the ground (default) or lifted on a stand.
    pub load: Load,
}

impl Default for PlantSpec {
    fn default() -> Self {
        Self {
            motor: MotorParams::DEFAULT,
            driver: DriverParams::DEFAULT,
            body: BodyParams::DEFAULT,
            mismatch: Mismatch::default(),
            motor_mismatch: MotorMismatch::NONE,
            slip: [0.0; 2],
            encoder_noise_ticks_rms: 0.0,
            load: Load::Ground,
        }
    }
}

/// Largest encoder edge jitter the simulator models, ticks RMS: an edge's offset is
/// uniform in ±√3 · the jitter, so every edge stays within a tick of its true place.
pub const MAX_EDGE_JITTER_TICKS_RMS: f64 = 0.5;

/// Monte-Carlo spreads for `host-sim sweep`: each run draws every quantity uniformly in
/// the stated range, on top of the scenario's own values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepSpec {
    /// Wheel radius mismatch (both wheels), ± %.
    pub wheel_radius_pct: f64,
    /// Left/right radius difference, ± %.
    pub wheel_radius_left_right_pct: f64,
    /// Track width mismatch, ± %.
    pub track_width_pct: f64,
    /// Supply voltage, ± % (battery state of charge).
    pub supply_pct: f64,
    /// Coulomb friction, ± %.
    pub coulomb_friction_pct: f64,
    /// Left/right difference of the motors' torque constant (K_t and K_e), ± %.
    pub motor_left_right_pct: f64,
    /// Slip ratio of each wheel, drawn in [0, slip_max].
    pub slip_max: f64,
    /// Encoder edge jitter, drawn in [0, max] ticks RMS; with the scenario's own, at
    /// most [`MAX_EDGE_JITTER_TICKS_RMS`].
    pub encoder_noise_ticks_rms_max: f64,
    /// Start position offset in x and in y, ± m.
    pub start_position_m: f64,
    /// Start heading offset, ± rad.
    pub start_heading_rad: f64,
}

impl SweepSpec {
    /// ±1 % radius, ±0.5 % left/right, ±2 % track, ±10 % supply, ±50 % Coulomb friction,
    /// ±2 % left/right motor constant, up to 1 % slip per wheel, up to 0.5 tick jitter,
    /// ±0.1 m and ±0.2 rad of start pose.
    pub const DEFAULT: SweepSpec = SweepSpec {
        wheel_radius_pct: 1.0,
        wheel_radius_left_right_pct: 0.5,
        track_width_pct: 2.0,
        supply_pct: 10.0,
        coulomb_friction_pct: 50.0,
        motor_left_right_pct: 2.0,
        slip_max: 0.01,
        encoder_noise_ticks_rms_max: 0.5,
        start_position_m: 0.1,
        start_heading_rad: 0.2,
    };
}

impl Default for SweepSpec {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A validated scenario (see the module doc for the file format).
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Name (the file's `name`, else its stem).
    pub name: String,
    /// Free-text description.
    pub description: String,
    /// Simulated time, s.
    pub duration_s: f64,
    /// Plant (RK4) rate, Hz: an integer multiple ≥ 10 of the control rate.
    pub plant_rate_hz: u32,
    /// Seed of every random draw in the run.
    pub seed: u64,
    /// The path, world frame.
    pub path: Path,
    /// Reference speed v_r, m/s.
    pub reference_speed_m_s: f32,
    /// How the reference moves.
    pub reference_mode: ReferenceMode,
    /// True initial state.
    pub start: StartState,
    /// What the controller believes (validated by [`Params::new`]).
    pub robot: RobotConfig,
    /// The supervisor's settings (validated; the divergence check and the geofence derived
    /// from the path unless the `[supervisor]` section says otherwise).
    pub supervisor: SupervisorConfig,
    /// What the robot really is.
    pub plant: PlantSpec,
    /// Monte-Carlo spreads.
    pub sweep: SweepSpec,
    /// The run arms at step 0 (`[start] arm = "at-start"`, the default).
    pub arm_at_start: bool,
    /// Faults injected on the run's timeline (`[[faults]]`).
    pub faults: Vec<Fault>,
    /// The gyro, if the robot has one (`[gyro]`, see `gyro`).
    pub gyro: Option<GyroSetup>,
    /// A run in the velocity mode: its commands (`[velocity]`; `None`: path following).
    pub velocity: Option<VelocityTimeline>,
    /// How the virtual robot is miswired (`[virtual_robot] miswire`, the list
    /// `host-sim serve --miswire` takes; empty: wired as labelled). Only `host-sim serve`
    /// reads it.
    pub miswire: String,
}

impl Scenario {
    /// The built-in scenario `name`, if there is one.
    pub fn builtin(name: &str) -> Option<Result<Scenario, ScenarioError>> {
        BUILTIN
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(n, text)| Scenario::from_toml(text, n))
    }

    /// A built-in scenario's name, or a path to a `.toml` file.
    pub fn load(name_or_path: &str) -> Result<Scenario, ScenarioError> {
        let fs = FsPath::new(name_or_path);
        if fs.is_file() {
            let text = std::fs::read_to_string(fs).map_err(|source| ScenarioError::Io {
                path: name_or_path.to_string(),
                source,
            })?;
            let stem = fs
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| name_or_path.to_string());
            return parse(&text, name_or_path, &stem);
        }
        match Scenario::builtin(name_or_path) {
            Some(result) => result,
            None if name_or_path.ends_with(".toml") => Err(ScenarioError::Io {
                path: name_or_path.to_string(),
                source: std::io::Error::from(std::io::ErrorKind::NotFound),
            }),
            None => Err(ScenarioError::Unknown(name_or_path.to_string())),
        }
    }

    /// Parses and validates TOML `text`; `origin` (a file name or built-in name) is used
    /// in syntax errors and as the default name.
    pub fn from_toml(text: &str, origin: &str) -> Result<Scenario, ScenarioError> {
        parse(text, origin, origin)
    }

    /// The same scenario run for `duration_s` (s) instead, checked as `sim.duration_s`
    /// is in a file (for example a 24 h soak of a 30 s scenario).
    pub fn with_duration_s(mut self, duration_s: f64) -> Result<Scenario, ScenarioError> {
        checks::check_duration(duration_s, self.robot.control_rate_hz)?;
        self.duration_s = duration_s;
        Ok(self)
    }

    /// Steers by `heading`: the `[gyro]` table's choice and the robot's heading source
    /// together (`false`, and nothing changed, for a scenario without a `[gyro]` table).
    pub fn steer_by(&mut self, heading: HeadingChoice) -> bool {
        let Some(setup) = self.gyro.as_mut() else {
            return false;
        };
        setup.heading = heading;
        self.robot.gyro = setup.robot_gyro(self.robot.gyro);
        true
    }

    /// Validated controller parameters.
    pub fn params(&self) -> Result<Params, ScenarioError> {
        Params::new(self.robot).map_err(|e| param_error(e, "robot").into())
    }
}

impl fmt::Display for Scenario {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.name)
    }
}

fn parse(text: &str, origin: &str, default_name: &str) -> Result<Scenario, ScenarioError> {
    let file: ScenarioFile =
        crate::toml_text::from_str(text).map_err(|message| ScenarioError::Syntax {
            origin: origin.to_string(),
            message,
        })?;
    build::build(file, default_name)
}

/// Longest simulated time accepted, s.
pub const MAX_DURATION_S: f64 = 86_400.0;

/// Most control steps one run may take (duration × control rate): bounds the memory a
/// scenario file can ask for (the run keeps a trace and per-steering-step samples).
pub const MAX_CONTROL_STEPS: f64 = 1e8;

/// Largest distance a scenario takes, m: every coordinate of the path and the start is
/// within ± this of the origin, and every length and radius (the path's, the reference's
/// offset and look-ahead) at most this. The controller holds poses in `f32`, which
/// resolves 0.25 mm or finer within 4 km (an encoder tick of wheel travel is 0.14 mm), and
/// what the supervisor derives from the path and the start (the geofence, the
/// divergence check's settle time) stays far inside `f32`'s range; at 1e30 m the square
/// of a distance overflows it, and the refusal would name a key the file never wrote.
pub const MAX_POSITION_M: f64 = 1_000.0;

/// Fastest control loop accepted, Hz (the plant then runs at ≥ 10× this).
pub const MAX_CONTROL_RATE_HZ: u32 = 100_000;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_parses() {
        for (name, _) in BUILTIN {
            let s = Scenario::builtin(name).unwrap().unwrap();
            assert_eq!(s.name, name);
        }
    }
}
