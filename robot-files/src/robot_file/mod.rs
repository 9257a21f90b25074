//! The `[robot]` and `[supervisor]` TOML sections: one schema, parsed by this module for
//! the scenarios ([`crate::scenario`]) and for the ground station's `params get` /
//! `params set`, so a robot file tuned in the simulator is the robot file the real robot
//! takes.
//!
//! `robot.rs` holds `[robot]` (what the controller believes), `supervisor.rs`
//! `[supervisor]` (its settings in seconds); this file the whole file and the errors.
//!
//! ```toml
//! [robot]                      # every key optional; the rest from RobotConfig::REFERENCE_ROBOT
//! wheel_radius_m = 0.0325      # both wheels; or wheel_radius_left_m / wheel_radius_right_m
//! track_width_m = 0.15
//! encoder_lines_per_motor_rev = 12
//! gear_ratio = 30.0
//! control_rate_hz = 1000
//! steering_divider = 10
//! speed_window_steps = 20
//! max_plausible_wheel_speed_rad_s = 100.0
//! [robot.limits]               # max_rim_speed_m_s, max_linear_accel_m_s2, max_angular_accel_rad_s2
//! [robot.motor]                # rated_voltage_v, resistance_ohm, max_current_a
//! [robot.drive]                # min_supply_v, max_supply_v, supply_filter_tau_s, slew_v_per_s
//! [robot.wheels]               # both wheel loops: ks_v, kv_v_per_rad_s, kp_v_per_rad_s,
//!                              #   ti_s, td_s, d_filter_tau_s
//! [robot.left_wheel]           # … and per wheel, over [robot.wheels]
//! [robot.right_wheel]
//! [robot.law.paper]            # gamma, k, h, lambda
//! [robot.law.tracking]         # lambda, k_x, k_theta
//! [robot.law.kanayama]         # k_x, k_y, k_theta
//! [robot.velocity]             # the velocity mode: cmd_vel_timeout_steps (500 at 1 kHz)
//! [robot.velocity.linear_x]    # max_velocity, max_acceleration, max_jerk (m/s, m/s², m/s³)
//! [robot.velocity.angular_z]   # max_velocity, max_acceleration, max_jerk (rad/s, rad/s², rad/s³)
//! [robot.wiring]               # left/right_motor_inverted, motors_swapped,
//!                              #   left/right_encoder_inverted, encoders_swapped, supply_scale
//! [robot.gyro]                 # heading_source ("odometry" or "fused"), axis_inverted, scale,
//!                              #   full_scale_radps, bias_time_constant_s,
//!                              #   odometry_blend_time_constant_s, max_age_periods,
//!                              #   absent_limit_steps, stuck_limit_steps, stuck_turn_rad,
//!                              #   disagreement_threshold_radps, disagreement_window_s,
//!                              #   disagreement_stops
//!
//! [supervisor]                 # times in seconds; the supervisor counts control steps
//! run_time_limit_s = 120.0     # or "none" (the default: a soak can run for a day)
//! auto_arm_after_s = "none"
//! debounce_s = 0.02
//! long_press_s = 1.0
//! heartbeat_timeout_s = 0.5
//! brake_s = 0.5
//! max_consecutive_overruns = 5
//! background_timeout_s = 0.5
//! battery_warn_v = 5.0
//! battery_fault_v = 4.6
//! battery_debounce_s = 0.2
//! hold_speeds_rad_s = [5.0, 5.0]
//! [supervisor.missed_ticks]    # window_s, max_per_window, max_gap_periods
//! [supervisor.stall]           # min_volts, min_speed_rad_s, timeout_s
//! [supervisor.saturation]      # window_s, max_fraction
//! [supervisor.divergence]      # "auto" (from the path; the default), "off", or
//!                              #   settle_s, bound_m, persist_s
//! geofence_radius_m = "auto"   # "auto" (from the path), "off", or a radius in m
//! ```
//!
//! A bad value gets an error naming the key, e.g. `robot.motor.max_current_a must be > 0,
//! got -1`: the core's own validation ([`Params::new`](controller_core::params::Params::new),
//! [`SupervisorConfig::validate`]) decides, and its field name is turned into the TOML key.

mod gyro;
mod robot;
mod supervisor;

use std::fmt;

use controller_core::params::{ParamError, RobotConfig};
use controller_core::supervisor::{SupervisorConfig, SupervisorConfigError};
use serde::{Deserialize, Serialize};

pub use gyro::{GyroSection, HeadingSourceName};
pub use robot::{
    tuned_wheel_sections, AxisSection, DriveSection, KanayamaSection, LawSection, LimitsSection,
    MotorSection, PaperSection, RobotSection, TrackingSection, VelocitySection, WheelSection,
};
pub use supervisor::{
    DivergenceSection, DivergenceSetting, MissedTicksSection, PathContext, SaturationSection,
    StallSection, SupervisorSection,
};

/// A value that may be a number, or a keyword (`"none"`, `"off"`, `"auto"`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum NumberOr {
    /// A number.
    Number(f64),
    /// A keyword.
    Keyword(Keyword),
}

/// The keywords a [`NumberOr`] accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Keyword {
    /// No limit.
    None,
    /// Switched off.
    Off,
    /// Derived from the path.
    Auto,
}

/// Why a robot or supervisor section was rejected. `Display` names the TOML key.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{key} {problem}")]
pub struct SectionError {
    /// Dotted TOML key, e.g. `robot.motor.max_current_a`.
    pub key: String,
    /// What is wrong with it, with the value.
    pub problem: String,
}

impl SectionError {
    /// The error on `key` (dotted) with `problem`.
    fn new(key: impl Into<String>, problem: impl fmt::Display) -> Self {
        Self {
            key: key.into(),
            problem: problem.to_string(),
        }
    }
}

/// `*dst = value` when the file sets it.
fn set<T: Copy>(dst: &mut T, value: Option<T>) {
    if let Some(v) = value {
        *dst = v;
    }
}

/// The core's [`ParamError`] as an error naming the TOML key under `prefix`: the core
/// names the field by its path in `RobotConfig`, which is the key under `[robot]`.
pub fn param_error(e: ParamError, prefix: &str) -> SectionError {
    keyed_error(&e, e.field(), prefix)
}

/// An error whose message starts with its `field`, as an error naming the TOML key
/// `prefix.field` and the rest of the message as the problem.
fn keyed_error(e: &impl fmt::Display, field: &str, prefix: &str) -> SectionError {
    let full = e.to_string();
    let problem = full
        .strip_prefix(field)
        .map_or(full.as_str(), str::trim_start)
        .to_string();
    SectionError::new(format!("{prefix}.{field}"), problem)
}

/// The core's [`SupervisorConfigError`] as an error naming the TOML key under `prefix`.
pub fn supervisor_error(e: SupervisorConfigError, prefix: &str) -> SectionError {
    keyed_error(&e, e.field(), prefix)
}

/// A robot file: `[robot]` and `[supervisor]`, what `station params get` writes and
/// `station params set` reads.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotFile {
    /// `[robot]`.
    #[serde(default)]
    pub robot: RobotSection,
    /// `[supervisor]`.
    #[serde(default)]
    pub supervisor: SupervisorSection,
}

impl RobotFile {
    /// Parses a robot file; a syntax error or an unknown key names the line.
    pub fn from_toml(text: &str) -> Result<Self, SectionError> {
        crate::toml_text::from_str(text).map_err(|message| SectionError::new("file", message))
    }

    /// Both sections of a complete configuration.
    pub fn of(robot: &RobotConfig, supervisor: &SupervisorConfig) -> Self {
        Self {
            robot: RobotSection::of(robot),
            supervisor: SupervisorSection::of(supervisor, robot.control_rate_hz),
        }
    }

    /// The file as TOML text.
    pub fn to_toml(&self) -> String {
        // Every field is a number, a string keyword, a table or an array: this cannot fail.
        toml::to_string(self).unwrap_or_default()
    }

    /// The configuration this file describes over a robot's own, `robot` and
    /// `supervisor`: keys the file leaves out keep the robot's values; the start pose,
    /// and the path-derived checks (`divergence`, `geofence_radius_m`) left at "auto",
    /// keep the robot's, which it derives again from each committed path. Errors name
    /// the key.
    pub fn over(
        &self,
        robot: &RobotConfig,
        supervisor: &SupervisorConfig,
    ) -> Result<(RobotConfig, SupervisorConfig), SectionError> {
        let params = self.robot.params(*robot, "robot")?;
        let mut config = self.supervisor.config(&params, None, "supervisor")?;
        config.start_pose = supervisor.start_pose;
        if matches!(
            self.supervisor.divergence,
            None | Some(DivergenceSetting::Keyword(Keyword::Auto))
        ) {
            config.divergence = supervisor.divergence;
        }
        if matches!(
            self.supervisor.geofence_radius_m,
            None | Some(NumberOr::Keyword(Keyword::Auto))
        ) {
            config.geofence_radius_m = supervisor.geofence_radius_m;
        }
        Ok((*params.config(), config))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::params::Params;
    use controller_core::prelude::{Path, Point, Pose, Reference, ReferenceMode};

    fn reference() -> Reference {
        let path = Path::circle(Point::new(0.0, 0.0), 1.25, 0.0, true).unwrap();
        Reference::new(
            path,
            0.25,
            ReferenceMode::TimeIndexed {
                start_offset_m: 0.0,
            },
        )
        .unwrap()
    }

    #[test]
    fn a_complete_file_round_trips() {
        let mut robot = RobotConfig::REFERENCE_ROBOT;
        robot.wheel_radius_right_m = 0.033;
        robot.left_wheel.kp_v_per_rad_s = 0.7;
        let params = Params::new(robot).unwrap();
        let r = reference();
        let ctx = PathContext {
            reference: &r,
            start: Pose::new(1.0, 2.0, 0.5),
        };
        let mut supervisor = SupervisorSection::default()
            .config(&params, Some(ctx), "supervisor")
            .unwrap();
        supervisor.max_armed_steps = Some(120_000);
        let text = RobotFile::of(&robot, &supervisor).to_toml();
        let back = RobotFile::from_toml(&text).unwrap();
        assert_eq!(back.robot.apply(RobotConfig::REFERENCE_ROBOT), robot);
        let back_sup = back
            .supervisor
            .config(&params, Some(ctx), "supervisor")
            .unwrap();
        assert_eq!(back_sup, supervisor, "{text}");
    }

    #[test]
    fn the_gyro_section_round_trips_and_its_errors_name_the_key() {
        let file = RobotFile::from_toml(
            "[robot.gyro]\nheading_source = \"fused\"\naxis_inverted = true\nscale = 1.004\n",
        )
        .unwrap();
        let robot = file.robot.apply(RobotConfig::REFERENCE_ROBOT);
        assert_eq!(
            robot.gyro.heading_source,
            controller_core::gyro::HeadingSource::Fused
        );
        assert!(robot.gyro.axis_inverted);
        assert_eq!(robot.gyro.scale, 1.004);
        // What the section leaves out keeps the base's value.
        assert_eq!(
            robot.gyro.stuck_limit_steps,
            RobotConfig::REFERENCE_ROBOT.gyro.stuck_limit_steps
        );
        let params = Params::new(robot).unwrap();
        let supervisor = SupervisorSection::default()
            .config(&params, None, "supervisor")
            .unwrap();
        let text = RobotFile::of(&robot, &supervisor).to_toml();
        assert!(text.contains("[robot.gyro]"), "{text}");
        let back = RobotFile::from_toml(&text).unwrap();
        assert_eq!(
            back.robot.apply(RobotConfig::REFERENCE_ROBOT).gyro,
            robot.gyro
        );

        for (toml, key) in [
            ("scale = 2.5", "robot.gyro.scale must be in 0.5..=2"),
            (
                "stuck_limit_steps = 0",
                "robot.gyro.stuck_limit_steps must be > 0",
            ),
            (
                "odometry_blend_time_constant_s = -1.0",
                "robot.gyro.odometry_blend_time_constant_s must be ≥ 0",
            ),
        ] {
            let file = RobotFile::from_toml(&format!("[robot.gyro]\n{toml}\n")).unwrap();
            let e = file
                .robot
                .params(RobotConfig::REFERENCE_ROBOT, "robot")
                .unwrap_err();
            assert!(e.to_string().starts_with(key), "{toml}: {e}");
        }
        let e = RobotFile::from_toml("[robot.gyro]\nheading_source = \"compass\"\n").unwrap_err();
        assert!(e.to_string().contains("heading_source"), "{e}");
    }

    #[test]
    fn errors_name_the_key() {
        let file = RobotFile::from_toml("[robot.motor]\nmax_current_a = -1.0\n").unwrap();
        let e = file
            .robot
            .params(RobotConfig::REFERENCE_ROBOT, "robot")
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "robot.motor.max_current_a must be > 0, got -1"
        );
        let file = RobotFile::from_toml("[supervisor]\nbattery_fault_v = 3.0\n").unwrap();
        let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
        let e = file
            .supervisor
            .config(&params, None, "supervisor")
            .unwrap_err();
        assert!(
            e.to_string().starts_with("supervisor.battery thresholds"),
            "{e}"
        );
        let e = RobotFile::from_toml("[robot]\nwheel_radius = 0.03\n").unwrap_err();
        assert!(e.to_string().contains("wheel_radius"), "{e}");
        let file = RobotFile::from_toml("[supervisor]\nbrake_s = -1.0\n").unwrap();
        let e = file
            .supervisor
            .config(&params, None, "supervisor")
            .unwrap_err();
        assert_eq!(e.to_string(), "supervisor.brake_s must be ≥ 0 s, got -1");
    }

    #[test]
    fn keywords_switch_things_off_or_derive_them() {
        let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
        let r = reference();
        let ctx = Some(PathContext {
            reference: &r,
            start: Pose::default(),
        });
        let auto = SupervisorSection::default()
            .config(&params, ctx, "supervisor")
            .unwrap();
        assert!(auto.divergence.is_some() && auto.geofence_radius_m.is_some());
        assert_eq!(auto.max_armed_steps, None);
        let file = RobotFile::from_toml(
            "[supervisor]\ndivergence = \"off\"\ngeofence_radius_m = \"off\"\nrun_time_limit_s = 120\n",
        )
        .unwrap();
        let off = file.supervisor.config(&params, ctx, "supervisor").unwrap();
        assert_eq!(off.divergence, None);
        assert_eq!(off.geofence_radius_m, None);
        assert_eq!(off.max_armed_steps, Some(120_000));
    }

    #[test]
    fn per_wheel_sections_override_both_wheels() {
        let file = RobotFile::from_toml(
            "[robot.wheels]\nkp_v_per_rad_s = 0.5\n[robot.right_wheel]\nkp_v_per_rad_s = 0.6\n",
        )
        .unwrap();
        let c = file.robot.apply(RobotConfig::REFERENCE_ROBOT);
        assert_eq!(c.left_wheel.kp_v_per_rad_s, 0.5);
        assert_eq!(c.right_wheel.kp_v_per_rad_s, 0.6);
    }
}
