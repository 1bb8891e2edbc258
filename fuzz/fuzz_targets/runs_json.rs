#![no_main]
//! See `tonegate::fuzzing::runs_json`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| tonegate::fuzzing::runs_json(data));
