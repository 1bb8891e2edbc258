// agx (src/operators/agx.rs): AgX as three.js computes it, with the punchy
// look as an option.

// AGX_TO_REC2020, AGX_INSET, AGX_OUTSET and AGX_TO_SRGB are written before
// this text by the host, from src/operators/agx.rs.

struct OperatorConfig {
    exposure: f32,
    // 1: the punchy look between the sigmoid and the outset.
    punchy: f32,
}

const AGX_MIN_EV: f32 = -12.47393;
const AGX_MAX_EV: f32 = 4.026069;

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.exposure, 0.0, 0.0, 0.0);
}

fn agx_contrast(x: vec3<f32>) -> vec3<f32> {
    let x2 = x * x;
    let x4 = x2 * x2;
    return 15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x - 0.00232;
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    let v = AGX_INSET * (AGX_TO_REC2020 * (c * r.x));
    let e = (log2(max(v, vec3<f32>(1e-10))) - AGX_MIN_EV) / (AGX_MAX_EV - AGX_MIN_EV);
    var s = agx_contrast(clamp(e, vec3<f32>(0.0), vec3<f32>(1.0)));
    if (k.punchy != 0.0) {
        s = pow(max(s, vec3<f32>(0.0)), vec3<f32>(1.35));
        let luma = dot(s, vec3<f32>(0.2126, 0.7152, 0.0722));
        s = luma + 1.4 * (s - luma);
    }
    let o = pow(max(AGX_OUTSET * s, vec3<f32>(0.0)), vec3<f32>(2.2));
    return clamp(AGX_TO_SRGB * o, vec3<f32>(0.0), vec3<f32>(1.0));
}
