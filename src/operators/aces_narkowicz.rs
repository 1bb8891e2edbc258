//! `aces-narkowicz`: Krzysztof Narkowicz's fit of the ACES RRT+ODT curve
//! ("ACES Filmic Tone Mapping Curve", 2016; docs/operators.md), per channel:
//! clamp(x(2.51x + 0.03)/(x(2.43x + 0.59) + 0.14), 0, 1).

use super::fixed::{self, EXPOSURE};
use super::{Curve, Param, Resolution, ToneOperator, Values};
use super::{LuminanceStats, Unmeasured};

/// `aces-narkowicz`.
pub struct AcesNarkowicz;

/// The fit for one channel.
#[inline]
pub fn narkowicz(x: f64) -> f64 {
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

struct Fit;

impl Curve for Fit {
    #[inline]
    fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        c.map(narkowicz)
    }
}

impl ToneOperator for AcesNarkowicz {
    fn name(&self) -> &'static str {
        "aces-narkowicz"
    }
    fn summary(&self) -> &'static str {
        "ACES filmic, Narkowicz's per-channel fit (2016)"
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
        include_str!("../../shaders/operators/aces_narkowicz.wgsl")
    }
    fn gpu_exposure_word(&self) -> Option<super::ExposureWord> {
        Some(super::ExposureWord::FIRST)
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        vec![v.num("exposure") as f32]
    }
}
