//! The runtime link between the robot and its host tools.
//!
//! One `no_std`, heap-free protocol crate used on both ends: the firmware and the
//! simulator's virtual robot answer requests with it, the station (host CLI) and the tests
//! send them with it. It holds the messages, their framing, a streaming decoder, the
//! robot's path-upload assembler and bandwidth arithmetic; it knows nothing of serial
//! ports, sockets or timers (the robot service and the station own those).
//!
//! # Wire format
//!
//! `docs/protocol.md` specifies it byte by byte for clients in other languages (every
//! message and the types it carries, the handshake, the rates); `cargo xtask ci` checks
//! that page against this crate.
//!
//! ```text
//! payload = version (u8) ++ schema hash (u32 LE) ++ postcard(message)
//! frame   = COBS(payload ++ CRC-32/ISO-HDLC LE (payload)) ++ 0x00
//! ```
//!
//! - **postcard** encodes the message ([`Downlink`] host → robot, [`Uplink`] robot → host).
//! - **COBS** removes every 0x00 from the frame, so 0x00 marks the end of a frame and a
//!   receiver that lost bytes resynchronises at the next one. The overhead is one byte
//!   per 254, plus the delimiter.
//! - **CRC-32** (the Ethernet/zlib polynomial, computed bit by bit: no table) detects corruption on the
//!   line. A frame that fails COBS, the CRC, the size limit or postcard decoding is
//!   dropped and counted ([`RxCounters`]), never acted on, never a panic.
//! - **The header** is five fixed bytes, not postcard, and its layout never changes:
//!   [`PROTOCOL_VERSION`] and [`SCHEMA_HASH`], a 32-bit digest of the shape of both
//!   message enums computed at compile time from their postcard-schema `SCHEMA` (every
//!   field and variant, their names and types, recursively), and of the capacities the
//!   schema does not show ([`MAX_BODY_LEN`], bounded strings and vectors). A
//!   side reads it before decoding the body, so a peer built from other message types is
//!   recognised on *any* frame, even one whose body it could not decode, and the user is
//!   told both versions ([`Mismatch`]): `robot speaks protocol v1 schema 0x…, this station
//!   protocol v1 schema 0x…`. The robot answers such a frame with
//!   [`Uplink::VersionMismatch`], whose own header tells the host what the robot speaks.
//!   Why a hash of the schema rather than a hand-bumped number: it cannot be forgotten.
//!   Why in every frame rather than in a handshake: telemetry starts flowing without one,
//!   and a robot reflashed behind a running station is caught on its next frame.
//!
//! Limits: a body is at most [`MAX_BODY_LEN`] = 388 bytes, a frame at most
//! [`MAX_FRAME_LEN`] = 400 bytes on the wire.
//!
//! # Messages and their sizes
//!
//! Every [`Request`] travels in a [`Downlink`] with a `seq` that its one
//! [`Uplink::Reply`] echoes, carrying a [`Reply`] or a [`Refusal`] (the table of which
//! reply answers which request is in [`message`]). The robot also sends
//! [`Uplink::Telemetry`], [`Uplink::Event`], [`Uplink::Stats`], [`Uplink::RunReport`]
//! (a run's metrics, computed on the robot at the control rate, when the run ends),
//! [`Uplink::TuneReport`] (a wheel-loop tune's model and gains, when it ends) and,
//! from the simulator only, [`Uplink::GroundTruth`] and [`Uplink::GroundTruthRun`]. Messages carry the core's own types (`RobotConfig`,
//! `SupervisorConfig`, `Segment`, `Pose`, `Faults`, …), never copies of them.
//!
//! Sizes measured with `cargo run -p link --example sizes` (varints at their longest,
//! bounded strings full, the configuration at the core's defaults):
//!
//! | message | postcard body | on the wire |
//! |---|---|---|
//! | `SetParams` (reference robot, 1 kHz supervisor) | 293 B | 304 B |
//! | reply `Params` (the same configuration) | 295 B | 306 B |
//! | `Telemetry` | 146 B | 157 B |
//! | `PathChunk`, 4 arcs ([`SEGMENTS_PER_CHUNK`]) | 93 B | 104 B |
//! | `PathChunk`, 1 arc | 30 B | 41 B |
//! | `PathBegin` | 30 B | 41 B |
//! | reply `Info` (every string full, the clock a fallback) | 113 B | 124 B |
//! | reply `PanicRecord` (every string full) | 128 B | 139 B |
//! | `Stats` | 61 B | 72 B |
//! | `TuneReport` (a result) | 105 B | 116 B |
//! | `Ping` / `Heartbeat` / reply `Ack` | 9 / 4 / 6 B | 20 / 15 / 17 B |
//!
//! The configuration's longest possible encoding (every varint at its longest) is 311 B,
//! so `SetParams` never exceeds 315 B of body and reply `Params` 317 B: [`MAX_BODY_LEN`]
//! leaves room for three more bytes, and a test derived from the schema fails
//! before a configuration that could not be sent is released.
//!
//! # Using it
//!
//! Encoding writes one whole frame into a caller's buffer ([`encode`], [`encode_to_vec`]);
//! decoding takes bytes in any chunks ([`Decoder::feed`], or [`Decoder::push`] one byte at
//! a time from an interrupt) and yields each frame's [`Outcome`].
//!
//! ```
//! use link::{encode, Decoder, Downlink, Received, Reply, Request, Uplink, MAX_FRAME_LEN};
//!
//! // Host: ask.
//! let mut wire = [0u8; MAX_FRAME_LEN];
//! let len = encode(&Downlink { seq: 7, request: Request::Ping { nonce: 99 } }, &mut wire)?;
//!
//! // Robot: decode and answer.
//! let mut robot_rx = Decoder::new();
//! let mut answer = [0u8; MAX_FRAME_LEN];
//! let mut answer_len = 0;
//! for outcome in robot_rx.feed::<Downlink>(&wire[..len]) {
//!     if let Ok(Received::Message(Downlink { seq, request: Request::Ping { nonce } })) = outcome {
//!         let reply = Uplink::Reply { seq, result: Ok(Reply::Pong { nonce }) };
//!         answer_len = encode(&reply, &mut answer)?;
//!     }
//! }
//!
//! // Host: read the reply.
//! let mut host_rx = Decoder::new();
//! let got: Vec<_> = host_rx.feed::<Uplink>(&answer[..answer_len]).collect();
//! assert_eq!(got, [Ok(Received::Message(Uplink::Reply { seq: 7, result: Ok(Reply::Pong { nonce: 99 }) }))]);
//! # Ok::<(), link::EncodeError>(())
//! ```
//!
//! **The robot service** (inside the firmware's application logic, and the virtual robot)
//! keeps a [`Decoder`], a frame buffer of [`MAX_FRAME_LEN`] bytes and a
//! [`PathAssembler`], and for each [`Outcome`]:
//!
//! - `Ok(Received::Message(Downlink { seq, request }))`: act, then send
//!   `Uplink::Reply { seq, result }`. Refuse with [`Refusal::Armed`] what may not happen
//!   while armed (`SetParams`, `PersistParams`, `PathBegin`, `PathCommit`, `SetPose`); validate
//!   `SetParams` with the core's `Params::new` and `SupervisorConfig::validate`
//!   ([`FieldProblem::from_param_error`] needs no float formatting); hand path requests to
//!   the [`PathAssembler`] and install the path of a [`Commit::New`]; check rates with
//!   [`check_telemetry_rate`]; count heartbeats against its timeout in control steps.
//! - `Ok(Received::Mismatch(id))`: send `Uplink::VersionMismatch { received: id }`.
//! - `Err(_)`: nothing (already counted; report [`Decoder::counters`] in [`Stats`]).
//!
//! **The station** numbers its requests, matches replies by `seq`, re-sends on a timeout
//! (every request is safe to repeat: path chunks, begins and commits are idempotent, and
//! a repeated `PersistParams` is answered with the reply the robot kept; it is sent once
//! and awaited [`PERSIST_REPLY_TIMEOUT_MS`], as its erase stalls the robot),
//! prints a [`Mismatch`] with [`Mismatch::describe`], uploads a path with
//! [`upload::chunks`] and [`path_checksum`], and compares configurations by
//! [`params_hash`].
//!
//! # Path upload
//!
//! [`PathBegin`], then [`PathChunk`]s of up to [`SEGMENTS_PER_CHUNK`] segments in any
//! order, then [`PathCommit`] with the segment count and [`path_checksum`]. The robot's
//! [`PathAssembler`] (fixed capacity, 824 bytes) builds the path only at the commit, with
//! the core's `Path::from_segments`, so a half-sent path never becomes active; a lost
//! chunk is named in [`Refusal::UploadIncomplete`] and the upload stays open for it.
//! Details in [`upload`].
//!
//! # Bandwidth
//!
//! A UART with 8N1 framing carries `baud / 10` bytes per second. Keeping 30 %
//! ([`bandwidth::DEFAULT_RESERVED_PERCENT`]) free for replies, heartbeats and path chunks,
//! the largest telemetry frame (157 bytes on the wire) allows ([`max_telemetry_rate_hz`];
//! printed by `cargo run -p link --example sizes`; the unit tests of [`bandwidth`] check
//! the arithmetic):
//!
//! | baud | bytes/s | telemetry at most | rate accepted |
//! |---|---|---|---|
//! | 115 200 | 11 520 | 51 Hz | 51 Hz |
//! | 230 400 | 23 040 | 103 Hz | 100 Hz |
//! | 460 800 | 46 080 | 206 Hz | 100 Hz |
//! | 921 600 | 92 160 | 413 Hz | 100 Hz |
//!
//! Rates are capped at 100 Hz ([`TELEMETRY_RATE_HZ`]). A `SetParams` frame (243 bytes)
//! takes 21.1 ms at 115 200 baud.
//!
//! # Cost on the target
//!
//! Measured on the Cortex-M4F program `cortex-m4f/qemu-link` (built like the firmware:
//! `opt-level = "s"` for the program, fat LTO), whose `.text`/`.bss` `cargo xtask
//! link-qemu` prints:
//!
//! - **RAM:** [`Decoder`] 399 B of frame buffer plus its counters, a transmit buffer of
//!   [`MAX_FRAME_LEN`] = 400 B, [`PathAssembler`] 824 B (the new path is built at commit,
//!   about 0.9 KiB, and moved into the controller). A robot short of RAM keeps the
//!   upload's 768 B of segments ([`UploadSegments`]) where it has room and the rest of
//!   the assembler ([`UploadState`]) in 56 B (on a 64-bit host): robot-app assembles in
//!   its staging area.
//! - **Flash:** decoding every [`Downlink`] and encoding every [`Uplink`] took 11 812 B
//!   (11.5 KiB) of `.text` and 1 228 B of `.rodata` (mostly the 1 KiB CRC table): the
//!   difference between the program with its service replaced by a fixed reply hidden
//!   behind `black_box` (17 500 B of `.text`, 2 204 B of `.rodata`) and with the link
//!   removed altogether (5 688 B, 976 B). Most of the codec is serde's per-field code for
//!   the configuration types, in both directions. The whole test program, with its
//!   stand-in service (configuration checks, path assembly and geometry), has 29 604 B of
//!   `.text`.
//!
//! # Why not postcard-rpc
//!
//! postcard-rpc was considered and not used. Its UART server assumes embassy, while the
//! firmware is RTIC 2; its host client is built on tokio, while the station and the tests
//! are plain blocking programs; its COBS transport has no CRC, and a serial line corrupts
//! bytes; and its timeouts are wall-clock, while the robot counts its own (the heartbeat
//! timeout) in control steps. This crate keeps its good idea, keys derived from
//! postcard-schema descriptions of the message types (here one schema hash for the whole
//! protocol, in every frame's header), and adds the CRC, the fixed header and a decoder
//! that counts every drop, with no async runtime on either side.
#![no_std]
#![warn(missing_docs)]

pub mod bandwidth;
mod checksum;
pub mod decoder;
pub mod frame;
pub mod message;
pub mod protocol;
pub mod upload;

pub use crate::bandwidth::{
    check_telemetry_rate, max_telemetry_rate_hz, LINK_BAUD, TELEMETRY_RATE_HZ,
};
pub use crate::checksum::{crc32, params_hash, path_checksum};
pub use crate::decoder::{Decoder, Dropped, Outcome, Received, RxCounters};
pub use crate::frame::{
    encode, encode_body, encode_raw, encode_to_vec, max_wire_len, EncodeError, MAX_BODY_LEN,
    MAX_FRAME_LEN,
};
pub use crate::message::*;
pub use crate::protocol::{Mismatch, ProtocolId, PROTOCOL_VERSION, SCHEMA_HASH};
pub use crate::upload::{
    Commit, CommittedPath, PathAssembler, Progress, UploadSegments, UploadState,
};
