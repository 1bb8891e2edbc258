// reinhard-global (src/operators/reinhard_global.rs): white² = w²·Lmax.
//#include shared/reinhard.wgsl

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    let lavg = reinhard_adaptation(s.log_average, k);
    var lmax = k.fixed_max;
    if (lmax <= 0.0) {
        lmax = s.max_y;
    }
    // White itself, never white²: squaring leaves f32's range long before
    // white does (see reinhard_curve).
    let white = k.white_fraction * sqrt(lmax);
    return vec4<f32>(k.key, lavg, k.key / lavg, white);
}
