// The figures of two 8-bit RGB images that `metrics::compare` gives, on the
// GPU, a workgroup's partial sums each (the host adds them up):
//   errors  per 8x8 pixels: Σ (test − reference)², Σ reference², Σ |test −
//           reference| over the three channels, and the pixels with a
//           channel more than one code off, as integers (exact: a workgroup's
//           sums stay under 2^32); the largest difference into one atomic;
//   ssim    scikit-image's SSIM (Gaussian window σ 1.5, 11 taps; population
//           covariance; C1 = (0.01·255)², C2 = (0.03·255)²) at each pixel of
//           the map with its 5-pixel border cropped, averaged over channels,
//           summed per workgroup. Inside the crop the window never leaves
//           the image, so no border rule is needed. The variances are sums
//           of squares about the window's own mean, which in f32 keeps what
//           uxx − ux² would cancel away.
//   ssim_map the same S at every pixel, uncropped, the window mirrored at
//           the image's edges as scipy's mode='reflect' (d c b a | a b c d):
//           the map of a frame whose artifacts are kept.
// Locked to the CPU's by tests/it/gpu_metrics.rs.

struct Params {
    width: u32,
    height: u32,
    // Workgroups along x of each entry (its partial sums' row length).
    error_groups_x: u32,
    ssim_groups_x: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
// Pixels packed as r | g << 8 | b << 16.
@group(0) @binding(1) var<storage, read_write> input_ref: array<u32>;
@group(0) @binding(2) var<storage, read_write> input_test: array<u32>;
// Per workgroup: (Σ d², Σ r², Σ |d|, pixels over 1 code).
@group(0) @binding(3) var<storage, read_write> error_sums: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read_write> max_diff: atomic<u32>;
// The Gaussian's taps 0..=5 (symmetric), normalised to sum 1 over 11.
@group(0) @binding(5) var<storage, read_write> gauss: array<f32, 6>;
@group(0) @binding(6) var<storage, read_write> ssim_sums: array<f32>;
// S per pixel, row-major, width × height (the `ssim_map` entry).
@group(0) @binding(7) var<storage, read_write> ssim_out: array<f32>;

const C1: f32 = 6.5025;
const C2: f32 = 58.5225;

var<workgroup> wg_sums: array<vec4<u32>, 64>;
var<workgroup> wg_max: atomic<u32>;
var<workgroup> wg_ssim: array<f32, 64>;

fn channels(p: u32) -> vec3<i32> {
    return vec3<i32>(i32(p & 255u), i32((p >> 8u) & 255u), i32((p >> 16u) & 255u));
}

@compute @workgroup_size(8, 8, 1)
fn errors(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    if li == 0u {
        atomicStore(&wg_max, 0u);
    }
    workgroupBarrier();
    var s = vec4<u32>(0u);
    if id.x < params.width && id.y < params.height {
        let i = id.y * params.width + id.x;
        let t = channels(input_test[i]);
        let r = channels(input_ref[i]);
        let d = vec3<u32>(abs(t - r));
        let ru = vec3<u32>(r);
        s = vec4<u32>(
            dot(d, d),
            dot(ru, ru),
            d.x + d.y + d.z,
            select(0u, 1u, max(d.x, max(d.y, d.z)) > 1u),
        );
        atomicMax(&wg_max, max(d.x, max(d.y, d.z)));
    }
    wg_sums[li] = s;
    workgroupBarrier();
    for (var step = 32u; step > 0u; step >>= 1u) {
        if li < step {
            wg_sums[li] += wg_sums[li + step];
        }
        workgroupBarrier();
    }
    if li == 0u {
        error_sums[wg.y * params.error_groups_x + wg.x] = wg_sums[0];
        atomicMax(&max_diff, atomicLoad(&wg_max));
    }
}

fn sample(x: u32, y: u32) -> array<vec3<f32>, 2> {
    let i = y * params.width + x;
    return array<vec3<f32>, 2>(vec3<f32>(channels(input_test[i])), vec3<f32>(channels(input_ref[i])));
}

// Index c + d − 5 of a line of n pixels; at an edge, mirrored as scipy's
// mode='reflect' (metrics::ssim_kernel::reflect_index). One reflection is
// enough: the window reaches 5 pixels past a line of at least 11. (No `%`:
// GLSL leaves a negative operand's remainder undefined.)
fn tap(c: i32, d: i32, n: i32, edge: bool) -> u32 {
    let i = c + d - 5;
    if !edge {
        return u32(i);
    }
    if i < 0 {
        return u32(-i - 1);
    }
    return u32(select(i, 2 * n - 1 - i, i >= n));
}

// S at pixel (cx, cy), averaged over channels; `edge`: the window reaches
// past the image and is mirrored.
fn ssim_at(cx: i32, cy: i32, edge: bool) -> f32 {
    let w = i32(params.width);
    let h = i32(params.height);
    var mx = vec3<f32>(0.0);
    var my = vec3<f32>(0.0);
    for (var dy = 0; dy < 11; dy++) {
        let wy = gauss[u32(abs(dy - 5))];
        let y = tap(cy, dy, h, edge);
        for (var dx = 0; dx < 11; dx++) {
            let wt = gauss[u32(abs(dx - 5))] * wy;
            let p = sample(tap(cx, dx, w, edge), y);
            mx += wt * p[0];
            my += wt * p[1];
        }
    }
    var vx = vec3<f32>(0.0);
    var vy = vec3<f32>(0.0);
    var vxy = vec3<f32>(0.0);
    for (var dy = 0; dy < 11; dy++) {
        let wy = gauss[u32(abs(dy - 5))];
        let y = tap(cy, dy, h, edge);
        for (var dx = 0; dx < 11; dx++) {
            let wt = gauss[u32(abs(dx - 5))] * wy;
            let p = sample(tap(cx, dx, w, edge), y);
            let a = p[0] - mx;
            let b = p[1] - my;
            vx += wt * a * a;
            vy += wt * b * b;
            vxy += wt * a * b;
        }
    }
    let map = ((2.0 * mx * my + C1) * (2.0 * vxy + C2)) / ((mx * mx + my * my + C1) * (vx + vy + C2));
    return (map.x + map.y + map.z) / 3.0;
}

@compute @workgroup_size(8, 8, 1)
fn ssim(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    // Pixels of the cropped map: (5, 5) onwards, width − 10 by height − 10.
    var s = 0.0;
    if id.x + 10u < params.width && id.y + 10u < params.height {
        s = ssim_at(i32(id.x) + 5, i32(id.y) + 5, false);
    }
    wg_ssim[li] = s;
    workgroupBarrier();
    for (var step = 32u; step > 0u; step >>= 1u) {
        if li < step {
            wg_ssim[li] += wg_ssim[li + step];
        }
        workgroupBarrier();
    }
    if li == 0u {
        ssim_sums[wg.y * params.ssim_groups_x + wg.x] = wg_ssim[0];
    }
}

@compute @workgroup_size(8, 8, 1)
fn ssim_map(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let x = i32(id.x);
    let y = i32(id.y);
    let edge = x < 5 || y < 5 || x + 5 >= i32(params.width) || y + 5 >= i32(params.height);
    ssim_out[id.y * params.width + id.x] = ssim_at(x, y, edge);
}
