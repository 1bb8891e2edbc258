//! `grade_stats` pass: block sums of luminance, then one ordered combine.

use super::stages::{bind_group, groups, pipeline, storage_buffer, Bind, Dispatch};
use super::{GpuContext, HdrFormat};

const BLOCK: u32 = 16;

/// Mean luminance of `src` into `mean` (one f32).
pub fn grade_stats(
    ctx: &GpuContext,
    format: HdrFormat,
    src: &wgpu::Texture,
    mean: &wgpu::Buffer,
) -> Vec<Dispatch> {
    let blocks = groups(src.width(), BLOCK) * groups(src.height(), BLOCK);
    let sums = storage_buffer(ctx, "tonegate.grade_stats.sums", blocks as u64 * 8);
    let constants = [("BLOCK_W", BLOCK as f64), ("BLOCK_H", BLOCK as f64)];
    let p = pipeline(ctx, "grade_stats", "block_sums", format, &constants);
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.grade_stats",
        &[(0, Bind::Texture(src)), (1, Bind::Buffer(&sums))],
    );
    let first = Dispatch {
        pipeline: p,
        bind_group: bg,
        groups: (groups(blocks, 64), 1),
    };
    let p = pipeline(ctx, "grade_stats", "finish", format, &constants);
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.grade_stats.finish",
        &[
            (0, Bind::Texture(src)),
            (1, Bind::Buffer(&sums)),
            (2, Bind::Buffer(mean)),
        ],
    );
    vec![
        first,
        Dispatch {
            pipeline: p,
            bind_group: bg,
            groups: (1, 1),
        },
    ]
}
