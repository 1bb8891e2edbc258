// histogram: the frame's weighted histogram of log2 luminance, what eye
// adaptation meters under `metering = "histogram"` (reference/histogram.rs,
// docs/adaptation.md). 64 bins over [min_ev, max_ev): below it (zero
// included) the first, above it the last; a NaN, infinite or negative
// luminance is not binned. Two ways to count, each adding its non-empty
// bins to the frame's, which `adaptation` reads and clears: `main`, a
// workgroup per 16-wide, 64-tall tile counting into shared memory (for
// GPUs), and `block`, one invocation per 32×32 block counting into its own
// array, no barriers (for CPU adapters, where a workgroup barrier costs
// more than the atomics it saves, as for the statistics' block method).
//#include shared/colour.wgsl
//#include shared/extent.wgsl
//#include shared/adaptation.wgsl

override LUM_R: f32 = 0.2126;
override LUM_G: f32 = 0.7152;
override LUM_B: f32 = 0.0722;

@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> bins: array<atomic<u32>, HISTOGRAM_BINS>;
@group(0) @binding(2) var<uniform> steps: Steps;

const TILE_X: u32 = 16u;
const TILE_Y: u32 = 16u;
const ROWS: u32 = 4u;
var<workgroup> tile_bins: array<atomic<u32>, HISTOGRAM_BINS>;

// The bin of luminance `y`, or HISTOGRAM_BINS for one not binned.
fn bin_of(y: f32) -> u32 {
    if (!finite(y) || y < 0.0) {
        return HISTOGRAM_BINS;
    }
    if (y <= 0.0) {
        return 0u;
    }
    let at = floor((log2(y) - steps.min_ev) * steps.bins_per_ev);
    return u32(clamp(at, 0.0, f32(HISTOGRAM_BINS - 1u)));
}

// Four bands from each edge in, weighing 1 to 4 (reference/histogram.rs).
fn band(i: u32, n: u32) -> u32 {
    return 1u + 8u * min(i, n - 1u - i) / n;
}

fn weight(p: vec2<u32>) -> u32 {
    if (steps.mask == 0u) {
        return 1u;
    }
    return band(p.x, extent.frame.x) * band(p.y, extent.frame.y);
}

@compute @workgroup_size(16, 16)
fn main(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_id) lid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    if (li < HISTOGRAM_BINS) {
        atomicStore(&tile_bins[li], 0u);
    }
    workgroupBarrier();
    let x = wg.x * TILE_X + lid.x;
    if (x < extent.frame.x) {
        for (var r = 0u; r < ROWS; r = r + 1u) {
            let y = (wg.y * ROWS + r) * TILE_Y + lid.y;
            if (y < extent.frame.y) {
                let c = textureLoad(hdr, vec2<u32>(x, y), 0).rgb;
                let b = bin_of(luminance_with(c, vec3<f32>(LUM_R, LUM_G, LUM_B)));
                if (b < HISTOGRAM_BINS) {
                    atomicAdd(&tile_bins[b], weight(vec2<u32>(x, y)));
                }
            }
        }
    }
    workgroupBarrier();
    if (li < HISTOGRAM_BINS) {
        let n = atomicLoad(&tile_bins[li]);
        if (n != 0u) {
            atomicAdd(&bins[li], n);
        }
    }
}

const BLOCK: u32 = 32u;

@compute @workgroup_size(64)
fn block(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = extent.frame;
    let across = (dims.x + BLOCK - 1u) / BLOCK;
    let down = (dims.y + BLOCK - 1u) / BLOCK;
    if (id.x >= across * down) {
        return;
    }
    let x0 = (id.x % across) * BLOCK;
    let y0 = (id.x / across) * BLOCK;
    var counts: array<u32, HISTOGRAM_BINS>;
    for (var y = y0; y < min(y0 + BLOCK, dims.y); y = y + 1u) {
        for (var x = x0; x < min(x0 + BLOCK, dims.x); x = x + 1u) {
            let c = textureLoad(hdr, vec2<u32>(x, y), 0).rgb;
            let b = bin_of(luminance_with(c, vec3<f32>(LUM_R, LUM_G, LUM_B)));
            if (b < HISTOGRAM_BINS) {
                counts[b] = counts[b] + weight(vec2<u32>(x, y));
            }
        }
    }
    for (var i = 0u; i < HISTOGRAM_BINS; i = i + 1u) {
        if (counts[i] != 0u) {
            atomicAdd(&bins[i], counts[i]);
        }
    }
}
