//! The scenario's `[gyro]` table: the simulated gyro, the heading the robot steers by,
//! the rest before arming in which it learns the gyro's bias, and the sweep's gyro and
//! slip-patch spreads. Without the table the robot has no IMU and every run is as before.
//!
//! ```toml
//! [gyro]
//! heading = "fused"                          # fused | odometry | oracle (simulation only)
//! noise_density_rad_s_sqrt_hz = 4.887e-5     # ICM-42688-P: 0.0028 °/s/√Hz
//! turn_on_bias_rad_s = 0.0                   # the zero-rate offset at power-on
//! bias_random_walk_rad_s_sqrt_s = 8.1e-7     # rate random walk
//! scale_error_pct = 0.0                      # sensitivity error
//! full_scale_rad_s = 34.906586               # ±2000 °/s
//! lsb_rad_s = 1.0653e-3                      # 16-bit reading at ±2000 °/s
//! latency_periods = 0                        # control periods from reading to the step
//! rest_before_arming_s = 0.0                 # disarmed and still this long, then armed
//! sweep_turn_on_bias_rad_s = 0.0             # sweep: ± this on the turn-on bias
//! sweep_scale_error_pct = 0.0                # sweep: ± this on the scale error
//! sweep_slip_patches = 0                     # sweep: this many slip patches per run …
//! sweep_slip_patch_max = 0.0                 # … each of a slip ratio in [0, this] …
//! sweep_slip_patch_s = 0.0                   # … lasting up to this long, s
//! sweep_ticks_lost_max = 0.0                 # sweep: each encoder loses a fraction in [0, this] of its ticks
//! ```

use controller_core::gyro::{GyroConfig, HeadingSource};
use serde::Deserialize;

use super::checks::{check, finite, in_range, non_negative};
use super::ScenarioError;

/// The heading the robot steers by in a run with a gyro.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HeadingChoice {
    /// The gyro fused with odometry (the core's `HeadingSource::Fused`).
    #[default]
    Fused,
    /// Odometry alone: the gyro is read (telemetry, checks) but not steered by.
    Odometry,
    /// The true heading: the simulated gyro is replaced by an ideal one that reports each
    /// period's true turn exactly, and the robot fuses it (simulation only).
    Oracle,
}

impl HeadingChoice {
    /// The name in scenarios and on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            HeadingChoice::Fused => "fused",
            HeadingChoice::Odometry => "odometry",
            HeadingChoice::Oracle => "oracle",
        }
    }
}

/// The simulated gyro's yaw axis. Defaults: the ICM-42688-P datasheet (DS-000347) at
/// ±2000 °/s and 1 kHz, except the bias random walk, which it does not give.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroSensor {
    /// White-noise density, rad/s/√Hz (datasheet: 0.0028 °/s/√Hz).
    pub noise_density_rad_s_sqrt_hz: f64,
    /// Zero-rate offset at power-on, rad/s (datasheet: ±0.5 °/s typical).
    pub turn_on_bias_rad_s: f64,
    /// Rate random walk of the bias, rad/s/√s (not in the datasheet; see DESIGN.md).
    pub bias_random_walk_rad_s_sqrt_s: f64,
    /// Sensitivity error, % (datasheet: ±0.5 % initial tolerance).
    pub scale_error_pct: f64,
    /// Full scale, rad/s: readings are clipped here (±2000 °/s).
    pub full_scale_rad_s: f64,
    /// One count of the reading, rad/s (16 bits over ±2000 °/s).
    pub lsb_rad_s: f64,
    /// Control periods between the reading and the step it is handed to.
    pub latency_periods: u8,
}

impl GyroSensor {
    /// The ICM-42688-P at ±2000 °/s (see the type's doc).
    pub const ICM42688P: GyroSensor = GyroSensor {
        noise_density_rad_s_sqrt_hz: 0.0028 * core::f64::consts::PI / 180.0,
        turn_on_bias_rad_s: 0.0,
        bias_random_walk_rad_s_sqrt_s: 8.1e-7,
        scale_error_pct: 0.0,
        full_scale_rad_s: 2000.0 * core::f64::consts::PI / 180.0,
        lsb_rad_s: 2000.0 * core::f64::consts::PI / 180.0 / 32768.0,
        latency_periods: 0,
    };
}

/// The gyro spreads and the slip patches `host-sim sweep` draws for each run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GyroSweep {
    /// ± this on the turn-on bias, rad/s.
    pub turn_on_bias_rad_s: f64,
    /// ± this on the scale error, %.
    pub scale_error_pct: f64,
    /// Slip patches per run, each on a random wheel at a random time.
    pub slip_patches: u32,
    /// Each patch's slip ratio is drawn in [0, this].
    pub slip_patch_max: f64,
    /// Each patch lasts up to this long, s.
    pub slip_patch_s: f64,
    /// Each wheel's encoder loses a fraction of its ticks drawn in [0, this], for the
    /// whole run (a marginal encoder signal).
    pub ticks_lost_max: f64,
}

/// A run with a gyro: the sensor, the heading steered by, the rest before arming.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroSetup {
    /// The heading the robot steers by.
    pub heading: HeadingChoice,
    /// The simulated sensor.
    pub sensor: GyroSensor,
    /// The robot stands disarmed and still this long before it is armed, s.
    pub rest_before_arming_s: f64,
    /// The sweep's spreads.
    pub sweep: GyroSweep,
}

impl GyroSetup {
    /// The robot's gyro configuration `base` with this setup's heading (the oracle is
    /// the fusion fed an ideal gyro) and its sensor's full scale: what the scenario's
    /// robot carries in `RobotConfig::gyro`.
    pub fn robot_gyro(&self, base: GyroConfig) -> GyroConfig {
        let source = match self.heading {
            HeadingChoice::Odometry => HeadingSource::Odometry,
            HeadingChoice::Fused | HeadingChoice::Oracle => HeadingSource::Fused,
        };
        GyroConfig {
            full_scale_radps: self.sensor.full_scale_rad_s as f32,
            ..base.with_heading(source)
        }
    }
}

/// `[gyro]` as serde reads it.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileGyro {
    heading: Option<HeadingChoice>,
    noise_density_rad_s_sqrt_hz: Option<f64>,
    turn_on_bias_rad_s: Option<f64>,
    bias_random_walk_rad_s_sqrt_s: Option<f64>,
    scale_error_pct: Option<f64>,
    full_scale_rad_s: Option<f64>,
    lsb_rad_s: Option<f64>,
    latency_periods: Option<u8>,
    rest_before_arming_s: Option<f64>,
    sweep_turn_on_bias_rad_s: Option<f64>,
    sweep_scale_error_pct: Option<f64>,
    sweep_slip_patches: Option<u32>,
    sweep_slip_patch_max: Option<f64>,
    sweep_slip_patch_s: Option<f64>,
    sweep_ticks_lost_max: Option<f64>,
}

impl FileGyro {
    /// The validated setup, each error naming its key; a full scale the table omits is
    /// the robot's own, `robot_full_scale_radps` (rad/s), so `[robot.gyro]` is not
    /// overridden by a default.
    pub(super) fn build(&self, robot_full_scale_radps: f32) -> Result<GyroSetup, ScenarioError> {
        let d = GyroSensor::ICM42688P;
        let full_scale = non_negative(
            "gyro.full_scale_rad_s",
            self.full_scale_rad_s
                .unwrap_or(f64::from(robot_full_scale_radps)),
        )?;
        check(
            full_scale > 0.0,
            "gyro.full_scale_rad_s",
            "must be > 0",
            full_scale,
        )?;
        let scale_error = finite(
            "gyro.scale_error_pct",
            self.scale_error_pct.unwrap_or(d.scale_error_pct),
        )?;
        check(
            scale_error.abs() < 50.0,
            "gyro.scale_error_pct",
            "must be within ±50",
            scale_error,
        )?;
        let fraction = |key, value: Option<f64>| {
            in_range(key, value.unwrap_or(0.0), 0.0, 1.0, "must be in [0, 1)")
        };
        let slip_max = fraction("gyro.sweep_slip_patch_max", self.sweep_slip_patch_max)?;
        let ticks_lost_max = fraction("gyro.sweep_ticks_lost_max", self.sweep_ticks_lost_max)?;
        Ok(GyroSetup {
            heading: self.heading.unwrap_or_default(),
            sensor: GyroSensor {
                noise_density_rad_s_sqrt_hz: non_negative(
                    "gyro.noise_density_rad_s_sqrt_hz",
                    self.noise_density_rad_s_sqrt_hz
                        .unwrap_or(d.noise_density_rad_s_sqrt_hz),
                )?,
                turn_on_bias_rad_s: finite(
                    "gyro.turn_on_bias_rad_s",
                    self.turn_on_bias_rad_s.unwrap_or(d.turn_on_bias_rad_s),
                )?,
                bias_random_walk_rad_s_sqrt_s: non_negative(
                    "gyro.bias_random_walk_rad_s_sqrt_s",
                    self.bias_random_walk_rad_s_sqrt_s
                        .unwrap_or(d.bias_random_walk_rad_s_sqrt_s),
                )?,
                scale_error_pct: scale_error,
                full_scale_rad_s: full_scale,
                lsb_rad_s: non_negative("gyro.lsb_rad_s", self.lsb_rad_s.unwrap_or(d.lsb_rad_s))?,
                latency_periods: self.latency_periods.unwrap_or(d.latency_periods),
            },
            rest_before_arming_s: non_negative(
                "gyro.rest_before_arming_s",
                self.rest_before_arming_s.unwrap_or(0.0),
            )?,
            sweep: GyroSweep {
                turn_on_bias_rad_s: non_negative(
                    "gyro.sweep_turn_on_bias_rad_s",
                    self.sweep_turn_on_bias_rad_s.unwrap_or(0.0),
                )?,
                scale_error_pct: non_negative(
                    "gyro.sweep_scale_error_pct",
                    self.sweep_scale_error_pct.unwrap_or(0.0),
                )?,
                slip_patches: self.sweep_slip_patches.unwrap_or(0),
                slip_patch_max: slip_max,
                slip_patch_s: non_negative(
                    "gyro.sweep_slip_patch_s",
                    self.sweep_slip_patch_s.unwrap_or(0.0),
                )?,
                ticks_lost_max,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use controller_core::gyro::HeadingSource;

    use super::HeadingChoice;
    use crate::scenario::Scenario;

    #[test]
    fn the_gyro_table_sets_the_robots_heading_source_and_steer_by_moves_both() {
        let mut s = Scenario::load("paper-circle-gyro").expect("built in");
        let setup = s.gyro.expect("a [gyro] table");
        assert_eq!(setup.heading, HeadingChoice::Fused);
        assert_eq!(s.robot.gyro.heading_source, HeadingSource::Fused);
        assert_eq!(
            s.robot.gyro.full_scale_radps,
            setup.sensor.full_scale_rad_s as f32
        );
        assert!(s.steer_by(HeadingChoice::Odometry));
        assert_eq!(s.gyro.map(|g| g.heading), Some(HeadingChoice::Odometry));
        assert_eq!(s.robot.gyro.heading_source, HeadingSource::Odometry);
        // The oracle is the fusion, fed an ideal gyro.
        assert!(s.steer_by(HeadingChoice::Oracle));
        assert_eq!(s.robot.gyro.heading_source, HeadingSource::Fused);

        let mut plain = Scenario::load("paper-circle").expect("built in");
        assert_eq!(plain.robot.gyro.heading_source, HeadingSource::Odometry);
        assert!(!plain.steer_by(HeadingChoice::Fused));
        assert_eq!(plain.robot.gyro.heading_source, HeadingSource::Odometry);
    }

    #[test]
    fn a_full_scale_the_gyro_table_omits_is_the_robots() {
        // The built-in gyro scenario, whose [gyro] gives no full scale, on a robot with its own.
        let built_in = include_str!("../../scenarios/paper-circle-gyro.toml");
        let text = format!("{built_in}\n[robot.gyro]\nfull_scale_radps = 8.0\n");
        let s = Scenario::from_toml(&text, "test").expect("valid");
        assert_eq!(s.robot.gyro.full_scale_radps, 8.0);
        assert_eq!(s.gyro.map(|g| g.sensor.full_scale_rad_s), Some(8.0));
        let given = text.replace("[gyro]\n", "[gyro]\nfull_scale_rad_s = 4.0\n");
        let s = Scenario::from_toml(&given, "test").expect("valid");
        assert_eq!(s.robot.gyro.full_scale_radps, 4.0);
    }
}
