//! CRC-32 (ISO-HDLC, the one of Ethernet and zlib) for frames, path uploads and
//! configurations, computed bit by bit.
//!
//! No lookup table: a 256-entry table costs 1 KiB of flash, a tenth of what the robot's
//! whole link service may take, while the bitwise loop costs about eight instructions
//! per bit. At the fastest link rate (921 600 Bd, 92 kB/s) that is under 6 % of the
//! Cortex-M4F at 100 MHz, spent in the link task, never in the control step.

use controller_core::path::Segment;
use crc::{Crc, NoTable, CRC_32_ISO_HDLC};

use crate::frame::{encode_body, MAX_BODY_LEN};
use crate::message::ParamSet;

/// The CRC used everywhere in the link.
pub(crate) static CRC32: Crc<u32, NoTable> = Crc::<u32, NoTable>::new(&CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC of `bytes`, the link's own: for records that other crates protect
/// the same way (one implementation in the binary).
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

/// The checksum a [`PathCommit`](crate::PathCommit) carries: CRC-32 of the postcard
/// encodings of `segments`, concatenated in order. The host computes it over the
/// segments it sends; the robot over those it received.
pub fn path_checksum(segments: &[Segment]) -> u32 {
    let mut digest = CRC32.digest();
    let mut encoded = [0u8; SEGMENT_MAX_LEN];
    for segment in segments {
        // Every segment fits (a test checks the largest).
        let len = encode_body(segment, &mut encoded).unwrap_or(0);
        digest.update(encoded.get(..len).unwrap_or_default());
    }
    digest.finalize()
}

/// Bytes of the longest postcard encoding of a [`Segment`] (an arc: its variant and five
/// `f32`), with room to spare.
const SEGMENT_MAX_LEN: usize = 32;

/// A fingerprint of a configuration: CRC-32 of its postcard encoding. The robot reports
/// the one of its active configuration ([`RobotInfo::params_hash`](crate::RobotInfo),
/// [`Reply::ParamsApplied`](crate::Reply)); a host compares it with the one of the
/// configuration it holds.
pub fn params_hash(params: &ParamSet) -> u32 {
    let mut encoded = [0u8; MAX_BODY_LEN];
    // A configuration always fits a body (a test checks the margin).
    let len = encode_body(params, &mut encoded).unwrap_or(0);
    CRC32.checksum(encoded.get(..len).unwrap_or_default())
}

#[cfg(test)]
mod tests {
    extern crate std;

    use controller_core::kinematics::{Point, Pose, WheelSpeeds};
    use controller_core::params::RobotConfig;
    use controller_core::supervisor::SupervisorConfig;

    use super::*;

    #[test]
    fn crc_is_iso_hdlc() {
        // The standard check value of CRC-32/ISO-HDLC.
        assert_eq!(CRC32.checksum(b"123456789"), 0xcbf4_3926);
        assert_eq!(crc32(b"123456789"), 0xcbf4_3926);
    }

    fn segments() -> [Segment; 2] {
        [
            Segment::Line {
                start: Point::new(0.0, 0.0),
                heading_rad: 0.0,
                length_m: 1.0,
            },
            Segment::Arc {
                center: Point::new(1.0, 0.5),
                radius_m: 0.5,
                start_angle_rad: -core::f32::consts::FRAC_PI_2,
                sweep_rad: 1.0,
            },
        ]
    }

    #[test]
    fn path_checksum_is_the_crc_of_the_concatenated_encodings() {
        let s = segments();
        let mut bytes = std::vec::Vec::new();
        for segment in &s {
            bytes.extend_from_slice(&postcard::to_allocvec(segment).unwrap());
        }
        assert_eq!(path_checksum(&s), CRC32.checksum(&bytes));
        // Order matters.
        assert_ne!(path_checksum(&s), path_checksum(&[s[1], s[0]]));
        assert_eq!(path_checksum(&[]), CRC32.checksum(&[]));
        // The largest segment fits the buffer the checksum encodes it in.
        let arc = Segment::Arc {
            center: Point::new(f32::MAX, f32::MIN),
            radius_m: f32::MAX,
            start_angle_rad: f32::MIN,
            sweep_rad: f32::MAX,
        };
        let len = postcard::to_allocvec(&arc).unwrap().len();
        assert!(len <= SEGMENT_MAX_LEN, "{len}");
    }

    #[test]
    fn params_hash_sees_every_change() {
        let robot = RobotConfig::REFERENCE_ROBOT;
        let supervisor =
            SupervisorConfig::at_rate(1000, Pose::default(), WheelSpeeds::new(5.0, 5.0));
        let a = ParamSet { robot, supervisor };
        let mut b = a;
        b.supervisor.debounce_steps += 1;
        assert_eq!(params_hash(&a), params_hash(&{ a }));
        assert_ne!(params_hash(&a), params_hash(&b));
        assert_eq!(
            params_hash(&a),
            CRC32.checksum(&postcard::to_allocvec(&a).unwrap())
        );
    }
}
