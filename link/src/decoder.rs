//! The streaming decoder: feed it bytes as they come (any chunking), get whole messages
//! out. Anything that is not a whole, intact frame of our protocol is dropped and
//! counted, never returned, never a panic.

use core::fmt;

use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

use crate::checksum::CRC32;
use crate::frame::{CRC_LEN, MAX_FRAME_LEN};
use crate::message::Message;
use crate::protocol::{ProtocolId, HEADER_LEN};

/// COBS bytes a frame may have before its delimiter.
const STUFFED_CAP: usize = MAX_FRAME_LEN - 1;

/// What the decoder counted since it was made. Counters wrap at 2³².
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, Schema)]
pub struct RxCounters {
    /// Frames decoded into a message.
    pub frames_ok: u32,
    /// Frames whose CRC did not match: corrupted on the way.
    pub crc_errors: u32,
    /// Frames that were not valid COBS or too short to hold a header and a CRC.
    pub format_errors: u32,
    /// Frames longer than [`MAX_FRAME_LEN`], dropped whole.
    pub overflows: u32,
    /// Intact frames from a peer speaking another protocol (see
    /// [`Mismatch`](crate::Mismatch)).
    pub mismatches: u32,
    /// Intact frames of our protocol whose body is not a valid message (or has bytes
    /// left over after it).
    pub decode_errors: u32,
}

impl RxCounters {
    /// Frames dropped for any reason (mismatches included).
    pub const fn dropped(&self) -> u32 {
        self.crc_errors
            .wrapping_add(self.format_errors)
            .wrapping_add(self.overflows)
            .wrapping_add(self.mismatches)
            .wrapping_add(self.decode_errors)
    }
}

/// A frame that came through whole.
#[derive(Clone, Debug, PartialEq)]
pub enum Received<M> {
    /// A message of our protocol.
    Message(M),
    /// An intact frame whose header names another protocol; its body was not decoded.
    /// Tell the user ([`Mismatch::with`](crate::Mismatch::with)); a robot answers with
    /// [`Uplink::VersionMismatch`](crate::Uplink).
    Mismatch(ProtocolId),
}

/// Why a frame was dropped (each is also counted in [`RxCounters`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dropped {
    /// Not valid COBS.
    Cobs,
    /// Shorter than a header and a CRC.
    TooShort,
    /// The CRC does not match.
    Crc,
    /// Longer than [`MAX_FRAME_LEN`].
    Overflow,
    /// The body is not a message of the expected type.
    Decode,
}

impl fmt::Display for Dropped {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Dropped::Cobs => "frame dropped: not valid COBS",
            Dropped::TooShort => "frame dropped: too short for a header and a CRC",
            Dropped::Crc => "frame dropped: CRC mismatch",
            Dropped::Overflow => "frame dropped: longer than the link's maximum",
            Dropped::Decode => "frame dropped: the body is not a valid message",
        })
    }
}

/// The outcome of a delimiter: a frame that came through, or why it did not.
pub type Outcome<M> = Result<Received<M>, Dropped>;

/// A streaming frame decoder with a fixed buffer of [`MAX_FRAME_LEN`] − 1 bytes (no heap).
///
/// Frames end at a 0x00 byte. Empty frames (two delimiters in a row) are ignored without
/// counting, so a sender may start with a 0x00 to flush whatever a receiver had
/// half-read: those bytes end there as one frame, dropped and counted like any other
/// (a receiver that starts mid-frame drops its first frame the same way).
///
/// ```
/// use link::{encode, Decoder, Downlink, Received, Request, MAX_FRAME_LEN};
///
/// let mut wire = [0u8; MAX_FRAME_LEN];
/// let ping = Downlink { seq: 1, request: Request::Ping { nonce: 42 } };
/// let len = encode(&ping, &mut wire).unwrap();
///
/// let mut decoder = Decoder::new();
/// let (first, rest) = wire[..len].split_at(3);
/// assert_eq!(decoder.feed::<Downlink>(first).count(), 0); // half a frame: nothing yet
/// let out: Vec<_> = decoder.feed::<Downlink>(rest).collect();
/// assert_eq!(out, [Ok(Received::Message(ping))]);
/// assert_eq!(decoder.counters().frames_ok, 1);
/// ```
#[derive(Clone, Debug)]
pub struct Decoder {
    /// COBS bytes of the frame so far (delimiter excluded).
    buf: [u8; STUFFED_CAP],
    /// Bytes used in `buf`.
    len: usize,
    /// The frame outgrew `buf`: drop bytes until the next delimiter.
    overflowed: bool,
    counters: RxCounters,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// An empty decoder with zeroed counters.
    pub const fn new() -> Self {
        Self {
            buf: [0; STUFFED_CAP],
            len: 0,
            overflowed: false,
            counters: RxCounters {
                frames_ok: 0,
                crc_errors: 0,
                format_errors: 0,
                overflows: 0,
                mismatches: 0,
                decode_errors: 0,
            },
        }
    }

    /// What was counted so far.
    pub const fn counters(&self) -> RxCounters {
        self.counters
    }

    /// Forgets a partly received frame (counters are kept), e.g. after the serial line
    /// was reopened.
    pub fn reset(&mut self) {
        self.len = 0;
        self.overflowed = false;
    }

    /// Takes one byte; at a delimiter that ends a non-empty frame, returns what the frame
    /// was.
    pub fn push<M: Message>(&mut self, byte: u8) -> Option<Outcome<M>> {
        if byte != 0 {
            // Once the buffer is full every further byte finds no slot: the frame stays
            // overflowed until its delimiter.
            match self.buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                }
                None => self.overflowed = true,
            }
            return None;
        }
        if self.len == 0 && !self.overflowed {
            return None;
        }
        Some(self.end_frame())
    }

    /// Takes a chunk of bytes; iterates over the frames it completes. Bytes are consumed
    /// as the iterator advances: drain it (or the rest of the chunk is not read).
    pub fn feed<'a, M: Message>(&'a mut self, bytes: &'a [u8]) -> Feed<'a, M> {
        Feed {
            decoder: self,
            bytes: bytes.iter(),
            _message: core::marker::PhantomData,
        }
    }

    fn count<M>(&mut self, outcome: &Outcome<M>) {
        let c = &mut self.counters;
        let counter = match outcome {
            Ok(Received::Message(_)) => &mut c.frames_ok,
            Ok(Received::Mismatch(_)) => &mut c.mismatches,
            Err(Dropped::Cobs | Dropped::TooShort) => &mut c.format_errors,
            Err(Dropped::Crc) => &mut c.crc_errors,
            Err(Dropped::Overflow) => &mut c.overflows,
            Err(Dropped::Decode) => &mut c.decode_errors,
        };
        *counter = counter.wrapping_add(1);
    }

    /// What the frame that a delimiter just ended was; counts it and starts the next.
    ///
    /// Not inlined: the deserializer's temporaries are several copies of the message,
    /// and on a small stack they should not share a frame with what the caller does
    /// with the message.
    #[inline(never)]
    fn end_frame<M: Message>(&mut self) -> Outcome<M> {
        let outcome = if self.overflowed {
            Err(Dropped::Overflow)
        } else {
            self.decode_frame()
        };
        self.reset();
        self.count(&outcome);
        outcome
    }

    /// Un-stuffs, checks and decodes the frame in `buf[..len]`.
    fn decode_frame<M: Message>(&mut self) -> Outcome<M> {
        let stuffed = self.buf.get_mut(..self.len).ok_or(Dropped::Overflow)?;
        let len = cobs::decode_in_place(stuffed).map_err(|_| Dropped::Cobs)?;
        let frame = stuffed.get(..len).ok_or(Dropped::Cobs)?;
        if frame.len() < HEADER_LEN + CRC_LEN + 1 {
            return Err(Dropped::TooShort);
        }
        let (payload, crc) = frame.split_at(frame.len() - CRC_LEN);
        let crc = match *crc {
            [a, b, c, d] => u32::from_le_bytes([a, b, c, d]),
            _ => return Err(Dropped::TooShort),
        };
        if CRC32.checksum(payload) != crc {
            return Err(Dropped::Crc);
        }
        let (header, body) = payload.split_at(HEADER_LEN);
        let id = ProtocolId::from_header(header).ok_or(Dropped::TooShort)?;
        if id != ProtocolId::OURS {
            return Ok(Received::Mismatch(id));
        }
        match postcard::take_from_bytes::<M>(body) {
            Ok((message, [])) => Ok(Received::Message(message)),
            _ => Err(Dropped::Decode),
        }
    }
}

/// The frames completed by a chunk of bytes ([`Decoder::feed`]).
pub struct Feed<'a, M> {
    decoder: &'a mut Decoder,
    bytes: core::slice::Iter<'a, u8>,
    _message: core::marker::PhantomData<M>,
}

impl<M: Message> Iterator for Feed<'_, M> {
    type Item = Outcome<M>;

    fn next(&mut self) -> Option<Self::Item> {
        for &byte in self.bytes.by_ref() {
            if let Some(outcome) = self.decoder.push(byte) {
                return Some(outcome);
            }
        }
        None
    }
}
