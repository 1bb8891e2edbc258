// aces-narkowicz (src/operators/aces_narkowicz.rs): Narkowicz's fit of the
// ACES curve, per channel.

struct OperatorConfig {
    exposure: f32,
}

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.exposure, 0.0, 0.0, 0.0);
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    // The fit is 1 from x = 7.25 on (clamped); 1e4 keeps x² in f32's range
    // and changes nothing.
    let x = min(c * r.x, vec3<f32>(1e4));
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), vec3<f32>(0.0), vec3<f32>(1.0));
}
