//! `pbr-neutral`: the Khronos PBR Neutral tone mapper (Khronos 3D
//! Formats Working Group, 2024; docs/operators.md), as its reference GLSL
//! and three.js's `NeutralToneMapping` compute it: a small toe offset, then
//! above 0.76 a compression of the peak channel that keeps hue, and a
//! desaturation toward white as the peak is compressed.

use super::fixed::{self, EXPOSURE};
use super::{Curve, Param, Resolution, ToneOperator, Values};
use super::{LuminanceStats, Unmeasured};

/// `pbr-neutral`.
pub struct PbrNeutral;

/// Where highlight compression starts (0.8 − 0.04).
pub const START_COMPRESSION: f64 = 0.8 - 0.04;
/// How much a compressed highlight desaturates.
pub const DESATURATION: f64 = 0.15;

struct Fit;

impl Curve for Fit {
    fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        let x = c[0].min(c[1].min(c[2]));
        let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
        let v = c.map(|v| v - offset);
        let peak = v[0].max(v[1].max(v[2]));
        if peak < START_COMPRESSION {
            return v;
        }
        let d = 1.0 - START_COMPRESSION;
        let new_peak = 1.0 - d * d / ((peak + d) - START_COMPRESSION);
        let v = v.map(|v| v * (new_peak / peak));
        let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
        v.map(|v| v * (1.0 - g) + new_peak * g)
    }
}

impl ToneOperator for PbrNeutral {
    fn name(&self) -> &'static str {
        "pbr-neutral"
    }
    fn summary(&self) -> &'static str {
        "Khronos PBR Neutral (glTF viewers, three.js NeutralToneMapping)"
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
        include_str!("../../shaders/operators/pbr_neutral.wgsl")
    }
    fn gpu_exposure_word(&self) -> Option<super::ExposureWord> {
        Some(super::ExposureWord::FIRST)
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        vec![v.num("exposure") as f32]
    }
}
