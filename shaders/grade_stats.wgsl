// grade_stats: mean BT.709 luminance of the frame entering the grade
// (contrast's grey), by barrier-free block sums and one ordered combine
// (`block_sums`, `finish`: CPU adapters), or by a workgroup tree
// (`tree_sums`, `tree_finish`: GPUs), as luminance_stats reduces. Blocks and
// tiles cover the texture, pixels are read inside `extent.frame` only (see
// luminance_stats.wgsl).
//#include shared/colour.wgsl
//#include shared/stats.wgsl
//#include shared/extent.wgsl

override BLOCK_W: u32 = 16u;
override BLOCK_H: u32 = 16u;

struct GradeMean {
    mean: f32,
}

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> sums: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> grade_mean: GradeMean;

@compute @workgroup_size(64)
fn block_sums(@builtin(global_invocation_id) id: vec3<u32>) {
    let grid = textureDimensions(src);
    let dims = extent.frame;
    let bx_count = (grid.x + BLOCK_W - 1u) / BLOCK_W;
    let by_count = (grid.y + BLOCK_H - 1u) / BLOCK_H;
    if (id.x >= bx_count * by_count) {
        return;
    }
    let x0 = (id.x % bx_count) * BLOCK_W;
    let y0 = (id.x / bx_count) * BLOCK_H;
    var s = vec2<f32>(0.0);
    for (var y = y0; y < min(y0 + BLOCK_H, dims.y); y = y + 1u) {
        for (var x = x0; x < min(x0 + BLOCK_W, dims.x); x = x + 1u) {
            let c = textureLoad(src, vec2<u32>(x, y), 0).rgb;
            s = kahan_add(s.x, s.y, luminance_with(c, vec3<f32>(0.2126, 0.7152, 0.0722)));
        }
    }
    sums[id.x] = s;
}

@compute @workgroup_size(1)
fn finish() {
    let grid = textureDimensions(src);
    let dims = extent.frame;
    let blocks = ((grid.x + BLOCK_W - 1u) / BLOCK_W) * ((grid.y + BLOCK_H - 1u) / BLOCK_H);
    var s = vec2<f32>(0.0);
    for (var i = 0u; i < blocks; i = i + 1u) {
        s = kahan_add(s.x, s.y, sums[i].x);
        s = kahan_add(s.x, s.y, sums[i].y);
    }
    grade_mean.mean = (s.x + s.y) / (f32(dims.x) * f32(dims.y));
}

// Workgroup tree: the tiles and order of luminance_stats' tree_partials.
const TREE_X: u32 = 32u;
const TREE_Y: u32 = 8u;
const TREE_ROWS: u32 = 4u;
const TREE_SIZE: u32 = 256u;
var<workgroup> tree: array<vec2<f32>, TREE_SIZE>;

// (sum, compensation) pairs merged as luminance_stats merges its partials.
fn merge_sum(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let s = kahan_add(a.x, a.y, b.x);
    return kahan_add(s.x, s.y, b.y);
}

fn tree_halve(li: u32) {
    for (var s = TREE_SIZE / 2u; s > 0u; s = s / 2u) {
        if (li < s) {
            tree[li] = merge_sum(tree[li], tree[li + s]);
        }
        workgroupBarrier();
    }
}

// The invocation's TREE_ROWS pixels of workgroup `wg`'s tile, summed.
fn tile_sum(wg: vec3<u32>, lid: vec3<u32>) -> vec2<f32> {
    let dims = extent.frame;
    let x = wg.x * TREE_X + lid.x;
    var s = vec2<f32>(0.0);
    if (x < dims.x) {
        for (var r = 0u; r < TREE_ROWS; r = r + 1u) {
            let y = (wg.y * TREE_ROWS + r) * TREE_Y + lid.y;
            if (y < dims.y) {
                let c = textureLoad(src, vec2<u32>(x, y), 0).rgb;
                s = kahan_add(s.x, s.y, luminance_with(c, vec3<f32>(0.2126, 0.7152, 0.0722)));
            }
        }
    }
    return s;
}

// The invocation's share of the tiles' sums: every TREE_SIZE-th, merged.
fn strided_sum(li: u32) -> vec2<f32> {
    let grid = textureDimensions(src);
    let tiles = ((grid.x + TREE_X - 1u) / TREE_X) * ((grid.y + TREE_Y * TREE_ROWS - 1u) / (TREE_Y * TREE_ROWS));
    var s = vec2<f32>(0.0);
    for (var i = li; i < tiles; i = i + TREE_SIZE) {
        s = merge_sum(s, sums[i]);
    }
    return s;
}

fn write_mean(s: vec2<f32>) {
    let dims = extent.frame;
    grade_mean.mean = (s.x + s.y) / (f32(dims.x) * f32(dims.y));
}

@compute @workgroup_size(32, 8)
fn tree_sums(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    tree[li] = tile_sum(wg, lid);
    workgroupBarrier();
    tree_halve(li);
    if (li == 0u) {
        sums[wg.y * groups.x + wg.x] = tree[0];
    }
}

@compute @workgroup_size(256)
fn tree_finish(@builtin(local_invocation_index) li: u32) {
    tree[li] = strided_sum(li);
    workgroupBarrier();
    tree_halve(li);
    if (li == 0u) {
        write_mean(tree[0]);
    }
}

//#if subgroups
// Subgroup tree: luminance_stats' butterfly of shuffles on the sums.
//#include shared/subgroup.wgsl

fn subgroup_merge(s: vec2<f32>, size: u32) -> vec2<f32> {
    var r = s;
    for (var m = 1u; m < size; m = m * 2u) {
        r = merge_sum(r, subgroupShuffleXor(r, m));
    }
    return r;
}

fn workgroup_merge(s: vec2<f32>, lanes: Lanes) -> vec2<f32> {
    let r = subgroup_merge(s, lanes.size);
    if (lanes.lane == 0u) {
        tree[lanes.id] = r;
    }
    workgroupBarrier();
    var q = vec2<f32>(0.0);
    for (var i = lanes.lane; i < lanes.count; i = i + lanes.size) {
        q = merge_sum(q, tree[i]);
    }
    return subgroup_merge(q, lanes.size);
}

// One-dimensional (subgroup builtins need it), the tile's 32×8 layout
// recovered from the invocation index.
@compute @workgroup_size(256)
fn subgroup_sums(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    lanes: Lanes,
) {
    let lid = vec3<u32>(lanes.li % TREE_X, lanes.li / TREE_X, 0u);
    let s = workgroup_merge(tile_sum(wg, lid), lanes);
    if (lanes.li == 0u) {
        sums[wg.y * groups.x + wg.x] = s;
    }
}

@compute @workgroup_size(256)
fn subgroup_finish(lanes: Lanes) {
    let s = workgroup_merge(strided_sum(lanes.li), lanes);
    if (lanes.li == 0u) {
        write_mean(s);
    }
}
//#endif
