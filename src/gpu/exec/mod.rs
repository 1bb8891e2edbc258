//! The executor and what it executes: `wiring` (a frame's fixed resources
//! and each stage's passes on them), `fused` (the stages `--execution
//! fused` merges into one pass), `input` (what a plan reads: a sphere, a
//! flat image, a caller's view) and `executor`, the one code that walks a
//! plan into passes and records them into an encoder, for the gate's
//! renderer and the `ToneMapper` alike.

pub(in crate::gpu) mod executor;
pub(in crate::gpu) mod fused;
pub(in crate::gpu) mod input;
pub(in crate::gpu) mod wiring;

pub(in crate::gpu) use executor::{draw, ComputeStamps, Draw, Executor};
