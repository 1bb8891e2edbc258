// reinhard02 (src/operators/reinhard02.rs): an absolute Lwhite, or the
// maximum scaled luminance when none is given.
//#include shared/reinhard.wgsl

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    let lavg = reinhard_adaptation(s.log_average, k);
    let key = k.key;
    var white = k.white;
    if (white <= 0.0) {
        white = key * s.max_y / lavg;
    }
    return vec4<f32>(key, lavg, key / lavg, white);
}
