//! `taa_sobel` pass: the edge-aware TAA's aliasing amount per pixel, in an
//! r32float texture (shaders/taa_sobel.wgsl).

use super::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use super::{GpuContext, HdrFormat};

/// The amount texture: one f32 per pixel, written as storage, read by `taa`.
pub fn amount_texture(ctx: &GpuContext, width: u32, height: u32) -> wgpu::Texture {
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("tonegate.taa_sobel"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R32Float,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
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
