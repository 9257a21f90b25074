//! # fuzz-checks
//!
//! The properties every decoder that faces outside bytes or text keeps on *any* input,
//! written once and run in two places: by the fuzz targets in `fuzz/` (cargo-fuzz,
//! libFuzzer, on nightly: `cargo xtask fuzz [SECONDS]`), and by this crate's tests on
//! stable, which replay every file of the committed corpus `fuzz/corpus/<target>/` and
//! the seeds of [`seeds`], so that what the fuzzer once found stays checked in CI.
//!
//! Each check takes the raw input and panics, naming the property, when the decoder
//! breaks one. "No panic" is the least of them:
//!
//! | target | check | input | properties |
//! |---|---|---|---|
//! | `link_frames` | [`frames::check`] | bytes off the line | one outcome per delimited frame, as a plain reading of the wire format predicts (overflow, COBS, length, CRC, header, body); the counters count exactly those; byte by byte or all at once, the same outcomes; a decoded message's own frame decodes to it again, no longer than the frame that came, and the same bytes when the body was of its canonical length |
//! | `link_messages` | [`messages::check`] | a postcard body, framed intact by the check | decoded exactly when postcard reads the whole body as a message; re-encoded, the message is stable, never longer, and the same bytes at the same length |
//! | `param_record` | [`param_record::check`] | a flash page, and the same bytes as the body of an intact record | the load is what the record format's definition gives: a configuration that passes the core's validation (every number finite) and stores back to a record that loads the same, or the one refusal the format names; the write plan agrees with the scan |
//! | `scenario` | [`scenario::check`] | a scenario file | a scenario loads with every value finite and within its documented bound, a configuration the core validates and a reference the core builds; or it is refused with a message naming a key |
//! | `robot_file` | [`robot_file::check`] | a robot file | the sections give a configuration the core validates, every number finite, or an error naming a key of the section; a configuration written back as a robot file reads back to itself |
//!
//! [`TARGETS`] lists the targets by name; [`check`] runs one by name.

#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod frames;
pub mod messages;
pub mod numbers;
pub mod param_record;
pub mod robot_file;
pub mod scenario;
pub mod seeds;

/// The fuzz targets, by the name of their binary in `fuzz/` and of their corpus
/// directory `fuzz/corpus/<name>/`.
pub const TARGETS: [&str; 5] = [
    "link_frames",
    "link_messages",
    "param_record",
    "scenario",
    "robot_file",
];

/// Runs the check of the target `name` on `input`; `false` when there is no such target.
/// Panics when the input breaks a property (the panic's message names it).
pub fn check(name: &str, input: &[u8]) -> bool {
    let check: fn(&[u8]) = match name {
        "link_frames" => frames::check,
        "link_messages" => messages::check,
        "param_record" => param_record::check,
        "scenario" => scenario::check,
        "robot_file" => robot_file::check,
        _ => return false,
    };
    check(input);
    true
}
