//! The IMU (an ICM-42688-P) on SPI2, read once at the start of every control step.
//!
//! **Optional, found at start-up.** [`Imu::probe`] resets the part and reads WHO_AM_I
//! (the `imu` crate); anything but the ICM-42688-P's identity (no IMU fitted: MISO
//! pulled down reads 0x00) leaves the board without one, and every step passes no gyro
//! reading, as on a robot built before the IMU: the control side then runs on its
//! encoders alone, exactly as it did.
//!
//! **Read inside the control step, at a bounded cost.** One SPI transaction of six
//! bytes (command, GYRO_DATA_Z1, Z0, two timestamp bytes, INT_STATUS) at [`SPI_HZ`]:
//! 3.8 µs of clocking, about 5 µs (500 cycles at 100 MHz, 0.5 % of the period) with the
//! driver around it. A master cannot be held off by its slave, so the cost is the same
//! whatever the part does or whether it is there; and each byte's wait is bounded
//! ([`ImuSpi`]), so a disabled or misconfigured SPI2 ends the read with an error after
//! 2.6 µs instead of spinning the step until the watchdog: that step has no reading, and
//! the control core reports the gyro absent once readings have been missing for its
//! limit. A separate task would save none of it
//! (the control step needs the reading before it starts) and add a context and its
//! hand-over; the link USART's interrupt, above the control task, still preempts the
//! read, so the USART2 rule holds unchanged.
//!
//! **One sample a step, its age known.** The gyro runs at 1 kHz, the control rate. The
//! burst's data-ready flag says whether a sample arrived since the previous step's read
//! (reading clears it): then its rate is handed over with age 0 (taken within the last
//! period), otherwise none (the two 1 kHz clocks drift against each other, so now and
//! then a step has no new sample, or a sample is overwritten before it is read). A bus
//! error or the sensor's no-data code also hands over none; the control core decides
//! when missing, stuck or saturated readings make the gyro failed.

use controller_core::gyro::GyroSample;
use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice, MODE_3};
use imu::{Icm42688, ProbeError};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::rcc::Rcc;
use stm32f4xx_hal::spi::{self, Spi};

use super::pins::{ImuPins, Out};
use super::wait::within_cycles;
use super::{CLOCK_PLAN, SYSCLK_HZ};

/// The SPI clock asked of the HAL, Hz: PCLK1 ÷ 4 on the F411 (50 MHz → 12.5 MHz);
/// ÷ 2 would be 25 MHz, over the part's [`imu::SPI_MAX_HZ`].
pub const SPI_HZ: u32 = 12_500_000;

/// The clock the HAL sets for [`SPI_HZ`], Hz: PCLK1 over the power of two it picks
/// from the whole ratio PCLK1 / `SPI_HZ` (stm32f4xx-hal's `Spi::pre_init`: 1–2 → ÷ 2,
/// 3–5 → ÷ 4, 6–11 → ÷ 8, …), which may be up to a quarter faster than asked.
const fn spi_clock_hz(pclk_hz: u32, asked_hz: u32) -> u32 {
    let ratio = pclk_hz / asked_hz;
    let mut divider = 2;
    let mut upper = 2;
    while ratio > upper && divider < 256 {
        divider *= 2;
        upper = divider + divider / 2 - 1;
    }
    pclk_hz / divider
}
const _: () = assert!(
    spi_clock_hz(CLOCK_PLAN.tree.pclk1_hz, SPI_HZ) <= imu::SPI_MAX_HZ,
    "the IMU's SPI clock is above the part's maximum"
);

/// The longest wait for one byte's flag (TXE before it is sent, RXNE after), core
/// cycles: four byte times at the SPI clock the HAL sets (64 cycles a byte at 100 MHz
/// and 12.5 MHz, so 256 cycles, 2.6 µs). A running SPI2 raises each flag within one byte
/// time, so only a disabled or misconfigured peripheral reaches it; the wait polls once
/// more after the bound, so a step preempted meanwhile (the link USART's interrupt) does
/// not time out on a byte that came.
const BYTE_WAIT_CYCLES: u32 = 4 * 8 * (SYSCLK_HZ / spi_clock_hz(CLOCK_PLAN.tree.pclk1_hz, SPI_HZ));

/// Why an SPI transaction with the IMU failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImuBusError {
    /// The peripheral reported an error (overrun, mode fault, CRC).
    Spi(spi::Error),
    /// A byte's flag did not come within [`BYTE_WAIT_CYCLES`].
    Timeout,
}

impl core::fmt::Display for ImuBusError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Spi(e) => write!(f, "SPI2 error: {e:?}"),
            Self::Timeout => write!(f, "SPI2 gave no byte within {BYTE_WAIT_CYCLES} cycles"),
        }
    }
}

impl core::error::Error for ImuBusError {}

impl embedded_hal::spi::Error for ImuBusError {
    fn kind(&self) -> ErrorKind {
        match self {
            Self::Spi(e) => e.kind(),
            Self::Timeout => ErrorKind::Other,
        }
    }
}

/// The SPI bus with the IMU's chip select (PB12, active low) around each transaction.
/// Every byte is exchanged with a bounded wait ([`BYTE_WAIT_CYCLES`]), never the HAL's
/// unbounded blocking calls: the control step reads through it.
pub struct ImuSpi {
    bus: Spi<pac::SPI2>,
    chip_select: Out<'B', 12>,
}

impl ImuSpi {
    /// Sends `out` and returns the byte clocked in meanwhile (full duplex: every byte
    /// sent brings one back, which is read so that the next one finds RXNE clear).
    fn exchange(&mut self, out: u8) -> Result<u8, ImuBusError> {
        let bus = &mut self.bus;
        within_bound(|| bus.write_nonblocking(out))?;
        within_bound(|| bus.read_nonblocking())
    }
}

/// Polls `poll` until it answers or [`BYTE_WAIT_CYCLES`] pass.
fn within_bound<T>(mut poll: impl FnMut() -> nb::Result<T, spi::Error>) -> Result<T, ImuBusError> {
    let mut answer = None;
    within_cycles(BYTE_WAIT_CYCLES, || match poll() {
        Err(nb::Error::WouldBlock) => false,
        other => {
            answer = Some(other);
            true
        }
    });
    match answer {
        Some(Ok(value)) => Ok(value),
        Some(Err(nb::Error::Other(e))) => Err(ImuBusError::Spi(e)),
        Some(Err(nb::Error::WouldBlock)) | None => Err(ImuBusError::Timeout),
    }
}

impl ErrorType for ImuSpi {
    type Error = ImuBusError;
}

impl SpiDevice for ImuSpi {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ImuBusError> {
        self.chip_select.set_low();
        let result = operations
            .iter_mut()
            .try_for_each(|operation| match operation {
                Operation::Read(words) => words.iter_mut().try_for_each(|word| {
                    *word = self.exchange(0)?;
                    Ok(())
                }),
                Operation::Write(words) => words.iter().try_for_each(|word| {
                    self.exchange(*word)?;
                    Ok(())
                }),
                Operation::Transfer(read, write) => {
                    // As embedded-hal specifies: as many bytes as the longer of the two,
                    // zeros sent past `write`'s end, the bytes past `read`'s dropped.
                    for i in 0..read.len().max(write.len()) {
                        let back = self.exchange(write.get(i).copied().unwrap_or(0))?;
                        if let Some(word) = read.get_mut(i) {
                            *word = back;
                        }
                    }
                    Ok(())
                }
                Operation::TransferInPlace(words) => words.iter_mut().try_for_each(|word| {
                    *word = self.exchange(*word)?;
                    Ok(())
                }),
                Operation::DelayNs(ns) => {
                    CycleDelay.delay_ns(*ns);
                    Ok(())
                }
            });
        // Every byte is clocked out when the last exchange returns (it waited for that
        // byte's RXNE), so raising the select here ends the frame after it.
        self.chip_select.set_high();
        result
    }
}

/// A busy wait of at least the asked time, counted in core cycles at [`SYSCLK_HZ`].
pub struct CycleDelay;

impl DelayNs for CycleDelay {
    fn delay_ns(&mut self, ns: u32) {
        let cycles = (u64::from(ns) * u64::from(SYSCLK_HZ)).div_ceil(1_000_000_000);
        cortex_m::asm::delay(u32::try_from(cycles).unwrap_or(u32::MAX));
    }
}

/// The IMU found at start-up.
pub struct Imu {
    part: Icm42688<ImuSpi>,
}

impl Imu {
    /// Configures SPI2 (mode 3, [`SPI_HZ`]) on the IMU's pins and looks for the part
    /// (about 47 ms when it is there: its reset and its gyro's start-up); `None`, logged,
    /// when there is none or it does not take its configuration.
    pub fn probe(spi2: pac::SPI2, pins: ImuPins, rcc: &mut Rcc) -> Option<Self> {
        let ImuPins {
            sck,
            miso,
            mosi,
            chip_select,
        } = pins;
        let bus = Spi::new(
            spi2,
            (Some(sck), Some(miso), Some(mosi)),
            MODE_3,
            stm32f4xx_hal::time::Hertz::from_raw(SPI_HZ),
            rcc,
        );
        match Icm42688::probe(ImuSpi { bus, chip_select }, &mut CycleDelay) {
            Ok(part) => {
                defmt::info!(
                    "imu: ICM-42688-P on SPI2 at {=u32} Hz, gyro z ±{=f32} °/s at 1 kHz",
                    SPI_HZ,
                    imu::FULL_SCALE_DPS
                );
                Some(Self { part })
            }
            Err(ProbeError::Absent { who_am_i }) => {
                defmt::info!(
                    "imu: none (WHO_AM_I read {=u8:#04x}): heading from the encoders alone",
                    who_am_i
                );
                None
            }
            Err(ProbeError::Configuration {
                register,
                wrote,
                read,
            }) => {
                defmt::warn!(
                    "imu: ICM-42688-P found, but register {=u8:#04x} read {=u8:#04x} after {=u8:#04x} was written: not used",
                    register,
                    read,
                    wrote
                );
                None
            }
            Err(ProbeError::Bus(_)) => {
                defmt::warn!("imu: SPI2 error while probing: not used");
                None
            }
        }
    }

    /// This step's gyro sample: the newest reading if one arrived since the previous
    /// step (module doc), `None` otherwise.
    #[inline(always)]
    pub fn sample(&mut self) -> Option<GyroSample> {
        let reading = self.part.read_gyro_z().ok()?;
        reading.new_yaw_rate_radps().map(|rate| GyroSample {
            yaw_rate_radps: rate,
            age_periods: 0,
        })
    }
}
