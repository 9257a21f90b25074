//! Every message survives encode → frame → decode bit for bit, for every variant, with
//! values generated from the messages' own schemas.

mod support;

use link::{Decoder, Downlink, Message, Received, Uplink};
use proptest::prelude::*;
use support::{frame, random_value, variant_count, Tape};

/// Encodes a random `M` whose top-level variant is `variant`, decodes its frame, and
/// checks the decoded message re-encodes to the same bytes (bitwise, NaNs included).
fn round_trip<M: Message + core::fmt::Debug>(tape: &[u8], variant: usize) {
    let (message, bytes) = random_value::<M>(&mut Tape::new(tape), Some(variant));
    assert_eq!(
        postcard::to_allocvec(&message).unwrap(),
        bytes,
        "postcard re-encodes the generated value differently"
    );
    let wire = frame(&message);
    assert_eq!(wire.last(), Some(&0), "a frame ends with its delimiter");
    assert!(
        !wire[..wire.len() - 1].contains(&0),
        "COBS leaves no 0x00 inside"
    );
    let mut decoder = Decoder::new();
    let out: Vec<_> = decoder.feed::<M>(&wire).collect();
    match out.as_slice() {
        [Ok(Received::Message(decoded))] => {
            assert_eq!(
                postcard::to_allocvec(decoded).unwrap(),
                bytes,
                "{message:?}"
            );
        }
        other => panic!("{message:?} came back as {other:?}"),
    }
    assert_eq!(decoder.counters().frames_ok, 1);
    assert_eq!(decoder.counters().dropped(), 0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn every_downlink_round_trips(variant in 0..64usize, tape in prop::collection::vec(any::<u8>(), 0..600)) {
        round_trip::<Downlink>(&tape, variant);
    }

    #[test]
    fn every_uplink_round_trips(variant in 0..64usize, tape in prop::collection::vec(any::<u8>(), 0..600)) {
        round_trip::<Uplink>(&tape, variant);
    }
}

/// Every variant, explicitly, with tapes of all zeros, all ones and a counting pattern:
/// proptest's sampling could in principle miss one.
#[test]
fn each_variant_round_trips() {
    let tapes: [Vec<u8>; 3] = [
        vec![0; 600],
        vec![0xff; 600],
        (0..600).map(|i| i as u8).collect(),
    ];
    assert!(
        variant_count::<Downlink>() >= 15,
        "Request has at least 15 variants"
    );
    assert!(
        variant_count::<Uplink>() >= 6,
        "Uplink has at least 6 variants"
    );
    for tape in &tapes {
        for variant in 0..variant_count::<Downlink>() {
            round_trip::<Downlink>(tape, variant);
        }
        for variant in 0..variant_count::<Uplink>() {
            round_trip::<Uplink>(tape, variant);
        }
    }
}

/// The latched faults cross as named booleans: one byte each, in field order (the
/// controller's `encoder_jump` and `non_finite` first), so the bit set is not on the wire.
#[test]
fn faults_cross_as_named_booleans_in_field_order() {
    use controller_core::supervisor::{Fault, Faults};
    let none = postcard::to_allocvec(&Faults::NONE).unwrap_or_default();
    assert_eq!(none, [0u8; Fault::ALL.len()]);
    for (i, fault) in Fault::ALL.iter().enumerate() {
        let one = Faults::NONE.with(*fault);
        let bytes = postcard::to_allocvec(&one).unwrap_or_default();
        let mut expected = [0u8; Fault::ALL.len()];
        expected[i] = 1;
        assert_eq!(bytes, expected, "{fault:?}");
        assert_eq!(postcard::from_bytes::<Faults>(&bytes).ok(), Some(one));
    }
}
