//! What every stage's pass setup shares: pipelines by name, textures, bind groups.

use super::{GpuContext, HdrFormat};
use crate::gpu::device::pipelines::{PipelineKey, PipelineKind};

/// A compute pipeline for `entry` of shader `stage`, labelled
/// `tonegate.<stage>` (or `tonegate.<stage>.<entry>` for secondary entries),
/// with its override constants. Layouts are derived from the shader.
pub fn pipeline(
    ctx: &GpuContext,
    stage: &str,
    entry: &str,
    format: HdrFormat,
    constants: &[(&str, f64)],
) -> wgpu::ComputePipeline {
    pipeline_with(ctx, stage, entry, format, constants, None)
}

/// [`pipeline`] for a stage that includes an operator's module (its
/// `ToneOperator::wgsl`): the operator is part of the pipeline's key.
pub fn pipeline_with(
    ctx: &GpuContext,
    stage: &str,
    entry: &str,
    format: HdrFormat,
    constants: &[(&str, f64)],
    operator: Option<&'static str>,
) -> wgpu::ComputePipeline {
    let kind = PipelineKind::Compute {
        stage: stage.to_owned(),
        entry: entry.to_owned(),
    };
    let key = PipelineKey::new(kind, format, constants, operator);
    ctx.cached_pipeline(key, || {
        let label = if entry == "main" {
            format!("tonegate.{stage}")
        } else {
            format!("tonegate.{stage}.{entry}")
        };
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(&label),
                source: wgpu::ShaderSource::Wgsl(
                    super::shaders::compose_with(stage, format, ctx.subgroups, operator).into(),
                ),
            });
        ctx.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(&label),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    zero_initialize_workgroup_memory: false,
                },
                cache: None,
            })
    })
}

/// An intermediate image: written as storage, read with textureLoad, copied out.
pub fn hdr_texture(
    ctx: &GpuContext,
    label: &str,
    width: u32,
    height: u32,
    format: HdrFormat,
) -> wgpu::Texture {
    texture(ctx, label, width, height, format.texture_format())
}

/// An intermediate of any format, with every intermediate's usages (COPY_DST
/// included: a storage texture without it made llvmpipe's GPU timestamps of
/// the whole process meaningless).
pub fn texture(
    ctx: &GpuContext,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    ctx.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

/// A bind group of whole buffers at their bindings for group 0 of
/// `pipeline` (whose layout the shader gave): the metrics' passes bind
/// nothing else.
pub fn bind_buffers(
    ctx: &GpuContext,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    entries: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = entries
        .iter()
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    ctx.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

/// A buffer holding `contents` from its creation.
pub fn buffer_with(
    ctx: &GpuContext,
    label: &str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    ctx.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage,
    })
}

/// A buffer the host maps to read what the GPU copied into it.
pub fn read_buffer(ctx: &GpuContext, label: &str, size: u64) -> wgpu::Buffer {
    ctx.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Uploads `img` (RGB f32) into the top-left corner of an RGBA texture of
/// `format` at least as large.
pub fn upload(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    img: &crate::image::HdrImage,
    format: HdrFormat,
) {
    let (wide, half);
    let bytes: &[u8] = match format {
        HdrFormat::Rgba32Float => {
            wide = img
                .pixels
                .iter()
                .flat_map(|p| [p[0], p[1], p[2], 1.0])
                .collect::<Vec<f32>>();
            bytemuck::cast_slice(&wide)
        }
        HdrFormat::Rgba16Float => {
            half = img
                .pixels
                .iter()
                .flat_map(|p| [p[0], p[1], p[2], 1.0].map(|c| half::f16::from_f32(c).to_bits()))
                .collect::<Vec<u16>>();
            bytemuck::cast_slice(&half)
        }
    };
    ctx.queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        bytes,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(img.width * format.bytes_per_pixel()),
            rows_per_image: Some(img.height),
        },
        wgpu::Extent3d {
            width: img.width,
            height: img.height,
            depth_or_array_layers: 1,
        },
    );
}

pub fn storage_buffer(ctx: &GpuContext, label: &str, size: u64) -> wgpu::Buffer {
    ctx.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A small buffer one stage writes as storage and later stages read as a
/// uniform: llvmpipe loads a uniform-buffer value once for all SIMD lanes,
/// while a storage load inside a per-pixel kernel goes lane by lane (it
/// cannot prove the first lane active), which cost tonemap ~1 ms per
/// 1080p frame for two scalars.
pub fn shared_buffer(ctx: &GpuContext, label: &str, size: u64) -> wgpu::Buffer {
    ctx.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        // Uniform bindings are read in 16-byte rows.
        size: size.max(16).div_ceil(16) * 16,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::UNIFORM
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

pub fn uniform_buffer(ctx: &GpuContext, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    let buffer = ctx.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (bytes.len() as u64).max(16),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    ctx.queue.write_buffer(&buffer, 0, bytes);
    buffer
}

/// A resource bound at one binding of group 0.
pub enum Bind<'a> {
    /// The whole texture (its default view).
    Texture(&'a wgpu::Texture),
    /// A view of one, as given.
    View(&'a wgpu::TextureView),
    Buffer(&'a wgpu::Buffer),
    Sampler(&'a wgpu::Sampler),
}

/// An image a stage reads: a view of a texture, with the size of the image
/// in it, which a view does not tell (its mip level's size, or less: an
/// image in the view's top-left corner).
#[derive(Clone, Debug)]
pub struct ImageView {
    pub view: wgpu::TextureView,
    pub width: u32,
    pub height: u32,
}

impl ImageView {
    /// The whole of `texture`'s first level.
    pub fn whole(texture: &wgpu::Texture) -> ImageView {
        ImageView {
            view: texture.create_view(&wgpu::TextureViewDescriptor::default()),
            width: texture.width(),
            height: texture.height(),
        }
    }
}

/// A bind group for `layout` from (binding, resource) pairs.
pub fn bind_group_for(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    label: &str,
    binds: &[(u32, Bind)],
) -> wgpu::BindGroup {
    let views: Vec<Option<wgpu::TextureView>> = binds
        .iter()
        .map(|(_, b)| match b {
            Bind::Texture(t) => Some(t.create_view(&wgpu::TextureViewDescriptor::default())),
            Bind::View(_) | Bind::Buffer(_) | Bind::Sampler(_) => None,
        })
        .collect();
    let entries: Vec<wgpu::BindGroupEntry> = binds
        .iter()
        .zip(&views)
        .map(|((binding, b), v)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: match (b, v) {
                (Bind::Buffer(buf), _) => buf.as_entire_binding(),
                (Bind::Sampler(s), _) => wgpu::BindingResource::Sampler(s),
                (Bind::View(view), _) => wgpu::BindingResource::TextureView(view),
                (Bind::Texture(_), Some(view)) => wgpu::BindingResource::TextureView(view),
                (Bind::Texture(_), None) => unreachable!("views are made for every texture"),
            },
        })
        .collect();
    ctx.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// A bind group for `pipeline` from (binding, resource) pairs: only the
/// bindings the entry point uses, since layouts are derived per entry.
pub fn bind_group(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    label: &str,
    binds: &[(u32, Bind)],
) -> wgpu::BindGroup {
    bind_group_for(ctx, &pipeline.get_bind_group_layout(0), label, binds)
}

/// Workgroups of `size` needed to cover `n`.
pub fn groups(n: u32, size: u32) -> u32 {
    n.div_ceil(size)
}

/// A dispatch: pipeline, bind group and workgroup counts, and for an entry
/// point that reads the frame's extent (shaders/shared/extent.wgsl), the
/// bind group of group 1 holding it.
#[derive(Clone)]
pub struct Dispatch {
    pub pipeline: wgpu::ComputePipeline,
    pub bind_group: wgpu::BindGroup,
    pub groups: (u32, u32),
    pub extent: Option<wgpu::BindGroup>,
}

impl Dispatch {
    pub fn new(
        pipeline: wgpu::ComputePipeline,
        bind_group: wgpu::BindGroup,
        groups: (u32, u32),
    ) -> Dispatch {
        Dispatch {
            pipeline,
            bind_group,
            groups,
            extent: None,
        }
    }

    /// Binds `extent` (the renderer's [`Extent`] uniform) as group 1: only
    /// for entry points that read it, since layouts are derived per entry.
    pub fn sized(mut self, ctx: &GpuContext, extent: &wgpu::Buffer) -> Dispatch {
        self.extent = Some(ctx.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tonegate.extent"),
            layout: &self.pipeline.get_bind_group_layout(1),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: extent.as_entire_binding(),
            }],
        }));
        self
    }

    pub fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        if let Some(extent) = &self.extent {
            pass.set_bind_group(1, extent, &[]);
        }
        pass.dispatch_workgroups(self.groups.0, self.groups.1, 1);
    }
}

/// Mirrors `Extent` in shaders/shared/extent.wgsl: the image's size and its
/// bloom's low-resolution size, inside textures that may be larger (a
/// renderer kept for a size class).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Extent {
    pub frame: [u32; 2],
    pub low: [u32; 2],
}

/// The uniform buffer of an [`Extent`], rewritten when a kept renderer takes
/// an image of another size.
pub fn extent_buffer(ctx: &GpuContext, extent: Extent) -> wgpu::Buffer {
    let buffer = ctx.create_buffer(&wgpu::BufferDescriptor {
        label: Some("tonegate.extent"),
        size: std::mem::size_of::<Extent>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    ctx.queue
        .write_buffer(&buffer, 0, bytemuck::bytes_of(&extent));
    buffer
}

/// Workgroup shape of the per-pixel passes: 64 pixels along a row, so a
/// group's SIMD lanes touch contiguous memory on llvmpipe.
pub const GROUP_X: u32 = 64;

/// A 2-D dispatch over `width`×`height` pixels in 64×1 workgroups.
pub fn dispatch_2d(
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    width: u32,
    height: u32,
) -> Dispatch {
    Dispatch::new(pipeline, bind_group, (groups(width, GROUP_X), height))
}

/// The extent of a frame of `size` with the bloom's `factor`.
pub(crate) fn extent_of(size: (u32, u32), bloom_factor: Option<u32>) -> Extent {
    let low = bloom_factor.map_or(size, |f| {
        crate::reference::bloom_downsample::downsampled_size(size.0, size.1, f)
    });
    Extent {
        frame: [size.0, size.1],
        low: [low.0, low.1],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_context_compiles_each_pipeline_variant_once() {
        let ctx = GpuContext::new(&crate::gpu::AdapterChoice::default()).expect("lavapipe");
        let a = pipeline(&ctx, "floor", "main", HdrFormat::Rgba32Float, &[]);
        let b = pipeline(&ctx, "floor", "main", HdrFormat::Rgba32Float, &[]);
        assert_eq!(a, b, "the second call is served from the cache");
        let c = pipeline(&ctx, "floor", "main", HdrFormat::Rgba16Float, &[]);
        assert_ne!(a, c, "another format is another pipeline");
        let d = pipeline(
            &ctx,
            "sphere",
            "main",
            HdrFormat::Rgba32Float,
            &[("SPP", 1.0)],
        );
        let e = pipeline(
            &ctx,
            "sphere",
            "main",
            HdrFormat::Rgba32Float,
            &[("SPP", 4.0)],
        );
        assert_ne!(d, e, "other override constants are another pipeline");
        assert_eq!(ctx.cached_pipelines(), 4);
    }
}
