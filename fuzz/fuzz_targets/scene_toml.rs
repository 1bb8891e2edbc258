#![no_main]
//! See `tonegate::fuzzing::scene`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| tonegate::fuzzing::scene(data));
