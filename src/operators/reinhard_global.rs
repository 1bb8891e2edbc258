//! `reinhard-global`: Reinhard's global operator with a white point at a
//! fraction `w` of the scene maximum: the brightest areas burn as `w` falls;
//! Ld = L(1 + L/(w²·Lmax))/(1 + L) (docs/operators.md).

use super::reinhard::{self, GpuNumbers, COLOUR, KEY, LOG_AVERAGE};
use super::{Kind, Param, Range, Resolution, ToneOperator, Value, Values};
use super::{LuminanceStats, StatsNeeds, Unmeasured};

/// `reinhard-global`.
pub struct ReinhardGlobal;

const PARAMS: &[Param] = &[
    KEY,
    Param {
        name: "white_fraction",
        doc: "Fraction w of the scene maximum that maps to white (Lwhite² = w²·Lmax)",
        // Under 1e-6 every lit pixel burns to white already; a fraction
        // below f32's range would reach the GPU as 0, "never burn".
        kind: Kind::Number(Range::closed(1e-6, 1.0)),
        default: Value::Number(reinhard::DEFAULT_WHITE_FRACTION),
    },
    LOG_AVERAGE,
    Param {
        name: "max_luminance",
        doc: "Fixed Lmax instead of the measured maximum",
        kind: Kind::Number(Range::LUMINANCE),
        default: Value::Unset,
    },
    COLOUR,
];

impl ToneOperator for ReinhardGlobal {
    fn name(&self) -> &'static str {
        super::REINHARD_GLOBAL
    }
    fn aliases(&self) -> &'static [&'static str] {
        &["seed000"]
    }
    fn summary(&self) -> &'static str {
        "Reinhard 2002 global, white at a fraction of the scene maximum"
    }
    fn params(&self) -> &'static [Param] {
        PARAMS
    }
    fn needs(&self, v: &Values) -> StatsNeeds {
        StatsNeeds {
            log_average: v.number("log_average").is_none(),
            max: v.number("max_luminance").is_none(),
            ..Default::default()
        }
    }
    fn resolved_names(&self) -> &'static [&'static str] {
        reinhard::RESOLVED
    }
    fn resolve(&self, v: &Values, stats: &LuminanceStats) -> Result<Resolution, Unmeasured> {
        let measured = |v: Option<f64>, what| v.ok_or(Unmeasured(what));
        let lavg = measured(v.number("log_average").or(stats.log_average), "log-average")?;
        let lmax = measured(v.number("max_luminance").or(stats.max), "maximum")?;
        let w = v.num("white_fraction");
        let white_sq = reinhard::finite_positive_or_inf(w * w * lmax);
        Ok(reinhard::resolution(
            v.num("key"),
            lavg,
            white_sq,
            reinhard::weights(false),
            v,
        ))
    }
    fn gpu_resolved(&self, _v: &Values, slots: [f32; 4]) -> Vec<(&'static str, f64)> {
        reinhard::gpu_resolved(slots)
    }
    fn wgsl(&self) -> &'static str {
        include_str!("../../shaders/operators/reinhard_global.wgsl")
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        GpuNumbers {
            weights: reinhard::weights(false),
            key: v.num("key"),
            white_fraction: v.num("white_fraction"),
            white: 0.0,
            fixed_log_average: v.number("log_average").unwrap_or(0.0),
            fixed_max: v.number("max_luminance").unwrap_or(0.0),
        }
        .config()
    }
    fn gpu_constants(&self, v: &Values) -> Vec<(&'static str, f64)> {
        vec![reinhard::colour_constant(v)]
    }
}
