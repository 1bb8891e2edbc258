//! The GPU tone mapper on wgpu: one compute pass per stage of the plan, each
//! timed with GPU timestamps. Stage names match the WGSL files, the CPU
//! reference functions and the pipeline labels (`tonegate.<stage>`).

pub mod bench;
pub mod context;
pub mod renderer;
pub mod shaders;
pub mod stages;
pub mod timing;

pub use context::{AdapterChoice, AdapterReport, GpuContext};
pub use renderer::{
    Execution, GpuConfig, GpuFrame, GpuInput, GpuRenderer, GpuStats, ReductionMethod,
};
pub use timing::{StageTiming, TimingSummary};

use serde::Serialize;

/// Format of the HDR intermediates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HdrFormat {
    /// Half floats: half the bandwidth; overflows above 65504.
    Rgba16Float,
    /// Full floats: the default, exact enough to match the f64 reference.
    #[default]
    Rgba32Float,
}

impl HdrFormat {
    pub fn wgsl_name(self) -> &'static str {
        match self {
            HdrFormat::Rgba16Float => "rgba16float",
            HdrFormat::Rgba32Float => "rgba32float",
        }
    }

    pub fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            HdrFormat::Rgba16Float => wgpu::TextureFormat::Rgba16Float,
            HdrFormat::Rgba32Float => wgpu::TextureFormat::Rgba32Float,
        }
    }

    pub fn bytes_per_pixel(self) -> u32 {
        match self {
            HdrFormat::Rgba16Float => 8,
            HdrFormat::Rgba32Float => 16,
        }
    }
}

impl std::str::FromStr for HdrFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rgba16float" | "f16" => Ok(HdrFormat::Rgba16Float),
            "rgba32float" | "f32" => Ok(HdrFormat::Rgba32Float),
            _ => Err(format!(
                "unknown HDR format {s:?}: use rgba16float (f16) or rgba32float (f32)"
            )),
        }
    }
}

/// How `sphere` filters the environment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EnvFilter {
    /// Bilinear in the shader from four loads: the reference's arithmetic.
    #[default]
    Manual,
    /// The texture unit's linear filter (needs float32-filterable textures).
    Hardware,
}

impl std::str::FromStr for EnvFilter {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "manual" => Ok(EnvFilter::Manual),
            "hardware" => Ok(EnvFilter::Hardware),
            _ => Err(format!("unknown filter {s:?}: use manual or hardware")),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// The adapter lacks a feature the chosen configuration needs.
    #[error("{adapter} lacks {feature}, which {what} needs")]
    MissingFeature {
        adapter: String,
        feature: &'static str,
        what: &'static str,
    },
    /// No adapter at all: the Vulkan driver is missing.
    #[error("no GPU adapter found (Vulkan): install mesa-vulkan-drivers for lavapipe, e.g. `apt-get install mesa-vulkan-drivers`")]
    NoAdapter,
    /// `--adapter NAME` matched nothing.
    #[error("no adapter matches {wanted:?}; available: {available}")]
    AdapterNotFound { wanted: String, available: String },
    /// The device could not be created (missing features or limits).
    #[error("cannot open {adapter}: {detail}")]
    Device { adapter: String, detail: String },
    /// The frame exceeds what the adapter can hold in one texture.
    #[error("{width}x{height} exceeds the adapter's texture limit of {limit} pixels per side")]
    TooLarge { width: u32, height: u32, limit: u32 },
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
    /// A wgpu validation error: a bug in tonegate, reported rather than panicking.
    #[error("GPU validation error (a tonegate bug, please report): {0}")]
    Validation(String),
    /// Reading results back failed.
    #[error("GPU readback failed: {0}")]
    Readback(String),
}

mod bloom_blur;
mod bloom_bright;
mod bloom_composite;
mod bloom_downsample;
mod encode;
mod floor;
mod fused;
mod grade;
mod grade_stats;
mod luminance_stats;
pub mod sphere;
mod tonemap;
