//! Any text as a robot file: `fuzz_checks::robot_file::check`.
#![no_main]

libfuzzer_sys::fuzz_target!(|input: &[u8]| fuzz_checks::robot_file::check(input));
