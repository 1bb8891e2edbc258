// The tone curve applied to one pixel, shared by the `tonemap` stage and the
// fused kernels (fused.wgsl). The including shader declares `config`
// (ToneConfig) and includes shared/colour.wgsl.

// 0 = ratio (scale RGB by Ld/Y), 1 = CIE xyY round trip.
override COLOUR: u32 = 0u;
// Fault injection only (`check --fault-gain`): 1 in every real run.
override FAULT_GAIN: f32 = 1.0;

// Operator constants written once by the host (mirrors `tone_config` in
// src/gpu/tonemap.rs).
struct ToneConfig {
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

fn tonemap_pixel(c: vec3<f32>, scale: f32, white: f32) -> vec3<f32> {
    if (COLOUR == 0u) {
        let y = luminance_with(c, config.weights.xyz);
        if (!(y >= SMALLEST_NORMAL)) {
            return vec3<f32>(0.0);
        }
        return c * (reinhard_curve(scale * y, white) / y);
    }
    let xyz = vec3<f32>(dot(config.to_xyz0.xyz, c), dot(config.to_xyz1.xyz, c), dot(config.to_xyz2.xyz, c));
    let sum = xyz.x + xyz.y + xyz.z;
    if (!(xyz.y >= SMALLEST_NORMAL) || !(sum >= SMALLEST_NORMAL)) {
        return vec3<f32>(0.0);
    }
    let x = xyz.x / sum;
    let y = xyz.y / sum;
    let ld = reinhard_curve(scale * xyz.y, white);
    let out = vec3<f32>(x * ld / y, ld, (1.0 - x - y) * ld / y);
    return vec3<f32>(dot(config.to_rgb0.xyz, out), dot(config.to_rgb1.xyz, out), dot(config.to_rgb2.xyz, out));
}

// What the `tonemap` stage stores for HDR colour c: the curve, then the
// fault gain (1 in every real run).
fn toned(c: vec3<f32>, scale: f32, white: f32) -> vec3<f32> {
    return tonemap_pixel(c, scale, white) * FAULT_GAIN;
}
