#![no_main]
//! See `tonegate::fuzzing::suite`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| tonegate::fuzzing::suite(data));
