//! `luminance_stats` pass: block partials (seed 001), 2×2 ping-pong (seed
//! 000) or a workgroup tree.

use super::stages::{bind_group, groups, pipeline, storage_buffer, uniform_buffer, Bind, Dispatch};
use super::{GpuContext, HdrFormat, ReductionMethod};
use crate::plan::StatsNeeds;

/// Bytes of one `Partial` (8 × f32).
const PARTIAL_BYTES: u64 = 32;
/// Pixels per invocation of the block method.
pub const BLOCK: u32 = 16;
/// Side of the square tile one workgroup of the tree method reduces
/// (shaders/luminance_stats.wgsl: TREE_X, TREE_Y·TREE_ROWS).
pub const TREE_TILE: u32 = 32;

/// The dispatches that reduce `hdr` into `stats`.
#[allow(clippy::too_many_arguments)]
pub fn luminance_stats(
    ctx: &GpuContext,
    format: HdrFormat,
    method: ReductionMethod,
    needs: StatsNeeds,
    weights: [f64; 3],
    delta: f64,
    hdr: &wgpu::Texture,
    stats: &wgpu::Buffer,
) -> Vec<Dispatch> {
    let (w, h) = (hdr.width(), hdr.height());
    let constants = [
        ("LUM_R", weights[0]),
        ("LUM_G", weights[1]),
        ("LUM_B", weights[2]),
        ("DELTA", delta),
        (
            "NEED_LOG",
            (needs.log_average || needs.weighted_log_average) as u32 as f64,
        ),
        ("NEED_WEIGHTED", needs.weighted_log_average as u32 as f64),
        ("BLOCK_W", BLOCK as f64),
        ("BLOCK_H", BLOCK as f64),
    ];
    let level = |src: (u32, u32), dst: (u32, u32)| {
        let words = [src.0, src.1, dst.0, dst.1];
        uniform_buffer(
            ctx,
            "tonegate.luminance_stats.level",
            bytemuck::cast_slice(&words),
        )
    };
    let mut out = Vec::new();
    match method {
        ReductionMethod::Tree | ReductionMethod::BlockPartials | ReductionMethod::Auto => {
            // One pass of partials (a workgroup per 32×32 tile, or an
            // invocation per 16×16 block), then one combine.
            let (first, combine, n, first_groups) = match method {
                ReductionMethod::Tree => {
                    let tiles = (groups(w, TREE_TILE), groups(h, TREE_TILE));
                    ("tree_partials", "tree_finish", tiles.0 * tiles.1, tiles)
                }
                _ => {
                    let blocks = groups(w, BLOCK) * groups(h, BLOCK);
                    ("block_partials", "finish", blocks, (groups(blocks, 64), 1))
                }
            };
            let a = storage_buffer(
                ctx,
                "tonegate.luminance_stats.partials",
                n as u64 * PARTIAL_BYTES,
            );
            let p = pipeline(ctx, "luminance_stats", first, format, &constants);
            let bg = bind_group(
                ctx,
                &p,
                "tonegate.luminance_stats",
                &[(0, Bind::Texture(hdr)), (1, Bind::Buffer(&a))],
            );
            out.push(Dispatch {
                pipeline: p,
                bind_group: bg,
                groups: first_groups,
            });
            let lv = level((n, 1), (1, 1));
            let p = pipeline(ctx, "luminance_stats", combine, format, &constants);
            let bg = bind_group(
                ctx,
                &p,
                "tonegate.luminance_stats.finish",
                &[
                    (0, Bind::Texture(hdr)),
                    (1, Bind::Buffer(&a)),
                    (3, Bind::Buffer(stats)),
                    (4, Bind::Buffer(&lv)),
                ],
            );
            out.push(Dispatch {
                pipeline: p,
                bind_group: bg,
                groups: (1, 1),
            });
        }
        ReductionMethod::PingPong => {
            // log2 levels, each ceil(size/2): odd sizes keep their last row/column.
            let first = (w.div_ceil(2), h.div_ceil(2));
            let cap = first.0 as u64 * first.1 as u64 * PARTIAL_BYTES;
            let bufs = [
                storage_buffer(ctx, "tonegate.luminance_stats.ping", cap),
                storage_buffer(ctx, "tonegate.luminance_stats.pong", cap),
            ];
            let p = pipeline(
                ctx,
                "luminance_stats",
                "downsample_first",
                format,
                &constants,
            );
            let lv = level((w, h), first);
            let bg = bind_group(
                ctx,
                &p,
                "tonegate.luminance_stats.first",
                &[
                    (0, Bind::Texture(hdr)),
                    (1, Bind::Buffer(&bufs[0])),
                    (4, Bind::Buffer(&lv)),
                ],
            );
            out.push(Dispatch {
                pipeline: p,
                bind_group: bg,
                groups: (groups(first.0, super::stages::GROUP_X), first.1),
            });
            let step = pipeline(
                ctx,
                "luminance_stats",
                "downsample_step",
                format,
                &constants,
            );
            let mut size = first;
            let mut current = 0usize;
            while size != (1, 1) {
                let next = (size.0.div_ceil(2), size.1.div_ceil(2));
                let p = step.clone();
                let lv = level(size, next);
                let bg = bind_group(
                    ctx,
                    &p,
                    "tonegate.luminance_stats.step",
                    &[
                        (1, Bind::Buffer(&bufs[current])),
                        (2, Bind::Buffer(&bufs[1 - current])),
                        (4, Bind::Buffer(&lv)),
                    ],
                );
                out.push(Dispatch {
                    pipeline: p,
                    bind_group: bg,
                    groups: (groups(next.0, super::stages::GROUP_X), next.1),
                });
                current = 1 - current;
                size = next;
            }
            let finish = pipeline(ctx, "luminance_stats", "finish", format, &constants);
            let lv = level((1, 1), (1, 1));
            let bg = bind_group(
                ctx,
                &finish,
                "tonegate.luminance_stats.finish",
                &[
                    (0, Bind::Texture(hdr)),
                    (1, Bind::Buffer(&bufs[current])),
                    (3, Bind::Buffer(stats)),
                    (4, Bind::Buffer(&lv)),
                ],
            );
            out.push(Dispatch {
                pipeline: finish,
                bind_group: bg,
                groups: (1, 1),
            });
        }
    }
    out
}
