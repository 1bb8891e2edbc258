//! What a [`super::ToneMapper`] reads and writes: the formats, the views
//! with what wgpu does not tell of a view, the path into the target, and
//! the errors that refuse them.

use super::super::GpuError;
use crate::gpu::encode::TARGETS;

/// The HDR formats the tone mapper reads (linear, scene-referred).
pub const INPUT_FORMATS: [wgpu::TextureFormat; 2] = [
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba16Float,
];

/// The formats the tone mapper writes (docs/embedding.md#targets): the
/// 8-bit codes of the encoding in the four 8-bit formats (an `…Srgb`
/// format holds the same bytes as its twin), 10-bit codes of the encoding
/// or of PQ in `Rgb10a2Unorm`, scRGB in `Rgba16Float`.
pub const TARGET_FORMATS: [wgpu::TextureFormat; TARGETS.len()] = {
    let mut formats = [wgpu::TextureFormat::Rgba8Unorm; TARGETS.len()];
    let mut i = 0;
    while i < TARGETS.len() {
        formats[i] = TARGETS[i].format;
        i += 1;
    }
    formats
};

/// How the tone mapper writes its target.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum OutputPath {
    /// A compute pass where the target texture has `STORAGE_BINDING` and
    /// its format can be stored to on the device; a render pass otherwise.
    #[default]
    Auto,
    /// A compute pass: the target needs `STORAGE_BINDING`, and a format a
    /// shader can store to (`Rgba8Unorm`, `Rgba16Float`, and `Bgra8Unorm`
    /// on a device with `Features::BGRA8UNORM_STORAGE`).
    Compute,
    /// A fullscreen triangle in a render pass: the target needs
    /// `RENDER_ATTACHMENT`; every target format.
    RenderPass,
}

/// The HDR image a [`super::ToneMapper`] reads: a view, with the mip level
/// it starts at (a view does not tell) and, for an image smaller than the
/// level (dynamic resolution), its size from the view's top-left corner.
#[derive(Clone, Copy, Debug)]
pub struct SourceView<'a> {
    /// The view (a 2-D one of one layer).
    pub view: &'a wgpu::TextureView,
    /// The texture's mip level the view starts at.
    pub mip_level: u32,
    /// The image's width and height, or `None` for the whole level.
    pub size: Option<(u32, u32)>,
}

impl<'a> From<&'a wgpu::TextureView> for SourceView<'a> {
    /// The whole first level of the view (a view made with the default
    /// descriptor).
    fn from(view: &'a wgpu::TextureView) -> SourceView<'a> {
        SourceView {
            view,
            mip_level: 0,
            size: None,
        }
    }
}

impl<'a> SourceView<'a> {
    /// The view starts at `mip_level` of its texture.
    pub fn at_level(self, mip_level: u32) -> SourceView<'a> {
        SourceView { mip_level, ..self }
    }

    /// The image is `width`×`height` in the view's top-left corner.
    pub fn with_size(self, width: u32, height: u32) -> SourceView<'a> {
        SourceView {
            size: Some((width, height)),
            ..self
        }
    }
}

/// Where a [`super::ToneMapper`] writes: a view of the target (in the
/// settings' `target` format), the mip level it starts at, and where the
/// image goes in it: the whole level, the image's size, by default, or a
/// region of the image's size from `origin` (the rest of the texture is
/// left as it was).
#[derive(Clone, Copy, Debug)]
pub struct TargetView<'a> {
    /// The view (a 2-D one of one layer, in the settings' target format).
    pub view: &'a wgpu::TextureView,
    /// The texture's mip level the view starts at.
    pub mip_level: u32,
    /// Where the image's top-left corner goes, or `None` for a level of
    /// the image's size.
    pub origin: Option<(u32, u32)>,
}

impl<'a> From<&'a wgpu::TextureView> for TargetView<'a> {
    /// The whole first level of the view.
    fn from(view: &'a wgpu::TextureView) -> TargetView<'a> {
        TargetView {
            view,
            mip_level: 0,
            origin: None,
        }
    }
}

impl<'a> TargetView<'a> {
    /// The view starts at `mip_level` of its texture.
    pub fn at_level(self, mip_level: u32) -> TargetView<'a> {
        TargetView { mip_level, ..self }
    }

    /// The image goes to the region from (`x`, `y`).
    pub fn at(self, x: u32, y: u32) -> TargetView<'a> {
        TargetView {
            origin: Some((x, y)),
            ..self
        }
    }
}

/// Which of the two textures a [`ToneMapperError`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureRole {
    /// The HDR texture read.
    Input,
    /// The texture written.
    Output,
    /// The motion vectors TAA reads.
    Motion,
}

impl std::fmt::Display for TextureRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TextureRole::Input => "input",
            TextureRole::Output => "output",
            TextureRole::Motion => "motion vectors",
        })
    }
}

/// Why a [`super::ToneMapper`] refused its settings or a pair of views,
/// before anything was recorded. Each variant carries what a caller needs
/// to act on it; the messages say the same in words.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ToneMapperError {
    /// PQ codes need more than 8 bits.
    #[error("encoding pq into a {format:?} target: PQ needs 10 bits or more; write Rgb10a2Unorm (PQ codes) or Rgba16Float (scRGB), or use the sRGB transfer or a gamma")]
    PqIntoEightBits {
        /// The 8-bit target format.
        format: wgpu::TextureFormat,
    },
    /// PQ needs the display the operator maps onto.
    #[error("encoding pq: operator {operator} maps onto no display of known black and peak, which PQ codes need (see `tonegate operators` for one with display levels)")]
    PqWithoutLevels {
        /// The operator's name.
        operator: String,
    },
    /// The settings' target is not one of [`TARGET_FORMATS`].
    #[error(
        "target format {format:?}: the tone mapper writes {}",
        crate::gpu::encode::target_format_names()
    )]
    TargetFormat {
        /// The format asked for.
        format: wgpu::TextureFormat,
    },
    /// [`OutputPath::Compute`] into a format no shader can store to here.
    #[error("a compute pass cannot write {format:?} on this device (not a storage format{}); use OutputPath::RenderPass or Auto", if *.format == wgpu::TextureFormat::Bgra8Unorm { " without Features::BGRA8UNORM_STORAGE" } else { "" })]
    ComputeTarget {
        /// The target format.
        format: wgpu::TextureFormat,
    },
    /// The input is not one of [`INPUT_FORMATS`].
    #[error("the input texture is {format:?}; the tone mapper reads Rgba32Float or Rgba16Float (linear HDR)")]
    InputFormat {
        /// The input's format.
        format: wgpu::TextureFormat,
    },
    /// The output's texture is not of the settings' target format (nor its
    /// sRGB twin, which a view can reinterpret).
    #[error("the output texture is {format:?}; the settings' target is {target:?}")]
    OutputFormat {
        /// The output texture's format.
        format: wgpu::TextureFormat,
        /// The settings' target format.
        target: wgpu::TextureFormat,
    },
    /// A texture lacks a usage the mapper binds it with.
    #[error("the {texture} texture lacks {} usage", usage_name(*.usage))]
    MissingUsage {
        /// Which texture.
        texture: TextureRole,
        /// The usage it lacks.
        usage: wgpu::TextureUsages,
    },
    /// A texture that is not 2-D with one sample.
    #[error("the {texture} texture must be 2-D, not multisampled")]
    Not2d {
        /// Which texture.
        texture: TextureRole,
    },
    /// A mip level the texture does not have.
    #[error("the {texture} view's mip level {level} is past the texture's {levels} levels")]
    MipLevel {
        /// Which texture.
        texture: TextureRole,
        /// The level given.
        level: u32,
        /// The texture's levels.
        levels: u32,
    },
    /// The image's region does not fit in the level.
    #[error("the {texture} region {}x{} at ({}, {}) is outside its {}x{} level", .region.2, .region.3, .region.0, .region.1, .level.0, .level.1)]
    Outside {
        /// Which texture.
        texture: TextureRole,
        /// x, y, width, height.
        region: (u32, u32, u32, u32),
        /// The level's width and height.
        level: (u32, u32),
    },
    /// The whole output level is not the input image's size.
    #[error("the input image is {}x{} and the output {}x{}; they must be the same size (or give the output an origin)", .input.0, .input.1, .output.0, .output.1)]
    SizeMismatch {
        /// The input image's width and height.
        input: (u32, u32),
        /// The output level's width and height.
        output: (u32, u32),
    },
    /// A camera past the last one a mapper adapts.
    #[error("camera {camera}: a ToneMapper adapts cameras 0 to {}", super::cameras::MAX_CAMERAS - 1)]
    Camera {
        /// The camera asked for.
        camera: usize,
    },
    /// A frame time that is negative, infinite or NaN.
    #[error("frame time {seconds} s: must be a finite number >= 0")]
    FrameSeconds {
        /// The seconds given.
        seconds: f64,
    },
    /// A bloom, grade or TAA parameter out of its range (the ranges of a
    /// scene's `[bloom]`, `[grade]` and `[taa]`, docs/display.md#limits).
    #[error("{table}.{key}: {reason}")]
    Display {
        /// `bloom`, `grade` or `taa`.
        table: &'static str,
        /// The parameter.
        key: &'static str,
        /// Its range and the value given.
        reason: String,
    },
    /// The settings have TAA and the frame came without motion vectors.
    #[error("the settings have TAA, which finds each pixel's history by the frame's motion vectors: record with record_with_motion")]
    NoMotionVectors,
    /// TAA reads the whole first level of the input texture.
    #[error("TAA reads the whole first level of the input texture ({}x{}); the input is {}x{} at mip level {level}", .texture.0, .texture.1, .size.0, .size.1)]
    TaaInput {
        /// The view's mip level.
        level: u32,
        /// The image's width and height.
        size: (u32, u32),
        /// The texture's width and height.
        texture: (u32, u32),
    },
    /// The motion vectors' texture is not one of [`super::MOTION_FORMATS`].
    #[error("the motion vectors' texture is {format:?}; TAA reads them from Rg16Float, Rg32Float, Rgba16Float or Rgba32Float")]
    MotionFormat {
        /// The texture's format.
        format: wgpu::TextureFormat,
    },
    /// The motion vectors are not of the input image's size.
    #[error("the motion vectors are {}x{} and the input image {}x{}; they must be the same size", .motion.0, .motion.1, .input.0, .input.1)]
    MotionSize {
        /// The motion texture's width and height.
        motion: (u32, u32),
        /// The input image's width and height.
        input: (u32, u32),
    },
    /// Wiring the passes failed: a tonegate bug, reported rather than a
    /// panic.
    #[error("wiring the tone mapper's passes: {0} (a tonegate bug)")]
    Internal(GpuError),
    /// The device lacks a feature asked for ([`super::ToneMapper::enable_timestamps`]).
    #[error("the device was opened without {feature:?}, which this needs")]
    MissingFeature {
        /// The feature.
        feature: wgpu::Features,
    },
    /// The device failed a readback ([`super::ToneMapper::read_adapted_luminance`]).
    #[error("reading back from the device: {0}")]
    Readback(GpuError),
    /// Over the device's limits ([`GpuError::TooLarge`] or
    /// [`GpuError::FrameTooLarge`]).
    #[error(transparent)]
    Limits(GpuError),
}

fn usage_name(usage: wgpu::TextureUsages) -> String {
    let names: Vec<&str> = usage.iter_names().map(|(name, _)| name).collect();
    names.join(" | ")
}

/// The size of `texture`'s level `level`, or why there is none.
pub(super) fn level_size(
    texture: &wgpu::Texture,
    role: TextureRole,
    level: u32,
) -> Result<(u32, u32), ToneMapperError> {
    if level >= texture.mip_level_count() {
        return Err(ToneMapperError::MipLevel {
            texture: role,
            level,
            levels: texture.mip_level_count(),
        });
    }
    Ok((
        (texture.width() >> level).max(1),
        (texture.height() >> level).max(1),
    ))
}

/// Refuses a texture that is not 2-D and single-sampled, or lacks `usage`.
pub(super) fn check_texture(
    texture: &wgpu::Texture,
    role: TextureRole,
    usage: wgpu::TextureUsages,
) -> Result<(), ToneMapperError> {
    if !texture.usage().contains(usage) {
        return Err(ToneMapperError::MissingUsage {
            texture: role,
            usage,
        });
    }
    if texture.dimension() != wgpu::TextureDimension::D2 || texture.sample_count() != 1 {
        return Err(ToneMapperError::Not2d { texture: role });
    }
    Ok(())
}

/// Can a compute pass store `format` on a device with `features`?
pub(super) fn storable(format: wgpu::TextureFormat, features: wgpu::Features) -> bool {
    crate::gpu::encode::storage(format, features).is_some()
}
