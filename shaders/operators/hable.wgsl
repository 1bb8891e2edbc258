// hable (src/operators/hable.rs): Hable's filmic curve per channel.

struct OperatorConfig {
    a: f32,
    b: f32,
    c: f32,
    d: f32,
    e: f32,
    f: f32,
    bias: f32,
    // 1/f(W), from the host in f64.
    white_scale: f32,
    exposure: f32,
}

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.exposure, 0.0, 0.0, 0.0);
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    // f tends to A/A − E/F; from 1e9 on it is within f32's rounding of
    // that, and the bound keeps x² in range.
    let x = min(c * r.x * k.bias, vec3<f32>(1e9));
    let f = (x * (k.a * x + k.c * k.b) + k.d * k.e) / (x * (k.a * x + k.b) + k.d * k.f) - k.e / k.f;
    return f * k.white_scale;
}
