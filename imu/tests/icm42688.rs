//! The driver against a mocked SPI device: every byte on the bus is the one the test
//! names, in order (embedded-hal-mock fails the test on any other, or on one missing).

use embedded_hal::delay::DelayNs;
use embedded_hal_mock::eh1::spi::{Mock, Transaction};
use imu::registers::*;
use imu::{GyroZReading, Icm42688, ProbeError, GYRO_START_UP_US, RADPS_PER_LSB, RESET_WAIT_US};

/// Adds up the waits asked for.
#[derive(Default)]
struct Waits(u64);

impl DelayNs for Waits {
    fn delay_ns(&mut self, ns: u32) {
        self.0 += u64::from(ns);
    }
}

fn write(register: u8, value: u8) -> Vec<Transaction<u8>> {
    vec![
        Transaction::transaction_start(),
        Transaction::write_vec(vec![register, value]),
        Transaction::transaction_end(),
    ]
}

fn read(register: u8, value: u8) -> Vec<Transaction<u8>> {
    vec![
        Transaction::transaction_start(),
        Transaction::write_vec(vec![register | 0x80]),
        Transaction::read_vec(vec![value]),
        Transaction::transaction_end(),
    ]
}

/// Bank 0, the soft reset and WHO_AM_I answering `who_am_i`.
fn reset_and_identity(who_am_i: u8) -> Vec<Transaction<u8>> {
    [write(0x76, 0x00), write(0x11, 0x01), read(0x75, who_am_i)].concat()
}

/// INTF_CONFIG1 read at its reset value (0x91: AFSR field 10, enabled), written with the
/// AFSR field 01 (disabled) and its other bits kept, and read back.
fn afsr_off() -> Vec<Transaction<u8>> {
    [read(0x4D, 0x91), write(0x4D, 0x51), read(0x4D, 0x51)].concat()
}

/// The whole start-up sequence of a present part that keeps every value.
fn start_up() -> Vec<Transaction<u8>> {
    [
        reset_and_identity(0x47),
        afsr_off(),
        write(0x4F, 0x06),
        read(0x4F, 0x06),
        write(0x64, 0x00),
        read(0x64, 0x00),
        write(0x65, 0x08),
        read(0x65, 0x08),
        write(0x4E, 0x0C),
        read(0x4E, 0x0C),
    ]
    .concat()
}

/// The probe, on a bus that goes as `bus`, refuses the part because `register` read
/// `read` back after `wrote`, and uses the whole of `bus`.
fn refused_at(bus: &[Vec<Transaction<u8>>], register: u8, wrote: u8, read: u8) {
    let mut spi = Mock::new(&bus.concat());
    let result = Icm42688::probe(spi.clone(), &mut Waits::default());
    assert_eq!(
        result.unwrap_err(),
        ProbeError::Configuration {
            register,
            wrote,
            read
        }
    );
    spi.done();
}

fn burst(bytes: [u8; 5]) -> Vec<Transaction<u8>> {
    vec![
        Transaction::transaction_start(),
        Transaction::write_vec(vec![0x29 | 0x80]),
        Transaction::read_vec(bytes.to_vec()),
        Transaction::transaction_end(),
    ]
}

#[test]
fn a_wrong_who_am_i_means_no_imu_and_nothing_more_is_written() {
    for who_am_i in [0x00, 0xFF, 0x98] {
        let mut spi = Mock::new(&reset_and_identity(who_am_i));
        let result = Icm42688::probe(spi.clone(), &mut Waits::default());
        assert_eq!(result.unwrap_err(), ProbeError::Absent { who_am_i });
        spi.done();
    }
}

#[test]
fn the_start_up_sequence_resets_identifies_configures_reads_back_and_waits() {
    let mut spi = Mock::new(&start_up());
    let mut waits = Waits::default();
    let imu = Icm42688::probe(spi.clone(), &mut waits).unwrap();
    assert_eq!(
        waits.0,
        u64::from(RESET_WAIT_US + GYRO_START_UP_US) * 1000,
        "1 ms after the reset, the gyro's start-up after the power mode"
    );
    drop(imu.release());
    spi.done();
}

#[test]
fn the_configuration_is_a_1_khz_2000_dps_low_noise_gyro_with_the_accelerometer_off() {
    assert_eq!(GYRO_2000DPS_1KHZ >> 5, 0b000, "GYRO_FS_SEL ±2000 °/s");
    assert_eq!(GYRO_2000DPS_1KHZ & 0x0F, 0b0110, "GYRO_ODR 1 kHz");
    assert_eq!(
        (GYRO_LOW_NOISE_ACCEL_OFF >> 2) & 0b11,
        0b11,
        "GYRO_MODE low noise"
    );
    assert_eq!(GYRO_LOW_NOISE_ACCEL_OFF & 0b11, 0b00, "ACCEL_MODE off");
}

#[test]
fn the_adaptive_full_scale_range_is_disabled_and_the_other_interface_bits_kept() {
    // Bits 7:6 become 01 whatever they were; bits 5:0 are the part's.
    for (read_value, written) in [(0x91, 0x51), (0xFF, 0x7F), (0x00, 0x40), (0x40, 0x40)] {
        assert_eq!(afsr_disabled(read_value), written, "{read_value:#04x}");
    }
    assert_eq!(INTF_CONFIG1, 0x4D);
    // On the bus: read, then the field written, then read back, before any other
    // configuration register; a part whose value differs from the reset value keeps its
    // other bits.
    refused_at(
        &[
            reset_and_identity(0x47),
            read(0x4D, 0x93),
            write(0x4D, 0x53),
            read(0x4D, 0x53),
            write(0x4F, 0x06),
            read(0x4F, 0x00),
        ],
        0x4F,
        0x06,
        0x00,
    );
}

#[test]
fn an_interface_register_that_keeps_the_adaptive_range_refuses_the_part() {
    refused_at(
        &[
            reset_and_identity(0x47),
            read(0x4D, 0x91),
            write(0x4D, 0x51),
            read(0x4D, 0x91),
        ],
        0x4D,
        0x51,
        0x91,
    );
}

#[test]
fn a_register_that_does_not_keep_its_value_refuses_the_part() {
    refused_at(
        &[
            reset_and_identity(0x47),
            afsr_off(),
            write(0x4F, 0x06),
            read(0x4F, 0x00),
        ],
        0x4F,
        0x06,
        0x00,
    );
}

#[test]
fn a_reading_is_one_burst_scaled_to_rad_per_s_counter_clockwise_positive() {
    let readings = [
        // +1000 counts = 1000 / 16.4 °/s, data ready.
        ([0x03, 0xE8, 0x12, 0x34, DATA_RDY_INT], 1000i16, true),
        // −1000 counts, data ready among other status bits.
        ([0xFC, 0x18, 0x00, 0x00, 0x7F], -1000, true),
        // No new sample since the last read.
        ([0x00, 0x10, 0x00, 0x00, 0x10], 16, false),
    ];
    let expected: Vec<_> = readings.iter().flat_map(|(b, _, _)| burst(*b)).collect();
    let mut spi = Mock::new(&[start_up(), expected].concat());
    let mut imu = Icm42688::probe(spi.clone(), &mut Waits::default()).unwrap();
    for (_, counts, ready) in readings {
        let reading = imu.read_gyro_z().unwrap();
        assert_eq!(
            reading,
            GyroZReading {
                counts,
                data_ready: ready
            }
        );
        let rate = reading.yaw_rate_radps().unwrap();
        let want = f32::from(counts) / 16.4 * std::f32::consts::PI / 180.0;
        assert!(
            (rate - want).abs() < 1e-6,
            "{rate} rad/s for {counts} counts"
        );
        assert_eq!(rate.signum(), f32::from(counts).signum());
        assert_eq!(reading.new_yaw_rate_radps().is_some(), ready);
    }
    drop(imu.release());
    spi.done();
}

#[test]
fn full_scale_is_2000_dps_and_both_ends_read_as_saturated() {
    let top = GyroZReading {
        counts: i16::MAX,
        data_ready: true,
    };
    let bottom = GyroZReading {
        counts: -i16::MAX,
        data_ready: true,
    };
    let inside = GyroZReading {
        counts: i16::MAX - 1,
        data_ready: true,
    };
    assert!(top.saturated() && bottom.saturated() && !inside.saturated());
    let full_scale_dps = top.yaw_rate_radps().unwrap().to_degrees();
    assert!(
        (full_scale_dps - 1998.0).abs() < 0.5,
        "{full_scale_dps} °/s"
    );
    assert!((RADPS_PER_LSB - 0.061_f32.to_radians()).abs() < 1e-5);
}

#[test]
fn the_no_data_code_is_no_rate_even_when_flagged_ready() {
    let reading = GyroZReading::from_burst([0x80, 0x00, 0, 0, DATA_RDY_INT]);
    assert_eq!(reading.counts, i16::MIN);
    assert_eq!(reading.yaw_rate_radps(), None);
    assert_eq!(reading.new_yaw_rate_radps(), None);
    assert!(!reading.saturated());
}

#[test]
fn probe_errors_name_what_they_read() {
    let absent: ProbeError<()> = ProbeError::Absent { who_am_i: 0xFF };
    assert_eq!(
        absent.to_string(),
        "no ICM-42688-P: WHO_AM_I read 0xff, expected 0x47"
    );
    let config: ProbeError<()> = ProbeError::Configuration {
        register: 0x4F,
        wrote: 0x06,
        read: 0x00,
    };
    assert!(config.to_string().contains("0x4f"));
}

/// A bus whose every transaction fails.
#[derive(Debug)]
struct BrokenBus;

impl embedded_hal::spi::ErrorType for BrokenBus {
    type Error = embedded_hal::spi::ErrorKind;
}

impl embedded_hal::spi::SpiDevice for BrokenBus {
    fn transaction(
        &mut self,
        _operations: &mut [embedded_hal::spi::Operation<'_, u8>],
    ) -> Result<(), Self::Error> {
        Err(embedded_hal::spi::ErrorKind::ModeFault)
    }
}

#[test]
fn a_bus_error_while_probing_is_a_bus_error_not_a_part() {
    let mut waits = Waits::default();
    let result = Icm42688::probe(BrokenBus, &mut waits);
    assert_eq!(
        result.unwrap_err(),
        ProbeError::Bus(embedded_hal::spi::ErrorKind::ModeFault)
    );
    assert_eq!(waits.0, 0, "it gave up at the first failed write");
}
