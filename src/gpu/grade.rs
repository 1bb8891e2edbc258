//! `grade` pass.

use super::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use super::{GpuContext, HdrFormat};
use crate::scene::Grade;

pub fn grade(
    ctx: &GpuContext,
    format: HdrFormat,
    g: &Grade,
    mean: &wgpu::Buffer,
    src: &wgpu::Texture,
    graded_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let constants = [
        ("BRIGHTNESS", g.brightness.get()),
        ("CONTRAST", g.contrast.get()),
        ("SATURATION", g.saturation.get()),
    ];
    let p = pipeline(ctx, "grade", "main", format, &constants);
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.grade",
        &[
            (0, Bind::Buffer(mean)),
            (1, Bind::Texture(src)),
            (2, Bind::Texture(graded_out)),
        ],
    );
    dispatch_2d(p, bg, src.width(), src.height()).sized(ctx, extent)
}
