//! Any text as a scenario file: `fuzz_checks::scenario::check`.
#![no_main]

libfuzzer_sys::fuzz_target!(|input: &[u8]| fuzz_checks::scenario::check(input));
