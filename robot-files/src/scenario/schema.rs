//! The scenario file's schema, as serde reads it: every table denies unknown keys, so a
//! typo is an error, not a silent default. Values are checked afterwards, with their key,
//! by the `build` module.

use serde::Deserialize;

use super::raw_value::RawValue;
use crate::faults::FaultEntry;
use crate::robot_file::{RobotSection, SupervisorSection};

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileSim {
    pub(super) duration_s: Option<f64>,
    pub(super) plant_rate_hz: Option<u32>,
    pub(super) seed: Option<u64>,
}

#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub(super) enum PathKind {
    Circle,
    Line,
    Polyline,
    FigureEight,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FilePath {
    pub(super) kind: PathKind,
    pub(super) center_m: Option<RawValue>,
    pub(super) radius_m: Option<f64>,
    pub(super) start_angle_rad: Option<f64>,
    pub(super) counter_clockwise: Option<bool>,
    pub(super) start_m: Option<RawValue>,
    pub(super) heading_rad: Option<f64>,
    pub(super) length_m: Option<f64>,
    pub(super) waypoints_m: Option<RawValue>,
    pub(super) corner_radius_m: Option<f64>,
    pub(super) closed: Option<bool>,
    pub(super) lobe_radius_m: Option<f64>,
}

#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
pub(super) enum ModeName {
    #[default]
    TimeIndexed,
    PathFollowing,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FileReference {
    pub(super) speed_m_s: f64,
    #[serde(default)]
    pub(super) mode: ModeName,
    pub(super) start_offset_m: Option<f64>,
    pub(super) lookahead_m: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FileStart {
    pub(super) x_m: f64,
    pub(super) y_m: f64,
    pub(super) theta_rad: f64,
    #[serde(default)]
    pub(super) v_m_s: f64,
    #[serde(default)]
    pub(super) omega_rad_s: f64,
    #[serde(default)]
    pub(super) arm: ArmAtStart,
}

/// `[start] arm`: whether the run arms at t = 0.
#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
pub(super) enum ArmAtStart {
    /// Armed at step 0 (in motion if the start moves), as an operator at the robot would.
    #[default]
    AtStart,
    /// Left disarmed: a `button-press` fault on the timeline arms it (or nothing does).
    None,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileMotor {
    pub(super) resistance_ohm: Option<f64>,
    pub(super) torque_constant_nm_per_a: Option<f64>,
    pub(super) back_emf_v_s_per_rad: Option<f64>,
    pub(super) rotor_inertia_kg_m2: Option<f64>,
    pub(super) gear_efficiency: Option<f64>,
    pub(super) viscous_friction_nm_s_per_rad: Option<f64>,
    pub(super) coulomb_friction_nm: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileBody {
    pub(super) mass_kg: Option<f64>,
    pub(super) yaw_inertia_kg_m2: Option<f64>,
    pub(super) wheel_inertia_kg_m2: Option<f64>,
    pub(super) com_ahead_of_axle_m: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileMismatch {
    pub(super) wheel_radius_pct: Option<f64>,
    pub(super) wheel_radius_left_right_pct: Option<f64>,
    pub(super) track_width_pct: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileMotorMismatch {
    pub(super) resistance_left_right_pct: Option<f64>,
    pub(super) torque_constant_left_right_pct: Option<f64>,
    pub(super) viscous_friction_left_right_pct: Option<f64>,
    pub(super) coulomb_friction_left_right_pct: Option<f64>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileSlip {
    pub(super) left: Option<f64>,
    pub(super) right: Option<f64>,
}

#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub(super) enum DriverName {
    Tb6612,
    Drv8833,
}

#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub(super) enum LoadName {
    Ground,
    Lifted,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FilePlant {
    pub(super) driver: Option<DriverName>,
    pub(super) supply_v: Option<f64>,
    pub(super) pwm_levels: Option<u32>,
    pub(super) dead_band_duty: Option<f64>,
    pub(super) encoder_noise_ticks_rms: Option<f64>,
    pub(super) load: Option<LoadName>,
    #[serde(default)]
    pub(super) motor: FileMotor,
    #[serde(default)]
    pub(super) body: FileBody,
    #[serde(default)]
    pub(super) mismatch: FileMismatch,
    #[serde(default)]
    pub(super) motor_mismatch: FileMotorMismatch,
    #[serde(default)]
    pub(super) slip: FileSlip,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileSweep {
    pub(super) wheel_radius_pct: Option<f64>,
    pub(super) wheel_radius_left_right_pct: Option<f64>,
    pub(super) track_width_pct: Option<f64>,
    pub(super) supply_pct: Option<f64>,
    pub(super) coulomb_friction_pct: Option<f64>,
    pub(super) motor_left_right_pct: Option<f64>,
    pub(super) slip_max: Option<f64>,
    pub(super) encoder_noise_ticks_rms_max: Option<f64>,
    pub(super) start_position_m: Option<f64>,
    pub(super) start_heading_rad: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ScenarioFile {
    pub(super) name: Option<String>,
    #[serde(default)]
    pub(super) description: String,
    #[serde(default)]
    pub(super) sim: FileSim,
    pub(super) path: FilePath,
    pub(super) reference: FileReference,
    pub(super) start: FileStart,
    #[serde(default)]
    pub(super) robot: RobotSection,
    #[serde(default)]
    pub(super) supervisor: SupervisorSection,
    #[serde(default)]
    pub(super) plant: FilePlant,
    #[serde(default)]
    pub(super) sweep: FileSweep,
    #[serde(default)]
    pub(super) faults: Vec<FaultEntry>,
    pub(super) gyro: Option<super::gyro::FileGyro>,
    pub(super) velocity: Option<FileVelocity>,
    #[serde(default)]
    pub(super) virtual_robot: FileVirtualRobot,
}

/// `[velocity]` (see the `velocity` module).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FileVelocity {
    pub(super) commands: RawValue,
    pub(super) command_period_s: Option<f64>,
    pub(super) stop_sending_s: Option<f64>,
}

/// `[virtual_robot]`: what only `host-sim serve` reads.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileVirtualRobot {
    #[serde(default)]
    pub(super) miswire: String,
}
