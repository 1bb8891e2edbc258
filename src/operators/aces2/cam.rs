//! ACES 2.0's colour appearance model (a CAM16 variant, "JMh") and the two
//! steps that work in it before gamut compression: the tone scale (Daniele
//! Siragusano's curve, applied to J through Y) and the chroma compression.
//! f64 throughout; the structure and constants are those of OpenColorIO's
//! ACES 2 fixed function (docs/operators.md#aces2).

use crate::color::{apply, inverse, mul, npm, Mat3};

/// A chromaticity pair (x, y) for each of red, green, blue, then the white.
pub type Primaries = [[f64; 2]; 4];

/// ACES AP0 (ACES2065-1).
pub const AP0: Primaries = [[0.7347, 0.2653], [0.0, 1.0], [0.0001, -0.077], ACES_WHITE];
/// ACES AP1 (ACEScg): the gamut compression's reach.
pub const AP1: Primaries = [[0.713, 0.293], [0.165, 0.83], [0.128, 0.044], ACES_WHITE];
/// ACES's white, near D60.
const ACES_WHITE: [f64; 2] = [0.32168, 0.33767];
/// BT.709 with a D65 white: the SDR output's limiting gamut.
pub const REC709: Primaries = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06], [0.3127, 0.329]];
/// The model's own (non-physical) primaries: CAM16's cone space, written
/// as chromaticities.
const CAM16: Primaries = [
    [0.8336, 0.1735],
    [2.3854, -1.4659],
    [0.087, -0.125],
    [0.333, 0.333],
];

/// The luminance 1.0 stands for, cd/m².
pub const REFERENCE_LUMINANCE: f64 = 100.0;
/// The adapting field's luminance, cd/m².
const L_A: f64 = 100.0;
/// The background's relative luminance.
const Y_B: f64 = 20.0;
/// A dim surround's F, c, N_c.
const SURROUND: [f64; 3] = [0.9, 0.59, 0.9];
/// J's scale.
const J_SCALE: f64 = 100.0;
/// The cone-response compression's offset, 0.2713 × 100.
const NL_OFFSET: f64 = 0.2713 * 100.0;
/// The achromatic response's scale, 4 × 100.
const NL_SCALE: f64 = 4.0 * 100.0;

/// One RGB space seen through the model: the matrices into and out of the
/// adapted cone space and the achromatic scaling.
#[derive(Clone, Debug)]
pub struct JmhSpace {
    pub(super) to_cone: Mat3,
    pub(super) from_cone: Mat3,
    pub(super) cone_to_aab: Mat3,
    pub(super) aab_to_cone: Mat3,
    /// F_L / 100.
    pub(super) f_l_n: f64,
    /// c·z, the exponent from achromatic response to J.
    pub(super) cz: f64,
    /// The achromatic response of the adapting white.
    pub(super) a_w_j: f64,
}

/// The exponent c·z of the model (and the chroma compression's 1/γ).
pub fn model_gamma() -> f64 {
    SURROUND[1] * (1.48 + (Y_B / REFERENCE_LUMINANCE).sqrt())
}

fn diag(v: [f64; 3]) -> Mat3 {
    [[v[0], 0.0, 0.0], [0.0, v[1], 0.0], [0.0, 0.0, v[2]]]
}

fn rgb_to_xyz(p: &Primaries) -> Mat3 {
    npm([p[0], p[1], p[2]], p[3])
}

/// The cone response's compression, x ↦ x^0.42 / (27.13 + x^0.42), for a
/// magnitude.
#[inline]
fn compress(v: f64) -> f64 {
    let f = v.powf(0.42);
    f / (NL_OFFSET + f)
}

#[inline]
fn compress_signed(v: f64) -> f64 {
    compress(v.abs()).copysign(v)
}

/// Its inverse, with the response held below 0.99 (where it would reach
/// infinity at 1).
#[inline]
fn uncompress(ra: f64) -> f64 {
    let ra = ra.min(0.99);
    (NL_OFFSET * ra / (1.0 - ra)).powf(1.0 / 0.42)
}

#[inline]
fn uncompress_signed(v: f64) -> f64 {
    uncompress(v.abs()).copysign(v)
}

impl JmhSpace {
    /// The model for RGB of `primaries`, 1.0 = 100 cd/m².
    pub fn new(primaries: &Primaries) -> JmhSpace {
        let base: Mat3 = [
            [2.0, 1.0, 1.0 / 20.0],
            [1.0, -12.0 / 11.0, 1.0 / 11.0],
            [1.0 / 9.0, 1.0 / 9.0, -2.0 / 9.0],
        ];
        let xyz_to_cam16 = inverse(&rgb_to_xyz(&CAM16));
        let to_xyz = rgb_to_xyz(primaries);
        let xyz_w = apply(&to_xyz, [REFERENCE_LUMINANCE; 3]);
        let y_w = xyz_w[1];
        let rgb_w = apply(&xyz_to_cam16, xyz_w);
        let k = 1.0 / (5.0 * L_A + 1.0);
        let k4 = k * k * k * k;
        let f_l = 0.2 * k4 * (5.0 * L_A) + 0.1 * (1.0 - k4).powi(2) * (5.0 * L_A).cbrt();
        let f_l_n = f_l / REFERENCE_LUMINANCE;
        let cz = model_gamma();
        let d = rgb_w.map(|w| f_l_n * y_w / w);
        let rgb_aw: [f64; 3] = std::array::from_fn(|i| compress_signed(d[i] * rgb_w[i]));
        let cone_to_aab = mul(&diag([NL_SCALE; 3]), &base);
        let a_w: f64 = (0..3).map(|j| cone_to_aab[0][j] * rgb_aw[j]).sum();
        let a_w_j = compress(f_l);
        let to_cam16 = mul(
            &mul(&xyz_to_cam16, &to_xyz),
            &diag([REFERENCE_LUMINANCE; 3]),
        );
        let to_cone = mul(&diag(d), &to_cam16);
        let s = 43.0 * SURROUND[2];
        let cone_to_aab: Mat3 = [
            cone_to_aab[0].map(|v| v / a_w),
            cone_to_aab[1].map(|v| v * s),
            cone_to_aab[2].map(|v| v * s),
        ];
        JmhSpace {
            from_cone: inverse(&to_cone),
            to_cone,
            aab_to_cone: inverse(&cone_to_aab),
            cone_to_aab,
            f_l_n,
            cz,
            a_w_j,
        }
    }

    /// RGB to the achromatic response A and the opponent pair (a, b).
    #[inline]
    pub fn rgb_to_aab(&self, rgb: [f64; 3]) -> [f64; 3] {
        let cone = apply(&self.to_cone, rgb).map(compress_signed);
        apply(&self.cone_to_aab, cone)
    }

    /// (A, a, b) to J, M and the hue h in degrees, [0, 360); all 0 where A
    /// is not positive.
    #[inline]
    pub fn aab_to_jmh(&self, aab: [f64; 3]) -> [f64; 3] {
        if aab[0] <= 0.0 {
            return [0.0; 3];
        }
        let (m, h) = aab_to_mh(aab);
        [self.a_to_j(aab[0]), m, h]
    }

    /// RGB to JMh (J, M, h).
    pub fn rgb_to_jmh(&self, rgb: [f64; 3]) -> [f64; 3] {
        self.aab_to_jmh(self.rgb_to_aab(rgb))
    }

    /// J and M at a hue whose cosine and sine are given, to RGB.
    #[inline]
    pub fn jm_to_rgb(&self, j: f64, m: f64, cos_h: f64, sin_h: f64) -> [f64; 3] {
        let a = (j / J_SCALE).powf(1.0 / self.cz);
        let cone = apply(&self.aab_to_cone, [a, m * cos_h, m * sin_h]).map(uncompress_signed);
        apply(&self.from_cone, cone)
    }

    /// JMh to RGB.
    pub fn jmh_to_rgb(&self, jmh: [f64; 3]) -> [f64; 3] {
        let (sin_h, cos_h) = jmh[2].to_radians().sin_cos();
        self.jm_to_rgb(jmh[0], jmh[1], cos_h, sin_h)
    }

    /// The luminance Y (100 = the reference white) of achromatic response
    /// A.
    #[inline]
    pub fn a_to_y(&self, a: f64) -> f64 {
        uncompress(self.a_w_j * a) / self.f_l_n
    }

    /// J of an achromatic luminance Y (sign kept).
    #[inline]
    pub fn y_to_j(&self, y: f64) -> f64 {
        let ra = compress(y.abs() * self.f_l_n);
        (J_SCALE * (ra / self.a_w_j).powf(self.cz)).copysign(y)
    }

    /// The achromatic response A of lightness J.
    pub fn j_to_a(&self, j: f64) -> f64 {
        (j / J_SCALE).powf(1.0 / self.cz)
    }

    /// The lightness J of achromatic response A.
    pub fn a_to_j(&self, a: f64) -> f64 {
        J_SCALE * a.powf(self.cz)
    }
}

/// M and h (degrees, [0, 360)) of (A, a, b), for a positive A: JMh
/// without J.
#[inline]
pub fn aab_to_mh(aab: [f64; 3]) -> (f64, f64) {
    let h = aab[2].atan2(aab[1]).to_degrees();
    let m = (aab[1] * aab[1] + aab[2] * aab[2]).sqrt();
    (m, if h < 0.0 { h + 360.0 } else { h })
}

/// The tone scale's constants for a display peak (cd/m²).
#[derive(Clone, Copy, Debug)]
pub struct ToneScale {
    /// The display's peak, cd/m².
    pub peak: f64,
    pub(super) n_r: f64,
    pub(super) g: f64,
    pub(super) t_1: f64,
    /// Middle grey's output (0.18 in) relative to n_r.
    pub c_t: f64,
    pub(super) s_2: f64,
    pub(super) m_2: f64,
    /// The scene value beyond which the reach is searched no further.
    pub forward_limit: f64,
    /// log10(peak / 100).
    pub log_peak: f64,
}

impl ToneScale {
    /// The constants for `peak` cd/m²: grey 0.18 to 10.013 cd/m² at 100
    /// cd/m², a contrast of 1.15, a toe of 0.04, and the scene value that
    /// reaches the peak from 128 (100 cd/m²) to 896 (10 000 cd/m²).
    pub fn new(peak: f64) -> ToneScale {
        let n = peak;
        let n_r = 100.0;
        let g = 1.15;
        let c = 0.18;
        let c_d = 10.013;
        let w_g = 0.14;
        let t_1 = 0.04;
        let (r_hit_min, r_hit_max) = (128.0, 896.0);
        let r_hit =
            r_hit_min + (r_hit_max - r_hit_min) * ((n / n_r).ln() / (10000.0f64 / 100.0).ln());
        let m_0 = n / n_r;
        let m_1 = 0.5 * (m_0 + (m_0 * (m_0 + 4.0 * t_1)).sqrt());
        let u = ((r_hit / m_1) / ((r_hit / m_1) + 1.0)).powf(g);
        let m = m_1 / u;
        let w_i = (n / 100.0).log2();
        let c_t = c_d / n_r * (1.0 + w_i * w_g);
        let g_ip = 0.5 * (c_t + (c_t * (c_t + 4.0 * t_1)).sqrt());
        let g_ipp2 = -(m_1 * (g_ip / m).powf(1.0 / g)) / ((g_ip / m).powf(1.0 / g) - 1.0);
        let w_2 = c / g_ipp2;
        let s_2 = w_2 * m_1 * REFERENCE_LUMINANCE;
        let u_2 = ((r_hit / m_1) / ((r_hit / m_1) + w_2)).powf(g);
        let m_2 = m_1 / u_2;
        ToneScale {
            peak: n,
            n_r,
            g,
            t_1,
            c_t,
            s_2,
            m_2,
            forward_limit: 8.0 * r_hit,
            log_peak: (n / n_r).log10(),
        }
    }

    /// The curve on luminance Y (100 = the reference white): display
    /// luminance in the same scale.
    #[inline]
    pub fn apply(&self, y: f64) -> f64 {
        let f = self.m_2 * (y / (y + self.s_2)).powf(self.g);
        (f * f / (f + self.t_1)).max(0.0) * self.n_r
    }

    /// The achromatic response of the toned luminance of achromatic
    /// response A (> 0): OpenColorIO's tone scale from A to J, stopped
    /// before its last power (J = 100·A^γ, [`JmhSpace::a_to_j`]).
    #[inline]
    pub fn a_to_toned_a(&self, a: f64, space: &JmhSpace) -> f64 {
        let y = self.apply(space.a_to_y(a));
        compress(y * space.f_l_n) / space.a_w_j
    }
}

/// The chroma compression's constants for a display peak.
#[derive(Clone, Copy, Debug)]
pub struct ChromaCompression {
    pub(super) sat: f64,
    pub(super) sat_thr: f64,
    pub(super) compr: f64,
    pub(super) scale: f64,
}

impl ChromaCompression {
    /// For the tone scale `ts`.
    pub fn new(ts: &ToneScale) -> ChromaCompression {
        let (compress, compress_fact) = (2.4, 3.3);
        let (expand, expand_fact, expand_thr) = (1.3, 0.69, 0.5);
        ChromaCompression {
            sat: (expand - expand * expand_fact * ts.log_peak).max(0.2),
            sat_thr: expand_thr / ts.peak,
            compr: compress + compress * compress_fact * ts.log_peak,
            scale: (0.03379 * ts.peak).powf(0.30596) - 0.45135,
        }
    }

    /// M's normalisation at a hue (a three-harmonic fit), from the hue's
    /// cosine and sine.
    #[inline]
    pub fn norm(&self, cos_h: f64, sin_h: f64) -> f64 {
        let cos2 = 2.0 * cos_h * cos_h - 1.0;
        let sin2 = 2.0 * cos_h * sin_h;
        let cos3 = 4.0 * cos_h * cos_h * cos_h - 3.0 * cos_h;
        let sin3 = 3.0 * sin_h - 4.0 * sin_h * sin_h * sin_h;
        let m = 11.34072 * cos_h + 16.46899 * cos2 + 7.88380 * cos3 + 14.66441 * sin_h
            - 6.37224 * sin2
            + 9.19364 * sin3
            + 77.12896;
        m * self.scale
    }

    /// M after the tone scale moved J to J_ts: scaled with J, then
    /// compressed towards the reach's limit at this hue (`reach_m`), with
    /// the norm `m_norm`. `nj` is J_ts over the display peak's J; the two
    /// ratios OpenColorIO raises to 1/γ (γ the model's c·z) come as the
    /// ratios of achromatic responses they equal: `scale` = (J_ts/J)^(1/γ),
    /// `limit_scale` = nj^(1/γ).
    #[inline]
    pub fn apply(
        &self,
        m: f64,
        nj: f64,
        scale: f64,
        limit_scale: f64,
        m_norm: f64,
        reach_m: f64,
    ) -> f64 {
        if m == 0.0 {
            return m;
        }
        let snj = (1.0 - nj).max(0.0);
        let limit = limit_scale * reach_m / m_norm;
        let mut mc = m * scale / m_norm;
        mc = limit
            - toe(
                limit - mc,
                limit - 0.001,
                snj * self.sat,
                (nj * nj + self.sat_thr).sqrt(),
            );
        mc = toe(mc, limit, nj * self.compr, snj);
        mc * m_norm
    }
}

/// The quadratic toe: x below `limit` bent with k1, k2.
#[inline]
fn toe(x: f64, limit: f64, k1: f64, k2: f64) -> f64 {
    if x > limit {
        return x;
    }
    let k2 = k2.max(0.001);
    let k1 = (k1 * k1 + k2 * k2).sqrt();
    let k3 = (limit + k1) / (limit + k2);
    let minus_b = k3 * x - k1;
    let minus_ac = k2 * k3 * x;
    0.5 * (minus_b + (minus_b * minus_b + 4.0 * minus_ac).sqrt())
}
