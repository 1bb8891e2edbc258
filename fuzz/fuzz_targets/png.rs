#![no_main]
//! See `tonegate::fuzzing::png`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| tonegate::fuzzing::png(data));
