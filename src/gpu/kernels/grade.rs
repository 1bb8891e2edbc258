//! `grade` pass.

use crate::gpu::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch};
use crate::gpu::{GpuContext, HdrFormat};
use crate::scene::Grade;

/// The grade's override constants (shaders/grade.wgsl).
pub fn grade_constants(g: &Grade) -> [(&'static str, f64); 3] {
    [
        ("BRIGHTNESS", g.brightness.get()),
        ("CONTRAST", g.contrast.get()),
        ("SATURATION", g.saturation.get()),
    ]
}

pub fn grade(
    ctx: &GpuContext,
    format: HdrFormat,
    g: &Grade,
    mean: &wgpu::Buffer,
    src: &wgpu::Texture,
    graded_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(ctx, "grade", "main", format, &grade_constants(g));
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
