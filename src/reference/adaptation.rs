//! `adaptation`: the luminance the eye is adapted to, carried across
//! frames (scene::Adaptation; docs/adaptation.md), in f64.

use super::histogram::Histogram;
use crate::operators::{LuminanceStats, StatsNeeds};
use crate::scene::Adaptation;

/// What a sequence is adapted to after a frame: the natural logarithms of
/// the adapted log average and weighted log average (each where measured).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adapted {
    pub log_average: f64,
    pub weighted_log_average: Option<f64>,
    /// ln of the adapted largest luminance (`adapt_white`, for an operator
    /// that reads one), once a frame had a finite one.
    pub max: Option<f64>,
}

/// A frame's measurement, natural logarithms: the log average and the
/// weighted one (where the operator reads it). Not finite: no measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metered {
    pub log_average: f64,
    pub weighted_log_average: Option<f64>,
    /// ln of the frame's largest luminance, where its white point adapts.
    pub max: Option<f64>,
}

impl Metered {
    /// The log-average metering of `stats` (which measured the log
    /// average, and the weighted one where the operator reads it).
    pub fn log_average(stats: &LuminanceStats) -> Metered {
        Metered {
            log_average: stats.log_average.map_or(f64::NAN, f64::ln),
            weighted_log_average: stats.weighted_log_average.map(f64::ln),
            max: None,
        }
    }

    /// With the frame's largest luminance from `stats` where `a` adapts the
    /// white point of an operator that reads it (`needs`).
    pub fn with_white(self, stats: &LuminanceStats, a: &Adaptation, needs: StatsNeeds) -> Metered {
        Metered {
            max: (a.adapt_white && needs.max).then(|| stats.max.map_or(f64::NAN, f64::ln)),
            ..self
        }
    }

    /// The histogram's metering (NaN when it kept no weight), for an
    /// operator with `needs`: a weighted log average reads the same value.
    pub fn histogram(h: &Histogram, a: &Adaptation, needs: StatsNeeds) -> Metered {
        let m = h
            .metered_ev(a)
            .map_or(f64::NAN, |ev| ev * std::f64::consts::LN_2);
        Metered {
            log_average: m,
            weighted_log_average: needs.weighted_log_average.then_some(m),
            max: None,
        }
    }
}

/// One frame's step: `before` (None on the first frame, or after a reset)
/// moved toward the target of the frame's measurement (compensated and
/// clamped, [`Adaptation::target`]) by the rule of `a.speed` for a frame of
/// `dt` seconds; a first frame takes the target.
pub fn adapt(measured: Metered, before: Option<&Adapted>, a: &Adaptation, dt: f64) -> Adapted {
    // A non-finite measurement (a NaN or infinite pixel in a log average,
    // a histogram that kept nothing) never enters the state: the adapted
    // value stays, and a first frame takes ln 1, clamped
    // (docs/adaptation.md#bad-pixels).
    let step = |before: Option<f64>, m: f64| match before {
        _ if !m.is_finite() => before.unwrap_or_else(|| a.target(0.0)),
        None => a.target(m),
        Some(b) => a.follow(b, a.target(m), dt),
    };
    Adapted {
        log_average: step(before.map(|b| b.log_average), measured.log_average),
        weighted_log_average: measured
            .weighted_log_average
            .map(|w| step(before.and_then(|b| b.weighted_log_average), w)),
        // The white point follows the frame's largest luminance by the same
        // rule, unclamped and uncompensated; a non-finite one (a NaN or
        // infinite pixel, an all-black frame) leaves it, and until a frame
        // had a finite one each frame keeps its own.
        max: measured.max.and_then(|m| {
            let b = before.and_then(|b| b.max);
            match b {
                _ if !m.is_finite() => b,
                None => Some(m),
                Some(b) => Some(a.follow(b, m, dt)),
            }
        }),
    }
}

impl Adapted {
    /// The statistics the operator reads: the adapted values in place of
    /// the measured ones.
    pub fn statistics(&self, measured: &LuminanceStats) -> LuminanceStats {
        LuminanceStats {
            log_average: Some(self.log_average.exp()),
            weighted_log_average: self.weighted_log_average.map(f64::exp),
            max: self.max.map(f64::exp).or(measured.max),
            ..*measured
        }
    }

    /// The scale of an operator's input that keys on no log average
    /// (`needs`): `key` over the adapted luminance; 1 for the others.
    pub fn exposure(&self, adaptation: &Adaptation, needs: StatsNeeds) -> f64 {
        if needs.keys_on_average() {
            1.0
        } else {
            adaptation.key.get() / self.log_average.exp()
        }
    }
}

#[cfg(test)]
#[path = "adaptation_tests.rs"]
mod tests;
