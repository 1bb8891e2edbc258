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

@compute @workgroup_size(8, 8, 1)
fn ssim(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wg: vec3<u32>,
) {
    // Pixels of the cropped map: (5, 5) onwards, width − 10 by height − 10.
    var s = 0.0;
    if id.x + 10u < params.width && id.y + 10u < params.height {
        let cx = id.x + 5u;
        let cy = id.y + 5u;
        var mx = vec3<f32>(0.0);
        var my = vec3<f32>(0.0);
        for (var dy = 0u; dy < 11u; dy++) {
            let wy = gauss[u32(abs(i32(dy) - 5))];
            for (var dx = 0u; dx < 11u; dx++) {
                let w = gauss[u32(abs(i32(dx) - 5))] * wy;
                let p = sample(cx + dx - 5u, cy + dy - 5u);
                mx += w * p[0];
                my += w * p[1];
            }
        }
        var vx = vec3<f32>(0.0);
        var vy = vec3<f32>(0.0);
        var vxy = vec3<f32>(0.0);
        for (var dy = 0u; dy < 11u; dy++) {
            let wy = gauss[u32(abs(i32(dy) - 5))];
            for (var dx = 0u; dx < 11u; dx++) {
                let w = gauss[u32(abs(i32(dx) - 5))] * wy;
                let p = sample(cx + dx - 5u, cy + dy - 5u);
                let a = p[0] - mx;
                let b = p[1] - my;
                vx += w * a * a;
                vy += w * b * b;
                vxy += w * a * b;
            }
        }
        let map = ((2.0 * mx * my + C1) * (2.0 * vxy + C2)) / ((mx * mx + my * my + C1) * (vx + vy + C2));
        s = (map.x + map.y + map.z) / 3.0;
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
