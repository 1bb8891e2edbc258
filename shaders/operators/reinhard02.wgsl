// reinhard02 (src/operators/reinhard02.rs): an absolute Lwhite, or the
// maximum scaled luminance when none is given.
//#include shared/reinhard.wgsl

fn operator_resolve(s: Stats) -> vec4<f32> {
    let lavg = reinhard_adaptation(s.log_average);
    let key = config.key;
    var white = config.white;
    if (white <= 0.0) {
        white = key * s.max_y / lavg;
    }
    return vec4<f32>(key, lavg, key / lavg, white);
}
