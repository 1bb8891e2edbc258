//! `floor` passes: not plan stages; the bench's units of a fullscreen write.

use crate::gpu::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use crate::gpu::{GpuContext, HdrFormat};

/// A trivial fullscreen write of the same size and format: the bench's unit.
pub fn floor(ctx: &GpuContext, format: HdrFormat, out: &wgpu::Texture) -> Dispatch {
    let p = pipeline(ctx, "floor", "main", format, &[]);
    let bg = bind_group(ctx, &p, "tonegate.floor", &[(0, Bind::Texture(out))]);
    dispatch_2d(p, bg, out.width(), out.height())
}

/// One load and one store per pixel, from `input` to `out` (same size): the
/// minimum of a stage that reads a frame and writes one.
pub fn floor_rw(
    ctx: &GpuContext,
    format: HdrFormat,
    input: &wgpu::Texture,
    out: &wgpu::Texture,
) -> Dispatch {
    let p = pipeline(ctx, "floor", "main_rw", format, &[]);
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.floor_rw",
        &[(0, Bind::Texture(out)), (1, Bind::Texture(input))],
    );
    dispatch_2d(p, bg, out.width(), out.height())
}
