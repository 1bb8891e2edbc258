// luminance_stats: min, max, Σ ln(δ+Y), Σ w·ln(δ+Y), Σ w of the HDR frame.
// Three methods: single-pass block partials (`block_partials`, then `finish`
// over the partials; from the modified Reinhard for training simulators), 2×2
// ping-pong downsampling (`downsample_first`, `downsample_step` repeatedly,
// then `finish`; from Reinhard's global operator in real time; both in
// docs/bibliography.md), and a workgroup tree (`tree_partials`, then
// `tree_finish`) for GPUs, where one
// invocation walking thousands of partials serially is the slowest part,
// also with subgroup operations (`subgroup_partials`, `subgroup_finish`)
// where the device has them.
// Sums are Neumaier-compensated in f32 so 2 Mpx stay within 1e-6 of f64.
// Blocks, tiles and levels cover the textures (a size class, see
// shared/extent.wgsl); only pixels inside `extent.frame` are read, so those
// beyond it reduce to empty partials, which every merge leaves unchanged.
//#include shared/colour.wgsl
//#include shared/stats.wgsl
//#include shared/extent.wgsl

override LUM_R: f32 = 0.2126;
override LUM_G: f32 = 0.7152;
override LUM_B: f32 = 0.0722;
override DELTA: f32 = 1e-4;
// Only what the plan needs is computed.
override NEED_LOG: bool = true;
override NEED_WEIGHTED: bool = false;
// Block of pixels one invocation reduces (block method).
override BLOCK_W: u32 = 16u;
override BLOCK_H: u32 = 16u;

struct Level {
    // Size of the level being read (partials grid or the frame).
    src_size: vec2<u32>,
    // Size of the level being written.
    dst_size: vec2<u32>,
}

@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> partials_a: array<Partial>;
@group(0) @binding(2) var<storage, read_write> partials_b: array<Partial>;
@group(0) @binding(3) var<storage, read_write> stats: Stats;
@group(0) @binding(4) var<uniform> level: Level;

fn pixel_partial(c: vec3<f32>) -> Partial {
    var p = empty_partial();
    let y = luminance_with(c, vec3<f32>(LUM_R, LUM_G, LUM_B));
    p.min_y = y;
    p.max_y = y;
    if (NEED_LOG || NEED_WEIGHTED) {
        let l = log(DELTA + y);
        p.log_sum = l;
        if (NEED_WEIGHTED) {
            // w = 1 − e^(−Y) = −expm1(−Y). Below 0.03 the subtraction would
            // lose up to ε/Y; the series Y(1 − Y/2(1 − Y/3(1 − Y/4))) is then
            // accurate to 2e-10 relative instead.
            var w = 1.0 - exp(-y);
            if (y < 0.03) {
                w = y * (1.0 - 0.5 * y * (1.0 - y / 3.0 * (1.0 - 0.25 * y)));
            }
            p.wlog_sum = w * l;
            p.w_sum = w;
        }
    }
    return p;
}

fn add_pixel(p: Partial, c: vec3<f32>) -> Partial {
    return merge_partial(p, pixel_partial(c));
}

// One invocation per BLOCK_W×BLOCK_H block, no barriers: on llvmpipe this ran
// 6–12× faster than a shared-memory tree.
@compute @workgroup_size(64)
fn block_partials(@builtin(global_invocation_id) id: vec3<u32>) {
    let grid = textureDimensions(hdr);
    let dims = extent.frame;
    let bx_count = (grid.x + BLOCK_W - 1u) / BLOCK_W;
    let by_count = (grid.y + BLOCK_H - 1u) / BLOCK_H;
    if (id.x >= bx_count * by_count) {
        return;
    }
    let bx = id.x % bx_count;
    let by = id.x / bx_count;
    let x0 = bx * BLOCK_W;
    let y0 = by * BLOCK_H;
    let x1 = min(x0 + BLOCK_W, dims.x);
    let y1 = min(y0 + BLOCK_H, dims.y);
    var p = empty_partial();
    for (var y = y0; y < y1; y = y + 1u) {
        for (var x = x0; x < x1; x = x + 1u) {
            p = add_pixel(p, textureLoad(hdr, vec2<u32>(x, y), 0).rgb);
        }
    }
    partials_a[id.x] = p;
}

// First ping-pong level: each invocation reduces a 2×2 block of pixels;
// blocks cut by an odd edge reduce only the pixels they have.
@compute @workgroup_size(64, 1)
fn downsample_first(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= level.dst_size.x || id.y >= level.dst_size.y) {
        return;
    }
    var p = empty_partial();
    for (var dy = 0u; dy < 2u; dy = dy + 1u) {
        for (var dx = 0u; dx < 2u; dx = dx + 1u) {
            let s = vec2<u32>(id.x * 2u + dx, id.y * 2u + dy);
            if (s.x < extent.frame.x && s.y < extent.frame.y) {
                p = add_pixel(p, textureLoad(hdr, s, 0).rgb);
            }
        }
    }
    partials_a[id.y * level.dst_size.x + id.x] = p;
}

// Later levels: 2×2 partials of `partials_a` into `partials_b` (the host swaps
// the bindings between levels).
@compute @workgroup_size(64, 1)
fn downsample_step(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= level.dst_size.x || id.y >= level.dst_size.y) {
        return;
    }
    var p = empty_partial();
    for (var dy = 0u; dy < 2u; dy = dy + 1u) {
        for (var dx = 0u; dx < 2u; dx = dx + 1u) {
            let s = vec2<u32>(id.x * 2u + dx, id.y * 2u + dy);
            if (s.x < level.src_size.x && s.y < level.src_size.y) {
                p = merge_partial(p, partials_a[s.y * level.src_size.x + s.x]);
            }
        }
    }
    partials_b[id.y * level.dst_size.x + id.x] = p;
}

// Combines the `level.src_size.x` partials of `partials_a` in order and
// writes the statistics.
@compute @workgroup_size(1)
fn finish() {
    var p = empty_partial();
    for (var i = 0u; i < level.src_size.x; i = i + 1u) {
        p = merge_partial(p, partials_a[i]);
    }
    write_stats(p);
}

// The statistics of the whole frame's partial `p`. Σw = 0 falls back to the
// plain log-average.
fn write_stats(p: Partial) {
    let dims = extent.frame;
    let n = f32(dims.x) * f32(dims.y);
    let log_average = exp((p.log_sum + p.log_c) / n);
    let w = p.w_sum + p.w_c;
    var weighted = log_average;
    if (w > 0.0) {
        weighted = exp((p.wlog_sum + p.wlog_c) / w);
    }
    stats.log_average = log_average;
    stats.weighted_log_average = weighted;
    stats.min_y = p.min_y;
    stats.max_y = p.max_y;
    stats.weight_sum = w;
}

// Workgroup tree. One workgroup of TREE_X×TREE_Y invocations reduces a
// TREE_X-wide, TREE_Y·TREE_ROWS-tall tile: each invocation sums TREE_ROWS
// pixels down its column (neighbouring invocations read neighbouring pixels),
// then the workgroup halves its partials in shared memory until one is left.
// Pairwise order keeps the f32 error near log₂(n)·ε even where a compiler
// drops the compensation terms.
const TREE_X: u32 = 32u;
const TREE_Y: u32 = 8u;
const TREE_ROWS: u32 = 4u;
const TREE_SIZE: u32 = 256u;
var<workgroup> tree: array<Partial, TREE_SIZE>;

fn tree_halve(li: u32) {
    for (var s = TREE_SIZE / 2u; s > 0u; s = s / 2u) {
        if (li < s) {
            tree[li] = merge_partial(tree[li], tree[li + s]);
        }
        workgroupBarrier();
    }
}

// The invocation's TREE_ROWS pixels of workgroup `wg`'s tile, merged.
fn tile_partial(wg: vec3<u32>, lid: vec3<u32>) -> Partial {
    let dims = extent.frame;
    let x = wg.x * TREE_X + lid.x;
    var p = empty_partial();
    if (x < dims.x) {
        for (var r = 0u; r < TREE_ROWS; r = r + 1u) {
            let y = (wg.y * TREE_ROWS + r) * TREE_Y + lid.y;
            if (y < dims.y) {
                p = add_pixel(p, textureLoad(hdr, vec2<u32>(x, y), 0).rgb);
            }
        }
    }
    return p;
}

// The invocation's share of the `level.src_size.x` partials: every
// TREE_SIZE-th, merged.
fn strided_partial(li: u32) -> Partial {
    var p = empty_partial();
    for (var i = li; i < level.src_size.x; i = i + TREE_SIZE) {
        p = merge_partial(p, partials_a[i]);
    }
    return p;
}

@compute @workgroup_size(32, 8)
fn tree_partials(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    tree[li] = tile_partial(wg, lid);
    workgroupBarrier();
    tree_halve(li);
    if (li == 0u) {
        partials_a[wg.y * groups.x + wg.x] = tree[0];
    }
}

// One workgroup: each invocation merges every TREE_SIZE-th of the
// `level.src_size.x` partials, the tree merges those, and invocation 0
// writes the statistics as `finish` does.
@compute @workgroup_size(256)
fn tree_finish(@builtin(local_invocation_index) li: u32) {
    tree[li] = strided_partial(li);
    workgroupBarrier();
    tree_halve(li);
    if (li == 0u) {
        write_stats(tree[0]);
    }
}

//#if subgroups
// Subgroup tree: the same tiles and shares, merged within each subgroup by a
// butterfly of shuffles (lane i with lane i^1, then i^2, ...: pairwise and
// compensated, no shared memory, no barrier); one partial per subgroup goes
// to shared memory, and every subgroup merges those the same way, so each
// subgroup operation runs in uniform control flow; invocation 0's result is
// the one used. Subgroups are assumed full: 256 invocations fill any
// power-of-two subgroup size up to 128, though Vulkan does not promise full
// subgroups unless a pipeline asks for them.
//#include shared/subgroup.wgsl

fn shuffle_partial(p: Partial, mask: u32) -> Partial {
    let a = subgroupShuffleXor(vec4<f32>(p.min_y, p.max_y, p.log_sum, p.log_c), mask);
    let b = subgroupShuffleXor(vec4<f32>(p.wlog_sum, p.wlog_c, p.w_sum, p.w_c), mask);
    return Partial(a.x, a.y, a.z, a.w, b.x, b.y, b.z, b.w);
}

fn subgroup_merge(p: Partial, size: u32) -> Partial {
    var r = p;
    for (var m = 1u; m < size; m = m * 2u) {
        r = merge_partial(r, shuffle_partial(r, m));
    }
    return r;
}

fn workgroup_merge(p: Partial, lanes: Lanes) -> Partial {
    let r = subgroup_merge(p, lanes.size);
    if (lanes.lane == 0u) {
        tree[lanes.id] = r;
    }
    workgroupBarrier();
    var q = empty_partial();
    for (var i = lanes.lane; i < lanes.count; i = i + lanes.size) {
        q = merge_partial(q, tree[i]);
    }
    return subgroup_merge(q, lanes.size);
}

// One-dimensional (subgroup builtins need it), the tile's 32×8 layout
// recovered from the invocation index.
@compute @workgroup_size(256)
fn subgroup_partials(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    lanes: Lanes,
) {
    let lid = vec3<u32>(lanes.li % TREE_X, lanes.li / TREE_X, 0u);
    let p = workgroup_merge(tile_partial(wg, lid), lanes);
    if (lanes.li == 0u) {
        partials_a[wg.y * groups.x + wg.x] = p;
    }
}

@compute @workgroup_size(256)
fn subgroup_finish(lanes: Lanes) {
    let p = workgroup_merge(strided_partial(lanes.li), lanes);
    if (lanes.li == 0u) {
        write_stats(p);
    }
}
//#endif
