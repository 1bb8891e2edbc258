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
// A(F − E) and B(C·F − E), from the host in f64.
override HABLE_P: f32 = 0.0638;
override HABLE_Q: f32 = 0.006;

struct OperatorConfig {
    exposure: f32,
}

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.exposure, 0.0, 0.0, 0.0);
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    let x = c * r.x * HABLE_BIAS;
    // f(x) − E/F with its constant terms cancelled on the host: written as
    // the reference has it, the subtraction of E/F leaves f32's rounding
    // of E/F (about 1e-7 of it) where the curve itself is small (near
    // black, or everywhere with a white point of 1e-6), which showed as up
    // to 5 LSB over random parameters (tests/it/random_params.rs):
    //   x·(P·x + Q) / (F·(x·(A·x + B) + D·F))          for x ≤ 1,
    //   (P + Q·u) / (F·(A + B·u + D·F·u²)), u = 1/x     above,
    // the same curve, the second with no x² to leave f32's range (x = +Inf
    // gives its limit, 1 − E/F) and no clamp of x that constants with a
    // small A (a late shoulder) would notice: a clamp at 1e9 put the two
    // renderers 106 LSB apart.
    // Each form on its own side of 1 only, so neither meets the other's
    // extremes (every intermediate stays finite).
    let u = 1.0 / max(x, vec3<f32>(1.0));
    let v = min(x, vec3<f32>(1.0));
    let low = v * (HABLE_P * v + HABLE_Q) / (HABLE_F * (v * (HABLE_A * v + HABLE_B) + HABLE_D * HABLE_F));
    let high = (HABLE_P + HABLE_Q * u) / (HABLE_F * (HABLE_A + u * (HABLE_B + HABLE_D * HABLE_F * u)));
    let f = select(high, low, x <= vec3<f32>(1.0));
    return f * HABLE_WHITE_SCALE;
}
