//! `histogram` pass: a frame's weighted log2-luminance histogram, what eye
//! adaptation meters under `metering = "histogram"` (shaders/histogram.wgsl;
//! the f64 reference is `reference::histogram`), counted into bins that
//! the `adaptation` pass reads and clears.

use crate::gpu::stages::{bind_group, pipeline, storage_buffer, Bind, Dispatch};
use crate::gpu::{GpuContext, HdrFormat, ReductionMethod};
use crate::scene::HISTOGRAM_BINS;

/// The histogram's bins, u32 each: `histogram` adds a frame's into them,
/// `adaptation` reads and clears them.
pub fn bins_buffer(ctx: &GpuContext) -> wgpu::Buffer {
    storage_buffer(ctx, "tonegate.adaptation.bins", (HISTOGRAM_BINS * 4) as u64)
}

/// The histogram pass over `hdr` (a texture of `size`, the frame within
/// `extent`), into `bins`: by blocks, one invocation each, where the
/// statistics reduce by blocks (a CPU adapter), else a workgroup per 16×64
/// tile counting in shared memory.
#[allow(clippy::too_many_arguments)]
pub fn histogram(
    ctx: &GpuContext,
    format: HdrFormat,
    reduction: ReductionMethod,
    weights: [f64; 3],
    hdr: &wgpu::TextureView,
    size: (u32, u32),
    bins: &wgpu::Buffer,
    steps: &wgpu::Buffer,
    extent: &wgpu::Buffer,
) -> Dispatch {
    let constants = [
        ("LUM_R", weights[0]),
        ("LUM_G", weights[1]),
        ("LUM_B", weights[2]),
    ];
    let by_blocks = reduction == ReductionMethod::BlockPartials;
    let entry = if by_blocks { "block" } else { "main" };
    let p = pipeline(ctx, "histogram", entry, format, &constants);
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.histogram",
        &[
            (0, Bind::View(hdr)),
            (1, Bind::Buffer(bins)),
            (2, Bind::Buffer(steps)),
        ],
    );
    let groups = if by_blocks {
        let blocks = size.0.div_ceil(32) * size.1.div_ceil(32);
        (blocks.div_ceil(64), 1)
    } else {
        (size.0.div_ceil(16), size.1.div_ceil(64))
    };
    Dispatch::new(p, bg, groups).sized(ctx, extent)
}
