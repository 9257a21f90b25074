//! Bytes from a hostile or broken line: nothing panics, nothing corrupted is returned as
//! a message, every drop is counted under its reason, and a frame split anywhere
//! decodes.

mod support;

use link::{
    encode_raw, Decoder, Downlink, Dropped, ProtocolId, Received, Request, RxCounters, Uplink,
    MAX_BODY_LEN, MAX_FRAME_LEN,
};
use proptest::prelude::*;
use support::{decode_all, frame, random_value, Tape};

fn ping(seq: u16) -> Downlink {
    Downlink {
        seq,
        request: Request::Ping {
            nonce: 0xdead_beef ^ u32::from(seq),
        },
    }
}

/// Frames in `bytes`: runs of non-zero bytes ended by a 0x00.
fn delimited_frames(bytes: &[u8]) -> usize {
    bytes
        .split(|&b| b == 0)
        .rev()
        .skip(1) // the part after the last 0x00 is not ended yet
        .filter(|part| !part.is_empty())
        .count()
}

fn total(c: &RxCounters) -> u32 {
    c.frames_ok + c.dropped()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    /// Random bytes: one outcome per delimited frame, each counted once.
    #[test]
    fn random_bytes_never_panic_and_are_counted(bytes in prop::collection::vec(any::<u8>(), 0..3000)) {
        let mut decoder = Decoder::new();
        let out = decode_all::<Downlink>(&mut decoder, &bytes);
        prop_assert_eq!(out.len(), delimited_frames(&bytes));
        prop_assert_eq!(total(&decoder.counters()) as usize, out.len());
        let mut uplink = Decoder::new();
        prop_assert_eq!(decode_all::<Uplink>(&mut uplink, &bytes).len(), out.len());
    }

    /// Random bytes *with few zeros*: long frames, mostly overflows and CRC errors.
    #[test]
    fn random_long_frames_never_panic(bytes in prop::collection::vec(1u8..=255, 0..1500), cut in prop::collection::vec(0usize..1500, 0..4)) {
        let mut bytes = bytes;
        for c in cut {
            if let Some(b) = bytes.get_mut(c) {
                *b = 0;
            }
        }
        bytes.push(0);
        let mut decoder = Decoder::new();
        let out = decode_all::<Downlink>(&mut decoder, &bytes);
        prop_assert_eq!(out.len(), delimited_frames(&bytes));
        prop_assert!(out.iter().all(|o| !matches!(o, Ok(Received::Message(_)))));
    }

    /// One bit flipped anywhere in a valid frame: never a message. A flip that makes a
    /// 0x00 splits the frame in two; both halves are dropped.
    #[test]
    fn a_bit_flip_is_never_read_as_a_message(
        tape in prop::collection::vec(any::<u8>(), 0..400),
        position in any::<prop::sample::Index>(),
        bit in 0u8..8,
    ) {
        let (message, _) = random_value::<Downlink>(&mut Tape::new(&tape), None);
        let mut wire = frame(&message);
        let at = position.index(wire.len() - 1); // not the delimiter
        wire[at] ^= 1 << bit;
        let mut decoder = Decoder::new();
        let out = decode_all::<Downlink>(&mut decoder, &wire);
        prop_assert!(!out.is_empty());
        prop_assert!(out.iter().all(|o| o.is_err()), "{:?}", out);
        let c = decoder.counters();
        prop_assert_eq!(c.frames_ok, 0);
        prop_assert_eq!(c.crc_errors + c.format_errors + c.decode_errors, out.len() as u32);
        // The decoder is back in step: the next frame is read.
        let next = decode_all::<Downlink>(&mut decoder, &frame(&ping(9)));
        prop_assert_eq!(next, vec![Ok(Received::Message(ping(9)))]);
    }

    /// A valid frame cut short, then a delimiter: dropped as a format or CRC error.
    #[test]
    fn a_truncated_frame_is_dropped(tape in prop::collection::vec(any::<u8>(), 0..400), keep in any::<prop::sample::Index>()) {
        let (message, _) = random_value::<Uplink>(&mut Tape::new(&tape), None);
        let wire = frame(&message);
        let keep = 1 + keep.index(wire.len() - 2); // at least 1 byte, not the whole frame
        let mut cut = wire[..keep].to_vec();
        cut.push(0);
        let mut decoder = Decoder::new();
        let out = decode_all::<Uplink>(&mut decoder, &cut);
        prop_assert_eq!(out.len(), 1);
        prop_assert!(matches!(out[0], Err(Dropped::Cobs | Dropped::TooShort | Dropped::Crc)), "{:?}", out);
        prop_assert_eq!(decoder.counters().crc_errors + decoder.counters().format_errors, 1);
    }

    /// Messages separated by garbage and split at arbitrary points decode in order.
    #[test]
    fn frames_split_anywhere_decode(
        tapes in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..200), 1..6),
        garbage in prop::collection::vec(prop::collection::vec(1u8..=255, 0..20), 6),
        splits in prop::collection::vec(any::<prop::sample::Index>(), 0..12),
    ) {
        let mut stream = Vec::new();
        let mut sent = Vec::new();
        for (tape, junk) in tapes.iter().zip(&garbage) {
            // Garbage then its own delimiter: one dropped frame when non-empty.
            stream.extend_from_slice(junk);
            stream.push(0);
            let (message, _) = random_value::<Uplink>(&mut Tape::new(tape), None);
            stream.extend_from_slice(&frame(&message));
            sent.push(message);
        }
        let mut cuts: Vec<usize> = splits.iter().map(|s| s.index(stream.len() + 1)).collect();
        cuts.sort_unstable();
        let mut decoder = Decoder::new();
        let mut received = Vec::new();
        let mut from = 0;
        for to in cuts.into_iter().chain([stream.len()]) {
            for outcome in decoder.feed::<Uplink>(&stream[from..to]) {
                if let Ok(Received::Message(m)) = outcome {
                    received.push(postcard::to_allocvec(&m).unwrap());
                }
            }
            from = to;
        }
        let expected: Vec<_> = sent.iter().map(|m| postcard::to_allocvec(m).unwrap()).collect();
        prop_assert_eq!(received, expected);
        prop_assert_eq!(decoder.counters().frames_ok as usize, sent.len());
    }
}

#[test]
fn an_oversized_frame_is_one_overflow_and_the_next_frame_is_read() {
    for len in [MAX_FRAME_LEN, MAX_FRAME_LEN + 1, 3 * MAX_FRAME_LEN] {
        let mut bytes = vec![0x55u8; len];
        bytes.push(0);
        bytes.extend_from_slice(&frame(&ping(1)));
        let mut decoder = Decoder::new();
        let out = decode_all::<Downlink>(&mut decoder, &bytes);
        assert_eq!(
            out,
            vec![Err(Dropped::Overflow), Ok(Received::Message(ping(1)))]
        );
        let c = decoder.counters();
        assert_eq!((c.overflows, c.frames_ok, c.dropped()), (1, 1, 1));
    }
}

#[test]
fn the_largest_frame_fits() {
    // A body of MAX_BODY_LEN non-zero bytes: COBS at its worst. It fits the decoder (no
    // overflow) and is then refused as not a message.
    let body = vec![0xa5u8; MAX_BODY_LEN];
    let mut wire = vec![0u8; MAX_FRAME_LEN];
    let len = encode_raw(ProtocolId::OURS, &body, &mut wire).unwrap();
    assert!(len <= MAX_FRAME_LEN);
    let mut decoder = Decoder::new();
    let out = decode_all::<Downlink>(&mut decoder, &wire[..len]);
    assert_eq!(out, vec![Err(Dropped::Decode)]);
    assert_eq!(decoder.counters().decode_errors, 1);
}

#[test]
fn a_foreign_header_is_reported_not_decoded() {
    let body = postcard::to_allocvec(&ping(3)).unwrap();
    for other in [
        ProtocolId {
            version: ProtocolId::OURS.version + 1,
            ..ProtocolId::OURS
        },
        ProtocolId {
            schema_hash: ProtocolId::OURS.schema_hash ^ 1,
            ..ProtocolId::OURS
        },
    ] {
        let mut wire = [0u8; MAX_FRAME_LEN];
        let len = encode_raw(other, &body, &mut wire).unwrap();
        let mut decoder = Decoder::new();
        let out = decode_all::<Downlink>(&mut decoder, &wire[..len]);
        assert_eq!(out, vec![Ok(Received::Mismatch(other))]);
        let c = decoder.counters();
        assert_eq!((c.mismatches, c.frames_ok), (1, 0));
    }
}

#[test]
fn an_intact_frame_with_a_bad_body_is_a_decode_error() {
    let good = postcard::to_allocvec(&ping(4)).unwrap();
    let mut trailing = good.clone();
    trailing.push(7);
    let bad_variant = [0x04, 0x00, 0x7f]; // seq 4, Request variant 127
    let mut decoder = Decoder::new();
    for body in [
        &trailing[..],
        &good[..good.len() - 1],
        &good[..1],
        &bad_variant[..],
        &[][..],
    ] {
        let mut wire = [0u8; MAX_FRAME_LEN];
        let len = encode_raw(ProtocolId::OURS, body, &mut wire).unwrap();
        let out = decode_all::<Downlink>(&mut decoder, &wire[..len]);
        // An empty body is shorter than the minimum frame; one byte is a (bad) body.
        let expected = if body.is_empty() {
            Dropped::TooShort
        } else {
            Dropped::Decode
        };
        assert_eq!(out, vec![Err(expected)], "body {body:02x?}");
    }
    let c = decoder.counters();
    assert_eq!((c.decode_errors, c.format_errors, c.frames_ok), (4, 1, 0));
}

#[test]
fn each_drop_says_why() {
    let all = [
        (Dropped::Cobs, "COBS"),
        (Dropped::TooShort, "too short"),
        (Dropped::Crc, "CRC"),
        (Dropped::Overflow, "longer than the link's maximum"),
        (Dropped::Decode, "not a valid message"),
    ];
    for (dropped, why) in all {
        let text = dropped.to_string();
        assert!(
            text.starts_with("frame dropped: ") && text.contains(why),
            "{text}"
        );
    }
}

#[test]
fn empty_frames_and_leading_noise_are_ignored_silently() {
    let mut bytes = vec![0, 0, 0];
    bytes.extend_from_slice(&frame(&ping(5)));
    bytes.extend_from_slice(&[0, 0]);
    let mut decoder = Decoder::new();
    let out = decode_all::<Downlink>(&mut decoder, &bytes);
    assert_eq!(out, vec![Ok(Received::Message(ping(5)))]);
    assert_eq!(decoder.counters().dropped(), 0);
}

#[test]
fn reset_forgets_a_partial_frame() {
    let wire = frame(&ping(6));
    let mut decoder = Decoder::new();
    assert!(decode_all::<Downlink>(&mut decoder, &wire[..4]).is_empty());
    decoder.reset();
    let out = decode_all::<Downlink>(&mut decoder, &wire);
    assert_eq!(out, vec![Ok(Received::Message(ping(6)))]);
}

#[test]
fn crc_errors_are_counted_as_such() {
    // Flip a bit of the CRC's last byte (COBS keeps data bytes in place except for the
    // code bytes; the byte before the delimiter is data here).
    let mut wire = frame(&ping(7));
    let last = wire.len() - 2;
    wire[last] ^= if wire[last] == 0x01 { 0x02 } else { 0x01 };
    let mut decoder = Decoder::new();
    let out = decode_all::<Downlink>(&mut decoder, &wire);
    assert_eq!(out, vec![Err(Dropped::Crc)]);
    assert_eq!(decoder.counters().crc_errors, 1);
}
