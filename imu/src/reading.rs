//! One reading of the gyro's z axis, as the sensor gave it, and its scale.

/// The gyro's full-scale range, °/s (GYRO_FS_SEL = 000). The reference robot's fastest
/// commanded turn, both rims at 1.0 m/s in opposite directions on a 0.15 m track, is
/// 13.3 rad/s (764 °/s); the full scale leaves room for a wheel running away, which is
/// when the gyro's view matters most, at a quantisation (0.061 °/s) below the sensor's
/// own noise over its bandwidth.
pub const FULL_SCALE_DPS: f32 = 2000.0;

/// The gyro's sensitivity at [`FULL_SCALE_DPS`], counts per °/s (datasheet table 1).
const COUNTS_PER_DPS: f32 = 16.4;

/// rad/s per count of the gyro's data registers at [`FULL_SCALE_DPS`].
pub const RADPS_PER_LSB: f32 = core::f32::consts::PI / 180.0 / COUNTS_PER_DPS;

/// The sensor's code for "no valid data" in a data register (datasheet section 14:
/// data registers read −32 768 while the sensor is off or has no sample yet).
const NO_DATA: i16 = i16::MIN;

/// One burst read of the z-axis rate and the data-ready flag.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GyroZReading {
    /// GYRO_DATA_Z as read, two's complement counts ([`RADPS_PER_LSB`] each).
    pub counts: i16,
    /// DATA_RDY_INT was set: a sample arrived since the previous reading (reading
    /// clears it).
    pub data_ready: bool,
}

impl GyroZReading {
    /// The reading from the five bytes of a burst from GYRO_DATA_Z1 (Z1, Z0,
    /// TMST_FSYNCH, TMST_FSYNCL, INT_STATUS).
    pub const fn from_burst(bytes: [u8; 5]) -> Self {
        Self {
            counts: i16::from_be_bytes([bytes[0], bytes[1]]),
            data_ready: bytes[4] & crate::registers::DATA_RDY_INT != 0,
        }
    }

    /// The rate about the sensor's z axis, rad/s (counter-clockwise seen from +z is
    /// positive); `None` when the register holds the sensor's no-data code.
    pub fn yaw_rate_radps(&self) -> Option<f32> {
        (self.counts != NO_DATA).then(|| f32::from(self.counts) * RADPS_PER_LSB)
    }

    /// The rate when the reading is a new, valid sample; `None` otherwise (no sample
    /// since the previous reading, or no valid data).
    pub fn new_yaw_rate_radps(&self) -> Option<f32> {
        if self.data_ready {
            self.yaw_rate_radps()
        } else {
            None
        }
    }

    /// The register is at either end of its range: the true rate may be beyond
    /// [`FULL_SCALE_DPS`].
    pub const fn saturated(&self) -> bool {
        self.counts == i16::MAX || self.counts == NO_DATA + 1
    }
}
