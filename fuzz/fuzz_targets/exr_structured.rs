#![no_main]
//! See `tonegate::fuzzing::exr_structured`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| tonegate::fuzzing::exr_structured(data));
