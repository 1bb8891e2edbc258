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
override BT2390_TARGET_BLACK: f32 = 0.0;
override BT2390_TARGET_RANGE: f32 = 100.0;

// SMPTE ST 2084.
const PQ_M1: f32 = 0.1593017578125;
const PQ_M2: f32 = 78.84375;
const PQ_C1: f32 = 0.8359375;
const PQ_C2: f32 = 18.8515625;
const PQ_C3: f32 = 18.6875;

struct OperatorConfig {
    exposure: f32,
}

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.exposure, 0.0, 0.0, 0.0);
}

// ST 2084 in f32 without its two losses of precision: q = (c1 + c2·y) /
// (1 + c3·y) and p = E^(1/m2) lie close below 1, where f32 keeps only
// about 7 digits of 1 − q and 1 − p, and raising q to m2 = 78.8 (or
// decoding p, whose c2 − c3·p cancels) multiplies that loss some 80-400
// times (3e-5 of a cd/m² value in a plain transcription, against llvmpipe,
// 2026-11-26). Since c2 − c3 = 1 − c1, 1 − q = (1 − c1)(1 − y)/(1 + c3·y)
// is exact to rounding, and so is 1 − p from ln(E)/m2 by its series.
const PQ_ONE_MINUS_C1: f32 = 0.1640625;

// ln(1 − w) for 0 ≤ w ≤ 0.17: −2 atanh(w / (2 − w)), four terms (the
// fifth is below 1e-9 of the sum).
fn bt2390_ln_one_minus(w: vec3<f32>) -> vec3<f32> {
    let z = w / (2.0 - w);
    let z2 = z * z;
    return -2.0 * z * (1.0 + z2 * (1.0 / 3.0 + z2 * (1.0 / 5.0 + z2 * (1.0 / 7.0))));
}

// cd/m² to PQ signal; 0 cd/m² is signal 0, as on the host.
fn bt2390_pq_encode(nits: vec3<f32>) -> vec3<f32> {
    let y = pow(nits * (1.0 / 10000.0), vec3<f32>(PQ_M1));
    let w = PQ_ONE_MINUS_C1 * (1.0 - y) / (1.0 + PQ_C3 * y);
    let e = exp(PQ_M2 * bt2390_ln_one_minus(w));
    return select(e, vec3<f32>(0.0), nits <= vec3<f32>(0.0));
}

fn bt2390_pq_decode(e: vec3<f32>) -> vec3<f32> {
    // s = ln(p) ≥ ln(c1^m2)/m2 = −0.18 where anything is lit; v = 1 − p =
    // −expm1(s) by its series (six terms: the seventh is below 2e-9).
    let s = max(log(e) * (1.0 / PQ_M2), vec3<f32>(-0.25));
    let v = -s * (1.0 + s * (1.0 / 2.0 + s * (1.0 / 6.0 + s * (1.0 / 24.0 + s * (1.0 / 120.0 + s * (1.0 / 720.0))))));
    let ratio = max(PQ_ONE_MINUS_C1 - v, vec3<f32>(0.0)) / (PQ_ONE_MINUS_C1 + PQ_C3 * v);
    return 10000.0 * pow(ratio, vec3<f32>(1.0 / PQ_M1));
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    let nits = clamp(c * r.x * BT2390_REFERENCE_WHITE, vec3<f32>(BT2390_SOURCE_BLACK), vec3<f32>(BT2390_SOURCE_PEAK));
    var x = (bt2390_pq_encode(nits) - BT2390_E_MIN) / BT2390_E_RANGE;
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
    return clamp((bt2390_pq_decode(e) - BT2390_TARGET_BLACK) / BT2390_TARGET_RANGE, vec3<f32>(0.0), vec3<f32>(1.0));
}
