// bt2390 (src/operators/bt2390.rs): BT.2390's EETF on each channel's PQ
// signal. The constants are override constants the host computes in f64
// from the definition.

override BT2390_REFERENCE_WHITE: f32 = 203.0;
override BT2390_SOURCE_BLACK: f32 = 0.0;
override BT2390_SOURCE_PEAK: f32 = 1000.0;
override BT2390_E_MIN: f32 = 0.0;
override BT2390_E_RANGE: f32 = 1.0;
override BT2390_MIN_LUM: f32 = 0.0;
override BT2390_MAX_LUM: f32 = 1.0;
override BT2390_KS: f32 = 1.0;
override BT2390_BP: f32 = 4.0;
override BT2390_GAIN: f32 = 1.0;
override BT2390_OUT_MIN: f32 = 0.0;
override BT2390_OUT_MAX: f32 = 1.0;
override BT2390_BLACK_SNAP: f32 = 0.0;
override BT2390_TARGET_BLACK: f32 = 0.0;
override BT2390_TARGET_RANGE: f32 = 100.0;

//#include shared/pq.wgsl

struct OperatorConfig {
    exposure: f32,
}

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.exposure, 0.0, 0.0, 0.0);
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    let nits = clamp(c * r.x * BT2390_REFERENCE_WHITE, vec3<f32>(BT2390_SOURCE_BLACK), vec3<f32>(BT2390_SOURCE_PEAK));
    var x = (pq_signal(nits) - BT2390_E_MIN) / BT2390_E_RANGE;
    // The Hermite roll-off above the knee (none when the target is as
    // bright as the source: KS ≥ 1).
    let t = (x - BT2390_KS) / (1.0 - BT2390_KS);
    let t2 = t * t;
    let t3 = t2 * t;
    let spline = (2.0 * t3 - 3.0 * t2 + 1.0) * BT2390_KS + (t3 - 2.0 * t2 + t) * (1.0 - BT2390_KS) + (-2.0 * t3 + 3.0 * t2) * BT2390_MAX_LUM;
    x = select(x, spline, x >= vec3<f32>(BT2390_KS) & vec3<bool>(BT2390_KS < 1.0));
    // The black-point lift, then the gain that keeps the peak; nothing to
    // do for a target black at or below the source's (the default), and a
    // branch on override constants costs nothing once llvmpipe folds it.
    if (BT2390_MIN_LUM > 0.0) {
        let lifted = x + BT2390_MIN_LUM * pow(max(1.0 - x, vec3<f32>(0.0)), vec3<f32>(BT2390_BP));
        x = select(x, BT2390_GAIN * (lifted - BT2390_MIN_LUM) + BT2390_MIN_LUM, x < vec3<f32>(1.0));
    } else if (BT2390_MIN_LUM < 0.0) {
        // bp is 4 here.
        let u = max(1.0 - x, vec3<f32>(0.0));
        let u2 = u * u;
        let lifted = x + BT2390_MIN_LUM * (u2 * u2);
        x = select(x, BT2390_GAIN * (lifted - BT2390_MIN_LUM) + BT2390_MIN_LUM, x < vec3<f32>(1.0));
    }
    let e = clamp(x * BT2390_E_RANGE + BT2390_E_MIN, vec3<f32>(BT2390_OUT_MIN), vec3<f32>(BT2390_OUT_MAX));
    // A signal within 4 f32 steps of the target's black is that black, 0
    // exactly: the lift lands the source's black there, and PQ's decoding
    // would turn the last step's rounding into a residue that a steep
    // encoding (gamma 3 and up) shows as LSBs. The peak is 1 exactly.
    let rel = clamp((pq_nits(e) - BT2390_TARGET_BLACK) / BT2390_TARGET_RANGE, vec3<f32>(0.0), vec3<f32>(1.0));
    let black = e <= vec3<f32>(BT2390_BLACK_SNAP);
    return select(select(rel, vec3<f32>(0.0), black), vec3<f32>(1.0), e >= vec3<f32>(BT2390_OUT_MAX));
}
