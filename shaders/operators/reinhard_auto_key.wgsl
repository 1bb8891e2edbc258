// reinhard-auto-key (src/operators/reinhard_auto_key.rs): the weighted
// log-average, an automatic or fixed key, white = the scaled maximum.
//#include shared/reinhard.wgsl

// The key from min, average and max instead of k.key.
override AUTO_KEY: bool = false;

// a = 0.18·2^(2(B − A)/(A + B)); A + B = Lmax − Lmin, 0 for a uniform frame.
fn automatic_key(lmin: f32, lavg: f32, lmax: f32) -> f32 {
    let span = lmax - lmin;
    if (!(span >= SMALLEST_NORMAL)) {
        return 0.18;
    }
    let ratio = clamp(((lavg - lmin) - (lmax - lavg)) / span, -1.0, 1.0);
    return 0.18 * exp2(2.0 * ratio);
}

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    let lavg = s.weighted_log_average;
    var key = k.key;
    if (AUTO_KEY) {
        key = automatic_key(s.min_y, lavg, s.max_y);
    }
    return vec4<f32>(key, lavg, key / lavg, key * s.max_y / lavg);
}
