//! The gyro's reading as the control step receives it.
//!
//! A board with an IMU reads its z-axis rate and hands the newest reading to the control
//! step as a [`GyroSample`]; a board without one, or a step with no new reading, passes
//! `None` ([`crate::controller::StepInput::gyro`]). The reading is the sensor's own:
//! the core applies the axis sign, the scale factor and the bias estimate.

/// One reading of the gyro's yaw axis, as the sensor gave it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct GyroSample {
    /// Angular rate about the sensor's z axis, rad/s, in the sensor's own frame and
    /// scale: before the axis sign, the scale factor and the bias are applied. For a
    /// sensor read faster than the control rate, the mean of the readings since the last
    /// sample handed over.
    pub yaw_rate_radps: f32,
    /// Whole control periods between the end of the interval this reading covers and the
    /// start of the step it is handed to: 0 for a reading taken within the last period.
    pub age_periods: u8,
}
