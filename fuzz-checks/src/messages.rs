//! The link's message decoding on any body ([`check`]): the input is a postcard body,
//! which the check frames intact (our header, a correct CRC) so that every input reaches
//! the message decoder through the real streaming decoder.

use std::fmt::Debug;

use link::{
    encode_raw, Decoder, Downlink, Dropped, EncodeError, Message, Outcome, ProtocolId, Received,
    Uplink, MAX_BODY_LEN, MAX_FRAME_LEN,
};

use crate::frames::body_of;

/// Frames `body` intact and decodes it as a [`Downlink`] and as an [`Uplink`]; panics
/// naming the broken property.
pub fn check(body: &[u8]) {
    check_as::<Downlink>(body);
    check_as::<Uplink>(body);
}

fn check_as<M: Message + Debug>(body: &[u8]) {
    let mut wire = [0u8; MAX_FRAME_LEN];
    let len = match encode_raw(ProtocolId::OURS, body, &mut wire) {
        Ok(len) => len,
        Err(EncodeError::TooLarge) => {
            assert!(
                body.len() > MAX_BODY_LEN,
                "a body of {} bytes (≤ {MAX_BODY_LEN}) was refused as too large",
                body.len()
            );
            return;
        }
        Err(e) => panic!("a buffer of MAX_FRAME_LEN bytes holds any frame, yet: {e}"),
    };
    let mut decoder = Decoder::new();
    let outcomes: Vec<Outcome<M>> = decoder.feed::<M>(&wire[..len]).collect();
    let [outcome] = &outcomes[..] else {
        panic!("one frame, one outcome: {outcomes:?}");
    };
    match (outcome, postcard::take_from_bytes::<M>(body)) {
        (Ok(Received::Message(message)), Ok((read, []))) => {
            assert_eq!(
                body_of(message),
                body_of(&read),
                "the decoder's message is postcard's"
            );
            assert_round_trip(body, message);
        }
        // No message is empty: the decoder refuses an empty body before reading it.
        (Err(Dropped::TooShort), Err(_)) if body.is_empty() => {}
        (Err(Dropped::Decode), Err(_)) => {}
        (Err(Dropped::Decode), Ok((_, rest))) if !rest.is_empty() => {}
        (outcome, read) => panic!(
            "the decoder gave {outcome:?} where postcard reads {:?}",
            read.map(|(message, rest)| (message, rest.len()))
        ),
    }
}

/// A decoded `message` re-encodes to a body that decodes to the same message (a fixed
/// point), and that is canonical against the `received` one ([`assert_canonical`]).
fn assert_round_trip<M: Message + Debug>(received: &[u8], message: &M) {
    let ours = body_of(message);
    match postcard::from_bytes::<M>(&ours) {
        Ok(again) => assert_eq!(
            body_of(&again),
            ours,
            "re-encoding a decoded message is stable"
        ),
        Err(e) => panic!("a re-encoded message does not decode ({e}): {message:?}"),
    }
    assert_canonical(received, &ours);
}

/// The canonical encoding `ours` of a message decoded from `received` is never longer,
/// and the same bytes when it is as long: postcard accepts over-long varints (more bytes
/// for the same value) but no other second spelling of a value.
pub(crate) fn assert_canonical(received: &[u8], ours: &[u8]) {
    assert!(
        ours.len() <= received.len(),
        "the canonical body ({} bytes) is longer than the one received ({} bytes)",
        ours.len(),
        received.len()
    );
    if ours.len() == received.len() {
        assert_eq!(
            ours, received,
            "a body of the canonical length is the canonical body"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use link::Request;

    #[test]
    fn an_over_long_varint_decodes_and_re_encodes_shorter() {
        let ping = Downlink {
            seq: 3,
            request: Request::Ping { nonce: 5 },
        };
        let canonical = body_of(&ping);
        assert_eq!(canonical, [3, 1, 5]);
        // The sequence number 3 in two bytes.
        let over_long = [0x83, 0x00, 1, 5];
        check(&over_long);
        let (read, _) = postcard::take_from_bytes::<Downlink>(&over_long).unwrap();
        assert_eq!(read, ping);
    }

    #[test]
    #[should_panic(expected = "a body of the canonical length is the canonical body")]
    fn a_second_spelling_of_the_same_length_is_caught() {
        assert_canonical(&[1, 2, 3], &[1, 2, 4]);
    }
}
