// aces2 (src/operators/aces2/): the ACES 2.0 SDR Output Transform (100
// cd/m², Rec.709), in f32. The matrices and the model's scalars (ACES2_*)
// are written before this text by the host, from the f64 model; the hue,
// cusp and reach tables come in the uniform.

// The gamut compression step; off is the faster, clipping variant.
override ACES2_GAMUT_COMPRESSION: bool = true;

const ACES2_TABLE: i32 = 363;
const ACES2_UPPER_WRAP: i32 = 361;

struct OperatorConfig {
    exposure: f32,
    // J of the display's peak.
    limit_j: f32,
    // J of the tone scale's middle grey.
    mid_j: f32,
    focus_dist: f32,
    lower_gamma_inv: f32,
    // The band around a hue's uniform position its entry lies in.
    search_lo: f32,
    search_hi: f32,
    // A of limit_j.
    limit_a: f32,
    // The reach's M at each whole degree (entry 1 = 0°), four to a vec4.
    reach: array<vec4<f32>, 91>,
    // Per hue entry: the cusp's J, its M, the upper hull's 1/γ, the hue.
    cusps: array<vec4<f32>, 363>,
}

// The tables are read from the including shader's `config` (tone.wgsl's
// convention) rather than from the copy handed to operator_pixel: an index
// into the global is a load, into a copy a spill.

fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32> {
    return vec4<f32>(k.exposure, 0.0, 0.0, 0.0);
}

fn aces2_compress(v: vec3<f32>) -> vec3<f32> {
    let f = pow(abs(v), vec3<f32>(0.42));
    return sign(v) * f / (27.13 + f);
}

fn aces2_uncompress(v: vec3<f32>) -> vec3<f32> {
    let ra = min(abs(v), vec3<f32>(0.99));
    return sign(v) * pow(27.13 * ra / (1.0 - ra), vec3<f32>(1.0 / 0.42));
}

fn aces2_compress1(v: f32) -> f32 {
    let f = pow(v, 0.42);
    return f / (27.13 + f);
}

fn aces2_reach(h: f32) -> f32 {
    let base = i32(h);
    let t = h - f32(base);
    let lo = min(base + 1, ACES2_TABLE - 2);
    let a = config.reach[lo / 4][lo % 4];
    let b = config.reach[(lo + 1) / 4][(lo + 1) % 4];
    return mix(a, b, t);
}

fn aces2_toe(x: f32, limit: f32, k1_in: f32, k2_in: f32) -> f32 {
    if (x > limit) {
        return x;
    }
    let k2 = max(k2_in, 0.001);
    let k1 = sqrt(k1_in * k1_in + k2 * k2);
    let k3 = (limit + k1) / (limit + k2);
    let minus_b = k3 * x - k1;
    return 0.5 * (minus_b + sqrt(minus_b * minus_b + 4.0 * k2 * k3 * x));
}

// The cusp's J and M, the upper hull's 1/γ at hue h (a search of the hue
// table in the band the host measured, then a lerp).
fn aces2_cusp(h: f32) -> vec3<f32> {
    var i = 1 + i32(h);
    var lo = max(i + i32(config.search_lo), 0);
    var hi = min(i + i32(config.search_hi), ACES2_UPPER_WRAP);
    loop {
        if (lo + 1 >= hi) {
            break;
        }
        if (h > config.cusps[i].w) {
            lo = i;
        } else {
            hi = i;
        }
        i = (lo + hi) / 2;
    }
    hi = max(hi, 1);
    let a = config.cusps[hi - 1];
    let b = config.cusps[hi];
    return mix(a.xyz, b.xyz, (h - a.w) / (b.w - a.w));
}

fn aces2_focus_gain(j: f32, threshold: f32, limit_j: f32, focus_dist: f32) -> f32 {
    let gain = limit_j * focus_dist;
    if (j > threshold) {
        let adjust = log2((limit_j - threshold) / max(limit_j - j, 0.0001)) * 0.30102999566;
        return gain * (adjust * adjust + 1.0);
    }
    return gain;
}

fn aces2_j_intersect(j: f32, m: f32, focus_j: f32, max_j: f32, slope_gain: f32) -> f32 {
    let m_scaled = m / slope_gain;
    let a = m_scaled / focus_j;
    if (j < focus_j) {
        let b = 1.0 - m_scaled;
        let c = -j;
        return -2.0 * c / (b + sqrt(b * b - 4.0 * a * c));
    }
    let b = -(1.0 + m_scaled + max_j * a);
    let c = max_j * m_scaled + j;
    return -2.0 * c / (b - sqrt(b * b - 4.0 * a * c));
}

fn aces2_hull(j_axis: f32, slope: f32, gamma_inv: f32, j_max: f32, m_max: f32, j_ref: f32) -> f32 {
    let shifted = j_ref * pow(j_axis / j_ref, gamma_inv);
    return shifted * m_max / (j_max - slope * m_max);
}

// J and M compressed into Rec.709 at the peak (src/operators/aces2/gamut.rs).
fn aces2_gamut(j: f32, m: f32, h: f32, reach_m: f32, k: OperatorConfig) -> vec2<f32> {
    if (j <= 0.0) {
        return vec2<f32>(0.0);
    }
    if (m <= 0.0 || j > k.limit_j) {
        return vec2<f32>(j, 0.0);
    }
    let cusp = aces2_cusp(h);
    let focus_j = mix(cusp.x, k.mid_j, min(1.0, 1.3 - cusp.x / k.limit_j));
    let threshold = mix(cusp.x, k.limit_j, 0.3);
    let gain = aces2_focus_gain(j, threshold, k.limit_j, k.focus_dist);
    let j_source = aces2_j_intersect(j, m, focus_j, k.limit_j, gain);
    var scale = k.limit_j - j_source;
    if (j_source < focus_j) {
        scale = j_source;
    }
    let slope = scale * (j_source - focus_j) / (focus_j * gain);
    let j_cusp = aces2_j_intersect(cusp.x, cusp.y, focus_j, k.limit_j, gain);
    let lower = aces2_hull(j_source, slope, k.lower_gamma_inv, cusp.x, cusp.y, j_cusp);
    let upper = aces2_hull(k.limit_j - j_source, -slope, cusp.z, k.limit_j - cusp.x, cusp.y, k.limit_j - j_cusp);
    let s = 0.12 * cusp.y;
    let w = max(s - abs(lower - upper), 0.0) / s;
    let boundary = min(lower, upper) - w * w * w * s / 6.0;
    if (boundary <= 0.0) {
        return vec2<f32>(j, 0.0);
    }
    let reach = aces2_hull(j_source, slope, ACES2_GAMMA_INV, k.limit_j, reach_m, k.limit_j);
    let proportion = max(boundary / reach, 0.75);
    let t = proportion * boundary;
    var out_m = m;
    if (m > t && proportion < 1.0) {
        let reach_offset = reach - t;
        let sc = reach_offset / (reach_offset / (boundary - t) - 1.0);
        let nd = (m - t) / sc;
        out_m = t + sc * nd / (1.0 + nd);
    }
    return vec2<f32>(j_source + out_m * slope, out_m);
}

fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) -> vec3<f32> {
    // The preamble; max/min rather than clamp so that a NaN becomes 0.
    let ap1 = min(max(ACES2_TO_AP1 * (c * r.x), vec3<f32>(0.0)), vec3<f32>(1024.0));
    let aab = ACES2_CONE_TO_AAB * aces2_compress(ACES2_AP1_TO_CONE * ap1);
    if (aab.x <= 0.0) {
        return vec3<f32>(0.0);
    }
    let m = length(aab.yz);
    var h = degrees(atan2(aab.z, aab.y));
    if (h < 0.0) {
        h += 360.0;
    }
    var cos_h = 1.0;
    var sin_h = 0.0;
    if (m > 0.0) {
        cos_h = aab.y / m;
        sin_h = aab.z / m;
    }
    let reach_m = aces2_reach(h);

    // The tone scale on Y, through A; a_ts is the toned J's achromatic
    // response, so that (J_ts/J)^(1/cz) is a_ts/A and (J_ts/J_limit)^(1/cz)
    // is a_ts/A_limit (cz is also the chroma compression's gamma).
    let ra_in = min(ACES2_A_W_J * aab.x, 0.99);
    let y = pow(27.13 * ra_in / (1.0 - ra_in), 1.0 / 0.42) / ACES2_F_L_N;
    let f = ACES2_TS_M_2 * pow(y / (y + ACES2_TS_S_2), ACES2_TS_G);
    let y_ts = max(f * f / (f + ACES2_TS_T_1), 0.0) * ACES2_TS_N_R;
    let a_ts = aces2_compress1(y_ts * ACES2_F_L_N) / ACES2_A_W_J;
    let j_ts = 100.0 * pow(a_ts, ACES2_CZ);

    // The chroma compression.
    var m_cp = m;
    if (m != 0.0) {
        let cos2 = 2.0 * cos_h * cos_h - 1.0;
        let sin2 = 2.0 * cos_h * sin_h;
        let cos3 = 4.0 * cos_h * cos_h * cos_h - 3.0 * cos_h;
        let sin3 = 3.0 * sin_h - 4.0 * sin_h * sin_h * sin_h;
        let norm = (11.34072 * cos_h + 16.46899 * cos2 + 7.88380 * cos3 + 14.66441 * sin_h - 6.37224 * sin2 + 9.19364 * sin3 + 77.12896) * ACES2_CC_SCALE;
        let nj = j_ts / k.limit_j;
        let snj = max(1.0 - nj, 0.0);
        let limit = a_ts / k.limit_a * reach_m / norm;
        var x = m * (a_ts / aab.x) / norm;
        x = limit - aces2_toe(limit - x, limit - 0.001, snj * ACES2_CC_SAT, sqrt(nj * nj + ACES2_CC_SAT_THR));
        x = aces2_toe(x, limit, nj * ACES2_CC_COMPR, snj);
        m_cp = x * norm;
    }

    var jm = vec2<f32>(max(j_ts, 0.0), select(0.0, m_cp, j_ts > 0.0));
    if (ACES2_GAMUT_COMPRESSION) {
        jm = aces2_gamut(j_ts, m_cp, h, reach_m, k);
    }
    let a = pow(jm.x * 0.01, ACES2_INV_CZ);
    let cone = aces2_uncompress(ACES2_AAB_TO_CONE_OUT * vec3<f32>(a, jm.y * cos_h, jm.y * sin_h));
    return clamp(ACES2_CONE_TO_REC709 * cone, vec3<f32>(0.0), vec3<f32>(1.0));
}
