// tonemap: the global Reinhard 2002 family, one curve for every variant
// (reference/tonemap.rs): Ld = L/(1+L)·(1 + L/white²), L = scale·Y.
//#include shared/colour.wgsl
//#include shared/stats.wgsl
//#include shared/tone.wgsl
//#include shared/extent.wgsl

// 0 = reinhard-global, 1 = reinhard-auto-key, 2 = reinhard02 (Reinhard 2002);
// see `operator_code` in src/gpu/tonemap.rs.
override OPERATOR: u32 = 0u;
// `reinhard-auto-key`'s automatic key from min, average and max.
override AUTO_KEY: bool = false;

@group(0) @binding(0) var<uniform> config: ToneConfig;
// `resolve` writes the statistics buffer; `main` reads the same buffer as a
// uniform (binding 4), which llvmpipe loads once per SIMD batch instead of
// lane by lane.
@group(0) @binding(1) var<storage, read_write> stats: Stats;
@group(0) @binding(2) var hdr: texture_2d<f32>;
@group(0) @binding(3) var toned_out: texture_storage_2d<HDR_FORMAT, write>;
@group(0) @binding(4) var<uniform> resolved: Stats;

// a = 0.18·2^(2(B − A)/(A + B)); A + B = Lmax − Lmin, 0 for a uniform frame.
fn automatic_key(lmin: f32, lavg: f32, lmax: f32) -> f32 {
    let span = lmax - lmin;
    if (!(span >= SMALLEST_NORMAL)) {
        return 0.18;
    }
    let ratio = clamp(((lavg - lmin) - (lmax - lavg)) / span, -1.0, 1.0);
    return 0.18 * exp2(2.0 * ratio);
}

// One invocation: turns the statistics into the curve's parameters.
@compute @workgroup_size(1)
fn resolve() {
    var lavg = config.fixed_log_average;
    if (lavg <= 0.0) {
        if (OPERATOR == 1u) {
            lavg = stats.weighted_log_average;
        } else {
            lavg = stats.log_average;
        }
    }
    var key = config.key;
    if (OPERATOR == 1u && AUTO_KEY) {
        key = automatic_key(stats.min_y, lavg, stats.max_y);
    }
    // white itself, never white²: squaring leaves f32's range long before
    // white does (see reinhard_curve).
    var white = 0.0;
    if (OPERATOR == 0u) {
        var lmax = config.fixed_max;
        if (lmax <= 0.0) {
            lmax = stats.max_y;
        }
        // `reinhard-global`: white² = w²·Lmax.
        white = config.white_fraction * sqrt(lmax);
    } else {
        white = config.white;
        if (OPERATOR == 1u || white <= 0.0) {
            white = key * stats.max_y / lavg;
        }
    }
    stats.key = key;
    stats.adaptation = lavg;
    stats.scale = key / lavg;
    stats.white = white;
}

@compute @workgroup_size(64, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = extent.frame;
    if (id.x >= dims.x || id.y >= dims.y) {
        return;
    }
    let c = textureLoad(hdr, id.xy, 0).rgb;
    let out = toned(c, resolved.scale, resolved.white);
    textureStore(toned_out, vec2<i32>(id.xy), vec4<f32>(out, 1.0));
}
