// What the Reinhard 2002 operators share (src/operators/reinhard.rs): their
// `OperatorConfig`, the curve and the two colour paths. The resolved vec4 is
// (key, adaptation luminance, scale = key/adaptation, Lwhite); Lwhite <= 0
// or +Inf never burns.
//#include shared/colour.wgsl

// 0 = ratio (scale RGB by Ld/Y), 1 = CIE xyY round trip.
override COLOUR: u32 = 0u;

// Written once by the host (mirrors `GpuNumbers::config` in
// src/operators/reinhard.rs).
struct OperatorConfig {
    weights: vec4<f32>,
    // RGB→XYZ rows and their inverse (xyY path).
    to_xyz0: vec4<f32>,
    to_xyz1: vec4<f32>,
    to_xyz2: vec4<f32>,
    to_rgb0: vec4<f32>,
    to_rgb1: vec4<f32>,
    to_rgb2: vec4<f32>,
    key: f32,
    white_fraction: f32,
    // Absolute Lwhite (Reinhard 2002); 0 = the maximum scaled luminance.
    white: f32,
    // Fixed adaptation luminance; 0 = measured.
    fixed_log_average: f32,
    // Fixed Lmax (`reinhard-global`); 0 = measured.
    fixed_max: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// Ld = L/(1+L)·(1 + L/white²), range-safe under every rewrite a driver may
// apply (docs/stress.md#range-safe-arithmetic): white is clamped to
// [2^-63, 2^63], so white², 1/white and 1/white² are normal f32s whether
// the driver evaluates (L/white)/white as written, as L/(white·white) or
// through reciprocals; and L enters the burn term at most 2^40·white, so
// L/white² stays under 2^103. Neither clamp changes a displayed pixel: a
// white under 2^-63 leaves only pixels darker than 2^-63 unburned, and
// L ≥ 2^40·white burns to white either way. The reference clamps the same
// (src/operators/reinhard.rs). white <= 0, +Inf or NaN means "never burn",
// as the reference's +Inf.
const WHITE_MIN: f32 = 1.0842022e-19;
const WHITE_MAX: f32 = 9.223372e18;
const BURN_SPAN: f32 = 1099511627776.0;

fn reinhard_curve(l: f32, white: f32) -> f32 {
    var burn = 0.0;
    if (white > 0.0 && white <= 3.4028235e38) {
        let w = clamp(white, WHITE_MIN, WHITE_MAX);
        let lc = min(l, w * BURN_SPAN);
        burn = (lc / w) / w;
    }
    return l / (1.0 + l) * (1.0 + burn);
}

// The adaptation luminance: fixed, or `measured`.
fn reinhard_adaptation(measured: f32, k: OperatorConfig) -> f32 {
    if (k.fixed_log_average > 0.0) {
        return k.fixed_log_average;
    }
    return measured;
}

fn reinhard_pixel(c: vec3<f32>, scale: f32, white: f32, k: OperatorConfig) -> vec3<f32> {
    if (COLOUR == 0u) {
        let y = luminance_with(c, k.weights.xyz);
        if (!(y >= SMALLEST_NORMAL)) {
            return vec3<f32>(0.0);
        }
        return c * (reinhard_curve(scale * y, white) / y);
    }
    let xyz = vec3<f32>(dot(k.to_xyz0.xyz, c), dot(k.to_xyz1.xyz, c), dot(k.to_xyz2.xyz, c));
    let sum = xyz.x + xyz.y + xyz.z;
    if (!(xyz.y >= SMALLEST_NORMAL) || !(sum >= SMALLEST_NORMAL)) {
        return vec3<f32>(0.0);
    }
    let x = xyz.x / sum;
    let y = xyz.y / sum;
    let ld = reinhard_curve(scale * xyz.y, white);
    let out = vec3<f32>(x * ld / y, ld, (1.0 - x - y) * ld / y);
    return vec3<f32>(dot(k.to_rgb0.xyz, out), dot(k.to_rgb1.xyz, out), dot(k.to_rgb2.xyz, out));
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    return reinhard_pixel(c, r.z, r.w, k);
}
