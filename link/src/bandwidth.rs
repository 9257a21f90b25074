//! How much a serial link carries: bytes on the wire per frame and the telemetry rate a
//! baud rate affords.
//!
//! A UART with 8N1 framing sends 10 bits per byte (start, 8 data, stop), so a link at
//! `baud` carries `baud / 10` bytes per second. Telemetry may take at most
//! `100 − reserved_percent` % of that; the rest stays free for replies, heartbeats and
//! path chunks.

use controller_core::controller::MotorCommand;
use controller_core::kinematics::{Pose, TrackingError, WheelSpeeds};
use controller_core::supervisor::{Faults, RunMode, State};

use crate::frame::max_wire_len;
use crate::message::{PidParts, TelemetryFrame, Uplink};

/// Bits per byte on a UART with 8N1 framing.
pub const BITS_PER_BYTE_8N1: u32 = 10;

/// The telemetry rates a robot accepts, Hz ([`Request::SetTelemetryRate`](crate::Request)).
pub const TELEMETRY_RATE_HZ: core::ops::RangeInclusive<u8> = 1..=100;

/// The robot's serial link rate (8N1), bit/s: 230 400, the lowest standard rate that
/// carries the whole telemetry range (100 Hz of 157-byte frames with 30 % of the line
/// kept for replies: [`max_telemetry_rate_hz`] gives 102 Hz, where 115 200 stops at
/// 51 Hz). Both boards configure it and the station opens the port at it by default.
pub const LINK_BAUD: u32 = 230_400;

/// Share of the link (percent) kept free for replies, heartbeats and path chunks when
/// sizing telemetry: 30 %.
pub const DEFAULT_RESERVED_PERCENT: u8 = 30;

/// Bytes per second a UART at `baud` carries with 8N1 framing.
pub const fn bytes_per_second(baud: u32) -> u32 {
    baud / BITS_PER_BYTE_8N1
}

/// Most frames per second of `frame_wire_len` bytes (delimiter included) a UART at
/// `baud` carries while keeping `reserved_percent` % of it free (clamped to 100 %),
/// rounded down.
pub const fn max_frame_rate_hz(baud: u32, frame_wire_len: usize, reserved_percent: u8) -> u32 {
    let reserved = if reserved_percent > 100 {
        100
    } else {
        reserved_percent as u64
    };
    let usable = bytes_per_second(baud) as u64 * (100 - reserved) / 100;
    if frame_wire_len == 0 {
        return 0;
    }
    (usable / frame_wire_len as u64) as u32
}

/// The largest telemetry sample: every varint at its longest. Its fields other than the
/// step, tick and encoder counts are defaults; their size does not depend on their value.
pub fn largest_telemetry() -> Uplink {
    Uplink::Telemetry(TelemetryFrame {
        step: u32::MAX,
        state: State::Disarmed,
        run_mode: RunMode::FollowPath,
        faults: Faults::default(),
        pose: Pose::default(),
        tracking_error: TrackingError::default(),
        lyapunov: 0.0,
        lyapunov_rate: 0.0,
        wheel_setpoint: WheelSpeeds::default(),
        wheel_speed: WheelSpeeds::default(),
        duty: MotorCommand::default(),
        pid_left: PidParts::default(),
        pid_right: PidParts::default(),
        supply_v: 0.0,
        missed_ticks: u32::MAX,
        gyro_yaw_rate_radps: 0.0,
        gyro_bias_radps: 0.0,
        fused_heading_rad: 0.0,
        odometry_heading_rad: 0.0,
        gyro_health: controller_core::gyro::GyroHealth::Failed(
            controller_core::gyro::GyroFailure::NonFinite,
        ),
        raw_counts: crate::RawCounts {
            left: i32::MIN,
            right: i32::MIN,
        },
    })
}

/// Bytes on the wire of the largest telemetry frame ([`largest_telemetry`]), delimiter
/// included.
pub fn telemetry_wire_len() -> usize {
    let body = postcard::experimental::serialized_size(&largest_telemetry()).unwrap_or(0);
    max_wire_len(body)
}

/// The fastest telemetry rate, Hz, a UART at `baud` (8N1) affords while keeping
/// `reserved_percent` % free, capped to the accepted range ([`TELEMETRY_RATE_HZ`]); 0
/// when even 1 Hz does not fit.
pub fn max_telemetry_rate_hz(baud: u32, reserved_percent: u8) -> u8 {
    let rate = max_frame_rate_hz(baud, telemetry_wire_len(), reserved_percent);
    let max = *TELEMETRY_RATE_HZ.end();
    u8::try_from(rate).map_or(max, |r| r.min(max))
}

/// Accepts a telemetry rate in [`TELEMETRY_RATE_HZ`], or the refusal to send.
pub fn check_telemetry_rate(hz: u8) -> Result<u8, crate::Refusal> {
    if TELEMETRY_RATE_HZ.contains(&hz) {
        Ok(hz)
    } else {
        Err(crate::Refusal::InvalidArgument(crate::FieldProblem::new(
            "hz",
            "must be in 1..=100",
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eight_n_one_is_ten_bits_per_byte() {
        assert_eq!(bytes_per_second(115_200), 11_520);
        assert_eq!(bytes_per_second(921_600), 92_160);
    }

    #[test]
    fn frame_rate_keeps_the_reserve() {
        // 11 520 B/s, 70 % usable = 8064 B/s, 121-byte frames: 66.6 → 66 Hz.
        assert_eq!(max_frame_rate_hz(115_200, 121, 30), 66);
        // No reserve: 11 520 / 121 = 95.2.
        assert_eq!(max_frame_rate_hz(115_200, 121, 0), 95);
        // A reserve over 100 % leaves nothing; so does a zero-length frame.
        assert_eq!(max_frame_rate_hz(115_200, 121, 100), 0);
        assert_eq!(max_frame_rate_hz(115_200, 121, 250), 0);
        assert_eq!(max_frame_rate_hz(115_200, 0, 30), 0);
        // The rate and the frame length trade one for one.
        assert_eq!(max_frame_rate_hz(230_400, 242, 30), 66);
    }

    #[test]
    fn telemetry_rate_follows_the_frame_and_is_capped() {
        let wire = telemetry_wire_len();
        assert!(wire > 100 && wire < 160, "{wire}");
        for baud in [115_200u32, 230_400, 460_800, 921_600] {
            let usable = u64::from(baud / 10) * 70 / 100;
            let uncapped = usable / wire as u64;
            let expected = uncapped.min(100) as u8;
            assert_eq!(max_telemetry_rate_hz(baud, 30), expected, "{baud} baud");
            // The rate chosen, plus the reserve, fits in the link.
            let used = u64::from(expected) * wire as u64;
            assert!(used * 100 <= u64::from(baud / 10) * 70);
        }
        assert_eq!(max_telemetry_rate_hz(921_600, 30), 100, "capped");
        assert_eq!(
            max_telemetry_rate_hz(1_200, 30),
            0,
            "not even 1 Hz at 1200 baud"
        );
    }

    #[test]
    fn telemetry_rates_outside_1_to_100_are_refused() {
        for hz in [1, 50, 100] {
            assert_eq!(check_telemetry_rate(hz), Ok(hz));
        }
        for hz in [0, 101, 255] {
            match check_telemetry_rate(hz) {
                Err(crate::Refusal::InvalidArgument(p)) => assert_eq!(p.field.as_str(), "hz"),
                other => panic!("{hz} Hz: {other:?}"),
            }
        }
    }
}
