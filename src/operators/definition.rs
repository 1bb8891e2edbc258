//! [`ToneOperator`]: what an operator defines once (its name, parameters,
//! statistics, f64 curve and WGSL), with the curve and the display levels
//! it resolves to.

use super::{Luminance, LuminanceStats, Param, StatsNeeds, Unmeasured, Value, Values};
use serde::Serialize;

/// The f64 per-pixel function an operator resolves to for one frame: from
/// linear scene RGB to linear display RGB (1 = the display's white for an
/// SDR operator).
pub trait Curve: Send + Sync {
    /// The display colour of scene colour `c`. Must not return NaN for any
    /// finite or infinite input, and must map black to black.
    fn pixel(&self, c: [f64; 3]) -> [f64; 3];
}

/// What [`ToneOperator::resolve`] makes of one frame: the numbers it resolved
/// (for reports and for comparing with the GPU's) and the curve itself.
pub struct Resolution {
    /// Named resolved values, in the order of
    /// [`ToneOperator::resolved_names`].
    pub values: Vec<(&'static str, f64)>,
    /// The per-pixel function.
    pub curve: Box<dyn Curve>,
}

/// A tone-mapping operator: the one type every operator implements,
/// built-in or a caller's own.
///
/// The WGSL ([`ToneOperator::wgsl`]) must define
/// - `struct OperatorConfig`, the uniform the host writes from
///   [`ToneOperator::gpu_config`] (as many f32 as the struct holds, in
///   WGSL's uniform layout);
/// - `fn operator_resolve(s: Stats, k: OperatorConfig) -> vec4<f32>`, run
///   once per frame on the measured statistics (`Stats` is
///   shaders/shared/stats.wgsl's), whose result reaches every pixel;
/// - `fn operator_pixel(c: vec3<f32>, r: vec4<f32>, k: OperatorConfig) ->
///   vec3<f32>`, the curve for linear colour `c` and the resolved `r`.
///
/// The source may `//#include shared/<file>.wgsl` (colour.wgsl has
/// `SMALLEST_NORMAL` and `luminance_with`) and declare `override`
/// constants, which [`ToneOperator::gpu_constants`] sets. Every stage that
/// includes it declares the uniform as `config`: an operator with tables
/// in its `OperatorConfig` indexes `config` directly (as `aces2` does), so
/// that a dynamic index reads the uniform rather than a copy of it.
pub trait ToneOperator: Send + Sync + 'static {
    /// The name scene files, flags and the API use (`kind = "…"`).
    fn name(&self) -> &'static str;
    /// Other names accepted for it (earlier names of the same operator).
    fn aliases(&self) -> &'static [&'static str] {
        &[]
    }
    /// One line for documentation, `--help` and the API schema.
    fn summary(&self) -> &'static str;
    /// Its parameters, in the order a scene file is written back in.
    fn params(&self) -> &'static [Param];
    /// Checks between parameters, beyond each one's own range.
    fn check(&self, _values: &Values) -> Result<(), String> {
        Ok(())
    }
    /// The luminance its statistics are measured in.
    fn luminance(&self, _values: &Values) -> Luminance {
        Luminance::BT709
    }
    /// The statistics it needs measured: by default none, as for a fixed
    /// curve.
    fn needs(&self, _values: &Values) -> StatsNeeds {
        StatsNeeds::default()
    }
    /// The names of the (at most four) values it resolves per frame, in the
    /// order of `operator_resolve`'s vec4.
    fn resolved_names(&self) -> &'static [&'static str];
    /// The f64 reference: the frame's resolved values and curve. A statistic
    /// the operator needs but `stats` lacks is [`Unmeasured`].
    fn resolve(&self, values: &Values, stats: &LuminanceStats) -> Result<Resolution, Unmeasured>;
    /// The GPU's resolved vec4 as reported values (by default the
    /// [`ToneOperator::resolved_names`] in order).
    fn gpu_resolved(&self, _values: &Values, slots: [f32; 4]) -> Vec<(&'static str, f64)> {
        self.resolved_names()
            .iter()
            .zip(slots)
            .map(|(n, v)| (*n, v as f64))
            .collect()
    }
    /// The WGSL module (see the trait's documentation).
    fn wgsl(&self) -> &'static str;
    /// The `OperatorConfig` uniform's contents for these values.
    fn gpu_config(&self, values: &Values) -> Vec<f32>;
    /// Where [`ToneOperator::gpu_config`] puts the `exposure` parameter,
    /// for an operator that has one, so that a frame's new exposure
    /// (`ToneMapper::set_exposure`) is one word written in place, with no
    /// values built; `None` (the default) for an operator without one.
    fn gpu_exposure_word(&self) -> Option<ExposureWord> {
        None
    }
    /// The module's override constants for these values.
    fn gpu_constants(&self, _values: &Values) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
    /// Values of its parameters that trade accuracy for speed, each a
    /// change from the values a scene gives: `tradeoff` renders the scene
    /// with each and measures it against the scene as written. By default
    /// none.
    fn speed_knobs(&self) -> &'static [(&'static str, Value)] {
        &[]
    }
    /// The display its curve maps onto, in cd/m²: output 0 is `black`, 1
    /// is `peak`. `None` (the default) for a curve whose output is relative
    /// to an SDR display's white, which has no absolute level and so no
    /// PQ or HLG output.
    fn display_levels(&self, _values: &Values) -> Option<DisplayLevels> {
        None
    }
}

/// The black and peak, in cd/m², of the display an operator maps onto
/// ([`ToneOperator::display_levels`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DisplayLevels {
    /// What output 0 stands for.
    pub black: f64,
    /// What output 1 stands for.
    pub peak: f64,
}

impl DisplayLevels {
    /// One display-relative BT.709 pixel as BT.2020 light on this display,
    /// cd/m²: black + clamp(v, 0, 1)·(peak − black) (NaN as 0), then `m`
    /// (BT.709 → BT.2020). What a PQ or HLG encoding starts from.
    pub fn bt2020_nits(&self, m: &crate::color::Mat3, c: [f64; 3]) -> [f64; 3] {
        let DisplayLevels { black, peak } = *self;
        let light = c.map(|v| {
            let v = if v > 0.0 { v.min(1.0) } else { 0.0 };
            black + v * (peak - black)
        });
        // Each row of the matrix is non-negative and sums to 1, so a colour
        // within [black, peak] stays within it: the clamp only takes off
        // rounding (white came out 1e-13 above the peak).
        crate::color::apply(m, light).map(|v| v.clamp(0.0, peak))
    }
}

impl std::fmt::Debug for dyn ToneOperator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The word of the `OperatorConfig` uniform that holds an operator's
/// `exposure`, and how: `(exposure / divisor) as f32`, exactly as its
/// `gpu_config` writes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExposureWord {
    /// The word's index in the uniform.
    pub index: usize,
    /// What the exposure is divided by before it is stored (three.js's
    /// ACES fit stores exposure / 0.6).
    pub divisor: f64,
}

impl ExposureWord {
    /// The exposure as the first word, as it is.
    pub const FIRST: ExposureWord = ExposureWord {
        index: 0,
        divisor: 1.0,
    };

    /// The word for `exposure`.
    pub fn word(&self, exposure: f64) -> f32 {
        (exposure / self.divisor) as f32
    }
}
