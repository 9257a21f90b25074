//! Any flash page, and any record body, into the persisted parameter record's loader: `fuzz_checks::param_record::check`.
#![no_main]

libfuzzer_sys::fuzz_target!(|input: &[u8]| fuzz_checks::param_record::check(input));
