//! The encoder: exact sizes, and errors (never panics) when a frame does not fit.

mod support;

use controller_core::kinematics::{Pose, WheelSpeeds};
use controller_core::params::RobotConfig;
use controller_core::supervisor::SupervisorConfig;
use link::bandwidth::largest_telemetry;
use link::{
    encode, encode_raw, encode_to_vec, max_wire_len, Downlink, EncodeError, ParamSet, ProtocolId,
    Reply, Request, Uplink, MAX_BODY_LEN, MAX_FRAME_LEN,
};
use postcard_schema::Schema;
use proptest::prelude::*;
use support::{random_value, Tape};

fn set_params() -> Downlink {
    Downlink {
        seq: u16::MAX,
        request: Request::SetParams(ParamSet {
            robot: RobotConfig::REFERENCE_ROBOT,
            supervisor: SupervisorConfig::at_rate(
                1000,
                Pose::new(-1.0, -1.2, 2.0),
                WheelSpeeds::new(5.0, 5.0),
            ),
        }),
    }
}

proptest! {
    /// The frame is never longer than `max_wire_len` of its body, and exactly that long
    /// when header + body + CRC stay under 254 bytes.
    #[test]
    fn wire_length_matches_the_bound(tape in prop::collection::vec(any::<u8>(), 0..600)) {
        let (message, body) = random_value::<Uplink>(&mut Tape::new(&tape), None);
        let mut wire = [0u8; MAX_FRAME_LEN];
        let len = encode(&message, &mut wire).unwrap();
        prop_assert!(len <= max_wire_len(body.len()));
        if body.len() + 9 < 254 {
            prop_assert_eq!(len, max_wire_len(body.len()));
        }
    }

    /// Every buffer size: the frame or `BufferTooSmall`, never a panic or a short frame.
    #[test]
    fn small_buffers_are_reported(tape in prop::collection::vec(any::<u8>(), 0..600)) {
        let (message, _) = random_value::<Downlink>(&mut Tape::new(&tape), None);
        let mut full = [0u8; MAX_FRAME_LEN];
        let len = encode(&message, &mut full).unwrap();
        for size in 0..len {
            let mut buf = vec![0u8; size];
            prop_assert_eq!(
                encode(&message, &mut buf),
                Err(EncodeError::BufferTooSmall { available: size })
            );
        }
        let mut exact = vec![0u8; len];
        prop_assert_eq!(encode(&message, &mut exact), Ok(len));
        prop_assert_eq!(&exact[..], &full[..len]);
    }
}

#[test]
fn every_configuration_fits() {
    // The longest body any configuration can take, from the schema: every varint at its
    // longest, every option present. The request and the reply add their own envelope
    // (seq at its longest, the enum tags) to the configuration.
    let longest_config = support::max_encoded_len(ParamSet::SCHEMA).unwrap();
    let config_now = |set: &ParamSet| postcard::to_allocvec(set).unwrap().len();
    let Request::SetParams(set) = set_params().request else {
        unreachable!()
    };
    let request_envelope = postcard::to_allocvec(&set_params()).unwrap().len() - config_now(&set);
    let reply = Uplink::Reply {
        seq: u16::MAX,
        result: Ok(Reply::Params(set)),
    };
    let reply_envelope = postcard::to_allocvec(&reply).unwrap().len() - config_now(&set);
    let longest = longest_config + request_envelope.max(reply_envelope);
    assert_eq!(
        (longest_config, request_envelope, reply_envelope),
        (378, 4, 6),
        "the configuration's shape changed: check MAX_BODY_LEN and its doc"
    );
    assert!(
        longest <= MAX_BODY_LEN,
        "a configuration can take {longest} bytes of body, over MAX_BODY_LEN = {MAX_BODY_LEN}"
    );
}

#[test]
fn the_longest_encoding_bound_is_reached() {
    // The bound is exact for a value with every varint at its longest: a segment (the
    // core's, no varint) and a pose encode to exactly their bound.
    for (bound, value) in [
        (
            support::max_encoded_len(controller_core::path::Segment::SCHEMA),
            postcard::to_allocvec(&controller_core::path::Segment::Arc {
                center: controller_core::kinematics::Point::new(1.0, 2.0),
                radius_m: 1.0,
                start_angle_rad: 0.0,
                sweep_rad: 1.0,
            })
            .unwrap()
            .len(),
        ),
        (
            support::max_encoded_len(u32::SCHEMA),
            postcard::to_allocvec(&u32::MAX).unwrap().len(),
        ),
        (
            support::max_encoded_len(Option::<u16>::SCHEMA),
            postcard::to_allocvec(&Some(u16::MAX)).unwrap().len(),
        ),
    ] {
        assert_eq!(bound, Some(value));
    }
    // Sequences have no bound in the schema.
    assert_eq!(support::max_encoded_len(link::Downlink::SCHEMA), None);
}

#[test]
fn telemetry_stays_near_145_bytes() {
    // 145 bytes measured; a change of more than a few fields shows here and in the
    // bandwidth table of the crate doc.
    let body = postcard::to_allocvec(&largest_telemetry()).unwrap().len();
    assert!((138..=152).contains(&body), "telemetry body {body} bytes");
}

#[test]
fn encode_to_vec_fills_or_reports() {
    let mut big: heapless::Vec<u8, MAX_FRAME_LEN> = heapless::Vec::new();
    encode_to_vec(&set_params(), &mut big).unwrap();
    let mut slice = [0u8; MAX_FRAME_LEN];
    let len = encode(&set_params(), &mut slice).unwrap();
    assert_eq!(&big[..], &slice[..len]);

    let mut small: heapless::Vec<u8, 64> = heapless::Vec::new();
    small.extend_from_slice(&[1, 2, 3]).unwrap();
    assert_eq!(
        encode_to_vec(&set_params(), &mut small),
        Err(EncodeError::BufferTooSmall { available: 64 })
    );
    assert!(small.is_empty());
}

#[test]
fn a_body_over_the_limit_is_refused() {
    let mut wire = vec![0u8; 2 * MAX_FRAME_LEN];
    let at_limit = vec![1u8; MAX_BODY_LEN];
    assert!(encode_raw(ProtocolId::OURS, &at_limit, &mut wire).is_ok());
    let over = vec![1u8; MAX_BODY_LEN + 1];
    assert_eq!(
        encode_raw(ProtocolId::OURS, &over, &mut wire),
        Err(EncodeError::TooLarge)
    );
    // Not written past the limit.
    assert!(wire[MAX_FRAME_LEN..].iter().all(|&b| b == 0));
    // With a buffer too small for any frame, the buffer is what is reported.
    let mut small = [0u8; 16];
    assert_eq!(
        encode_raw(ProtocolId::OURS, &over, &mut small),
        Err(EncodeError::BufferTooSmall { available: 16 })
    );
}

#[test]
fn the_header_opens_the_payload() {
    // A frame of a 1-byte body: COBS leaves short zero-free payloads readable.
    let id = ProtocolId {
        version: 3,
        schema_hash: 0x0403_0201,
    };
    let mut wire = [0u8; 32];
    let len = encode_raw(id, &[0x42], &mut wire).unwrap();
    let mut payload = wire[..len - 1].to_vec();
    let n = cobs::decode_in_place(&mut payload).unwrap();
    assert_eq!(&payload[..6], &[3, 1, 2, 3, 4, 0x42]);
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&payload[..6]);
    assert_eq!(&payload[6..n], &crc.to_le_bytes());
    assert_eq!(n, 10);
}
