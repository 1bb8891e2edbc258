//! `aces-hill`: Stephen Hill's fit of the ACES RRT+ODT for sRGB displays
//! ("ACES fitted"), as three.js's `ACESFilmicToneMapping` computes it
//! (docs/operators.md): the input scaled by exposure/0.6, three.js's input
//! matrix, the rational RRT+ODT fit, its output matrix, clamped to [0, 1].

use super::fixed::{self, mul3, wgsl_mat3, EXPOSURE};
use super::{Curve, Param, Resolution, ToneOperator, Values};
use super::{LuminanceStats, Unmeasured};

/// `aces-hill`.
pub struct AcesHill;

/// three.js's ACESInputMat (sRGB → the fit's space, with the RRT's
/// saturation), row-major.
pub const INPUT: [[f64; 3]; 3] = [
    [0.59719, 0.35458, 0.04823],
    [0.07600, 0.90834, 0.01566],
    [0.02840, 0.13383, 0.83777],
];

/// three.js's ACESOutputMat (back to sRGB, with the ODT's saturation).
pub const OUTPUT: [[f64; 3]; 3] = [
    [1.60475, -0.53108, -0.07367],
    [-0.10208, 1.10813, -0.00605],
    [-0.00327, -0.07276, 1.07602],
];

/// Hill's rational fit of the RRT+ODT, per channel.
#[inline]
pub fn rrt_odt_fit(v: f64) -> f64 {
    let a = v * (v + 0.0245786) - 0.000090537;
    let b = v * (0.983729 * v + 0.4329510) + 0.238081;
    a / b
}

struct Fit;

impl Curve for Fit {
    fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        // three.js: color *= toneMappingExposure / 0.6 (the exposure is
        // applied before, so this is the 1/0.6).
        let v = mul3(&INPUT, c.map(|x| x * (1.0 / 0.6)));
        mul3(&OUTPUT, v.map(rrt_odt_fit)).map(|x| x.clamp(0.0, 1.0))
    }
}

impl ToneOperator for AcesHill {
    fn name(&self) -> &'static str {
        "aces-hill"
    }
    fn summary(&self) -> &'static str {
        "ACES fitted (Hill), as three.js's ACESFilmicToneMapping"
    }
    fn params(&self) -> &'static [Param] {
        &[EXPOSURE]
    }
    fn resolved_names(&self) -> &'static [&'static str] {
        fixed::RESOLVED
    }
    fn resolve(&self, v: &Values, _: &LuminanceStats) -> Result<Resolution, Unmeasured> {
        Ok(fixed::resolution(v, Fit))
    }
    fn wgsl(&self) -> &'static str {
        static SOURCE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
        fixed::with_constants(
            &SOURCE,
            || wgsl_mat3("ACES_INPUT", &INPUT) + &wgsl_mat3("ACES_OUTPUT", &OUTPUT),
            include_str!("../../shaders/operators/aces_hill.wgsl"),
        )
    }
    fn gpu_exposure_word(&self) -> Option<super::ExposureWord> {
        Some(super::ExposureWord {
            index: 0,
            divisor: 0.6,
        })
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        vec![(v.num("exposure") / 0.6) as f32]
    }
}
