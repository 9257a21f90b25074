//! Encoding a message into a frame, and the frame's size limits.
//!
//! ```text
//! payload = header (5 bytes: version, schema hash LE) ++ postcard(message)
//! wire    = COBS(payload ++ CRC-32 LE(payload)) ++ 0x00
//! ```
//!
//! The encoder writes straight into the caller's buffer and reports, never panics, when
//! the buffer or the protocol's limit is too small: the payload goes in a few bytes from
//! the buffer's start (as many as COBS can add), the CRC after it, and COBS then runs in
//! place towards the start.
//!
//! Every value the link serializes — messages, a configuration for its hash or a
//! flash record, path segments for their checksum — goes through one postcard output,
//! [`encode_body`]'s, so a binary holds one encoder per type, not one per use.

use core::fmt;

use postcard::ser_flavors::Flavor;
use serde::Serialize;

use crate::checksum::CRC32;
use crate::message::Message;
use crate::protocol::{ProtocolId, HEADER_LEN};

/// Largest postcard body a frame may carry, bytes. The largest messages,
/// [`Request::SetParams`](crate::Request) and its twin [`Reply::Params`](crate::Reply),
/// take at most 382 and 384 bytes with *any* configuration (every varint at its longest,
/// every option present; a test derives these bounds from the message schema). 388
/// leaves room for one more `f32` field (4 bytes); each byte
/// here costs two of RAM on the robot (the receive and the transmit buffer).
pub const MAX_BODY_LEN: usize = 388;

/// Bytes of CRC after the payload.
pub const CRC_LEN: usize = 4;

/// Most bytes a frame with a `body_len`-byte body can take on the wire: header, body and
/// CRC after COBS (at most one extra byte per 254, plus one), and the 0x00 delimiter.
/// Exact when header + body + CRC < 254 bytes, as for every message but the
/// configuration.
pub const fn max_wire_len(body_len: usize) -> usize {
    let stuffed = HEADER_LEN + body_len + CRC_LEN;
    stuffed + stuffed / 254 + 1 + 1
}

/// Most bytes a frame takes on the wire (delimiter included): the size of a buffer that
/// holds any frame. The [`Decoder`](crate::Decoder) drops longer frames as overflows.
pub const MAX_FRAME_LEN: usize = max_wire_len(MAX_BODY_LEN);

/// Why a frame could not be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The frame does not fit the caller's buffer of `available` bytes. A buffer of
    /// [`MAX_FRAME_LEN`] bytes holds any frame within the protocol's limit (use one to
    /// tell this apart from [`EncodeError::TooLarge`]).
    BufferTooSmall {
        /// Bytes the buffer had.
        available: usize,
    },
    /// The frame would exceed [`MAX_FRAME_LEN`] (its body is over [`MAX_BODY_LEN`]): no
    /// peer could receive it.
    TooLarge,
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            EncodeError::BufferTooSmall { available } => write!(
                f,
                "the frame does not fit a buffer of {available} bytes ({MAX_FRAME_LEN} always \
                 suffice)"
            ),
            EncodeError::TooLarge => write!(
                f,
                "the message exceeds the link's limit of {MAX_BODY_LEN} bytes"
            ),
        }
    }
}

impl core::error::Error for EncodeError {}

/// Encodes `message` as one frame (delimiter included) at the start of `out`; returns
/// the frame's length. Sends with [`ProtocolId::OURS`] in the header. Never panics: a
/// buffer too small gives an error (and leaves `out` partly written).
pub fn encode<M: Message>(message: &M, out: &mut [u8]) -> Result<usize, EncodeError> {
    encode_with(ProtocolId::OURS, message, out)
}

/// [`encode`] into a `heapless::Vec` (cleared first; left empty on error).
pub fn encode_to_vec<M: Message, const N: usize>(
    message: &M,
    out: &mut heapless::Vec<u8, N>,
) -> Result<(), EncodeError> {
    out.clear();
    // Capacity N: filling with zeros cannot fail.
    let _ = out.resize_default(N);
    match encode(message, out) {
        Ok(len) => {
            out.truncate(len);
            Ok(())
        }
        Err(e) => {
            out.clear();
            Err(e)
        }
    }
}

/// Frames `body` (already-encoded postcard bytes, or anything else) under the header of
/// `id`: for tests and tools that need frames a normal sender would not make.
pub fn encode_raw(id: ProtocolId, body: &[u8], out: &mut [u8]) -> Result<usize, EncodeError> {
    encode_with(id, body, out)
}

/// Bytes COBS adds at most to the largest payload (one per 254, plus one): where the
/// payload is put before it is encoded in place.
const COBS_ROOM: usize = 1 + (HEADER_LEN + MAX_BODY_LEN + CRC_LEN) / 254;

/// The frame of `value` under the header of `id`. `value` is a message or a byte slice
/// (a `[u8]` goes in as it is).
fn encode_with<T: Encodable + ?Sized>(
    id: ProtocolId,
    value: &T,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let available = out.len();
    let limit = available.min(MAX_FRAME_LEN);
    // Telling the two errors apart by the buffer's size, rather than by measuring the
    // message, saves a second instance of every message's serializer (about 1.2 KiB of
    // flash on the target, measured).
    frame_into(id, value, out.get_mut(..limit).unwrap_or_default()).ok_or(
        if available >= MAX_FRAME_LEN {
            EncodeError::TooLarge
        } else {
            EncodeError::BufferTooSmall { available }
        },
    )
}

/// Header, body and CRC, then COBS in place and the delimiter, in `out`; the frame's
/// length, or `None` when `out` is too small.
fn frame_into<T: Encodable + ?Sized>(id: ProtocolId, value: &T, out: &mut [u8]) -> Option<usize> {
    // The raw payload and its CRC go after COBS_ROOM bytes, up to the end of `out`; COBS
    // adds at most COBS_ROOM bytes in front of them, so it never overtakes them, and
    // the delimiter, written last, may take the place of a raw byte already encoded.
    let header_end = COBS_ROOM + HEADER_LEN;
    out.get_mut(COBS_ROOM..header_end)?
        .copy_from_slice(&id.to_header());
    let body_room = out.get_mut(header_end..out.len().checked_sub(CRC_LEN)?)?;
    let body_len = value.write_body(body_room)?;
    let crc_at = header_end + body_len;
    let crc = CRC32.checksum(out.get(COBS_ROOM..crc_at)?);
    out.get_mut(crc_at..crc_at + CRC_LEN)?
        .copy_from_slice(&crc.to_le_bytes());
    let stuffed = cobs_in_place(out, COBS_ROOM, crc_at + CRC_LEN - COBS_ROOM)?;
    *out.get_mut(stuffed)? = 0;
    Some(stuffed + 1)
}

/// COBS-encodes the `len` bytes at `buf[start..]` into `buf[0..]`, in place; the encoded
/// length (no delimiter). For any non-empty input the result is byte for byte what the
/// `cobs` crate's encoder gives (empty input gives one empty block, `[1]`). `start` must be at least the overhead, 1 + `len` / 254, so that writing never
/// overtakes reading (checked: `None` otherwise).
pub(crate) fn cobs_in_place(buf: &mut [u8], start: usize, len: usize) -> Option<usize> {
    if start < 1 + len / 254 || start.checked_add(len)? > buf.len() {
        return None;
    }
    // The block's code byte goes at `code_at` once the block ends; data bytes at `out`.
    let mut code_at = 0;
    let mut out = 1;
    let mut code: u8 = 1;
    for i in start..start + len {
        let byte = *buf.get(i)?;
        if byte == 0 {
            *buf.get_mut(code_at)? = code;
            code_at = out;
            out += 1;
            code = 1;
            continue;
        }
        *buf.get_mut(out)? = byte;
        out += 1;
        code += 1;
        // A full block (254 data bytes) ends without a zero; a new one starts, unless
        // the data ends here.
        if code == 0xFF && i + 1 < start + len {
            *buf.get_mut(code_at)? = code;
            code_at = out;
            out += 1;
            code = 1;
        }
    }
    *buf.get_mut(code_at)? = code;
    Some(out)
}

/// The postcard encoding of `value` alone (no header, CRC or COBS) at the start of
/// `out`; its length. The link's one serializer output (module doc): use it for
/// anything else the link's types are encoded for (a record in flash, a hash), so that
/// the binary holds one encoder per type.
pub fn encode_body<T: Serialize + ?Sized>(value: &T, out: &mut [u8]) -> Result<usize, EncodeError> {
    let available = out.len();
    postcard::serialize_with_flavor(value, Body { out, len: 0 })
        .map_err(|_| EncodeError::BufferTooSmall { available })
}

/// postcard's output for everything the link encodes: bytes into a slice.
///
/// Pushing a byte is deliberately not inlined: postcard calls it from every field of
/// every message, and inlining it there multiplies the code (measured on
/// `cortex-m4f/qemu-link` at opt-level 3, an inlined CRC-and-COBS output took 49 024 B of
/// `.text`, an out-of-line one 39 328 B).
struct Body<'a> {
    out: &'a mut [u8],
    len: usize,
}

impl Flavor for Body<'_> {
    type Output = usize;

    #[inline(never)]
    fn try_push(&mut self, byte: u8) -> postcard::Result<()> {
        let slot = self
            .out
            .get_mut(self.len)
            .ok_or(postcard::Error::SerializeBufferFull)?;
        *slot = byte;
        self.len += 1;
        Ok(())
    }

    #[inline(never)]
    fn try_extend(&mut self, bytes: &[u8]) -> postcard::Result<()> {
        let end = self.len + bytes.len();
        self.out
            .get_mut(self.len..end)
            .ok_or(postcard::Error::SerializeBufferFull)?
            .copy_from_slice(bytes);
        self.len = end;
        Ok(())
    }

    fn finalize(self) -> postcard::Result<usize> {
        Ok(self.len)
    }
}

/// What can go into a frame's body: a message (postcard) or raw bytes (as they are).
trait Encodable {
    /// Writes the body at the start of `out`; its length, or `None` if it does not fit.
    fn write_body(&self, out: &mut [u8]) -> Option<usize>;
}

impl<M: Serialize> Encodable for M {
    fn write_body(&self, out: &mut [u8]) -> Option<usize> {
        encode_body(self, out).ok()
    }
}

impl Encodable for [u8] {
    fn write_body(&self, out: &mut [u8]) -> Option<usize> {
        out.get_mut(..self.len())?.copy_from_slice(self);
        Some(self.len())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use proptest::prelude::*;
    use std::string::ToString;
    use std::vec::Vec;

    use super::*;

    #[test]
    fn cobs_in_place_needs_its_overhead_in_front_and_the_data_inside() {
        // 10 bytes need 1 byte in front; 300 need 2.
        let mut buf = [7u8; 320];
        assert_eq!(cobs_in_place(&mut buf, 0, 10), None);
        assert_eq!(cobs_in_place(&mut buf, 1, 10), Some(11));
        assert_eq!(cobs_in_place(&mut buf, 1, 300), None);
        assert_eq!(cobs_in_place(&mut buf, 2, 300), Some(302));
        // Past the end of the buffer.
        assert_eq!(cobs_in_place(&mut buf, 20, 301), None);
    }

    #[test]
    fn encode_errors_say_what_to_do() {
        let small = EncodeError::BufferTooSmall { available: 12 }.to_string();
        assert!(small.contains("12 bytes") && small.contains(&MAX_FRAME_LEN.to_string()));
        let large = EncodeError::TooLarge.to_string();
        assert!(large.contains(&MAX_BODY_LEN.to_string()), "{large}");
    }

    /// `cobs_in_place` on `data`, placed at `start`.
    fn in_place(data: &[u8], start: usize) -> Option<Vec<u8>> {
        let mut buf = std::vec![0xAAu8; start + data.len()];
        buf[start..].copy_from_slice(data);
        let len = cobs_in_place(&mut buf, start, data.len())?;
        Some(buf[..len].to_vec())
    }

    /// The `cobs` crate's encoding of `data`.
    fn reference(data: &[u8]) -> Vec<u8> {
        let mut out = std::vec![0u8; cobs::max_encoding_length(data.len())];
        let len = cobs::encode(data, &mut out);
        out.truncate(len);
        out
    }

    #[test]
    fn the_block_boundaries_encode_like_the_cobs_crate() {
        for len in [1usize, 2, 253, 254, 255, 507, 508, 509, 600] {
            for fill in [0u8, 1, 0xFF] {
                let data = std::vec![fill; len];
                let start = 1 + len / 254;
                assert_eq!(
                    in_place(&data, start),
                    Some(reference(&data)),
                    "{len} × {fill:#x}"
                );
            }
        }
        // Too little room in front is refused, not overwritten.
        assert_eq!(in_place(&[1; 300], 1), None);
        // Nothing encodes as one empty block (the link's payloads are never empty: they
        // start with the header).
        assert_eq!(in_place(&[], 1), Some(std::vec![1]));
    }

    proptest! {
        #[test]
        fn any_payload_encodes_like_the_cobs_crate(
            data in proptest::collection::vec(prop_oneof![Just(0u8), any::<u8>()], 1..700),
            extra in 0usize..3,
        ) {
            let start = 1 + data.len() / 254 + extra;
            prop_assert_eq!(in_place(&data, start), Some(reference(&data)));
        }
    }

    #[test]
    fn a_body_that_does_not_fit_is_refused() {
        let mut small = [0u8; 3];
        assert_eq!(
            encode_body(&(u32::MAX, 2u32), &mut small),
            Err(EncodeError::BufferTooSmall { available: 3 })
        );
        let mut room = [0u8; 8];
        assert_eq!(encode_body(&(1u32, 300u32), &mut room), Ok(3));
        assert_eq!(&room[..3], &[1, 0xAC, 0x02]);
    }
}
