//! Bytes off the line into the link's streaming decoder: `fuzz_checks::frames::check`.
#![no_main]

libfuzzer_sys::fuzz_target!(|input: &[u8]| fuzz_checks::frames::check(input));
