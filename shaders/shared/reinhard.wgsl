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

// Ld = L/(1+L)·(1 + L/white²), with L/white² taken as (L/white)/white:
// neither division leaves f32's range for any white f32 can hold, where
// 1/white² does (white = 1.5e-33 in a frame of subnormals: 1/white² would be
// +Inf and the brightest pixel would not burn; found by the stress suite).
// white <= 0, +Inf or NaN means "never burn", as the reference's +Inf.
fn reinhard_curve(l: f32, white: f32) -> f32 {
    var burn = 0.0;
    if (white > 0.0 && white <= 3.4028235e38) {
        burn = (l / white) / white;
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
