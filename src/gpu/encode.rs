//! `encode` pass.

use super::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use super::{GpuContext, HdrFormat};
use crate::scene::Encoding;

/// The encoding's override constants (shaders/shared/encode.wgsl).
pub fn encode_constants(encoding: Encoding) -> [(&'static str, f64); 2] {
    match encoding {
        Encoding::Srgb => [("ENCODING", 0.0), ("GAMMA", 2.2)],
        Encoding::Gamma(g) => [("ENCODING", 1.0), ("GAMMA", g.get())],
    }
}

pub fn encode(
    ctx: &GpuContext,
    format: HdrFormat,
    encoding: Encoding,
    src: &wgpu::Texture,
    frame_out: &wgpu::Buffer,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(ctx, "encode", "main", format, &encode_constants(encoding));
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.encode",
        &[(0, Bind::Texture(src)), (1, Bind::Buffer(frame_out))],
    );
    dispatch_2d(p, bg, src.width(), src.height()).sized(ctx, extent)
}

/// `encode` into a caller's Rgba8Unorm storage texture (the same bytes as
/// [`encode`] packs into its buffer).
pub fn encode_to_texture(
    ctx: &GpuContext,
    format: HdrFormat,
    encoding: Encoding,
    src: &wgpu::Texture,
    frame_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(
        ctx,
        "encode",
        "to_texture",
        format,
        &encode_constants(encoding),
    );
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.encode.to_texture",
        &[(0, Bind::Texture(src)), (2, Bind::Texture(frame_out))],
    );
    dispatch_2d(p, bg, src.width(), src.height()).sized(ctx, extent)
}
