//! The link's streaming decoder on bytes off the line ([`check`]).
//!
//! The expectation for each frame comes from a plain reading of the wire format
//! (`link`'s crate doc), written here with a `Vec` and no streaming:
//!
//! ```text
//! frame   = the non-zero bytes before a 0x00 (empty frames are skipped)
//! payload = COBS⁻¹(frame) = header (5) ++ body ++ CRC-32 LE (4)
//! ```
//!
//! A frame longer than the decoder's buffer is an overflow; then, in order, invalid
//! COBS, a payload too short for a header, a CRC and one body byte, a CRC that does not
//! match, a header of another protocol (a mismatch, not a drop), and a body that is not
//! exactly one message.

use std::fmt::Debug;

use link::frame::CRC_LEN;
use link::protocol::HEADER_LEN;
use link::{
    crc32, encode, Decoder, Downlink, Dropped, Message, Outcome, ProtocolId, Received, RxCounters,
    Uplink, MAX_FRAME_LEN,
};

use crate::messages::assert_canonical;

/// Feeds `input` to a host's and a robot's decoder ([`Uplink`] and [`Downlink`]) and
/// checks every outcome against the wire format; panics naming the broken property.
pub fn check(input: &[u8]) {
    check_as::<Downlink>(input);
    check_as::<Uplink>(input);
}

/// What a frame should come out as, by the wire format.
#[derive(Debug, PartialEq)]
enum Expected {
    Dropped(Dropped),
    Mismatch(ProtocolId),
    /// A message whose postcard body is this.
    Message(Vec<u8>),
}

fn check_as<M: Message + Debug>(input: &[u8]) {
    let frames: Vec<&[u8]> = delimited_frames(input);

    let mut at_once = Decoder::new();
    let outcomes: Vec<Outcome<M>> = at_once.feed::<M>(input).collect();
    let mut byte_by_byte = Decoder::new();
    let pushed: Vec<Outcome<M>> = input
        .iter()
        .filter_map(|&byte| byte_by_byte.push::<M>(byte))
        .collect();

    assert_eq!(
        outcomes.len(),
        frames.len(),
        "one outcome per delimited frame: {outcomes:?}"
    );
    assert_eq!(
        outcomes.iter().map(as_expected).collect::<Vec<_>>(),
        pushed.iter().map(as_expected).collect::<Vec<_>>(),
        "fed at once and byte by byte, the same outcomes"
    );
    assert_eq!(at_once.counters(), byte_by_byte.counters());
    assert_eq!(
        at_once.counters(),
        counted(&outcomes),
        "each outcome counted once, under its reason"
    );
    for (frame, outcome) in frames.iter().zip(&outcomes) {
        let expected = expected::<M>(frame);
        assert_eq!(
            as_expected(outcome),
            expected,
            "frame {frame:02x?} came out as {outcome:?}"
        );
        if let Ok(Received::Message(message)) = outcome {
            assert_reframes(frame, message);
        }
    }
}

/// The frames of `input`: the non-empty runs of non-zero bytes that a 0x00 ends (what
/// follows the last 0x00 is not a frame yet).
fn delimited_frames(input: &[u8]) -> Vec<&[u8]> {
    let mut frames: Vec<&[u8]> = input.split(|&b| b == 0).collect();
    frames.pop();
    frames.retain(|frame| !frame.is_empty());
    frames
}

/// What `frame` (its COBS bytes, no delimiter) is by the wire format.
fn expected<M: Message>(frame: &[u8]) -> Expected {
    if frame.len() > MAX_FRAME_LEN - 1 {
        return Expected::Dropped(Dropped::Overflow);
    }
    let Some(payload) = cobs_decode(frame) else {
        return Expected::Dropped(Dropped::Cobs);
    };
    if payload.len() < HEADER_LEN + CRC_LEN + 1 {
        return Expected::Dropped(Dropped::TooShort);
    }
    let (covered, crc) = payload.split_at(payload.len() - CRC_LEN);
    if crc32(covered).to_le_bytes() != crc {
        return Expected::Dropped(Dropped::Crc);
    }
    let (header, body) = covered.split_at(HEADER_LEN);
    let id = ProtocolId {
        version: header[0],
        schema_hash: u32::from_le_bytes([header[1], header[2], header[3], header[4]]),
    };
    if id != ProtocolId::OURS {
        return Expected::Mismatch(id);
    }
    match postcard::take_from_bytes::<M>(body) {
        Ok((message, [])) => Expected::Message(body_of(&message)),
        _ => Expected::Dropped(Dropped::Decode),
    }
}

/// COBS decoding as its definition states it: blocks of a code byte `n` (1…255) and
/// `n − 1` data bytes, each block's data followed by a zero unless its code is 0xFF or
/// it is the last block. `None` when a block runs past the end.
fn cobs_decode(frame: &[u8]) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(frame.len());
    let mut rest = frame;
    while let Some((&code, after_code)) = rest.split_first() {
        let data = after_code.get(..usize::from(code).checked_sub(1)?)?;
        out.extend_from_slice(data);
        rest = &after_code[data.len()..];
        if code != 0xFF && !rest.is_empty() {
            out.push(0);
        }
    }
    Some(out)
}

/// An outcome as comparable data: a message by its postcard bytes, so that two messages
/// holding a NaN compare equal when their bits are.
fn as_expected<M: Message>(outcome: &Outcome<M>) -> Expected {
    match outcome {
        Ok(Received::Message(message)) => Expected::Message(body_of(message)),
        Ok(Received::Mismatch(id)) => Expected::Mismatch(*id),
        Err(dropped) => Expected::Dropped(*dropped),
    }
}

/// The counters `outcomes` should have left.
fn counted<M>(outcomes: &[Outcome<M>]) -> RxCounters {
    let mut c = RxCounters::default();
    for outcome in outcomes {
        let counter = match outcome {
            Ok(Received::Message(_)) => &mut c.frames_ok,
            Ok(Received::Mismatch(_)) => &mut c.mismatches,
            Err(Dropped::Cobs | Dropped::TooShort) => &mut c.format_errors,
            Err(Dropped::Crc) => &mut c.crc_errors,
            Err(Dropped::Overflow) => &mut c.overflows,
            Err(Dropped::Decode) => &mut c.decode_errors,
        };
        *counter += 1;
    }
    c
}

/// `message`'s postcard body.
pub(crate) fn body_of<M: Message>(message: &M) -> Vec<u8> {
    postcard::to_allocvec(message).unwrap_or_else(|e| panic!("a decoded message re-encodes: {e}"))
}

/// The frame `message` came in, `received` (COBS bytes), against the frame the link
/// makes of it: that one decodes to the same message, is no longer, and is the same
/// payload when the received body was as short as the canonical one.
fn assert_reframes<M: Message + Debug>(received: &[u8], message: &M) {
    let mut wire = [0u8; MAX_FRAME_LEN];
    let len = encode(message, &mut wire)
        .unwrap_or_else(|e| panic!("a decoded message fits a frame again ({e}): {message:?}"));
    let ours = &wire[..len];
    assert!(
        ours.len() <= received.len() + 1,
        "the canonical frame ({} bytes) is longer than the one received ({} bytes)",
        ours.len(),
        received.len() + 1
    );
    let mut decoder = Decoder::new();
    let again: Vec<Outcome<M>> = decoder.feed::<M>(ours).collect();
    assert_eq!(
        again.iter().map(as_expected).collect::<Vec<_>>(),
        [Expected::Message(body_of(message))],
        "the frame of a decoded message decodes to it"
    );
    let payload = |frame: &[u8]| cobs_decode(frame).unwrap_or_default();
    let (body_in, body_ours) = (payload(received), payload(&ours[..len - 1]));
    assert_canonical(strip(&body_in), strip(&body_ours));
}

/// The body of a payload (header and CRC cut off).
fn strip(payload: &[u8]) -> &[u8] {
    payload
        .get(HEADER_LEN..payload.len().saturating_sub(CRC_LEN))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use link::Request;

    #[test]
    fn the_reference_cobs_decoder_inverts_the_links_encoder() {
        let ping = Downlink {
            seq: 0x0100,
            request: Request::Ping { nonce: 0 },
        };
        let mut wire = [0u8; MAX_FRAME_LEN];
        let len = encode(&ping, &mut wire).expect("a ping fits");
        let payload = cobs_decode(&wire[..len - 1]).expect("valid COBS");
        assert_eq!(strip(&payload), &body_of(&ping)[..]);
        assert_eq!(&payload[..HEADER_LEN], &ProtocolId::OURS.to_header());
    }

    #[test]
    fn a_block_past_the_end_is_invalid_cobs() {
        assert_eq!(cobs_decode(&[3, 1]), None);
        assert_eq!(cobs_decode(&[2, 7, 1]), Some(vec![7, 0]));
        let full: Vec<u8> = std::iter::once(0xFF).chain([9; 254]).collect();
        assert_eq!(cobs_decode(&full), Some(vec![9; 254]));
    }

    #[test]
    fn frames_are_the_runs_a_delimiter_ends() {
        assert_eq!(
            delimited_frames(&[1, 2, 0, 0, 3, 0, 4]),
            [&[1, 2][..], &[3][..]]
        );
        assert!(delimited_frames(&[5, 6]).is_empty());
    }
}
