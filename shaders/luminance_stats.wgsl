// luminance_stats: min, max, Σ ln(δ+Y), Σ w·ln(δ+Y), Σ w of the HDR frame.
// Two methods: seed 001's single-pass block partials (`block_partials`, then
// `finish` over the partials) and seed 000's 2×2 ping-pong downsampling
// (`downsample_first`, `downsample_step` repeatedly, then `finish`).
// Sums are Neumaier-compensated in f32 so 2 Mpx stay within 1e-6 of f64.
//#include shared/colour.wgsl
//#include shared/stats.wgsl

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
    let dims = textureDimensions(hdr);
    let bx_count = (dims.x + BLOCK_W - 1u) / BLOCK_W;
    let by_count = (dims.y + BLOCK_H - 1u) / BLOCK_H;
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
            if (s.x < level.src_size.x && s.y < level.src_size.y) {
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
// writes the statistics. Σw = 0 falls back to the plain log-average.
@compute @workgroup_size(1)
fn finish() {
    let dims = textureDimensions(hdr);
    let n = f32(dims.x) * f32(dims.y);
    var p = empty_partial();
    for (var i = 0u; i < level.src_size.x; i = i + 1u) {
        p = merge_partial(p, partials_a[i]);
    }
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
