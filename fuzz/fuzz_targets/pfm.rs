#![no_main]
//! See `tonegate::fuzzing::hdr`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| tonegate::fuzzing::hdr(data));
