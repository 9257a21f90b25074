//! Why [`crate::Icm42688::probe`] found no usable IMU.

use core::fmt;

/// Why the probe gave no driver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeError<E> {
    /// The SPI bus reported an error.
    Bus(E),
    /// WHO_AM_I did not read [`crate::registers::ICM42688P_ID`]: no IMU (or another
    /// part) on the bus.
    Absent {
        /// What WHO_AM_I read.
        who_am_i: u8,
    },
    /// A configuration register did not read back what was written: the part answers
    /// its identity but does not take its configuration.
    Configuration {
        /// The register's address.
        register: u8,
        /// The value written.
        wrote: u8,
        /// The value read back.
        read: u8,
    },
}

impl<E: fmt::Debug> fmt::Display for ProbeError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Bus(e) => write!(f, "SPI bus error: {e:?}"),
            Self::Absent { who_am_i } => write!(
                f,
                "no ICM-42688-P: WHO_AM_I read {who_am_i:#04x}, expected {:#04x}",
                crate::registers::ICM42688P_ID
            ),
            Self::Configuration {
                register,
                wrote,
                read,
            } => write!(
                f,
                "register {register:#04x} read back {read:#04x} after {wrote:#04x} was written"
            ),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for ProbeError<E> {}
