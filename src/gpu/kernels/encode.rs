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

/// A format the encode stage writes into a caller's target: what a
/// texture of it holds, and how a compute pass stores into it where WGSL
/// can name the format.
#[derive(Clone, Copy, Debug)]
pub struct TargetFormat {
    pub format: wgpu::TextureFormat,
    pub texel: Texel,
    pub store: Option<Store>,
}

/// A compute pass's store into a target: the entry point
/// (`to_texture*` in shaders/encode.wgsl), the binding of the storage
/// texture it writes, and the device feature storing needs.
#[derive(Clone, Copy, Debug)]
pub struct Store {
    pub entry: &'static str,
    pub binding: u32,
    pub feature: wgpu::Features,
}

/// Every target format, once (docs/embedding.md#targets): the formats the
/// tone mapper takes, what each holds and which a compute pass stores
/// into are all read from here. An `…Srgb` format holds its twin's bytes,
/// written by the render pass (WGSL names no sRGB storage format).
pub const TARGETS: [TargetFormat; 6] = {
    use wgpu::TextureFormat as F;
    let none = wgpu::Features::empty();
    [
        TargetFormat {
            format: F::Rgba8Unorm,
            texel: Texel::Codes8,
            store: Some(Store {
                entry: "to_texture",
                binding: 2,
                feature: none,
            }),
        },
        TargetFormat {
            format: F::Rgba8UnormSrgb,
            texel: Texel::Codes8Srgb,
            store: None,
        },
        TargetFormat {
            format: F::Bgra8Unorm,
            texel: Texel::Codes8,
            store: Some(Store {
                entry: "to_texture_bgra8",
                binding: 5,
                feature: wgpu::Features::BGRA8UNORM_STORAGE,
            }),
        },
        TargetFormat {
            format: F::Bgra8UnormSrgb,
            texel: Texel::Codes8Srgb,
            store: None,
        },
        TargetFormat {
            format: F::Rgb10a2Unorm,
            texel: Texel::Codes10,
            store: None,
        },
        TargetFormat {
            format: F::Rgba16Float,
            texel: Texel::ScRgb,
            store: Some(Store {
                entry: "to_texture_rgba16f",
                binding: 4,
                feature: none,
            }),
        },
    ]
};

/// `format`'s row of [`TARGETS`], or `None` for a format no target takes.
pub fn target_format(format: wgpu::TextureFormat) -> Option<&'static TargetFormat> {
    TARGETS.iter().find(|t| t.format == format)
}

/// The formats of [`TARGETS`], in its order, as a sentence: "A, B or C".
pub fn target_format_names() -> String {
    let names: Vec<String> = TARGETS.iter().map(|t| format!("{:?}", t.format)).collect();
    match names.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => String::new(),
    }
}

impl Texel {
    /// What a texture of `format` holds, or `None` for a format no target
    /// takes.
    pub fn of(format: wgpu::TextureFormat) -> Option<Texel> {
        target_format(format).map(|t| t.texel)
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

/// How a compute pass stores into a target of `format` on a device with
/// `features`, or `None` where it cannot (a render pass can).
pub fn storage(format: wgpu::TextureFormat, features: wgpu::Features) -> Option<Store> {
    let store = target_format(format)?.store?;
    features.contains(store.feature).then_some(store)
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

/// `encode` into a caller's storage texture of `target_format` (one a
/// compute pass stores into: [`storage`]) through a compute pass, the
/// image at `origin` (a uniform of one `vec4<u32>`, xy used) in it.
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
    let target_row = self::target_format(target_format).expect("a target format");
    let store = target_row.store.expect("a storage target format");
    let p = pipeline(
        ctx,
        "encode",
        store.entry,
        format,
        &target_constants(encoding, levels, target_row.texel),
    );
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.encode.to_texture",
        &[
            (0, Bind::Texture(src)),
            (3, Bind::Buffer(origin)),
            (store.binding, Bind::View(target)),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Each stored target's entry point writes, through `textureStore`, the
    /// storage texture declared at its binding, in its own format: the
    /// table and shaders/encode.wgsl agree.
    #[test]
    fn the_target_table_matches_the_encode_shader() {
        let wgsl = crate::gpu::shaders::compose("encode", HdrFormat::Rgba32Float, false);
        let mut stored = 0;
        for t in TARGETS {
            let Some(store) = t.store else {
                continue;
            };
            let decl = format!("@group(0) @binding({}) var ", store.binding);
            let line = wgsl
                .lines()
                .find(|l| l.starts_with(&decl))
                .unwrap_or_else(|| panic!("no binding {} in encode.wgsl", store.binding));
            let name = line[decl.len()..].split(':').next().unwrap().trim();
            let wgsl_format = format!("{:?}", t.format).to_lowercase();
            assert!(
                line.contains(&format!("texture_storage_2d<{wgsl_format}, write>")),
                "{line}: not {wgsl_format}"
            );
            let body = wgsl
                .split(&format!("fn {}(", store.entry))
                .nth(1)
                .unwrap_or_else(|| panic!("no entry {}", store.entry));
            let body = &body[..body.find("\n}").unwrap()];
            assert!(
                body.contains(&format!("textureStore({name},")),
                "{} does not store to {name}",
                store.entry
            );
            stored += 1;
        }
        assert_eq!(stored, 3);
        assert!(target_format_names().ends_with("Rgb10a2Unorm or Rgba16Float"));
    }
}
