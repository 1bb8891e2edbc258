//! Performance figures shared by every layer: a stage's time in one frame,
//! its median and p95 over a run, and the quantile they are computed with;
//! `clock`, where a process's time goes by part.

pub mod clock;

use serde::Serialize;

/// One stage's time in one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StageTiming {
    pub stage: String,
    pub ms: f64,
}

/// Median and 95th percentile of one stage over a run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TimingSummary {
    pub name: String,
    pub median_ms: f64,
    pub p95_ms: f64,
}

/// The q-quantile (0..=1) of `values` by linear interpolation between order
/// statistics (numpy's default); NaN for an empty slice.
pub fn quantile(values: &[f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v: Vec<f64> = values.to_vec();
    v.sort_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
}

/// Median and p95 of each stage across frames, in plan order.
pub fn summarise(frames: &[Vec<StageTiming>]) -> Vec<TimingSummary> {
    let Some(first) = frames.first() else {
        return Vec::new();
    };
    first
        .iter()
        .map(|s| {
            let values: Vec<f64> = frames
                .iter()
                .filter_map(|f| f.iter().find(|t| t.stage == s.stage).map(|t| t.ms))
                .collect();
            TimingSummary {
                name: s.stage.clone(),
                median_ms: quantile(&values, 0.5),
                p95_ms: quantile(&values, 0.95),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_interpolate_like_numpy() {
        let v = [4.0, 1.0, 3.0, 2.0];
        assert_eq!(quantile(&v, 0.5), 2.5);
        assert_eq!(quantile(&v, 0.0), 1.0);
        assert_eq!(quantile(&v, 1.0), 4.0);
        assert!((quantile(&v, 0.95) - 3.85).abs() < 1e-12);
        assert!(quantile(&[], 0.5).is_nan());
    }
}
