// hable (src/operators/hable.rs): Hable's filmic curve per channel. The
// constants are override constants the host sets from the definition.

override HABLE_A: f32 = 0.22;
override HABLE_B: f32 = 0.3;
override HABLE_C: f32 = 0.1;
override HABLE_D: f32 = 0.2;
override HABLE_E: f32 = 0.01;
override HABLE_F: f32 = 0.3;
override HABLE_BIAS: f32 = 2.0;
// 1/f(W), from the host in f64.
override HABLE_WHITE_SCALE: f32 = 1.0;

struct OperatorConfig {
    exposure: f32,
}

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.exposure, 0.0, 0.0, 0.0);
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    // f tends to A/A − E/F; from 1e9 on it is within f32's rounding of
    // that, and the bound keeps x² in range.
    let x = min(c * r.x * HABLE_BIAS, vec3<f32>(1e9));
    let f = (x * (HABLE_A * x + HABLE_C * HABLE_B) + HABLE_D * HABLE_E) / (x * (HABLE_A * x + HABLE_B) + HABLE_D * HABLE_F) - HABLE_E / HABLE_F;
    return f * HABLE_WHITE_SCALE;
}
