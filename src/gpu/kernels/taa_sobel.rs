//! `taa_sobel` pass: the edge-aware TAA's aliasing amount per pixel, in an
//! r32float texture (shaders/taa_sobel.wgsl).

use crate::gpu::stages::{bind_group, dispatch_2d, pipeline, texture, Bind, Dispatch};
use crate::gpu::{GpuContext, HdrFormat};

/// The amount texture: one f32 per pixel, written as storage, read by `taa`.
pub fn amount_texture(ctx: &GpuContext, width: u32, height: u32) -> wgpu::Texture {
    texture(
        ctx,
        "tonegate.taa_sobel",
        width,
        height,
        wgpu::TextureFormat::R32Float,
    )
}

pub fn taa_sobel(
    ctx: &GpuContext,
    format: HdrFormat,
    current: &wgpu::Texture,
    amount_out: &wgpu::Texture,
) -> Dispatch {
    let p = pipeline(ctx, "taa_sobel", "main", format, &[]);
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.taa_sobel",
        &[(0, Bind::Texture(current)), (1, Bind::Texture(amount_out))],
    );
    dispatch_2d(p, bg, current.width(), current.height())
}
