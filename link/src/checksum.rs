//! CRC-32 (ISO-HDLC, the one of Ethernet and zlib) for frames, path uploads and
//! configurations. One 1 KiB table serves all three.

use controller_core::path::Segment;
use crc::{Crc, Digest, CRC_32_ISO_HDLC};
use postcard::ser_flavors::Flavor;
use serde::Serialize;

use crate::message::ParamSet;

/// The CRC used everywhere in the link.
pub(crate) static CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC of `bytes`, with the link's own table: for records that other crates
/// protect the same way (a second table would cost another 1 KiB of flash).
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

/// The checksum a [`PathCommit`](crate::PathCommit) carries: CRC-32 of the postcard
/// encodings of `segments`, concatenated in order. The host computes it over the
/// segments it sends; the robot over those it received.
pub fn path_checksum(segments: &[Segment]) -> u32 {
    let mut digest = CRC32.digest();
    for segment in segments {
        feed(&mut digest, segment);
    }
    digest.finalize()
}

/// A fingerprint of a configuration: CRC-32 of its postcard encoding. The robot reports
/// the one of its active configuration ([`RobotInfo::params_hash`](crate::RobotInfo),
/// [`Reply::ParamsApplied`](crate::Reply)); a host compares it with the one of the
/// configuration it holds.
pub fn params_hash(params: &ParamSet) -> u32 {
    let mut digest = CRC32.digest();
    feed(&mut digest, params);
    digest.finalize()
}

/// Runs `value`'s postcard encoding through `digest` without storing it.
fn feed<T: Serialize + ?Sized>(digest: &mut Digest<'static, u32>, value: &T) {
    // A digest never runs out of room, and the link's types have no unencodable
    // values, so there is no error to handle.
    let _ = postcard::serialize_with_flavor(value, DigestFlavor { digest });
}

/// A postcard output that only updates a CRC digest.
struct DigestFlavor<'a> {
    digest: &'a mut Digest<'static, u32>,
}

impl Flavor for DigestFlavor<'_> {
    type Output = ();

    // Not inlined, like the frame encoder's output: postcard calls these from every field.
    #[inline(never)]
    fn try_push(&mut self, data: u8) -> postcard::Result<()> {
        self.digest.update(&[data]);
        Ok(())
    }

    #[inline(never)]
    fn try_extend(&mut self, data: &[u8]) -> postcard::Result<()> {
        self.digest.update(data);
        Ok(())
    }

    fn finalize(self) -> postcard::Result<()> {
        Ok(())
    }
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
