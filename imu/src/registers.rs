//! The ICM-42688-P's registers this driver touches (user bank 0), with the field values
//! it writes. Addresses and fields from TDK InvenSense's datasheet DS-000347, section 14
//! ("Register map") and 15 ("User bank 0 register descriptions").
//!
//! SPI framing (datasheet section 9.6): the first byte is the register address with bit 7
//! set for a read; a read continues from the next address for as long as the chip select
//! stays low (burst), so a 16-bit value and the registers after it come in one
//! transaction. SPI mode 0 or 3, at most 24 MHz.

/// The read flag of an SPI command byte (bit 7 of the address byte).
pub const READ: u8 = 0x80;

/// DEVICE_CONFIG: bit 0 SOFT_RESET_CONFIG (1 = reset every register; the datasheet asks
/// for 1 ms before the next access).
pub const DEVICE_CONFIG: u8 = 0x11;
/// DEVICE_CONFIG value that starts a soft reset.
pub const SOFT_RESET: u8 = 0x01;

/// GYRO_DATA_Z1: the gyro's z axis, high byte; GYRO_DATA_Z0 (low byte) follows, then
/// TMST_FSYNCH, TMST_FSYNCL and [`INT_STATUS`] (0x2D): one burst of five bytes reads
/// the rate and whether it is new.
pub const GYRO_DATA_Z1: u8 = 0x29;
/// INT_STATUS: bit 3 DATA_RDY_INT, set when a new sample is in the data registers and
/// cleared by reading this register (INT_CONFIG0's reset value: clear on status read).
pub const INT_STATUS: u8 = 0x2D;
/// INT_STATUS's DATA_RDY_INT bit.
pub const DATA_RDY_INT: u8 = 1 << 3;

/// INTF_CONFIG1: bits 3:0 are the datasheet's (ACCEL_LP_CLK_SEL, RTC_MODE, CLKSEL; reset
/// value 0x91), bits 7:6 the adaptive full-scale range (AFSR), which the datasheet does
/// not describe: left at its reset value (10, enabled) the part switches the gyro's range
/// by itself and its output stalls for a moment while it does. ArduPilot and Betaflight
/// write 01 here to disable it; a stall would look to the control core's stuck check like
/// a failed gyro. The driver changes only these two bits ([`afsr_disabled`]).
pub const INTF_CONFIG1: u8 = 0x4D;
/// INTF_CONFIG1's AFSR field, bits 7:6.
pub const AFSR_MASK: u8 = 0b1100_0000;
/// INTF_CONFIG1's AFSR field value that disables the adaptive full-scale range.
pub const AFSR_DISABLE: u8 = 0b0100_0000;

/// `intf_config1` (an INTF_CONFIG1 value read from the part) with the adaptive
/// full-scale range disabled and every other bit kept.
pub const fn afsr_disabled(intf_config1: u8) -> u8 {
    (intf_config1 & !AFSR_MASK) | AFSR_DISABLE
}

/// PWR_MGMT0: bits 3:2 GYRO_MODE, bits 1:0 ACCEL_MODE (00 = off, 11 = low noise).
pub const PWR_MGMT0: u8 = 0x4E;
/// PWR_MGMT0 value: gyro in low-noise mode, accelerometer off, temperature sensor on.
pub const GYRO_LOW_NOISE_ACCEL_OFF: u8 = 0b11 << 2;

/// GYRO_CONFIG0: bits 7:5 GYRO_FS_SEL (000 = ±2000 °/s), bits 3:0 GYRO_ODR
/// (0110 = 1 kHz).
pub const GYRO_CONFIG0: u8 = 0x4F;
/// GYRO_CONFIG0 value: GYRO_FS_SEL 000, ±2000 °/s full scale ([`crate::FULL_SCALE_DPS`]),
/// and GYRO_ODR 0110, a 1 kHz output data rate (the control rate).
pub const GYRO_2000DPS_1KHZ: u8 = 0b0110;

/// INT_CONFIG1: bit 4 INT_ASYNC_RESET, which the datasheet asks to clear (reset value 1)
/// for the interrupt logic to work; bits 6 and 5 (pulse length 100 µs, de-assertion on)
/// stay at 0, as the datasheet requires for data rates up to 4 kHz.
pub const INT_CONFIG1: u8 = 0x64;
/// INT_CONFIG1 value: INT_ASYNC_RESET cleared.
pub const INT_CONFIG1_SYNC: u8 = 0x00;

/// INT_SOURCE0: bit 3 UI_DRDY_INT1_EN, the data-ready interrupt routed to INT1. Set so
/// that the data-ready event is generated (and [`DATA_RDY_INT`] with it) whether or not
/// the INT1 pin is wired; the firmware polls the status bit.
pub const INT_SOURCE0: u8 = 0x65;
/// INT_SOURCE0 value: data ready on INT1, nothing else.
pub const DATA_READY_ON_INT1: u8 = 1 << 3;

/// WHO_AM_I: the part's identity.
pub const WHO_AM_I: u8 = 0x75;
/// What an ICM-42688-P answers to [`WHO_AM_I`].
pub const ICM42688P_ID: u8 = 0x47;

/// REG_BANK_SEL: the register bank every other address refers to (0 after a power-on
/// reset, but not necessarily after a reset of the MCU alone).
pub const REG_BANK_SEL: u8 = 0x76;
/// REG_BANK_SEL value for user bank 0.
pub const BANK0: u8 = 0;
