//! The gate's front end: `renderer` (`GpuRenderer`, a plan's resources
//! for one input, recorded by the executor with `encode`'s packed frame as
//! its sink), `readback` (the ring of frames in flight), `timing` (its
//! timestamp queries), `pool` (renderers kept between flat images by size
//! class) and `inspect` (a stage's output read back, for the stage tests).

pub(in crate::gpu) mod inspect;
pub mod pool;
pub mod readback;
pub mod renderer;
pub mod timing;
