//! `agx`: Troy Sobotka's AgX as three.js's `AgXToneMapping` computes it
//! (docs/operators.md): sRGB to Rec.2020, the inset matrix, log2 encoding
//! over [−12.47393, 4.026069] EV, the sigmoid's polynomial fit, the outset
//! matrix, a 2.2 power, back to sRGB, clamped to [0, 1]. `look = "punchy"`
//! adds the punchy look between the sigmoid and the outset (slope 1, offset
//! 0, power 1.35, saturation 1.4 about BT.709 luma, as glsl-tone-map's
//! `agxPunchy`); a sigmoid value below 0 (a channel darker than about
//! 2e-4) is taken as 0 there, where the power has no real value.

use super::fixed::{self, mul3, wgsl_mat3, EXPOSURE};
use super::{Curve, Kind, Param, Resolution, ToneOperator, Value, Values};
use super::{LuminanceStats, Unmeasured};

/// `agx`.
pub struct Agx;

/// three.js's LINEAR_SRGB_TO_LINEAR_REC2020 (four decimals), row-major.
pub const SRGB_TO_REC2020: [[f64; 3]; 3] = [
    [0.6274, 0.3293, 0.0433],
    [0.0691, 0.9195, 0.0113],
    [0.0164, 0.0880, 0.8956],
];

/// three.js's LINEAR_REC2020_TO_LINEAR_SRGB.
pub const REC2020_TO_SRGB: [[f64; 3]; 3] = [
    [1.6605, -0.5876, -0.0728],
    [-0.1246, 1.1329, -0.0083],
    [-0.0182, -0.1006, 1.1187],
];

/// AgX's inset matrix (three.js's AgXInsetMatrix), row-major.
pub const INSET: [[f64; 3]; 3] = [
    [0.856627153315983, 0.0951212405381588, 0.0482516061458583],
    [0.137318972929847, 0.761241990602591, 0.101439036467562],
    [0.11189821299995, 0.0767994186031903, 0.811302368396859],
];

/// AgX's outset matrix (three.js's AgXOutsetMatrix).
pub const OUTSET: [[f64; 3]; 3] = [
    [
        1.1271005818144368,
        -0.11060664309660323,
        -0.016493938717834573,
    ],
    [
        -0.1413297634984383,
        1.157823702216272,
        -0.016493938717834257,
    ],
    [
        -0.14132976349843826,
        -0.11060664309660294,
        1.2519364065950405,
    ],
];

/// The log2 encoding's range in EV.
pub const MIN_EV: f64 = -12.47393;
/// The log2 encoding's top.
pub const MAX_EV: f64 = 4.026069;

/// The sigmoid's polynomial fit (three.js's agxDefaultContrastApprox), in
/// its evaluation order.
#[inline]
pub fn contrast(x: f64) -> f64 {
    let x2 = x * x;
    let x4 = x2 * x2;
    15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x
        - 0.00232
}

const LOOK: Param = Param {
    name: "look",
    doc: "AgX look: none, or punchy (power 1.35, saturation 1.4)",
    kind: Kind::Word(&["none", "punchy"]),
    default: Value::Word("none"),
};

struct Fit {
    punchy: bool,
}

impl Curve for Fit {
    fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        let v = mul3(&INSET, mul3(&SRGB_TO_REC2020, c));
        let mut s = v.map(|x| {
            let e = (x.max(1e-10).log2() - MIN_EV) / (MAX_EV - MIN_EV);
            contrast(e.clamp(0.0, 1.0))
        });
        if self.punchy {
            s = s.map(|x| x.max(0.0).powf(1.35));
            let luma = 0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2];
            s = s.map(|x| luma + 1.4 * (x - luma));
        }
        let v = mul3(&OUTSET, s).map(|x| x.max(0.0).powf(2.2));
        mul3(&REC2020_TO_SRGB, v).map(|x| x.clamp(0.0, 1.0))
    }
}

impl ToneOperator for Agx {
    fn name(&self) -> &'static str {
        super::AGX
    }
    fn summary(&self) -> &'static str {
        "AgX (Sobotka), as three.js's AgXToneMapping, with the punchy look as an option"
    }
    fn params(&self) -> &'static [Param] {
        &[EXPOSURE, LOOK]
    }
    fn resolved_names(&self) -> &'static [&'static str] {
        fixed::RESOLVED
    }
    fn resolve(&self, v: &Values, _: &LuminanceStats) -> Result<Resolution, Unmeasured> {
        Ok(fixed::resolution(
            v,
            Fit {
                punchy: v.word("look") == "punchy",
            },
        ))
    }
    fn wgsl(&self) -> &'static str {
        static SOURCE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
        fixed::with_constants(
            &SOURCE,
            || {
                [
                    wgsl_mat3("AGX_TO_REC2020", &SRGB_TO_REC2020),
                    wgsl_mat3("AGX_INSET", &INSET),
                    wgsl_mat3("AGX_OUTSET", &OUTSET),
                    wgsl_mat3("AGX_TO_SRGB", &REC2020_TO_SRGB),
                ]
                .concat()
            },
            include_str!("../../shaders/operators/agx.wgsl"),
        )
    }
    /// The look is in the uniform with the exposure, so an application
    /// switches it per frame without a new pipeline.
    fn gpu_exposure_word(&self) -> Option<super::ExposureWord> {
        Some(super::ExposureWord::FIRST)
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        let punchy = v.word("look") == "punchy";
        vec![v.num("exposure") as f32, f32::from(u8::from(punchy))]
    }
}
