//! Any postcard body, framed intact, into the link's message decoding: `fuzz_checks::messages::check`.
#![no_main]

libfuzzer_sys::fuzz_target!(|input: &[u8]| fuzz_checks::messages::check(input));
