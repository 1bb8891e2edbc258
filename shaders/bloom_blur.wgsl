// bloom_blur: one 1-D Gaussian pass (the host runs it horizontally, then
// vertically), clamping at the edges. Weights come from the host (f64 → f32).
//
// Each invocation writes RUN consecutive pixels along the pass and loads
// every source texel of their window once (RUN + 2·RADIUS loads instead of
// RUN·(2·RADIUS + 1)); on llvmpipe a texel load costs far more than a
// multiply-add. Each output still sums its taps in the order k = −r..r, the
// same products added in the same order as one tap loop per pixel, so the
// result does not depend on RUN.

override HORIZONTAL: bool = true;
override RADIUS: u32 = 6u;

// Pixels per invocation (the four accumulators below); the host divides the
// dispatch by the same number.
const RUN: i32 = 4;

//#include shared/extent.wgsl

// Up to 2·64 + 1 taps, four to a row (uniform arrays have a 16-byte
// stride). A uniform buffer, not a storage one: llvmpipe loads a uniform
// value once for all lanes from a uniform buffer, but loads storage lane by
// lane unless it can prove lane 0 is active.
@group(0) @binding(0) var<uniform> weights: array<vec4<f32>, 33>;

fn weight(k: i32) -> f32 {
    return weights[k / 4][k % 4];
}
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var blur_out: texture_storage_2d<HDR_FORMAT, write>;

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = vec2<i32>(extent.low);
    // The first pixel of this invocation's run.
    var first = vec2<i32>(i32(id.x) * RUN, i32(id.y));
    var along = dims.x;
    if (!HORIZONTAL) {
        // Neighbouring invocations take neighbouring columns.
        first = vec2<i32>(i32(id.x), i32(id.y) * RUN);
        along = dims.y;
    }
    if (first.x >= dims.x || first.y >= dims.y) {
        return;
    }
    let r = i32(RADIUS);
    let start = select(first.y, first.x, HORIZONTAL);
    // Output j's tap k = i − j − r is source texel i of the window, which
    // starts at start − r. Scalar accumulators: an indexed array would live
    // in memory on llvmpipe and cost more than the loads saved.
    let last = 2 * r;
    var acc0 = vec3<f32>(0.0);
    var acc1 = vec3<f32>(0.0);
    var acc2 = vec3<f32>(0.0);
    var acc3 = vec3<f32>(0.0);
    for (var i = 0; i <= last + RUN - 1; i = i + 1) {
        var s = first;
        let at = clamp(start - r + i, 0, along - 1);
        if (HORIZONTAL) {
            s.x = at;
        } else {
            s.y = at;
        }
        let t = textureLoad(src, s, 0).rgb;
        if (i <= last) {
            acc0 = acc0 + weight(i) * t;
        }
        if (i >= 1 && i - 1 <= last) {
            acc1 = acc1 + weight(i - 1) * t;
        }
        if (i >= 2 && i - 2 <= last) {
            acc2 = acc2 + weight(i - 2) * t;
        }
        if (i >= 3) {
            acc3 = acc3 + weight(i - 3) * t;
        }
    }
    store(first, start, along, 0, acc0);
    store(first, start, along, 1, acc1);
    store(first, start, along, 2, acc2);
    store(first, start, along, 3, acc3);
}

fn store(first: vec2<i32>, start: i32, along: i32, j: i32, c: vec3<f32>) {
    if (start + j >= along) {
        return;
    }
    var p = first;
    if (HORIZONTAL) {
        p.x = start + j;
    } else {
        p.y = start + j;
    }
    textureStore(blur_out, p, vec4<f32>(c, 1.0));
}
