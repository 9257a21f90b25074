//! The ICM-42688-P on an embedded-hal 1.0 [`SpiDevice`].

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Operation, SpiDevice};

use crate::registers::{self as reg, READ};
use crate::{GyroZReading, ProbeError};

/// The fastest SPI clock the part takes, Hz (datasheet table 6, f_SCLK).
pub const SPI_MAX_HZ: u32 = 24_000_000;

/// Wait after a soft reset before the next register access, µs (datasheet section
/// 15.1: 1 ms).
pub const RESET_WAIT_US: u32 = 1_000;

/// Wait after the gyro is switched on before its data is valid, µs: the datasheet's
/// gyro start-up time (table 1: 30 ms typical) with margin; it also covers the 200 µs
/// during which no register may be written after PWR_MGMT0 (section 12.9).
pub const GYRO_START_UP_US: u32 = 45_000;

/// An ICM-42688-P that answered its identity and took its configuration: adaptive
/// full-scale range off, gyro in low-noise mode at ±2000 °/s and 1 kHz, accelerometer off.
#[derive(Debug)]
pub struct Icm42688<SPI> {
    spi: SPI,
}

/// The configuration writes [`Icm42688::probe`] makes after the reset and INTF_CONFIG1's
/// read-modify-write, in order, each read back: the gyro's range and rate, the interrupt logic, the data-ready event, and
/// last the power mode (which starts the gyro).
const CONFIGURATION: [(u8, u8); 4] = [
    (reg::GYRO_CONFIG0, reg::GYRO_2000DPS_1KHZ),
    (reg::INT_CONFIG1, reg::INT_CONFIG1_SYNC),
    (reg::INT_SOURCE0, reg::DATA_READY_ON_INT1),
    (reg::PWR_MGMT0, reg::GYRO_LOW_NOISE_ACCEL_OFF),
];

impl<SPI: SpiDevice> Icm42688<SPI> {
    /// Looks for the part on `spi` and starts its gyro: bank 0, soft reset, wait
    /// [`RESET_WAIT_US`], WHO_AM_I, the adaptive full-scale range disabled (INTF_CONFIG1
    /// read, its AFSR field written, [`reg::afsr_disabled`]), the configuration (each
    /// register read back), then wait
    /// [`GYRO_START_UP_US`] for valid data. About 47 ms, nearly all of it in `delay`.
    ///
    /// # Errors
    ///
    /// [`ProbeError::Absent`] when WHO_AM_I is not the ICM-42688-P's (no IMU fitted),
    /// [`ProbeError::Configuration`] when a register does not keep its value,
    /// [`ProbeError::Bus`] on a bus error. The part is left as it was then; the caller
    /// may drop the bus.
    pub fn probe(mut spi: SPI, delay: &mut impl DelayNs) -> Result<Self, ProbeError<SPI::Error>> {
        write(&mut spi, reg::REG_BANK_SEL, reg::BANK0)?;
        write(&mut spi, reg::DEVICE_CONFIG, reg::SOFT_RESET)?;
        delay.delay_us(RESET_WAIT_US);
        let who_am_i = read(&mut spi, reg::WHO_AM_I)?;
        if who_am_i != reg::ICM42688P_ID {
            return Err(ProbeError::Absent { who_am_i });
        }
        let interface = read(&mut spi, reg::INTF_CONFIG1)?;
        configure(&mut spi, reg::INTF_CONFIG1, reg::afsr_disabled(interface))?;
        for (register, value) in CONFIGURATION {
            configure(&mut spi, register, value)?;
        }
        delay.delay_us(GYRO_START_UP_US);
        Ok(Self { spi })
    }

    /// Reads the z-axis rate and the data-ready flag (clearing it) in one burst of six
    /// bytes: the command byte, then GYRO_DATA_Z1 through INT_STATUS.
    ///
    /// # Errors
    ///
    /// The bus's error.
    pub fn read_gyro_z(&mut self) -> Result<GyroZReading, SPI::Error> {
        let mut burst = [0u8; 5];
        self.spi.transaction(&mut [
            Operation::Write(&[reg::GYRO_DATA_Z1 | READ]),
            Operation::Read(&mut burst),
        ])?;
        Ok(GyroZReading::from_burst(burst))
    }

    /// Gives the bus back.
    pub fn release(self) -> SPI {
        self.spi
    }
}

/// One register write: address, value.
fn write<SPI: SpiDevice>(spi: &mut SPI, register: u8, value: u8) -> Result<(), SPI::Error> {
    spi.write(&[register, value])
}

/// One register write read back: [`ProbeError::Configuration`] when the part does not
/// keep the value.
fn configure<SPI: SpiDevice>(
    spi: &mut SPI,
    register: u8,
    value: u8,
) -> Result<(), ProbeError<SPI::Error>> {
    write(spi, register, value)?;
    let back = read(spi, register)?;
    if back != value {
        return Err(ProbeError::Configuration {
            register,
            wrote: value,
            read: back,
        });
    }
    Ok(())
}

/// One register read: the address with the read flag, then its value.
fn read<SPI: SpiDevice>(spi: &mut SPI, register: u8) -> Result<u8, SPI::Error> {
    let mut value = [0u8];
    spi.transaction(&mut [
        Operation::Write(&[register | READ]),
        Operation::Read(&mut value),
    ])?;
    let [value] = value;
    Ok(value)
}

impl<E> From<E> for ProbeError<E> {
    fn from(e: E) -> Self {
        Self::Bus(e)
    }
}
