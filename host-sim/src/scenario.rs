//! Scenarios: a TOML file that says what to follow, where the robot starts, what the
//! controller believes about the robot and what the robot really is.
//!
//! Every quantity is in SI units named in its key (`_m`, `_m_s`, `_rad`, `_rad_s`, `_s`,
//! `_hz`, `_v`, `_ohm`, …); percentages end in `_pct`. Only `[path]`, `[reference]` and
//! `[start]` are required; everything else has a documented default. The built-in
//! scenarios in `host-sim/scenarios/` are commented examples of every section:
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
//! encoder_noise_ticks_rms = 0.0
//! load = "ground"            # or "lifted": on a stand, wheels in the air (no chassis)
//! [plant.motor]              # resistance_ohm, torque_constant_nm_per_a, …
//! [plant.body]               # mass_kg, yaw_inertia_kg_m2 (about the axle midpoint),
//!                            # wheel_inertia_kg_m2, com_ahead_of_axle_m (default 0)
//! [plant.mismatch]           # wheel_radius_pct, wheel_radius_left_right_pct, track_width_pct
//! [plant.slip]               # left, right (slip ratios in [0, 1))
//!
//! [sweep]                    # Monte-Carlo spreads for `host-sim sweep` (see SweepSpec)
//! ```
//!
//! The plant's bridge runs in slow decay like the firmware's (duty 0 = short brake; coasting
//! only when the driver is disabled or a motor disconnected), and the chassis' yaw inertia
//! is about the axle midpoint with the centre of mass `com_ahead_of_axle_m` ahead of the
//! axle (0 = on it); see [`crate::plant`].
//!
//! A bad file gets an error naming the key and the problem, e.g.
//! `robot.wheel_radius_m must be > 0, got -0.03`; an array key of the wrong length, e.g.
//! `path.center_m must have exactly 2 numbers, got 3`. Nothing in here panics on input.

use std::fmt;
use std::path::Path as FsPath;

use controller_core::params::{Params, RobotConfig};
use controller_core::path::{Path, PathError};
use controller_core::prelude::Point;
use controller_core::prelude::{Pose, Reference};
use controller_core::reference::ReferenceMode;
use controller_core::supervisor::SupervisorConfig;
use serde::Deserialize;

use crate::faults::{Fault, FaultEntry};
use crate::plant::{BodyParams, DriverKind, DriverParams, Load, MotorParams};
use crate::robot_file::{param_error, PathContext, RobotSection, SectionError, SupervisorSection};

/// The built-in scenarios: (name, TOML text).
pub const BUILTIN: [(&str, &str); 5] = [
    (
        "paper-circle",
        include_str!("../scenarios/paper-circle.toml"),
    ),
    ("paper-line", include_str!("../scenarios/paper-line.toml")),
    (
        "square-waypoints",
        include_str!("../scenarios/square-waypoints.toml"),
    ),
    (
        "figure-eight",
        include_str!("../scenarios/figure-eight.toml"),
    ),
    (
        "longest-path",
        include_str!("../scenarios/longest-path.toml"),
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
    /// The text is not valid TOML, or a key is unknown or of the wrong type (the TOML
    /// parser's message names the key and line).
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
    #[error("no scenario file or built-in scenario named `{0}` (built in: paper-circle, paper-line, square-waypoints, figure-eight, longest-path)")]
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

// ---------------------------------------------------------------------------------------
// The file's schema. Every table denies unknown keys, so a typo is an error, not a silent
// default.

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileSim {
    duration_s: Option<f64>,
    plant_rate_hz: Option<u32>,
    seed: Option<u64>,
}

#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
enum PathKind {
    Circle,
    Line,
    Polyline,
    FigureEight,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePath {
    kind: PathKind,
    center_m: Option<RawValue>,
    radius_m: Option<f64>,
    start_angle_rad: Option<f64>,
    counter_clockwise: Option<bool>,
    start_m: Option<RawValue>,
    heading_rad: Option<f64>,
    length_m: Option<f64>,
    waypoints_m: Option<RawValue>,
    corner_radius_m: Option<f64>,
    closed: Option<bool>,
    lobe_radius_m: Option<f64>,
}

#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
enum ModeName {
    #[default]
    TimeIndexed,
    PathFollowing,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileReference {
    speed_m_s: f64,
    #[serde(default)]
    mode: ModeName,
    start_offset_m: Option<f64>,
    lookahead_m: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileStart {
    x_m: f64,
    y_m: f64,
    theta_rad: f64,
    #[serde(default)]
    v_m_s: f64,
    #[serde(default)]
    omega_rad_s: f64,
    #[serde(default)]
    arm: ArmAtStart,
}

/// `[start] arm`: whether the run arms at t = 0.
#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
enum ArmAtStart {
    /// Armed at step 0 (in motion if the start moves), as an operator at the robot would.
    #[default]
    AtStart,
    /// Left disarmed: a `button-press` fault on the timeline arms it (or nothing does).
    None,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileMotor {
    resistance_ohm: Option<f64>,
    torque_constant_nm_per_a: Option<f64>,
    back_emf_v_s_per_rad: Option<f64>,
    rotor_inertia_kg_m2: Option<f64>,
    gear_efficiency: Option<f64>,
    viscous_friction_nm_s_per_rad: Option<f64>,
    coulomb_friction_nm: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileBody {
    mass_kg: Option<f64>,
    yaw_inertia_kg_m2: Option<f64>,
    wheel_inertia_kg_m2: Option<f64>,
    com_ahead_of_axle_m: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileMismatch {
    wheel_radius_pct: Option<f64>,
    wheel_radius_left_right_pct: Option<f64>,
    track_width_pct: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileSlip {
    left: Option<f64>,
    right: Option<f64>,
}

#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum DriverName {
    Tb6612,
    Drv8833,
}

#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
enum LoadName {
    Ground,
    Lifted,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FilePlant {
    driver: Option<DriverName>,
    supply_v: Option<f64>,
    pwm_levels: Option<u32>,
    dead_band_duty: Option<f64>,
    encoder_noise_ticks_rms: Option<f64>,
    load: Option<LoadName>,
    #[serde(default)]
    motor: FileMotor,
    #[serde(default)]
    body: FileBody,
    #[serde(default)]
    mismatch: FileMismatch,
    #[serde(default)]
    slip: FileSlip,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileSweep {
    wheel_radius_pct: Option<f64>,
    wheel_radius_left_right_pct: Option<f64>,
    track_width_pct: Option<f64>,
    supply_pct: Option<f64>,
    coulomb_friction_pct: Option<f64>,
    slip_max: Option<f64>,
    encoder_noise_ticks_rms_max: Option<f64>,
    start_position_m: Option<f64>,
    start_heading_rad: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenarioFile {
    name: Option<String>,
    #[serde(default)]
    description: String,
    #[serde(default)]
    sim: FileSim,
    path: FilePath,
    reference: FileReference,
    start: FileStart,
    #[serde(default)]
    robot: RobotSection,
    #[serde(default)]
    supervisor: SupervisorSection,
    #[serde(default)]
    plant: FilePlant,
    #[serde(default)]
    sweep: FileSweep,
    #[serde(default)]
    faults: Vec<FaultEntry>,
}

// ---------------------------------------------------------------------------------------
// Fixed-length number arrays. serde reads `[f64; N]` as a tuple of N elements, and the
// `toml` crate (1.x) does not check that the array ends there: `center_m = [5.0, 0.0,
// "junk"]` read as (5, 0). So every such key is read as a `RawValue`, which accepts any
// TOML value, and checked by `numbers` with its key: a wrong length, a non-number element
// or a non-array each get an error naming the key.

/// Any TOML value, kept just well enough to check it and to describe it in an error.
#[derive(Clone, Debug, PartialEq)]
enum RawValue {
    /// An integer or a float (integers as the nearest f64).
    Number(f64),
    /// An array of values.
    Array(Vec<RawValue>),
    /// Anything else, described for the error (`string "junk"`, `boolean true`, …).
    Other(String),
}

impl fmt::Display for RawValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RawValue::Number(v) => write!(f, "{v}"),
            RawValue::Array(items) => write!(f, "an array of {} elements", items.len()),
            RawValue::Other(what) => f.write_str(what),
        }
    }
}

impl<'de> Deserialize<'de> for RawValue {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(RawValueVisitor)
    }
}

struct RawValueVisitor;

impl<'de> serde::de::Visitor<'de> for RawValueVisitor {
    type Value = RawValue;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("any TOML value")
    }

    fn visit_bool<E>(self, v: bool) -> Result<RawValue, E> {
        Ok(RawValue::Other(format!("boolean {v}")))
    }

    fn visit_i64<E>(self, v: i64) -> Result<RawValue, E> {
        Ok(RawValue::Number(v as f64))
    }

    fn visit_u64<E>(self, v: u64) -> Result<RawValue, E> {
        Ok(RawValue::Number(v as f64))
    }

    fn visit_f64<E>(self, v: f64) -> Result<RawValue, E> {
        Ok(RawValue::Number(v))
    }

    fn visit_str<E>(self, v: &str) -> Result<RawValue, E> {
        Ok(RawValue::Other(format!("string {v:?}")))
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<RawValue, A::Error> {
        let mut items = Vec::new();
        while let Some(item) = seq.next_element()? {
            items.push(item);
        }
        Ok(RawValue::Array(items))
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<RawValue, A::Error> {
        while map
            .next_entry::<serde::de::IgnoredAny, serde::de::IgnoredAny>()?
            .is_some()
        {}
        Ok(RawValue::Other("a table".to_string()))
    }
}

/// The elements of `raw` (at `key`) if it is an array.
fn array<'a>(key: &str, raw: &'a RawValue, what: &str) -> Result<&'a [RawValue], ScenarioError> {
    match raw {
        RawValue::Array(items) => Ok(items),
        other => Err(ScenarioError::invalid(
            key,
            format!("must be an array of {what}, got {other}"),
        )),
    }
}

/// `raw` (at `key`) as exactly `N` numbers.
fn numbers<const N: usize>(key: &str, raw: &RawValue) -> Result<[f64; N], ScenarioError> {
    let items = array(key, raw, &format!("{N} numbers"))?;
    if items.len() != N {
        return Err(ScenarioError::invalid(
            key,
            format!("must have exactly {N} numbers, got {}", items.len()),
        ));
    }
    let mut out = [0.0; N];
    for (i, (o, item)) in out.iter_mut().zip(items).enumerate() {
        match item {
            RawValue::Number(v) => *o = *v,
            other => {
                return Err(ScenarioError::invalid(
                    format!("{key}[{i}]"),
                    format!("must be a number, got {other}"),
                ))
            }
        }
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------
// The validated scenario.

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
    /// Longitudinal slip ratios [left, right], in [0, 1).
    pub slip: [f64; 2],
    /// Encoder edge jitter, ticks RMS (0 = ideal).
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
            slip: [0.0; 2],
            encoder_noise_ticks_rms: 0.0,
            load: Load::Ground,
        }
    }
}

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
    /// Slip ratio of each wheel, drawn in [0, slip_max].
    pub slip_max: f64,
    /// Encoder edge jitter, drawn in [0, max] ticks RMS.
    pub encoder_noise_ticks_rms_max: f64,
    /// Start position offset in x and in y, ± m.
    pub start_position_m: f64,
    /// Start heading offset, ± rad.
    pub start_heading_rad: f64,
}

impl SweepSpec {
    /// ±1 % radius, ±0.5 % left/right, ±2 % track, ±10 % supply, ±50 % Coulomb friction,
    /// up to 1 % slip per wheel, up to 0.5 tick jitter, ±0.1 m and ±0.2 rad of start pose.
    pub const DEFAULT: SweepSpec = SweepSpec {
        wheel_radius_pct: 1.0,
        wheel_radius_left_right_pct: 0.5,
        track_width_pct: 2.0,
        supply_pct: 10.0,
        coulomb_friction_pct: 50.0,
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
        check_duration(duration_s, self.robot.control_rate_hz)?;
        self.duration_s = duration_s;
        Ok(self)
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
    let file: ScenarioFile = toml::from_str(text).map_err(|e| ScenarioError::Syntax {
        origin: origin.to_string(),
        message: e.to_string().trim_end().to_string(),
    })?;
    build(file, default_name)
}

// ---------------------------------------------------------------------------------------
// Validation helpers. Each returns the dotted key and the problem with the value.

/// `sim.duration_s` (s) at a control rate of `control_hz`: in (0, 24 h] and within the
/// simulator's step budget.
fn check_duration(duration_s: f64, control_hz: u32) -> Result<(), ScenarioError> {
    check(
        duration_s > 0.0 && duration_s <= MAX_DURATION_S,
        "sim.duration_s",
        &format!("must be in (0, {MAX_DURATION_S}]"),
        duration_s,
    )?;
    check(
        duration_s * f64::from(control_hz) <= MAX_CONTROL_STEPS,
        "sim.duration_s",
        &format!(
            "times robot.control_rate_hz ({control_hz}) must be ≤ {MAX_CONTROL_STEPS:e} control steps"
        ),
        duration_s,
    )
}

fn check(ok: bool, key: &str, rule: &str, value: impl fmt::Display) -> Result<(), ScenarioError> {
    if ok {
        Ok(())
    } else {
        Err(ScenarioError::invalid(key, format!("{rule}, got {value}")))
    }
}

fn positive(key: &str, v: f64) -> Result<f64, ScenarioError> {
    check(v > 0.0 && v.is_finite(), key, "must be > 0", v)?;
    Ok(v)
}

fn non_negative(key: &str, v: f64) -> Result<f64, ScenarioError> {
    check(v >= 0.0 && v.is_finite(), key, "must be ≥ 0", v)?;
    Ok(v)
}

fn finite(key: &str, v: f64) -> Result<f64, ScenarioError> {
    check(v.is_finite(), key, "must be finite", v)?;
    Ok(v)
}

fn in_range(key: &str, v: f64, lo: f64, hi: f64, rule: &str) -> Result<f64, ScenarioError> {
    check(v >= lo && v < hi && v.is_finite(), key, rule, v)?;
    Ok(v)
}

/// `v` as the f32 the controller uses; an error naming `key` if it does not fit.
fn as_f32(key: &str, v: f64) -> Result<f32, ScenarioError> {
    let f = v as f32;
    check(
        f.is_finite() || !v.is_finite(),
        key,
        "is beyond the f32 range of the controller (±3.4e38)",
        v,
    )?;
    Ok(f)
}

fn required<T: Copy>(value: Option<T>, key: &str, kind: &str) -> Result<T, ScenarioError> {
    value.ok_or_else(|| ScenarioError::invalid(key, format!("is required for kind = \"{kind}\"")))
}

/// The point at `key`, (0, 0) if the key is absent.
fn optional_point(key: &str, raw: Option<&RawValue>) -> Result<Point, ScenarioError> {
    point(key, raw.map_or(Ok([0.0, 0.0]), |raw| numbers(key, raw))?)
}

fn point(key: &str, p: [f64; 2]) -> Result<Point, ScenarioError> {
    let x = as_f32(&format!("{key}[0]"), finite(&format!("{key}[0]"), p[0])?)?;
    let y = as_f32(&format!("{key}[1]"), finite(&format!("{key}[1]"), p[1])?)?;
    Ok(Point::new(x, y))
}

fn path_error(e: PathError) -> ScenarioError {
    ScenarioError::invalid("path", format!("is not a valid path: {e}"))
}

fn build_path(p: &FilePath) -> Result<Path, ScenarioError> {
    let used: &[&str] = match p.kind {
        PathKind::Circle => &[
            "center_m",
            "radius_m",
            "start_angle_rad",
            "counter_clockwise",
        ],
        PathKind::Line => &["start_m", "heading_rad", "length_m"],
        PathKind::Polyline => &["waypoints_m", "corner_radius_m", "closed"],
        PathKind::FigureEight => &["center_m", "lobe_radius_m"],
    };
    let present = [
        ("center_m", p.center_m.is_some()),
        ("radius_m", p.radius_m.is_some()),
        ("start_angle_rad", p.start_angle_rad.is_some()),
        ("counter_clockwise", p.counter_clockwise.is_some()),
        ("start_m", p.start_m.is_some()),
        ("heading_rad", p.heading_rad.is_some()),
        ("length_m", p.length_m.is_some()),
        ("waypoints_m", p.waypoints_m.is_some()),
        ("corner_radius_m", p.corner_radius_m.is_some()),
        ("closed", p.closed.is_some()),
        ("lobe_radius_m", p.lobe_radius_m.is_some()),
    ];
    let kind_name = match p.kind {
        PathKind::Circle => "circle",
        PathKind::Line => "line",
        PathKind::Polyline => "polyline",
        PathKind::FigureEight => "figure-eight",
    };
    if let Some((name, _)) = present.iter().find(|(n, set)| *set && !used.contains(n)) {
        return Err(ScenarioError::invalid(
            format!("path.{name}"),
            format!(
                "is not used by kind = \"{kind_name}\" (it takes {})",
                used.join(", ")
            ),
        ));
    }
    let path = match p.kind {
        PathKind::Circle => {
            let center = optional_point("path.center_m", p.center_m.as_ref())?;
            let r = positive(
                "path.radius_m",
                required(p.radius_m, "path.radius_m", kind_name)?,
            )?;
            let a = finite("path.start_angle_rad", p.start_angle_rad.unwrap_or(0.0))?;
            Path::circle(
                center,
                as_f32("path.radius_m", r)?,
                as_f32("path.start_angle_rad", a)?,
                p.counter_clockwise.unwrap_or(true),
            )
        }
        PathKind::Line => {
            let raw = p.start_m.as_ref().ok_or_else(|| {
                ScenarioError::invalid("path.start_m", "is required for kind = \"line\"")
            })?;
            let start = point("path.start_m", numbers("path.start_m", raw)?)?;
            let h = finite("path.heading_rad", p.heading_rad.unwrap_or(0.0))?;
            let l = positive(
                "path.length_m",
                required(p.length_m, "path.length_m", kind_name)?,
            )?;
            Path::line(
                start,
                as_f32("path.heading_rad", h)?,
                as_f32("path.length_m", l)?,
            )
        }
        PathKind::Polyline => {
            let raw = p.waypoints_m.as_ref().ok_or_else(|| {
                ScenarioError::invalid("path.waypoints_m", "is required for kind = \"polyline\"")
            })?;
            let raw = array("path.waypoints_m", raw, "[x, y] points")?;
            let mut points = Vec::with_capacity(raw.len());
            for (i, w) in raw.iter().enumerate() {
                let key = format!("path.waypoints_m[{i}]");
                points.push(point(&key, numbers(&key, w)?)?);
            }
            let r = non_negative("path.corner_radius_m", p.corner_radius_m.unwrap_or(0.0))?;
            Path::polyline(
                &points,
                as_f32("path.corner_radius_m", r)?,
                p.closed.unwrap_or(false),
            )
        }
        PathKind::FigureEight => {
            let center = optional_point("path.center_m", p.center_m.as_ref())?;
            let r = positive(
                "path.lobe_radius_m",
                required(p.lobe_radius_m, "path.lobe_radius_m", kind_name)?,
            )?;
            Path::figure_eight(center, as_f32("path.lobe_radius_m", r)?)
        }
    };
    path.map_err(path_error)
}

fn build_plant(p: &FilePlant) -> Result<PlantSpec, ScenarioError> {
    let d = PlantSpec::default();
    let m = &p.motor;
    let motor = MotorParams {
        resistance_ohm: positive(
            "plant.motor.resistance_ohm",
            m.resistance_ohm.unwrap_or(d.motor.resistance_ohm),
        )?,
        torque_constant_nm_per_a: positive(
            "plant.motor.torque_constant_nm_per_a",
            m.torque_constant_nm_per_a
                .unwrap_or(d.motor.torque_constant_nm_per_a),
        )?,
        back_emf_v_s_per_rad: positive(
            "plant.motor.back_emf_v_s_per_rad",
            m.back_emf_v_s_per_rad
                .unwrap_or(d.motor.back_emf_v_s_per_rad),
        )?,
        rotor_inertia_kg_m2: non_negative(
            "plant.motor.rotor_inertia_kg_m2",
            m.rotor_inertia_kg_m2.unwrap_or(d.motor.rotor_inertia_kg_m2),
        )?,
        gear_efficiency: {
            let v = m.gear_efficiency.unwrap_or(d.motor.gear_efficiency);
            check(
                v > 0.0 && v <= 1.0,
                "plant.motor.gear_efficiency",
                "must be in (0, 1]",
                v,
            )?;
            v
        },
        viscous_friction_nm_s_per_rad: non_negative(
            "plant.motor.viscous_friction_nm_s_per_rad",
            m.viscous_friction_nm_s_per_rad
                .unwrap_or(d.motor.viscous_friction_nm_s_per_rad),
        )?,
        coulomb_friction_nm: non_negative(
            "plant.motor.coulomb_friction_nm",
            m.coulomb_friction_nm.unwrap_or(d.motor.coulomb_friction_nm),
        )?,
    };
    let pwm_levels = p.pwm_levels.unwrap_or(d.driver.pwm_levels);
    check(
        pwm_levels > 0,
        "plant.pwm_levels",
        "must be > 0",
        pwm_levels,
    )?;
    let kind = match p.driver {
        None => d.driver.kind,
        Some(DriverName::Tb6612) => DriverKind::Tb6612,
        Some(DriverName::Drv8833) => DriverKind::Drv8833,
    };
    let supply_v = positive("plant.supply_v", p.supply_v.unwrap_or(d.driver.supply_v))?;
    check(
        supply_v <= kind.max_supply_v(),
        "plant.supply_v",
        &format!(
            "must be ≤ {} V, the {}'s absolute maximum (plant.driver)",
            kind.max_supply_v(),
            kind.name()
        ),
        supply_v,
    )?;
    let driver = DriverParams {
        kind,
        supply_v,
        pwm_levels,
        dead_band_duty: in_range(
            "plant.dead_band_duty",
            p.dead_band_duty.unwrap_or(d.driver.dead_band_duty),
            0.0,
            1.0,
            "must be in [0, 1)",
        )?,
    };
    let b = &p.body;
    let body = BodyParams {
        mass_kg: positive("plant.body.mass_kg", b.mass_kg.unwrap_or(d.body.mass_kg))?,
        yaw_inertia_kg_m2: non_negative(
            "plant.body.yaw_inertia_kg_m2",
            b.yaw_inertia_kg_m2.unwrap_or(d.body.yaw_inertia_kg_m2),
        )?,
        wheel_inertia_kg_m2: non_negative(
            "plant.body.wheel_inertia_kg_m2",
            b.wheel_inertia_kg_m2.unwrap_or(d.body.wheel_inertia_kg_m2),
        )?,
        com_ahead_of_axle_m: finite(
            "plant.body.com_ahead_of_axle_m",
            b.com_ahead_of_axle_m.unwrap_or(d.body.com_ahead_of_axle_m),
        )?,
    };
    // The yaw inertia is about the axle, so it contains the centre of mass' own m d².
    let d_com = body.com_ahead_of_axle_m;
    check(
        body.mass_kg * d_com * d_com <= body.yaw_inertia_kg_m2,
        "plant.body.com_ahead_of_axle_m",
        &format!(
            "must satisfy mass_kg · d² ≤ yaw_inertia_kg_m2 (the inertia about the axle includes m d²; |d| ≤ {:.4} m here)",
            (body.yaw_inertia_kg_m2 / body.mass_kg).sqrt()
        ),
        d_com,
    )?;
    let pct = |key: &str, v: Option<f64>| {
        in_range(
            key,
            v.unwrap_or(0.0),
            -50.0,
            50.0 + f64::EPSILON,
            "must be in [-50, 50] %",
        )
    };
    let mismatch = Mismatch {
        wheel_radius_pct: pct(
            "plant.mismatch.wheel_radius_pct",
            p.mismatch.wheel_radius_pct,
        )?,
        wheel_radius_left_right_pct: pct(
            "plant.mismatch.wheel_radius_left_right_pct",
            p.mismatch.wheel_radius_left_right_pct,
        )?,
        track_width_pct: pct("plant.mismatch.track_width_pct", p.mismatch.track_width_pct)?,
    };
    let slip = [
        in_range(
            "plant.slip.left",
            p.slip.left.unwrap_or(0.0),
            0.0,
            1.0,
            "must be in [0, 1)",
        )?,
        in_range(
            "plant.slip.right",
            p.slip.right.unwrap_or(0.0),
            0.0,
            1.0,
            "must be in [0, 1)",
        )?,
    ];
    let encoder_noise_ticks_rms = non_negative(
        "plant.encoder_noise_ticks_rms",
        p.encoder_noise_ticks_rms.unwrap_or(0.0),
    )?;
    Ok(PlantSpec {
        motor,
        driver,
        body,
        mismatch,
        slip,
        encoder_noise_ticks_rms,
        load: match p.load {
            None | Some(LoadName::Ground) => Load::Ground,
            Some(LoadName::Lifted) => Load::Lifted,
        },
    })
}

fn build_sweep(s: &FileSweep) -> Result<SweepSpec, ScenarioError> {
    let d = SweepSpec::DEFAULT;
    let spread = |key: &str, v: Option<f64>, default: f64, max: f64| {
        let v = v.unwrap_or(default);
        check(
            v >= 0.0 && v <= max,
            key,
            &format!("must be in [0, {max}]"),
            v,
        )?;
        Ok::<f64, ScenarioError>(v)
    };
    Ok(SweepSpec {
        wheel_radius_pct: spread(
            "sweep.wheel_radius_pct",
            s.wheel_radius_pct,
            d.wheel_radius_pct,
            20.0,
        )?,
        wheel_radius_left_right_pct: spread(
            "sweep.wheel_radius_left_right_pct",
            s.wheel_radius_left_right_pct,
            d.wheel_radius_left_right_pct,
            20.0,
        )?,
        track_width_pct: spread(
            "sweep.track_width_pct",
            s.track_width_pct,
            d.track_width_pct,
            20.0,
        )?,
        supply_pct: spread("sweep.supply_pct", s.supply_pct, d.supply_pct, 50.0)?,
        coulomb_friction_pct: spread(
            "sweep.coulomb_friction_pct",
            s.coulomb_friction_pct,
            d.coulomb_friction_pct,
            100.0,
        )?,
        slip_max: spread("sweep.slip_max", s.slip_max, d.slip_max, 0.5)?,
        encoder_noise_ticks_rms_max: spread(
            "sweep.encoder_noise_ticks_rms_max",
            s.encoder_noise_ticks_rms_max,
            d.encoder_noise_ticks_rms_max,
            10.0,
        )?,
        start_position_m: spread(
            "sweep.start_position_m",
            s.start_position_m,
            d.start_position_m,
            10.0,
        )?,
        start_heading_rad: spread(
            "sweep.start_heading_rad",
            s.start_heading_rad,
            d.start_heading_rad,
            core::f64::consts::PI,
        )?,
    })
}

/// Longest simulated time accepted, s.
pub const MAX_DURATION_S: f64 = 86_400.0;

/// Most control steps one run may take (duration × control rate): bounds the memory a
/// scenario file can ask for (the run keeps a trace and per-steering-step samples).
pub const MAX_CONTROL_STEPS: f64 = 1e8;

/// Fastest control loop accepted, Hz (the plant then runs at ≥ 10× this).
pub const MAX_CONTROL_RATE_HZ: u32 = 100_000;

fn build(file: ScenarioFile, default_name: &str) -> Result<Scenario, ScenarioError> {
    let robot = file.robot.apply(RobotConfig::REFERENCE_ROBOT);
    // The simulator's own limit first: an absurd rate is refused as such.
    check(
        robot.control_rate_hz <= MAX_CONTROL_RATE_HZ,
        "robot.control_rate_hz",
        &format!("must be ≤ {MAX_CONTROL_RATE_HZ}"),
        robot.control_rate_hz,
    )?;
    // The core is the single source of truth for what a valid RobotConfig is.
    let params = file.robot.params(RobotConfig::REFERENCE_ROBOT, "robot")?;

    let duration_s = file.sim.duration_s.unwrap_or(30.0);
    let control = robot.control_rate_hz;
    check_duration(duration_s, control)?;
    let plant_rate_hz = file.sim.plant_rate_hz.unwrap_or(control.saturating_mul(10));
    check(
        plant_rate_hz % control == 0 && plant_rate_hz / control >= 10,
        "sim.plant_rate_hz",
        &format!("must be a multiple of robot.control_rate_hz ({control}) and at least 10× it"),
        plant_rate_hz,
    )?;

    let path = build_path(&file.path)?;

    let r = &file.reference;
    let speed = as_f32(
        "reference.speed_m_s",
        positive("reference.speed_m_s", r.speed_m_s)?,
    )?;
    let reference_mode = match r.mode {
        ModeName::TimeIndexed => {
            if r.lookahead_m.is_some() {
                return Err(ScenarioError::invalid(
                    "reference.lookahead_m",
                    "is only used with mode = \"path-following\"",
                ));
            }
            ReferenceMode::TimeIndexed {
                start_offset_m: as_f32(
                    "reference.start_offset_m",
                    non_negative("reference.start_offset_m", r.start_offset_m.unwrap_or(0.0))?,
                )?,
            }
        }
        ModeName::PathFollowing => {
            if r.start_offset_m.is_some() {
                return Err(ScenarioError::invalid(
                    "reference.start_offset_m",
                    "is only used with mode = \"time-indexed\"",
                ));
            }
            ReferenceMode::PathFollowing {
                lookahead_m: as_f32(
                    "reference.lookahead_m",
                    non_negative("reference.lookahead_m", r.lookahead_m.unwrap_or(0.0))?,
                )?,
            }
        }
    };

    let s = &file.start;
    for (key, v) in [
        ("start.x_m", s.x_m),
        ("start.y_m", s.y_m),
        ("start.theta_rad", s.theta_rad),
        ("start.v_m_s", s.v_m_s),
        ("start.omega_rad_s", s.omega_rad_s),
    ] {
        as_f32(key, v)?;
    }
    let start = StartState {
        x_m: finite("start.x_m", s.x_m)?,
        y_m: finite("start.y_m", s.y_m)?,
        theta_rad: finite("start.theta_rad", s.theta_rad)?,
        v_m_s: finite("start.v_m_s", s.v_m_s)?,
        omega_rad_s: finite("start.omega_rad_s", s.omega_rad_s)?,
    };
    // The initial wheel speeds must be within what the encoder check accepts.
    let half = 0.5 * start.omega_rad_s.abs() * f64::from(robot.track_width_m);
    let smaller_wheel = robot.wheel_radius_left_m.min(robot.wheel_radius_right_m);
    let fastest = (start.v_m_s.abs() + half) / f64::from(smaller_wheel);
    check(
        fastest < f64::from(robot.max_plausible_wheel_speed_rad_s),
        "start.v_m_s",
        &format!(
            "with start.omega_rad_s needs a wheel speed below robot.max_plausible_wheel_speed_rad_s ({})",
            robot.max_plausible_wheel_speed_rad_s
        ),
        start.v_m_s,
    )?;

    let reference = Reference::new(path.clone(), speed, reference_mode)
        .map_err(|e| ScenarioError::invalid("reference", format!("is not valid: {e}")))?;
    let start_pose = Pose::new(start.x_m as f32, start.y_m as f32, start.theta_rad as f32);
    let context = PathContext {
        reference: &reference,
        start: start_pose,
    };
    let supervisor = file
        .supervisor
        .config(&params, Some(context), "supervisor")?;

    Ok(Scenario {
        name: file.name.unwrap_or_else(|| default_name.to_string()),
        description: file.description,
        duration_s,
        plant_rate_hz,
        seed: file.sim.seed.unwrap_or(1),
        path,
        reference_speed_m_s: speed,
        reference_mode,
        start,
        robot,
        supervisor,
        plant: build_plant(&file.plant)?,
        arm_at_start: file.start.arm == ArmAtStart::AtStart,
        faults: file
            .faults
            .iter()
            .enumerate()
            .map(|(i, f)| f.build(i, control))
            .collect::<Result<_, _>>()
            .map_err(|e| ScenarioError::invalid(e.key, e.problem))?,
        sweep: build_sweep(&file.sweep)?,
    })
}

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
