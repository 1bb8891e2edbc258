//! `bloom_bright` pass.

use crate::gpu::stages::{bind_group, dispatch_2d, pipeline, Bind, Dispatch, ImageView};
use crate::gpu::{GpuContext, HdrFormat};
use crate::scene::{Bloom, BrightPass};

/// The bright pass's override constants (shaders/shared/bright.wgsl).
pub fn bright_constants(bloom: &Bloom, weights: [f64; 3]) -> [(&'static str, f64); 5] {
    [
        (
            "PASS",
            (bloom.bright_pass == BrightPass::Threshold) as u32 as f64,
        ),
        ("THRESHOLD", bloom.threshold.get()),
        ("LUM_R", weights[0]),
        ("LUM_G", weights[1]),
        ("LUM_B", weights[2]),
    ]
}

#[allow(clippy::too_many_arguments)]
pub fn bloom_bright(
    ctx: &GpuContext,
    format: HdrFormat,
    bloom: &Bloom,
    weights: [f64; 3],
    stats: &wgpu::Buffer,
    src: &ImageView,
    bright_out: &wgpu::Texture,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let p = pipeline(
        ctx,
        "bloom_bright",
        "main",
        format,
        &bright_constants(bloom, weights),
    );
    let binds = [
        (0, Bind::Buffer(stats)),
        (1, Bind::View(&src.view)),
        (2, Bind::Texture(bright_out)),
    ];
    let bg = bind_group(ctx, &p, "tonegate.bloom_bright", &binds);
    dispatch_2d(p, bg, src.width, src.height).sized(ctx, extent)
}
