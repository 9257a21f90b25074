//! Who speaks which protocol: the version byte and the schema hash that open every frame.
//!
//! Every frame's payload starts with a fixed five-byte header that is *not* postcard and
//! never changes layout across versions:
//!
//! | byte | content |
//! |---|---|
//! | 0 | [`PROTOCOL_VERSION`] |
//! | 1..5 | [`SCHEMA_HASH`], little-endian `u32` |
//!
//! Because the header is read before the body is decoded, a side that receives a frame
//! from a peer built with other message types still learns the peer's [`ProtocolId`] and
//! can say so ([`Mismatch`]), instead of failing to decode or, worse, misreading the body.

use core::fmt;

use postcard_schema::key::hash::fnv1a64::hash_ty_path;
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

use controller_core::path::MAX_SEGMENTS;

use crate::frame::MAX_BODY_LEN;
use crate::message::{
    Downlink, Uplink, FIELD_CAP, GIT_HASH_CAP, NAME_CAP, PANIC_FILE_CAP, PANIC_MESSAGE_CAP,
    PROBLEM_CAP, SEGMENTS_PER_CHUNK, VERSION_CAP,
};

/// Version of the protocol's rules (framing, request/reply semantics). Bump it when the
/// meaning of messages changes without their shape changing; shape changes are caught by
/// [`SCHEMA_HASH`] on their own.
pub const PROTOCOL_VERSION: u8 = 1;

/// Length of the fixed header at the start of every payload, bytes.
pub const HEADER_LEN: usize = 5;

/// A 32-bit digest of the shape of [`Downlink`] and [`Uplink`] (every field and variant
/// name and type, recursively, as described by their postcard-schema `SCHEMA`) and of
/// the capacities the schema does not describe ([`MAX_BODY_LEN`], the bounded strings'
/// and vectors' capacities, the core's `MAX_SEGMENTS`). Computed at compile time; two
/// builds agree on it exactly when they encode and decode the same bytes the same way.
pub const SCHEMA_HASH: u32 = {
    let mut state = fnv1a64_u64(FNV_BASIS, schema_hash64::<Downlink>("link/downlink"));
    state = fnv1a64_u64(state, schema_hash64::<Uplink>("link/uplink"));
    let capacities = [
        MAX_BODY_LEN,
        VERSION_CAP,
        GIT_HASH_CAP,
        NAME_CAP,
        FIELD_CAP,
        PROBLEM_CAP,
        SEGMENTS_PER_CHUNK,
        MAX_SEGMENTS,
        PANIC_FILE_CAP,
        PANIC_MESSAGE_CAP,
    ];
    let mut i = 0;
    while i < capacities.len() {
        state = fnv1a64_u64(state, capacities[i] as u64);
        i += 1;
    }
    fold(state)
};

/// The schema hash of any postcard-schema type `T`, folded to 32 bits: what
/// [`SCHEMA_HASH`] is built from. It changes when a field or variant of `T` (at any depth)
/// is added, removed, renamed, reordered or changes type; it does not depend on the
/// names of the types themselves.
pub const fn schema_hash_of<T: Schema + ?Sized>() -> u32 {
    fold(schema_hash64::<T>(""))
}

const FNV_BASIS: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

/// postcard-schema's FNV-1a-64 walk of `T::SCHEMA`, seeded with `path`.
const fn schema_hash64<T: Schema + ?Sized>(path: &str) -> u64 {
    u64::from_le_bytes(hash_ty_path::<T>(path))
}

/// FNV-1a-64 of the little-endian bytes of `value`, continuing from `state`.
const fn fnv1a64_u64(mut state: u64, value: u64) -> u64 {
    let bytes = value.to_le_bytes();
    let mut i = 0;
    while i < bytes.len() {
        state ^= bytes[i] as u64;
        state = state.wrapping_mul(FNV_PRIME);
        i += 1;
    }
    state
}

/// XOR of the two halves of a 64-bit hash.
const fn fold(hash: u64) -> u32 {
    (hash ^ (hash >> 32)) as u32
}

/// What a peer speaks: the protocol version and the schema hash of its frame header.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Schema)]
pub struct ProtocolId {
    /// [`PROTOCOL_VERSION`] of the peer.
    pub version: u8,
    /// [`SCHEMA_HASH`] of the peer.
    pub schema_hash: u32,
}

impl ProtocolId {
    /// What this build speaks.
    pub const OURS: ProtocolId = ProtocolId {
        version: PROTOCOL_VERSION,
        schema_hash: SCHEMA_HASH,
    };

    /// The header bytes that open a frame from a peer speaking `self`.
    pub const fn to_header(self) -> [u8; HEADER_LEN] {
        let h = self.schema_hash.to_le_bytes();
        [self.version, h[0], h[1], h[2], h[3]]
    }

    /// Reads the header at the start of `payload`; `None` when it is shorter than
    /// [`HEADER_LEN`].
    pub fn from_header(payload: &[u8]) -> Option<ProtocolId> {
        match *payload {
            [version, a, b, c, d, ..] => Some(ProtocolId {
                version,
                schema_hash: u32::from_le_bytes([a, b, c, d]),
            }),
            _ => None,
        }
    }
}

impl fmt::Display for ProtocolId {
    /// `protocol v1 schema 0x1a2b3c4d`
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "protocol v{} schema 0x{:08x}",
            self.version, self.schema_hash
        )
    }
}

/// A frame arrived from a peer that speaks another protocol than [`ProtocolId::OURS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mismatch {
    /// What the peer speaks (read from its frame header).
    pub remote: ProtocolId,
    /// What this side speaks.
    pub local: ProtocolId,
}

impl Mismatch {
    /// A mismatch with a peer speaking `remote`.
    pub const fn with(remote: ProtocolId) -> Self {
        Self {
            remote,
            local: ProtocolId::OURS,
        }
    }

    /// Text for a terminal naming both sides, e.g. with `"robot"` and `"this station"`:
    /// `robot speaks protocol v1 schema 0x…, this station protocol v2 schema 0x…; build
    /// both from the same version of the link crate`.
    pub fn describe<'a>(
        &'a self,
        remote_name: &'a str,
        local_name: &'a str,
    ) -> impl fmt::Display + 'a {
        Described {
            mismatch: self,
            remote_name,
            local_name,
        }
    }
}

struct Described<'a> {
    mismatch: &'a Mismatch,
    remote_name: &'a str,
    local_name: &'a str,
}

impl fmt::Display for Described<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} speaks {}, {} {}; build both from the same version of the link crate",
            self.remote_name, self.mismatch.remote, self.local_name, self.mismatch.local
        )
    }
}

impl fmt::Display for Mismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.describe("the peer", "this side").fmt(f)
    }
}

impl core::error::Error for Mismatch {}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;

    #[test]
    fn header_round_trips_and_is_little_endian() {
        let id = ProtocolId {
            version: 7,
            schema_hash: 0x1122_3344,
        };
        assert_eq!(id.to_header(), [7, 0x44, 0x33, 0x22, 0x11]);
        assert_eq!(ProtocolId::from_header(&id.to_header()), Some(id));
        assert_eq!(ProtocolId::from_header(&[7, 0x44, 0x33, 0x22]), None);
    }

    #[test]
    fn the_hash_steps_are_fnv_1a_and_a_fold() {
        // FNV-1a-64 of the bytes 08 07 06 05 04 03 02 01 from the standard basis, and of
        // eight zero bytes (computed independently from the FNV specification, checked
        // against its vector for "a", 0xaf63dc4c8601ec8c).
        assert_eq!(
            fnv1a64_u64(FNV_BASIS, 0x0102_0304_0506_0708),
            0x0c6d_4496_e178_59d5
        );
        assert_eq!(fnv1a64_u64(FNV_BASIS, 0), 0xa8c7_f832_281a_39c5);
        assert_eq!(fold(0x1234_5678_9abc_def0), 0x1234_5678 ^ 0x9abc_def0);
    }

    #[test]
    fn a_mismatch_reads_as_the_peer_and_this_side() {
        let theirs = ProtocolId {
            version: 9,
            schema_hash: 1,
        };
        let text = Mismatch::with(theirs).to_string();
        assert!(
            text.starts_with("the peer speaks protocol v9 schema 0x00000001, this side "),
            "{text}"
        );
    }

    #[test]
    fn mismatch_names_both_sides() {
        let theirs = ProtocolId {
            version: 2,
            schema_hash: 0xdead_beef,
        };
        let text = Mismatch::with(theirs)
            .describe("robot", "this station")
            .to_string();
        let ours =
            std::format!("this station protocol v{PROTOCOL_VERSION} schema 0x{SCHEMA_HASH:08x}");
        assert!(
            text.starts_with("robot speaks protocol v2 schema 0xdeadbeef, "),
            "{text}"
        );
        assert!(text.contains(&ours), "{text}");
    }

    /// Two small local message types: the hash must follow their shape. Only their
    /// schemas are used.
    #[allow(dead_code)]
    mod shapes {
        use postcard_schema::Schema;

        pub mod v1 {
            use super::Schema;
            #[derive(Schema)]
            pub struct Telemetry {
                pub step: u32,
                pub speed_m_s: f32,
            }
        }
        pub mod same_shape_other_name {
            use super::Schema;
            #[derive(Schema)]
            pub struct Sample {
                pub step: u32,
                pub speed_m_s: f32,
            }
        }
        pub mod wider_step {
            use super::Schema;
            #[derive(Schema)]
            pub struct Telemetry {
                pub step: u64,
                pub speed_m_s: f32,
            }
        }
        pub mod renamed_field {
            use super::Schema;
            #[derive(Schema)]
            pub struct Telemetry {
                pub step: u32,
                pub speed_rad_s: f32,
            }
        }
        pub mod extra_field {
            use super::Schema;
            #[derive(Schema)]
            pub struct Telemetry {
                pub step: u32,
                pub speed_m_s: f32,
                pub faulted: bool,
            }
        }
        pub mod reordered {
            use super::Schema;
            #[derive(Schema)]
            pub struct Telemetry {
                pub speed_m_s: f32,
                pub step: u32,
            }
        }
        pub mod enum_a {
            use super::Schema;
            #[derive(Schema)]
            pub enum Request {
                Ping(u32),
                Stop,
            }
        }
        pub mod enum_b {
            use super::Schema;
            #[derive(Schema)]
            pub enum Request {
                Stop,
                Ping(u32),
            }
        }
    }

    #[test]
    fn schema_hash_follows_the_shape_not_the_type_name() {
        use shapes::*;
        let base = schema_hash_of::<v1::Telemetry>();
        assert_eq!(base, schema_hash_of::<same_shape_other_name::Sample>());
        for (what, other) in [
            ("u32 -> u64", schema_hash_of::<wider_step::Telemetry>()),
            (
                "field renamed",
                schema_hash_of::<renamed_field::Telemetry>(),
            ),
            ("field added", schema_hash_of::<extra_field::Telemetry>()),
            ("fields reordered", schema_hash_of::<reordered::Telemetry>()),
        ] {
            assert_ne!(base, other, "{what} must change the hash");
        }
        assert_ne!(
            schema_hash_of::<enum_a::Request>(),
            schema_hash_of::<enum_b::Request>(),
            "variants reordered must change the hash"
        );
    }

    #[test]
    fn protocol_hash_covers_both_directions() {
        assert_eq!(ProtocolId::OURS.schema_hash, SCHEMA_HASH);
        // Not a fold of one direction alone.
        assert_ne!(SCHEMA_HASH, schema_hash_of::<Downlink>());
        assert_ne!(SCHEMA_HASH, schema_hash_of::<Uplink>());
        assert_ne!(schema_hash_of::<Downlink>(), schema_hash_of::<Uplink>());
        assert_eq!(
            ProtocolId::OURS.to_string(),
            std::format!("protocol v{PROTOCOL_VERSION} schema 0x{SCHEMA_HASH:08x}")
        );
    }
}
