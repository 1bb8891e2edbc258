// aces-hill (src/operators/aces_hill.rs): Hill's ACES fit as three.js
// computes it.

// ACES_INPUT and ACES_OUTPUT are written before this text by the host, from
// src/operators/aces_hill.rs.

struct OperatorConfig {
    // exposure / 0.6
    gain: f32,
}

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.gain * 0.6, 0.0, 0.0, 0.0);
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    // The fit tends to 1/0.983729 and is within f32's rounding of it from
    // 1e9 on; the bound keeps v² in range.
    let v = min(ACES_INPUT * (c * k.gain), vec3<f32>(1e9));
    let a = v * (v + 0.0245786) - 0.000090537;
    let b = v * (0.983729 * v + 0.4329510) + 0.238081;
    return clamp(ACES_OUTPUT * (a / b), vec3<f32>(0.0), vec3<f32>(1.0));
}
