//! `bloom_downsample` pass.

use crate::gpu::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use crate::gpu::{GpuContext, HdrFormat};

pub fn bloom_downsample(
    ctx: &GpuContext,
    format: HdrFormat,
    factor: u32,
    src: &wgpu::Texture,
    low_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(
        ctx,
        "bloom_downsample",
        "main",
        format,
        &[("FACTOR", factor as f64)],
    );
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.bloom_downsample",
        &[(0, Bind::Texture(src)), (1, Bind::Texture(low_out))],
    );
    dispatch_2d(p, bg, low_out.width(), low_out.height()).sized(ctx, extent)
}
