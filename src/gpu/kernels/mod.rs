//! The kernels: a file per stage (named as its shader in `shaders/` and
//! its CPU reference in `src/reference/`), each making its pipeline,
//! bindings and uniforms; `floor` the copy a stage's floor is measured
//! against.

pub mod adaptation;
pub(in crate::gpu) mod bloom_blur;
pub(in crate::gpu) mod bloom_bright;
pub(in crate::gpu) mod bloom_composite;
pub(in crate::gpu) mod bloom_downsample;
pub(in crate::gpu) mod encode;
#[cfg(feature = "gpu")]
pub(in crate::gpu) mod floor;
pub(in crate::gpu) mod grade;
pub(in crate::gpu) mod grade_stats;
pub(in crate::gpu) mod histogram;
pub(in crate::gpu) mod luminance_stats;
pub mod sphere;
pub(in crate::gpu) mod taa;
pub(in crate::gpu) mod taa_sobel;
pub(in crate::gpu) mod tonemap;
