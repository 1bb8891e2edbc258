//! `aces2`: the ACES 2.0 Output Transform for an SDR display (100 cd/m²,
//! Rec.709 primaries and white, sRGB encoding), as OpenColorIO 2.6's
//! built-in ACES 2.0 config renders the view "ACES 2.0 - SDR 100 nits
//! (Rec.709)" from "Linear Rec.709 (sRGB)" (docs/operators.md#aces2):
//!
//! 1. linear Rec.709 to AP1 (Bradford-adapted to the ACES white), clamped
//!    to [0, 1024], then to AP0: the ACES 2 preamble;
//! 2. AP0 to JMh, the ACES 2 appearance model (`cam`);
//! 3. the tone scale on J, and the chroma compression on M;
//! 4. the gamut compression into Rec.709 at the display's peak (`gamut`),
//!    which can be turned off (`gamut_compression = false`) for speed;
//! 5. JMh back to Rec.709 display-linear light, clamped to [0, 1].
//!
//! Computed in f64, with the same tables (hue, cusp, upper-hull γ, reach M)
//! OpenColorIO builds, built once per process.

pub mod cam;
pub mod gamut;
mod tables;

use super::fixed::{self, wgsl_mat3, EXPOSURE};
use super::{Curve, Kind, Param, Resolution, ToneOperator, Value, Values};
use super::{LuminanceStats, Unmeasured};
use crate::color::Mat3;
use cam::{ChromaCompression, JmhSpace, ToneScale};
use gamut::GamutTables;
use std::sync::OnceLock;

/// `aces2`.
pub struct Aces2;

/// Linear Rec.709 (D65) to AP1 with a Bradford adaptation to the ACES
/// white: OpenColorIO 2.6's built-in config composes this from its
/// "Linear Rec.709 (sRGB)" to ACES2065-1 matrix and the ACES 2 preamble's
/// AP0 → AP1 (tests/aces2/vectors.json records the chain; a test reads it
/// back).
pub const REC709_TO_AP1: Mat3 = [
    [0.6130974024011884, 0.3395231461841057, 0.04737945141470737],
    [0.07019372246958167, 0.9163538790573413, 0.01345239847307392],
    [0.020615592882227, 0.1095697729381357, 0.8698146341796398],
];

/// AP1 to AP0, the preamble's last step (same white, no adaptation).
pub const AP1_TO_AP0: Mat3 = [
    [0.6954522413574518, 0.1406786964702942, 0.163869062172254],
    [0.04479456337203763, 0.8596711184564216, 0.09553431817154036],
    [
        -0.005525882558113544,
        0.004025210305978659,
        1.001500672252135,
    ],
];

/// The preamble's clamp on AP1.
pub const AP1_MAX: f64 = 1024.0;

/// The SDR display's peak, cd/m².
pub const PEAK: f64 = 100.0;

const GAMUT: Param = Param {
    name: "gamut_compression",
    doc: "ACES 2.0's gamut compression into Rec.709 (false: skipped, faster, out-of-gamut colours clip)",
    kind: Kind::Flag,
    default: Value::Flag(true),
};

/// Everything the transform builds once for its display.
pub struct Model {
    /// The scene side: AP0.
    pub input: JmhSpace,
    /// The display side: Rec.709.
    pub output: JmhSpace,
    /// The tone scale for 100 cd/m².
    pub tone: ToneScale,
    /// The chroma compression.
    pub chroma: ChromaCompression,
    /// The gamut compression's tables.
    pub gamut: GamutTables,
}

impl Model {
    /// The model for an SDR display of `peak` cd/m² with Rec.709 primaries.
    pub fn new(peak: f64) -> Model {
        let input = JmhSpace::new(&cam::AP0);
        let output = JmhSpace::new(&cam::REC709);
        let reach = JmhSpace::new(&cam::AP1);
        let tone = ToneScale::new(peak);
        let chroma = ChromaCompression::new(&tone);
        let gamut = GamutTables::new(&input, &output, &reach, &tone);
        Model {
            input,
            output,
            tone,
            chroma,
            gamut,
        }
    }

    /// The 100 cd/m² model, built on first use.
    pub fn sdr() -> &'static Model {
        static MODEL: OnceLock<Model> = OnceLock::new();
        MODEL.get_or_init(|| Model::new(PEAK))
    }

    /// The output transform proper: AP0 to Rec.709 display-linear (1 = the
    /// peak), before the final clamp.
    pub fn transform(&self, ap0: [f64; 3], gamut_compression: bool) -> [f64; 3] {
        let aab = self.input.rgb_to_aab(ap0);
        if aab[0] <= 0.0 {
            return [0.0; 3];
        }
        let (m, h) = cam::aab_to_mh(aab);
        let reach_m = self.gamut.reach_m_at(h);
        let (sin_h, cos_h) = h.to_radians().sin_cos();
        let m_norm = self.chroma.norm(cos_h, sin_h);
        // (J_ts/J)^(1/γ) and (J_ts/J_limit)^(1/γ), which OpenColorIO
        // takes of J, are ratios of achromatic responses: J = 100·A^γ.
        let a_ts = self.tone.a_to_toned_a(aab[0], &self.input);
        let j_ts = self.input.a_to_j(a_ts);
        let m_cp = self.chroma.apply(
            m,
            j_ts / self.gamut.limit_j,
            a_ts / aab[0],
            a_ts / self.gamut.limit_a,
            m_norm,
            reach_m,
        );
        let [j_out, m_out] = if gamut_compression {
            self.gamut.compress(j_ts, m_cp, h, reach_m)
        } else {
            [j_ts.max(0.0), if j_ts > 0.0 { m_cp } else { 0.0 }]
        };
        self.output.jm_to_rgb(j_out, m_out, cos_h, sin_h)
    }
}

/// The whole chain on linear Rec.709 `c`: display-linear Rec.709 in [0, 1].
pub fn pixel(c: [f64; 3], gamut_compression: bool) -> [f64; 3] {
    let ap1 = fixed::mul3(&REC709_TO_AP1, c).map(|v| clamp_or_zero(v, AP1_MAX));
    let ap0 = fixed::mul3(&AP1_TO_AP0, ap1);
    Model::sdr()
        .transform(ap0, gamut_compression)
        .map(|v| clamp_or_zero(v, 1.0))
}

/// v clamped to [0, hi], with a NaN taken as 0 (f64::clamp keeps it).
#[inline]
fn clamp_or_zero(v: f64, hi: f64) -> f64 {
    if v > 0.0 {
        v.min(hi)
    } else {
        0.0
    }
}

struct Transform {
    gamut_compression: bool,
}

impl Curve for Transform {
    fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        pixel(c, self.gamut_compression)
    }
}

impl ToneOperator for Aces2 {
    fn name(&self) -> &'static str {
        "aces2"
    }
    fn summary(&self) -> &'static str {
        "ACES 2.0 Output Transform, SDR 100 nits Rec.709, as OpenColorIO 2.6 renders it"
    }
    fn params(&self) -> &'static [Param] {
        &[EXPOSURE, GAMUT]
    }
    fn resolved_names(&self) -> &'static [&'static str] {
        fixed::RESOLVED
    }
    fn resolve(&self, v: &Values, _: &LuminanceStats) -> Result<Resolution, Unmeasured> {
        Ok(fixed::resolution(
            v,
            Transform {
                gamut_compression: v.flag("gamut_compression"),
            },
        ))
    }
    fn wgsl(&self) -> &'static str {
        static SOURCE: OnceLock<String> = OnceLock::new();
        fixed::with_constants(
            &SOURCE,
            wgsl_constants,
            include_str!("../../../shaders/operators/aces2.wgsl"),
        )
    }
    fn gpu_exposure_word(&self) -> Option<super::ExposureWord> {
        Some(super::ExposureWord::FIRST)
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        let g = &Model::sdr().gamut;
        let mut out = vec![
            v.num("exposure") as f32,
            g.limit_j as f32,
            g.mid_j as f32,
            g.focus_dist as f32,
            g.lower_gamma_inv as f32,
            g.search[0] as f32,
            g.search[1] as f32,
            g.limit_a as f32,
        ];
        // reach: 363 values packed four to a vec4 (91 of them).
        let mut reach = g.reach_m.map(|x| x as f32).to_vec();
        reach.resize(gamut::TOTAL.div_ceil(4) * 4, 0.0);
        out.extend(reach);
        for (c, h) in g.cusps.iter().zip(&g.hues) {
            out.extend([c[0] as f32, c[1] as f32, c[2] as f32, *h as f32]);
        }
        out
    }
    fn speed_knobs(&self) -> &'static [(&'static str, Value)] {
        &[("gamut_compression", Value::Flag(false))]
    }
    fn gpu_constants(&self, v: &Values) -> Vec<(&'static str, f64)> {
        vec![(
            "ACES2_GAMUT_COMPRESSION",
            v.flag("gamut_compression") as u32 as f64,
        )]
    }
}

/// The matrices and scalars the WGSL takes from the model, as constants.
fn wgsl_constants() -> String {
    let m = Model::sdr();
    let into_cone = crate::color::mul(&m.input.to_cone, &AP1_TO_AP0);
    let mut s = [
        wgsl_mat3("ACES2_TO_AP1", &REC709_TO_AP1),
        wgsl_mat3("ACES2_AP1_TO_CONE", &into_cone),
        wgsl_mat3("ACES2_CONE_TO_AAB", &m.input.cone_to_aab),
        wgsl_mat3("ACES2_AAB_TO_CONE_OUT", &m.output.aab_to_cone),
        wgsl_mat3("ACES2_CONE_TO_REC709", &m.output.from_cone),
    ]
    .concat();
    let scalars = [
        ("ACES2_CZ", m.input.cz),
        ("ACES2_INV_CZ", 1.0 / m.input.cz),
        ("ACES2_F_L_N", m.input.f_l_n),
        ("ACES2_A_W_J", m.input.a_w_j),
        ("ACES2_TS_N_R", m.tone.n_r),
        ("ACES2_TS_G", m.tone.g),
        ("ACES2_TS_T_1", m.tone.t_1),
        ("ACES2_TS_S_2", m.tone.s_2),
        ("ACES2_TS_M_2", m.tone.m_2),
        ("ACES2_CC_SAT", m.chroma.sat),
        ("ACES2_CC_SAT_THR", m.chroma.sat_thr),
        ("ACES2_CC_COMPR", m.chroma.compr),
        ("ACES2_CC_SCALE", m.chroma.scale),
        ("ACES2_GAMMA_INV", 1.0 / cam::model_gamma()),
    ];
    for (name, v) in scalars {
        s.push_str(&format!("const {name}: f32 = {:?};\n", v as f32));
    }
    s
}
