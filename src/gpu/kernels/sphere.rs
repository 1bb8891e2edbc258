//! `sphere` pass: renders the view of the rotating environment, from the
//! environment map uploaded the way the chosen filter reads it.

use crate::gpu::stages::{
    bind_group, dispatch_2d, pipeline, storage_buffer, upload, Bind, Dispatch,
};
use crate::gpu::{EnvFilter, GpuContext, GpuError, HdrFormat};
use crate::image::HdrImage;

/// The environment on the GPU, as the chosen filter reads it.
pub enum Environment {
    /// RGBA f32 texels in a storage buffer, for the manual bilinear: on
    /// llvmpipe plain loads cost less than textureLoad.
    Buffer {
        texels: wgpu::Buffer,
        size: (u32, u32),
    },
    /// An Rgba32Float texture and a linear sampler (the texture unit's filter).
    Texture {
        texture: wgpu::Texture,
        sampler: wgpu::Sampler,
        size: (u32, u32),
    },
}

impl Environment {
    /// Uploads `env` for `filter`, refusing what the adapter cannot hold.
    pub fn upload(ctx: &GpuContext, env: &HdrImage, filter: EnvFilter) -> Result<Self, GpuError> {
        let size = (env.width, env.height);
        match filter {
            EnvFilter::Manual => {
                let bytes = env.pixel_count() as u64 * 16;
                let limit = ctx.limits.max_storage_buffer_binding_size;
                if bytes > limit {
                    return Err(GpuError::EnvironmentTooLarge {
                        width: env.width,
                        height: env.height,
                        bytes,
                        limit,
                    });
                }
                let texels: Vec<f32> = env
                    .pixels
                    .iter()
                    .flat_map(|p| [p[0], p[1], p[2], 1.0])
                    .collect();
                let buffer = storage_buffer(ctx, "tonegate.sphere.environment", bytes);
                ctx.queue
                    .write_buffer(&buffer, 0, bytemuck::cast_slice(&texels));
                Ok(Environment::Buffer {
                    texels: buffer,
                    size,
                })
            }
            EnvFilter::Hardware => {
                if !ctx.float32_filterable {
                    return Err(GpuError::MissingFeature {
                        adapter: ctx.adapter.name.clone(),
                        feature: "FLOAT32_FILTERABLE",
                        what: "--env-filter hardware",
                    });
                }
                ctx.check_size(env.width, env.height)?;
                let texture = ctx.create_texture(&wgpu::TextureDescriptor {
                    label: Some("tonegate.sphere.environment"),
                    size: wgpu::Extent3d {
                        width: env.width,
                        height: env.height,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba32Float,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                });
                upload(ctx, &texture, env, HdrFormat::Rgba32Float);
                let sampler = ctx.device.create_sampler(&wgpu::SamplerDescriptor {
                    label: Some("tonegate.sphere.sampler"),
                    address_mode_u: wgpu::AddressMode::Repeat,
                    address_mode_v: wgpu::AddressMode::ClampToEdge,
                    mag_filter: wgpu::FilterMode::Linear,
                    min_filter: wgpu::FilterMode::Linear,
                    ..Default::default()
                });
                Ok(Environment::Texture {
                    texture,
                    sampler,
                    size,
                })
            }
        }
    }

    fn size(&self) -> (u32, u32) {
        match self {
            Environment::Buffer { size, .. } | Environment::Texture { size, .. } => *size,
        }
    }
}

pub fn sphere(
    ctx: &GpuContext,
    format: HdrFormat,
    spp: u32,
    frame: &wgpu::Buffer,
    env: &Environment,
    hdr_out: &wgpu::Texture,
) -> Dispatch {
    let filter = match env {
        Environment::Buffer { .. } => EnvFilter::Manual,
        Environment::Texture { .. } => EnvFilter::Hardware,
    };
    let env_size = env.size();
    let constants = [
        ("SPP", spp as f64),
        ("ENV_W", env_size.0 as f64),
        ("ENV_H", env_size.1 as f64),
    ];
    let entry = match filter {
        EnvFilter::Manual => "main",
        EnvFilter::Hardware => "main_hardware",
    };
    let p = pipeline(ctx, "sphere", entry, format, &constants);
    let bg = match env {
        Environment::Buffer { texels: buf, .. } => bind_group(
            ctx,
            &p,
            "tonegate.sphere",
            &[
                (0, Bind::Buffer(frame)),
                (1, Bind::Buffer(buf)),
                (2, Bind::Texture(hdr_out)),
            ],
        ),
        Environment::Texture {
            texture: tex,
            sampler,
            ..
        } => bind_group(
            ctx,
            &p,
            "tonegate.sphere",
            &[
                (0, Bind::Buffer(frame)),
                (2, Bind::Texture(hdr_out)),
                (3, Bind::Texture(tex)),
                (4, Bind::Sampler(sampler)),
            ],
        ),
    };
    dispatch_2d(p, bg, hdr_out.width(), hdr_out.height())
}

/// Mirrors `FrameUniforms` in shaders/shared/frame.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(in crate::gpu) struct FrameUniforms {
    pub(in crate::gpu) rot: [[f32; 4]; 3],
    pub(in crate::gpu) size: [u32; 2],
    pub(in crate::gpu) tan_half: f32,
    pub(in crate::gpu) aspect: f32,
    pub(in crate::gpu) jitter: [f32; 2],
    /// The scene's light at this frame (`[[light]]`).
    pub(in crate::gpu) light: f32,
    /// WGSL rounds the struct up to 16 bytes.
    pub(in crate::gpu) _pad: f32,
}
