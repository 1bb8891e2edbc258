//! `grade_stats` pass: block sums of luminance and one ordered combine, or
//! the workgroup tree of `luminance_stats`.

use crate::gpu::stages::{bind_group, groups, pipeline, storage_buffer, Bind, Dispatch};
use crate::gpu::{GpuContext, HdrFormat, ReductionMethod};

const BLOCK: u32 = 16;

/// Mean luminance of `src` into `mean` (one f32), by the tree (shared
/// memory or subgroups) when `method` is one (already resolved), else by
/// block sums (the ping-pong method has no grade variant: its plans reduce
/// the grade's mean by blocks).
pub fn grade_stats(
    ctx: &GpuContext,
    format: HdrFormat,
    method: ReductionMethod,
    src: &wgpu::Texture,
    mean: &wgpu::Buffer,
    extent: &wgpu::Buffer,
) -> Vec<Dispatch> {
    let t = super::luminance_stats::TREE_TILE;
    let tiles = (groups(src.width(), t), groups(src.height(), t));
    let (side, entries, first_groups) = match method {
        ReductionMethod::Tree => (t, ("tree_sums", "tree_finish"), tiles),
        ReductionMethod::SubgroupTree => (t, ("subgroup_sums", "subgroup_finish"), tiles),
        _ => {
            let blocks = groups(src.width(), BLOCK) * groups(src.height(), BLOCK);
            (BLOCK, ("block_sums", "finish"), (groups(blocks, 64), 1))
        }
    };
    let blocks = groups(src.width(), side) * groups(src.height(), side);
    let sums = storage_buffer(ctx, "tonegate.grade_stats.sums", blocks as u64 * 8);
    let constants = [("BLOCK_W", BLOCK as f64), ("BLOCK_H", BLOCK as f64)];
    let p = pipeline(ctx, "grade_stats", entries.0, format, &constants);
    let bg = bind_group(
        ctx,
        &p,
        "tonegate.grade_stats",
        &[(0, Bind::Texture(src)), (1, Bind::Buffer(&sums))],
    );
    let first = Dispatch::new(p, bg, first_groups).sized(ctx, extent);
    let p = pipeline(ctx, "grade_stats", entries.1, format, &constants);
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
    vec![first, Dispatch::new(p, bg, (1, 1)).sized(ctx, extent)]
}
