//! Encoding a message into a frame, and the frame's size limits.
//!
//! ```text
//! payload = header (5 bytes: version, schema hash LE) ++ postcard(message)
//! wire    = COBS(payload ++ CRC-32 LE(payload)) ++ 0x00
//! ```
//!
//! The encoder writes straight into the caller's buffer (postcard's COBS and CRC
//! flavors, no intermediate copy) and reports, never panics, when the buffer or the
//! protocol's limit is too small.

use core::fmt;

use crc::Digest;
use postcard::ser_flavors::{Cobs, Flavor, Slice};
use serde::Serialize;

use crate::checksum::CRC32;
use crate::message::Message;
use crate::protocol::{ProtocolId, HEADER_LEN};

/// Largest postcard body a frame may carry, bytes. The largest messages,
/// [`Request::SetParams`](crate::Request) and its twin [`Reply::Params`](crate::Reply),
/// measured 222 and 224 bytes with the core's default configuration (see the crate
/// doc); 384 leaves room for 40 more `f32` fields in the configuration.
pub const MAX_BODY_LEN: usize = 384;

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
    frame_into(id, value, out.get_mut(..limit).unwrap_or_default()).map_err(|()| {
        if available >= MAX_FRAME_LEN {
            EncodeError::TooLarge
        } else {
            EncodeError::BufferTooSmall { available }
        }
    })
}

/// Header, body and CRC through COBS into `out`; the frame's length, or `Err` when `out`
/// is full.
fn frame_into<T: Encodable + ?Sized>(
    id: ProtocolId,
    value: &T,
    out: &mut [u8],
) -> Result<usize, ()> {
    let mut framer = Framer {
        cobs: Cobs::try_new(Slice::new(out)).map_err(drop)?,
        crc: CRC32.digest(),
    };
    framer.try_extend(&id.to_header()).map_err(drop)?;
    value.write(framer)
}

/// postcard's output for a frame: every byte goes into the CRC and through COBS into the
/// caller's buffer; `finalize` appends the CRC and the delimiter.
///
/// Pushing a byte is deliberately not inlined: postcard calls it from every field of
/// every message, and inlining the CRC and COBS steps there multiplies the code. Measured
/// on `tests/qemu-link` at opt-level 3, the program's `.text` went from 49 024 B (with
/// postcard's inlined CRC and COBS flavors) to 39 328 B.
struct Framer<'a> {
    cobs: Cobs<Slice<'a>>,
    crc: Digest<'static, u32>,
}

impl<'a> Flavor for Framer<'a> {
    type Output = &'a mut [u8];

    #[inline(never)]
    fn try_push(&mut self, byte: u8) -> postcard::Result<()> {
        self.crc.update(&[byte]);
        self.cobs.try_push(byte)
    }

    #[inline(never)]
    fn try_extend(&mut self, bytes: &[u8]) -> postcard::Result<()> {
        bytes.iter().try_for_each(|&b| self.try_push(b))
    }

    fn finalize(mut self) -> postcard::Result<Self::Output> {
        let crc = self.crc.finalize();
        for byte in crc.to_le_bytes() {
            self.cobs.try_push(byte)?;
        }
        self.cobs.finalize()
    }
}

/// What can go into a frame's body: a message (postcard) or raw bytes (as they are).
trait Encodable {
    /// Writes the body through `flavor` and finalises the frame; its length.
    fn write<F>(&self, flavor: F) -> Result<usize, ()>
    where
        F: Flavor,
        F::Output: AsRef<[u8]>;
}

impl<M: Serialize> Encodable for M {
    fn write<F>(&self, flavor: F) -> Result<usize, ()>
    where
        F: Flavor,
        F::Output: AsRef<[u8]>,
    {
        postcard::serialize_with_flavor(self, flavor)
            .map(|frame| frame.as_ref().len())
            .map_err(drop)
    }
}

impl Encodable for [u8] {
    fn write<F>(&self, mut flavor: F) -> Result<usize, ()>
    where
        F: Flavor,
        F::Output: AsRef<[u8]>,
    {
        flavor.try_extend(self).map_err(drop)?;
        flavor
            .finalize()
            .map(|frame| frame.as_ref().len())
            .map_err(drop)
    }
}
