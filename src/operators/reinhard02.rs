//! `reinhard02`: Reinhard 2002 global as pfstmo_reinhard02 without
//! --scales: key a, an absolute Lwhite, or the maximum scaled luminance when
//! unset (docs/operators.md).

use super::reinhard::{self, GpuNumbers, COLOUR, KEY, LOG_AVERAGE};
use super::{Kind, Luminance, Param, Range, Resolution, ToneOperator, Value, Values};
use super::{LuminanceStats, StatsNeeds, Unmeasured};

/// `reinhard02`.
pub struct Reinhard02;

const PARAMS: &[Param] = &[
    KEY,
    Param {
        name: "white",
        doc: "Absolute Lwhite (default: the maximum scaled luminance)",
        kind: Kind::Number(Range::LUMINANCE),
        default: Value::Unset,
    },
    LOG_AVERAGE,
    COLOUR,
    Param {
        name: "pfs_compatible",
        doc: "pfstools' luminance weights and δ = 1e-5 (the reinhard02 preset)",
        kind: Kind::Flag,
        default: Value::Flag(false),
    },
];

impl ToneOperator for Reinhard02 {
    fn name(&self) -> &'static str {
        super::REINHARD02
    }
    fn summary(&self) -> &'static str {
        "Reinhard 2002 global as pfstmo_reinhard02: key a and an absolute or scaled-maximum Lwhite"
    }
    fn params(&self) -> &'static [Param] {
        PARAMS
    }
    fn luminance(&self, v: &Values) -> Luminance {
        if v.flag("pfs_compatible") {
            Luminance {
                weights: reinhard::weights(true),
                delta: reinhard::DELTA_PFS,
            }
        } else {
            Luminance::BT709
        }
    }
    fn needs(&self, v: &Values) -> StatsNeeds {
        StatsNeeds {
            log_average: v.number("log_average").is_none(),
            max: v.number("white").is_none(),
            ..Default::default()
        }
    }
    fn resolved_names(&self) -> &'static [&'static str] {
        reinhard::RESOLVED
    }
    fn resolve(&self, v: &Values, stats: &LuminanceStats) -> Result<Resolution, Unmeasured> {
        let measured = |v: Option<f64>, what| v.ok_or(Unmeasured(what));
        let lavg = measured(v.number("log_average").or(stats.log_average), "log-average")?;
        let a = v.num("key");
        let white = match v.number("white") {
            Some(w) => w,
            None => a * measured(stats.max, "maximum")? / lavg,
        };
        Ok(reinhard::resolution(
            a,
            lavg,
            reinhard::finite_positive_or_inf(white * white),
            self.luminance(v).weights,
            v,
        ))
    }
    fn gpu_resolved(&self, _v: &Values, slots: [f32; 4]) -> Vec<(&'static str, f64)> {
        reinhard::gpu_resolved(slots)
    }
    fn wgsl(&self) -> &'static str {
        include_str!("../../shaders/operators/reinhard02.wgsl")
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        GpuNumbers {
            weights: self.luminance(v).weights,
            key: v.num("key"),
            white_fraction: 1.0,
            white: v.number("white").unwrap_or(0.0),
            fixed_log_average: v.number("log_average").unwrap_or(0.0),
            fixed_max: 0.0,
        }
        .config()
    }
    fn gpu_constants(&self, v: &Values) -> Vec<(&'static str, f64)> {
        vec![reinhard::colour_constant(v)]
    }
}

/// pfstmo_reinhard02's global mode with key `key`: the `reinhard02` preset.
pub fn preset(key: f64) -> Result<super::Operator, super::OperatorError> {
    super::Operator::with(
        std::sync::Arc::new(Reinhard02),
        &[
            ("key", Value::Number(key)),
            ("pfs_compatible", Value::Flag(true)),
        ],
    )
}
