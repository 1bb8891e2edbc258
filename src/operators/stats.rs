//! What an operator asks to be measured and what it is given: the frame's
//! luminance statistics (docs/statistics.md). `plan` builds the
//! `luminance_stats` stage from the first, and both renderers fill the
//! second.

use serde::Serialize;

/// Which luminance statistics a frame needs (what the Reinhard variants and a
/// `scaled` bloom adapt to).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct StatsNeeds {
    /// exp(mean ln(δ + Y)) over all pixels.
    pub log_average: bool,
    /// `reinhard-auto-key`'s exp(Σ w·ln(δ + Y) / Σ w), w = 1 − e^(−Y).
    pub weighted_log_average: bool,
    /// The smallest Y.
    pub min: bool,
    /// The largest Y.
    pub max: bool,
}

impl StatsNeeds {
    /// Whether the operator reads a log average, which eye adaptation
    /// replaces with the adapted one; one that reads none gets
    /// auto-exposure instead (docs/adaptation.md).
    pub fn keys_on_average(&self) -> bool {
        self.log_average || self.weighted_log_average
    }

    /// These needs and the log average: what a plan with eye adaptation
    /// measures.
    pub fn with_log_average(self) -> StatsNeeds {
        StatsNeeds {
            log_average: true,
            ..self
        }
    }

    /// Whether anything is measured at all.
    pub fn any(&self) -> bool {
        self.log_average || self.weighted_log_average || self.min || self.max
    }
}

/// The statistics a frame's operator needs; the ones not asked for are `None`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct LuminanceStats {
    /// exp(mean ln(δ + Y)) (docs/statistics.md#log-average).
    pub log_average: Option<f64>,
    /// exp(Σ w·ln(δ + Y) / Σ w), w = 1 − e^(−Y)
    /// (docs/statistics.md#weighted-log-average).
    pub weighted_log_average: Option<f64>,
    /// The smallest Y.
    pub min: Option<f64>,
    /// The largest Y.
    pub max: Option<f64>,
    /// Σw of the weighted mean; 0 means the fallback to the plain mean was used.
    pub weight_sum: Option<f64>,
}

/// A statistic the operator needs and the frame's plan did not measure: a
/// plan that does not measure what its operator needs is a tonegate bug
/// (the plan converts it into its own error).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("the operator needs the frame's {0}, which was not measured")]
pub struct Unmeasured(pub &'static str);
