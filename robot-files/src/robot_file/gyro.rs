//! `[robot.gyro]`: the gyro as the robot uses it (`controller_core::gyro::GyroConfig`):
//! the heading it steers by, the axis sign and scale factor bring-up finds, and the
//! limits that judge the sensor.

use controller_core::gyro::{GyroConfig, HeadingSource};
use serde::{Deserialize, Serialize};

use super::set;

/// The heading the robot steers by, as a robot file names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HeadingSourceName {
    /// The encoders alone.
    Odometry,
    /// The gyro fused with odometry.
    Fused,
}

impl From<HeadingSourceName> for HeadingSource {
    fn from(name: HeadingSourceName) -> Self {
        match name {
            HeadingSourceName::Odometry => HeadingSource::Odometry,
            HeadingSourceName::Fused => HeadingSource::Fused,
        }
    }
}

impl From<HeadingSource> for HeadingSourceName {
    fn from(source: HeadingSource) -> Self {
        match source {
            HeadingSource::Odometry => HeadingSourceName::Odometry,
            HeadingSource::Fused => HeadingSourceName::Fused,
        }
    }
}

/// `[robot.gyro]`: every key optional, over the base configuration's gyro.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroSection {
    /// `"odometry"` or `"fused"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading_source: Option<HeadingSourceName>,
    /// The sensor's z axis points down.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub axis_inverted: Option<bool>,
    /// Robot yaw rate per unit of sensor rate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale: Option<f32>,
    /// The sensor's full scale, rad/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub full_scale_radps: Option<f32>,
    /// Time constant of the bias estimate, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_time_constant_s: Option<f32>,
    /// Time constant of the fused heading's pull towards odometry's, s (0: none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub odometry_blend_time_constant_s: Option<f32>,
    /// Oldest usable reading, control periods.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_age_periods: Option<u8>,
    /// Steps without a usable reading after which the gyro has failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub absent_limit_steps: Option<u16>,
    /// Identical readings in a row after which the gyro is stuck.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stuck_limit_steps: Option<u16>,
    /// Odometry's turn meanwhile that makes identical readings stuck, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stuck_turn_rad: Option<f32>,
    /// Mean yaw-rate disagreement with odometry beyond which they disagree, rad/s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub disagreement_threshold_radps: Option<f32>,
    /// Time constant of the disagreement's running mean, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub disagreement_window_s: Option<f32>,
    /// A disagreement while armed stops the robot (true) or warns (false, the default).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub disagreement_stops: Option<bool>,
}

impl GyroSection {
    /// Sets in `g` what this section gives.
    pub(super) fn apply(&self, g: &mut GyroConfig) {
        if let Some(name) = self.heading_source {
            g.heading_source = name.into();
        }
        set(&mut g.axis_inverted, self.axis_inverted);
        set(&mut g.scale, self.scale);
        set(&mut g.full_scale_radps, self.full_scale_radps);
        set(&mut g.bias_time_constant_s, self.bias_time_constant_s);
        set(
            &mut g.odometry_blend_time_constant_s,
            self.odometry_blend_time_constant_s,
        );
        set(&mut g.max_age_periods, self.max_age_periods);
        set(&mut g.absent_limit_steps, self.absent_limit_steps);
        set(&mut g.stuck_limit_steps, self.stuck_limit_steps);
        set(&mut g.stuck_turn_rad, self.stuck_turn_rad);
        set(
            &mut g.disagreement_threshold_radps,
            self.disagreement_threshold_radps,
        );
        set(&mut g.disagreement_window_s, self.disagreement_window_s);
        set(&mut g.disagreement_stops, self.disagreement_stops);
    }

    /// Every field of `g`.
    pub(super) fn of(g: &GyroConfig) -> Self {
        Self {
            heading_source: Some(g.heading_source.into()),
            axis_inverted: Some(g.axis_inverted),
            scale: Some(g.scale),
            full_scale_radps: Some(g.full_scale_radps),
            bias_time_constant_s: Some(g.bias_time_constant_s),
            odometry_blend_time_constant_s: Some(g.odometry_blend_time_constant_s),
            max_age_periods: Some(g.max_age_periods),
            absent_limit_steps: Some(g.absent_limit_steps),
            stuck_limit_steps: Some(g.stuck_limit_steps),
            stuck_turn_rad: Some(g.stuck_turn_rad),
            disagreement_threshold_radps: Some(g.disagreement_threshold_radps),
            disagreement_window_s: Some(g.disagreement_window_s),
            disagreement_stops: Some(g.disagreement_stops),
        }
    }
}
