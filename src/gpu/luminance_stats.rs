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

#[cfg(test)]
mod tests {
    use super::{BLOCK, TREE_TILE};

    /// The f32 sum of `logs` (row-major, `w` wide) in the order the block
    /// method adds them (each 16×16 block row by row, then the blocks one
    /// after another) and in the tree's (shaders/luminance_stats.wgsl:
    /// 4 rows per invocation, halving over 256 invocations, the tiles
    /// strided over 256 invocations, halving again), both without the
    /// compensation terms: what a GPU compiler that drops them computes.
    fn uncompensated(logs: &[f32], w: usize, h: usize) -> (f32, f32) {
        let at = |x: usize, y: usize| if x < w && y < h { logs[y * w + x] } else { 0.0 };
        let (b, t) = (BLOCK as usize, TREE_TILE as usize);
        let mut serial = 0.0f32;
        for by in (0..h).step_by(b) {
            for bx in (0..w).step_by(b) {
                let mut p = 0.0f32;
                for y in by..by + b {
                    for x in bx..bx + b {
                        p += at(x, y);
                    }
                }
                serial += p;
            }
        }
        let halve = |v: &mut [f32]| {
            let mut s = v.len() / 2;
            while s > 0 {
                for i in 0..s {
                    v[i] += v[i + s];
                }
                s /= 2;
            }
            v[0]
        };
        let mut tiles = Vec::new();
        for ty in (0..h).step_by(t) {
            for tx in (0..w).step_by(t) {
                let mut lanes = [0.0f32; 256];
                for ly in 0..8 {
                    for lx in 0..32 {
                        for r in 0..4 {
                            lanes[ly * 32 + lx] += at(tx + lx, ty + r * 8 + ly);
                        }
                    }
                }
                tiles.push(halve(&mut lanes));
            }
        }
        let mut lanes = [0.0f32; 256];
        for (i, v) in tiles.iter().enumerate() {
            lanes[i % 256] += v;
        }
        (serial, halve(&mut lanes))
    }

    /// Issue 13: on an H100 the 8.4 Mpx stress case's statistics were
    /// 2.84e-5 off with block partials, as if the compensation were gone.
    /// Without it, the block method's serial order loses ~5e-6 of the mean
    /// log on that frame; the tree's pairwise order stays three orders of
    /// magnitude inside the 1e-5 bound, so it needs no compensation to hold.
    #[test]
    fn the_trees_order_holds_the_bound_on_8_mpx_without_compensation() {
        let img = crate::stress::cases::ramp(4096, 2048, 0.001, 5000.0);
        let (w, h) = (img.width as usize, img.height as usize);
        let logs: Vec<f32> = img
            .pixels
            .iter()
            .map(|p| (1e-5 + (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2])).ln())
            .collect();
        let exact: f64 = logs.iter().map(|&l| l as f64).sum();
        let n = logs.len() as f64;
        let (serial, tree) = uncompensated(&logs, w, h);
        // Error of the mean log = relative error of the log-average.
        let serial_err = (serial as f64 - exact).abs() / n;
        let tree_err = (tree as f64 - exact).abs() / n;
        println!("8.4 Mpx, no compensation: block order {serial_err:.2e}, tree {tree_err:.2e}");
        // Pairwise f32 sums err by at most ~log2(n)·ε·max|l| (23 × 6e-8 × 8.5
        // here); a tenth of the 1e-5 bound is asserted.
        assert!(tree_err <= 1e-6, "tree {tree_err:e}");
        assert!(
            serial_err >= 100.0 * tree_err,
            "serial {serial_err:e} vs tree {tree_err:e}"
        );
        // Odd sizes go through the same orders.
        let (w, h) = (1021, 509);
        let logs: Vec<f32> = (0..w * h)
            .map(|i| ((i % 977) as f32 * 0.01).ln_1p())
            .collect();
        let exact: f64 = logs.iter().map(|&l| l as f64).sum();
        let (_, tree) = uncompensated(&logs, w, h);
        let odd_err = (tree as f64 - exact).abs() / (w * h) as f64;
        assert!(odd_err <= 1e-6, "odd size: tree {odd_err:e}");
    }
}
