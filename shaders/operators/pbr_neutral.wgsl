// pbr-neutral (src/operators/pbr_neutral.rs): Khronos PBR Neutral.

struct OperatorConfig {
    exposure: f32,
}

const NEUTRAL_START: f32 = 0.76;
const NEUTRAL_DESATURATION: f32 = 0.15;

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.exposure, 0.0, 0.0, 0.0);
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    var v = c * r.x;
    let x = min(v.r, min(v.g, v.b));
    var offset = 0.04;
    if (x < 0.08) {
        offset = x - 6.25 * x * x;
    }
    v = v - offset;
    let peak = max(v.r, max(v.g, v.b));
    if (peak < NEUTRAL_START) {
        return v;
    }
    let d = 1.0 - NEUTRAL_START;
    let new_peak = 1.0 - d * d / ((peak + d) - NEUTRAL_START);
    v = v * (new_peak / peak);
    let g = 1.0 - 1.0 / (NEUTRAL_DESATURATION * (peak - new_peak) + 1.0);
    return mix(v, vec3<f32>(new_peak), g);
}
