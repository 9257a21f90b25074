//! The runtime link between the robot and its host tools (DRAFT DOC)
#![no_std]
#![warn(missing_docs)]

pub mod bandwidth;
mod checksum;
pub mod decoder;
pub mod frame;
pub mod message;
pub mod protocol;
pub mod upload;

pub use crate::bandwidth::{check_telemetry_rate, max_telemetry_rate_hz, TELEMETRY_RATE_HZ};
pub use crate::checksum::{params_hash, path_checksum};
pub use crate::decoder::{Decoder, Dropped, Outcome, Received, RxCounters};
pub use crate::frame::{
    encode, encode_raw, encode_to_vec, max_wire_len, EncodeError, MAX_BODY_LEN, MAX_FRAME_LEN,
};
pub use crate::message::*;
pub use crate::protocol::{Mismatch, ProtocolId, PROTOCOL_VERSION, SCHEMA_HASH};
pub use crate::upload::{Commit, CommittedPath, PathAssembler, Progress};
