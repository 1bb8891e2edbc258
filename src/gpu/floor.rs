//! `floor` pass: not a plan stage; the bench's unit of a fullscreen write.

use super::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use super::{GpuContext, HdrFormat};

/// A trivial fullscreen write of the same size and format: the bench's unit.
pub fn floor(ctx: &GpuContext, format: HdrFormat, out: &wgpu::Texture) -> Dispatch {
    let p = pipeline(ctx, "floor", "main", format, &[]);
    let bg = bind_group(ctx, &p, "tonegate.floor", &[(0, Bind::Texture(out))]);
    dispatch_2d(p, bg, out.width(), out.height())
}
