//! FNV-1a hashing of `f32` bit patterns, and the [`Digest`] of a run with its one-line
//! text form (printed by the target, parsed by `cargo xtask`).

use core::fmt;

use controller_core::kinematics::Pose;

/// The one NaN bit pattern the digest uses for every NaN.
///
/// The default NaN produced by the FPU differs in sign between x86 (`0xffc0_0000`) and ARM
/// (`0x7fc0_0000`), so NaN payloads are never compared.
pub const CANONICAL_NAN_BITS: u32 = 0x7fc0_0000;

/// The bits of `x`, with every NaN replaced by [`CANONICAL_NAN_BITS`].
#[inline]
pub fn canonical_bits(x: f32) -> u32 {
    if x.is_nan() {
        CANONICAL_NAN_BITS
    } else {
        x.to_bits()
    }
}

/// 64-bit FNV-1a: tiny, `no_std`, identical on every platform (bytes are fed little-endian).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv1a64(u64);

impl Fnv1a64 {
    const OFFSET_BASIS: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    /// A hasher in its initial state.
    pub const fn new() -> Self {
        Self(Self::OFFSET_BASIS)
    }

    /// Feeds `bytes`.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(Self::PRIME);
        }
    }

    /// Feeds a `u32`, little-endian.
    pub fn write_u32(&mut self, x: u32) {
        self.write(&x.to_le_bytes());
    }

    /// Feeds the canonical bits of an `f32` (see [`canonical_bits`]).
    pub fn write_f32(&mut self, x: f32) {
        self.write_u32(canonical_bits(x));
    }

    /// Feeds the canonical bits of a pose: x, y, θ.
    pub fn write_pose(&mut self, pose: &Pose) {
        self.write_f32(pose.x_m);
        self.write_f32(pose.y_m);
        self.write_f32(pose.theta_rad);
    }

    /// The hash so far.
    pub const fn finish(&self) -> u64 {
        self.0
    }
}

impl Default for Fnv1a64 {
    fn default() -> Self {
        Self::new()
    }
}

/// The fingerprint of one scenario run. Two runs computed the same numbers at every step
/// if and only if (up to hash collisions) their digests are equal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Digest {
    /// Control steps run.
    pub steps: u32,
    /// FNV-1a 64 over every step's motor command, odometry pose and true (plant) pose.
    pub hash: u64,
    /// Canonical bits of the final odometry pose (x, y, θ).
    pub pose_bits: [u32; 3],
    /// Canonical bits of the final true pose of the plant (x, y, θ).
    pub true_pose_bits: [u32; 3],
}

/// The first word of a digest line.
const LINE_PREFIX: &str = "digest";

impl Digest {
    /// The final odometry pose (world frame, m and rad).
    pub fn pose(&self) -> Pose {
        pose_from_bits(self.pose_bits)
    }

    /// The final true pose of the plant (world frame, m and rad).
    pub fn true_pose(&self) -> Pose {
        pose_from_bits(self.true_pose_bits)
    }

    /// Parses a line written by this type's `Display` (surrounding whitespace allowed).
    pub fn parse_line(line: &str) -> Option<Digest> {
        let mut words = line.split_whitespace();
        if words.next()? != LINE_PREFIX {
            return None;
        }
        let (mut steps, mut hash, mut pose, mut true_pose) = (None, None, None, None);
        for word in words {
            let (key, value) = word.split_once('=')?;
            match key {
                "steps" => steps = Some(value.parse().ok()?),
                "hash" => hash = Some(u64::from_str_radix(value, 16).ok()?),
                "pose" => pose = Some(parse_bits3(value)?),
                "true_pose" => true_pose = Some(parse_bits3(value)?),
                _ => return None,
            }
        }
        Some(Digest {
            steps: steps?,
            hash: hash?,
            pose_bits: pose?,
            true_pose_bits: true_pose?,
        })
    }
}

/// `digest steps=20000 hash=0123456789abcdef pose=xxxxxxxx,yyyyyyyy,tttttttt true_pose=…`,
/// all numbers in hex except `steps`.
impl fmt::Display for Digest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [px, py, pt] = self.pose_bits;
        let [tx, ty, tt] = self.true_pose_bits;
        write!(
            f,
            "{LINE_PREFIX} steps={} hash={:016x} pose={px:08x},{py:08x},{pt:08x} \
             true_pose={tx:08x},{ty:08x},{tt:08x}",
            self.steps, self.hash
        )
    }
}

/// Canonical bits of a pose's x, y, θ.
pub fn pose_bits(pose: &Pose) -> [u32; 3] {
    [
        canonical_bits(pose.x_m),
        canonical_bits(pose.y_m),
        canonical_bits(pose.theta_rad),
    ]
}

fn pose_from_bits(bits: [u32; 3]) -> Pose {
    Pose {
        x_m: f32::from_bits(bits[0]),
        y_m: f32::from_bits(bits[1]),
        theta_rad: f32::from_bits(bits[2]),
    }
}

fn parse_bits3(text: &str) -> Option<[u32; 3]> {
    let mut parts = text.split(',');
    let mut out = [0u32; 3];
    for slot in &mut out {
        *slot = u32::from_str_radix(parts.next()?, 16).ok()?;
    }
    parts.next().is_none().then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a64_matches_published_vectors() {
        let hash = |s: &str| {
            let mut h = Fnv1a64::new();
            h.write(s.as_bytes());
            h.finish()
        };
        assert_eq!(hash(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(hash("a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(hash("foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn every_nan_hashes_alike() {
        let arm_nan = f32::from_bits(0x7fc0_0000);
        let x86_nan = f32::from_bits(0xffc0_0000);
        let payload_nan = f32::from_bits(0x7f80_0001);
        for nan in [arm_nan, x86_nan, payload_nan, f32::NAN] {
            assert_eq!(canonical_bits(nan), CANONICAL_NAN_BITS);
        }
        // Everything else keeps its bits, including −0.
        assert_eq!(canonical_bits(-0.0), 0x8000_0000);
        assert_eq!(canonical_bits(f32::INFINITY), 0x7f80_0000);
    }

    #[test]
    fn line_round_trips_and_rejects_garbage() {
        let d = Digest {
            steps: 20_000,
            hash: 0x0123_4567_89ab_cdef,
            pose_bits: [0xbf80_0000, 0x3f80_0000, 0x8000_0000],
            true_pose_bits: [1, 2, CANONICAL_NAN_BITS],
        };
        let line = format!("{d}");
        assert_eq!(
            line,
            "digest steps=20000 hash=0123456789abcdef pose=bf800000,3f800000,80000000 \
             true_pose=00000001,00000002,7fc00000"
        );
        assert_eq!(Digest::parse_line(&line), Some(d));
        assert_eq!(Digest::parse_line(&format!("  {line}\r")), Some(d));
        assert_eq!(d.pose().x_m, -1.0);
        for bad in [
            "",
            "digest",
            "digest steps=1",
            "control step on Cortex-M4F: 400 instructions",
            &line.replace("pose=bf800000,", "pose="),
            &line.replace("hash=", "hash=x"),
            &format!("{line} extra=1"),
        ] {
            assert_eq!(Digest::parse_line(bad), None, "{bad:?}");
        }
    }
}
