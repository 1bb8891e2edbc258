//! `bloom_composite` pass.

use crate::gpu::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use crate::gpu::{GpuContext, HdrFormat};

pub fn bloom_composite(
    ctx: &GpuContext,
    format: HdrFormat,
    strength: f64,
    toned: &wgpu::Texture,
    bloom: &wgpu::Texture,
    composite_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(
        ctx,
        "bloom_composite",
        "main",
        format,
        &[("STRENGTH", strength)],
    );
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.bloom_composite",
        &[
            (0, Bind::Texture(toned)),
            (1, Bind::Texture(bloom)),
            (2, Bind::Texture(composite_out)),
        ],
    );
    dispatch_2d(p, bg, toned.width(), toned.height()).sized(ctx, extent)
}
