//! `reinhard-auto-key`: a weighted log-average (w = 1 − e^(−Y)), so large
//! near-black areas do not drag the exposure up; the key follows the scene's
//! spread around it (automatic) or is fixed; white = the scaled maximum
//! (docs/operators.md).

use super::reinhard::{self, GpuNumbers, COLOUR, DEFAULT_KEY, KEY};
use super::{Kind, Param, Resolution, ToneOperator, Value, Values};
use super::{LuminanceStats, StatsNeeds, Unmeasured};

/// `reinhard-auto-key`.
pub struct ReinhardAutoKey;

const PARAMS: &[Param] = &[
    Param {
        doc: "Key a, or \"auto\" (the default): from the frame's min, log-average and max",
        kind: Kind::NumberOrAuto(reinhard::KEY_RANGE),
        default: Value::Auto,
        ..KEY
    },
    COLOUR,
];

impl ToneOperator for ReinhardAutoKey {
    fn name(&self) -> &'static str {
        super::REINHARD_AUTO_KEY
    }
    fn aliases(&self) -> &'static [&'static str] {
        &["seed001"]
    }
    fn summary(&self) -> &'static str {
        "Reinhard 2002 global with a weighted log-average and an automatic key"
    }
    fn params(&self) -> &'static [Param] {
        PARAMS
    }
    fn needs(&self, v: &Values) -> StatsNeeds {
        StatsNeeds {
            weighted_log_average: true,
            max: true,
            min: v.is_auto("key"),
            ..Default::default()
        }
    }
    fn resolved_names(&self) -> &'static [&'static str] {
        reinhard::RESOLVED
    }
    fn resolve(&self, v: &Values, stats: &LuminanceStats) -> Result<Resolution, Unmeasured> {
        let measured = |v: Option<f64>, what| v.ok_or(Unmeasured(what));
        let lavg = measured(stats.weighted_log_average, "weighted log-average")?;
        let lmax = measured(stats.max, "maximum")?;
        let a = match v.number("key") {
            Some(k) => k,
            None => reinhard::automatic_key(measured(stats.min, "minimum")?, lavg, lmax),
        };
        let white = a * lmax / lavg;
        Ok(reinhard::resolution(
            a,
            lavg,
            reinhard::finite_positive_or_inf(white * white),
            reinhard::weights(false),
            v,
        ))
    }
    fn gpu_resolved(&self, _v: &Values, slots: [f32; 4]) -> Vec<(&'static str, f64)> {
        reinhard::gpu_resolved(slots)
    }
    fn wgsl(&self) -> &'static str {
        include_str!("../../shaders/operators/reinhard_auto_key.wgsl")
    }
    fn gpu_config(&self, v: &Values) -> Vec<f32> {
        GpuNumbers {
            weights: reinhard::weights(false),
            key: v.number("key").unwrap_or(DEFAULT_KEY),
            white_fraction: 1.0,
            white: 0.0,
            fixed_log_average: 0.0,
            fixed_max: 0.0,
        }
        .config()
    }
    fn gpu_constants(&self, v: &Values) -> Vec<(&'static str, f64)> {
        vec![
            reinhard::colour_constant(v),
            ("AUTO_KEY", v.is_auto("key") as u32 as f64),
        ]
    }
}
