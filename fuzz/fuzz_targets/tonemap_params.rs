#![no_main]
//! See `tonegate::fuzzing::tonemap_params`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| tonegate::fuzzing::tonemap_params(data));
