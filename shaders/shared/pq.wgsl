// SMPTE ST 2084 (PQ) in f32, accurately: what the `bt2390` operator's EETF
// and the PQ frames of `encode` (shared/encode.wgsl) evaluate; the host's
// f64 is color/hdr.rs.

const PQ_M1: f32 = 0.1593017578125;
const PQ_M2: f32 = 78.84375;
const PQ_C1: f32 = 0.8359375;
const PQ_C2: f32 = 18.8515625;
const PQ_C3: f32 = 18.6875;

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
fn pq_ln_one_minus(w: vec3<f32>) -> vec3<f32> {
    let z = w / (2.0 - w);
    let z2 = z * z;
    return -2.0 * z * (1.0 + z2 * (1.0 / 3.0 + z2 * (1.0 / 5.0 + z2 * (1.0 / 7.0))));
}

// cd/m² to PQ signal; 0 cd/m² is signal 0, as on the host.
fn pq_signal(nits: vec3<f32>) -> vec3<f32> {
    let y = pow(nits * (1.0 / 10000.0), vec3<f32>(PQ_M1));
    let w = PQ_ONE_MINUS_C1 * (1.0 - y) / (1.0 + PQ_C3 * y);
    let e = exp(PQ_M2 * pq_ln_one_minus(w));
    return select(e, vec3<f32>(0.0), nits <= vec3<f32>(0.0));
}

fn pq_nits(e: vec3<f32>) -> vec3<f32> {
    // s = ln(p) ≥ ln(c1^m2)/m2 = −0.18 where anything is lit; v = 1 − p =
    // −expm1(s) by its series (six terms: the seventh is below 2e-9).
    // ln of at least 1e-30 (-69, so s = -0.88 before the max): the same s
    // for every e, and no -Inf at e = 0 for a driver without infinities.
    let s = max(log(max(e, vec3<f32>(1e-30))) * (1.0 / PQ_M2), vec3<f32>(-0.25));
    let v = -s * (1.0 + s * (1.0 / 2.0 + s * (1.0 / 6.0 + s * (1.0 / 24.0 + s * (1.0 / 120.0 + s * (1.0 / 720.0))))));
    let ratio = max(PQ_ONE_MINUS_C1 - v, vec3<f32>(0.0)) / (PQ_ONE_MINUS_C1 + PQ_C3 * v);
    return 10000.0 * pow(ratio, vec3<f32>(1.0 / PQ_M1));
}
