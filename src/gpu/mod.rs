//! The GPU tone mapper on wgpu, a folder per job: `device` (adapters, the
//! context, what a device can do), `kernels` (a file per stage), `exec`
//! (the executor: a plan wired into passes and recorded), the two front
//! ends on it, `run` (the gate's renderer, frames read back packed) and
//! `tone_mapper` (an application's target), `metrics` (the pair metrics on
//! the GPU) and `bench`; beside them the plumbing every folder uses:
//! `config` (the knobs), `shaders` (the WGSL sources) and `stages` (buffers,
//! textures and dispatches). Stage names match the WGSL files, the CPU
//! reference functions and the pipeline labels (`tonegate.<stage>`).

#[cfg(feature = "gpu")]
pub mod bench;
pub mod config;
mod device;
mod exec;
mod kernels;
#[cfg(feature = "gpu")]
mod metrics;
#[cfg(feature = "gpu")]
mod run;
pub mod shaders;
pub mod stages;
#[deny(missing_docs)]
pub mod tone_mapper;

// Each job's modules under the names they had before the folders: a
// module's path says which job it belongs to, and a caller's does not
// change with it.
use device::created;
pub use device::{adapters, capability, context, listing, validation};
use exec::{input, wiring};
#[cfg(feature = "gpu")]
use kernels::floor;
pub use kernels::{adaptation, sphere};
use kernels::{
    bloom_blur, bloom_bright, bloom_composite, bloom_downsample, encode, grade, grade_stats,
    histogram, luminance_stats, taa, taa_sobel, tonemap,
};
#[cfg(feature = "gpu")]
pub use metrics::{compare, flip};
#[cfg(feature = "gpu")]
pub use run::{pool, readback, renderer, timing};

pub use adapters::{choose, AdapterChoice, AdapterPick, AdapterReport, BackendChoice, Candidate};
pub use config::{
    AdapterTraits, EnvFilter, Execution, GpuConfig, HdrFormat, ReductionMethod, TaaFault, F16_MAX,
};
pub use context::GpuContext;
pub use created::Created;
pub use input::GpuInput;
pub use luminance_stats::GpuStats;
#[cfg(feature = "gpu")]
pub use pool::{size_class, RendererPool};
#[cfg(feature = "gpu")]
pub use readback::{GpuFrame, Ticket, FRAMES_IN_FLIGHT};
#[cfg(feature = "gpu")]
pub use renderer::GpuRenderer;
pub use tone_mapper::{
    MapperTimings, MotionUnits, MotionVectors, OutputPath, SourceView, TargetView, TextureRole,
    ToneMapper, ToneMapperError, ToneMapperSettings, MAX_CAMERAS, MOTION_FORMATS,
};
// The stages' override constants, for the range-safety proof
// (`stress::range_safety`), which evaluates the shaders with them.
#[cfg(test)]
pub(crate) use {
    bloom_bright::bright_constants, encode::encode_constants, grade::grade_constants,
    luminance_stats::stats_constants,
};

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// The adapter lacks a feature the chosen configuration needs.
    #[error("{adapter} lacks {feature}, which {what} needs")]
    MissingFeature {
        adapter: String,
        feature: &'static str,
        what: &'static str,
    },
    /// No adapter at all: the driver is missing.
    #[error("no GPU adapter found on the backend asked for: install mesa-vulkan-drivers for lavapipe (Vulkan), e.g. `apt-get install mesa-vulkan-drivers`, or libegl-mesa0 for llvmpipe on GL; `tonegate adapters` lists what there is")]
    NoAdapter,
    /// `--adapter NAME` matched nothing.
    #[error("no adapter matches {wanted:?}; available: {available}")]
    AdapterNotFound { wanted: String, available: String },
    /// `--adapter hardware` on a machine whose adapters are all software.
    #[error("--adapter hardware: no hardware adapter was found, only software ones ({available}); drop --adapter to use the software rasterizer, or install the GPU's driver (`tonegate adapters` lists what there is)")]
    NoHardwareAdapter { available: String },
    /// The adapter lacks what every stage needs (a GL context without
    /// compute shaders): a property of the adapter, not a tonegate bug.
    #[error("{adapter} cannot run tonegate: it has {reason}")]
    Unsupported { adapter: String, reason: String },
    /// The device could not be created (missing features or limits).
    #[error("cannot open {adapter}: {detail}")]
    Device { adapter: String, detail: String },
    /// The frame exceeds what the adapter can hold in one texture.
    #[error("{width}x{height} exceeds the adapter's texture limit of {limit} pixels per side")]
    TooLarge { width: u32, height: u32, limit: u32 },
    /// The frame needs a buffer larger than the adapter allows.
    #[error("{width}x{height} needs {bytes}-byte buffers, over the adapter's buffer limit of {limit} bytes")]
    FrameTooLarge {
        width: u32,
        height: u32,
        bytes: u64,
        limit: u64,
    },
    /// The environment map exceeds one storage buffer binding.
    #[error("environment {width}x{height} needs {bytes} bytes, over the adapter's storage-buffer binding limit of {limit}; use a smaller map")]
    EnvironmentTooLarge {
        width: u32,
        height: u32,
        bytes: u64,
        limit: u64,
    },
    /// The GPU ran out of memory.
    #[error("GPU out of memory: {0}")]
    OutOfMemory(String),
    /// The device was lost (driver crash or reset).
    #[error("GPU device lost: {0}")]
    DeviceLost(String),
    /// A plan the renderer cannot execute: a bug in tonegate, reported rather than panicking.
    #[error(transparent)]
    Plan(#[from] crate::plan::PlanError),
    /// A wgpu validation error: a bug in tonegate, reported rather than panicking.
    #[error("GPU validation error (a tonegate bug, please report): {0}")]
    Validation(String),
    /// The driver's validation layer reported an error (`WGPU_VALIDATION=1`).
    #[error("validation layer error (a tonegate bug, please report): {0}")]
    LayerError(String),
    /// Reading results back failed.
    #[error("GPU readback failed: {0}")]
    Readback(String),
}
