//! `sphere` pass: renders the view of the rotating environment.

use super::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use super::EnvFilter;
use super::{GpuContext, HdrFormat};

/// The environment as the chosen filter reads it.
pub enum EnvSource<'a> {
    /// RGBA f32 texels in a storage buffer, for the manual bilinear.
    Buffer(&'a wgpu::Buffer),
    /// An Rgba32Float texture and a linear sampler.
    Texture(&'a wgpu::Texture, &'a wgpu::Sampler),
}

#[allow(clippy::too_many_arguments)]
pub fn sphere(
    ctx: &GpuContext,
    format: HdrFormat,
    spp: u32,
    frame: &wgpu::Buffer,
    env: EnvSource,
    env_size: (u32, u32),
    hdr_out: &wgpu::Texture,
) -> Dispatch {
    let filter = match env {
        EnvSource::Buffer(_) => EnvFilter::Manual,
        EnvSource::Texture(..) => EnvFilter::Hardware,
    };
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
        EnvSource::Buffer(buf) => bind_group(
            ctx,
            &p,
            "tonegate.sphere",
            &[
                (0, Bind::Buffer(frame)),
                (1, Bind::Buffer(buf)),
                (2, Bind::Texture(hdr_out)),
            ],
        ),
        EnvSource::Texture(tex, sampler) => bind_group(
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
