//! # imu
//!
//! The robot's IMU, as the control step needs it: one yaw-rate reading per control
//! period, or none. The first (and only) part is TDK InvenSense's ICM-42688-P on SPI
//! ([`Icm42688`]); only its gyro's z axis is used (the heading's rate), the accelerometer
//! stays off.
//!
//! | call | when | SPI traffic |
//! |---|---|---|
//! | [`Icm42688::probe`] | once, at start-up | soft reset, WHO_AM_I, the adaptive full-scale range off (a read-modify-write), four configuration writes, each read back |
//! | [`Icm42688::read_gyro_z`] | every control step | one 6-byte burst (≈ 4 µs at 12.5 MHz) |
//!
//! A board with no IMU answers WHO_AM_I with something else (a floating or pulled-down
//! MISO reads 0x00 or 0xFF): [`ProbeError::Absent`], and the robot runs on its encoders
//! alone. The reading is the sensor's own axis and scale ([`GyroZReading`]): the axis
//! sign, the scale factor and the bias are the control core's, as is deciding that a
//! gyro has failed (stuck, saturated, non-finite); this crate reports what the sensor
//! says about itself: no new sample (data-ready clear), no valid data (the sensor's
//! −32 768 code), at full scale.
//!
//! Nothing here allocates, loops without bound or panics; every transfer is one
//! `SpiDevice` transaction, so the chip select frames it (a bus shared with another
//! device stays correct).

#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

mod error;
mod icm42688;
mod reading;
pub mod registers;

pub use self::error::ProbeError;
pub use self::icm42688::{Icm42688, GYRO_START_UP_US, RESET_WAIT_US, SPI_MAX_HZ};
pub use self::reading::{GyroZReading, FULL_SCALE_DPS, RADPS_PER_LSB};
