//! `encode` pass.

use crate::color::bt709_to_bt2020;
use crate::gpu::stages::{bind_group, bind_group_for, dispatch_2d, pipeline, Bind, Dispatch};
use crate::gpu::{GpuContext, HdrFormat};
use crate::operators::DisplayLevels;
use crate::scene::Encoding;

/// The encoding's override constants (shaders/shared/encode.wgsl); a PQ
/// encoding also takes the display's levels and the BT.709 → BT.2020
/// matrix, computed here in f64. A PQ encoding without levels is refused
/// by the scene and the renderer before it gets here; it would encode a
/// 0..100 cd/m² display.
pub fn encode_constants(
    encoding: Encoding,
    levels: Option<DisplayLevels>,
) -> Vec<(&'static str, f64)> {
    match encoding {
        Encoding::Srgb => vec![("ENCODING", 0.0), ("GAMMA", 2.2)],
        Encoding::Gamma(g) => vec![("ENCODING", 1.0), ("GAMMA", g.get())],
        Encoding::Pq => {
            let levels = levels.unwrap_or(DisplayLevels {
                black: 0.0,
                peak: 100.0,
            });
            let m = bt709_to_bt2020();
            let mut c = vec![
                ("ENCODING", 2.0),
                ("GAMMA", 2.2),
                ("PQ_BLACK", levels.black),
                ("PQ_PEAK", levels.peak),
            ];
            const NAMES: [&str; 9] = [
                "PQ_M00", "PQ_M01", "PQ_M02", "PQ_M10", "PQ_M11", "PQ_M12", "PQ_M20", "PQ_M21",
                "PQ_M22",
            ];
            for (i, name) in NAMES.into_iter().enumerate() {
                c.push((name, m[i / 3][i % 3]));
            }
            c
        }
    }
}

/// Bytes of the packed frame per pixel: RGBA8 in one u32, or R|G and
/// B|A (16 bits each) in two.
pub fn frame_bytes_per_pixel(encoding: Encoding) -> u64 {
    u64::from(encoding.bits()) / 2
}

pub fn encode(
    ctx: &GpuContext,
    format: HdrFormat,
    encoding: Encoding,
    levels: Option<DisplayLevels>,
    src: &wgpu::Texture,
    frame_out: &wgpu::Buffer,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(
        ctx,
        "encode",
        "main",
        format,
        &encode_constants(encoding, levels),
    );
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.encode",
        &[(0, Bind::Texture(src)), (1, Bind::Buffer(frame_out))],
    );
    dispatch_2d(p, bg, src.width(), src.height()).sized(ctx, extent)
}

/// What a caller's texture holds of a pixel: the `TARGET` constant of
/// shaders/shared/encode.wgsl, by the texture's format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Texel {
    /// The 8-bit codes (`…8Unorm`).
    Codes8,
    /// The 8-bit codes through a format that applies the sRGB OETF as it
    /// stores (`…8UnormSrgb`).
    Codes8Srgb,
    /// 10-bit codes (`Rgb10a2Unorm`): the SDR transfer's, or PQ's.
    Codes10,
    /// scRGB (`Rgba16Float`): linear BT.709, 1.0 = 80 cd/m².
    ScRgb,
}

impl Texel {
    /// What a texture of `format` holds, or `None` for a format no target
    /// takes.
    pub fn of(format: wgpu::TextureFormat) -> Option<Texel> {
        use wgpu::TextureFormat as F;
        match format {
            F::Rgba8Unorm | F::Bgra8Unorm => Some(Texel::Codes8),
            F::Rgba8UnormSrgb | F::Bgra8UnormSrgb => Some(Texel::Codes8Srgb),
            F::Rgb10a2Unorm => Some(Texel::Codes10),
            F::Rgba16Float => Some(Texel::ScRgb),
            _ => None,
        }
    }

    fn constant(self) -> f64 {
        match self {
            Texel::Codes8 => 0.0,
            Texel::Codes8Srgb => 1.0,
            Texel::Codes10 => 2.0,
            Texel::ScRgb => 3.0,
        }
    }

    /// Bits per colour sample of what it holds (scRGB: a half float).
    pub fn bits(self) -> u32 {
        match self {
            Texel::Codes8 | Texel::Codes8Srgb => 8,
            Texel::Codes10 => 10,
            Texel::ScRgb => 16,
        }
    }
}

/// The entry point that stores into a storage texture of `format`, where
/// WGSL can name the format (`to_texture*` in shaders/encode.wgsl).
pub fn storage_entry(format: wgpu::TextureFormat) -> Option<&'static str> {
    use wgpu::TextureFormat as F;
    match format {
        F::Rgba8Unorm => Some("to_texture"),
        F::Bgra8Unorm => Some("to_texture_bgra8"),
        F::Rgba16Float => Some("to_texture_rgba16f"),
        _ => None,
    }
}

/// The binding of the storage texture `entry` writes.
fn storage_binding(entry: &str) -> u32 {
    match entry {
        "to_texture" => 2,
        "to_texture_rgba16f" => 4,
        _ => 5,
    }
}

/// [`encode_constants`] and the target's texel.
pub fn target_constants(
    encoding: Encoding,
    levels: Option<DisplayLevels>,
    texel: Texel,
) -> Vec<(&'static str, f64)> {
    let mut c = encode_constants(encoding, levels);
    c.push(("TARGET", texel.constant()));
    c
}

/// `encode` into a caller's storage texture of `target_format` (one with an
/// entry in [`storage_entry`]) through a compute pass, the image at
/// `origin` (a uniform of one `vec4<u32>`, xy used) in it.
#[allow(clippy::too_many_arguments)]
pub fn encode_to_storage(
    ctx: &GpuContext,
    format: HdrFormat,
    encoding: Encoding,
    levels: Option<DisplayLevels>,
    src: &wgpu::Texture,
    target: &wgpu::TextureView,
    target_format: wgpu::TextureFormat,
    origin: &wgpu::Buffer,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let entry = storage_entry(target_format).expect("a storage target format");
    let texel = Texel::of(target_format).expect("a target format");
    let p = pipeline(
        ctx,
        "encode",
        entry,
        format,
        &target_constants(encoding, levels, texel),
    );
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.encode.to_texture",
        &[
            (0, Bind::Texture(src)),
            (3, Bind::Buffer(origin)),
            (storage_binding(entry), Bind::View(target)),
        ],
    );
    dispatch_2d(p, bg, src.width(), src.height()).sized(ctx, extent)
}

/// The render pipeline that draws `encode` into a render attachment of
/// `target_format` (a fullscreen triangle; `to_attachment` in
/// shaders/encode.wgsl), compiled once per format and constants in the
/// context's cache. Blending off: the codes are written as they are.
pub fn encode_render_pipeline(
    ctx: &GpuContext,
    encoding: Encoding,
    levels: Option<DisplayLevels>,
    target_format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let texel = Texel::of(target_format).expect("a target format");
    let constants = target_constants(encoding, levels, texel);
    let kind = crate::gpu::device::pipelines::PipelineKind::Render {
        target: target_format,
    };
    let format = HdrFormat::Rgba32Float;
    let key = crate::gpu::device::pipelines::PipelineKey::new(kind, format, &constants, None);
    ctx.cached_render_pipeline(key, || {
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("tonegate.encode.to_attachment"),
                source: wgpu::ShaderSource::Wgsl(
                    crate::gpu::shaders::compose("encode", HdrFormat::Rgba32Float, ctx.subgroups)
                        .into(),
                ),
            });
        ctx.device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("tonegate.encode.to_attachment"),
                layout: None,
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("fullscreen"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("to_attachment"),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &constants,
                        zero_initialize_workgroup_memory: false,
                    },
                    targets: &[Some(wgpu::ColorTargetState {
                        format: target_format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
    })
}

/// The bind group of [`encode_render_pipeline`]'s pass.
pub fn encode_render_bind_group(
    ctx: &GpuContext,
    pipeline: &wgpu::RenderPipeline,
    src: &wgpu::Texture,
    origin: &wgpu::Buffer,
) -> wgpu::BindGroup {
    bind_group_for(
        ctx,
        &pipeline.get_bind_group_layout(0),
        "tonegate.encode.to_attachment",
        &[(0, Bind::Texture(src)), (3, Bind::Buffer(origin))],
    )
}
