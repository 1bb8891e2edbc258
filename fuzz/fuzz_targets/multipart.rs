#![no_main]
//! See `tonegate::fuzzing::multipart`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| tonegate::fuzzing::multipart(data));
