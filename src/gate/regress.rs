//! Nightly performance regressions: each scene's FPS and stage times against
//! the median of the previous runs on the same adapter, with a noise-aware
//! bound from the median absolute deviation.

use crate::check::SceneResult;
use crate::history::{History, HistoryError, Regression, TrendFilter};
use crate::perf::quantile;
use crate::suite::Performance;

/// 1.4826·MAD estimates the standard deviation of normally distributed noise
/// (1/Φ⁻¹(3/4)); unlike the standard deviation, one wild run in the window
/// barely moves it.
pub const MAD_TO_SIGMA: f64 = 1.4826;

/// The bound for `value` given its history, and whether it is crossed.
/// `higher_is_worse` for times, not for FPS. None with too little history.
pub fn judge(
    value: f64,
    history: &[f64],
    higher_is_worse: bool,
    policy: &Performance,
) -> Option<(f64, f64, f64, bool)> {
    let past: Vec<f64> = history.iter().copied().filter(|v| v.is_finite()).collect();
    if past.len() < policy.min_runs as usize || !value.is_finite() {
        return None;
    }
    let m = quantile(&past, 0.5);
    let dev: Vec<f64> = past.iter().map(|v| (v - m).abs()).collect();
    let mad = quantile(&dev, 0.5);
    let margin = (policy.mads * MAD_TO_SIGMA * mad).max(policy.min_relative * m.abs());
    let (bound, crossed) = if higher_is_worse {
        (m + margin, value > m + margin)
    } else {
        (m - margin, value < m - margin)
    };
    Some((m, mad, bound, crossed))
}

/// Compares every scene of run `run` with the previous `policy.window`
/// finished check runs on `adapter` with the same renderer `config` (spp,
/// intermediates, reduction, filter): other settings are other workloads.
pub fn find_regressions(
    history: &History,
    run: i64,
    adapter: &str,
    config: &str,
    results: &[SceneResult],
    policy: &Performance,
) -> Result<Vec<Regression>, HistoryError> {
    let mut found = Vec::new();
    for r in results {
        let mut metrics: Vec<(String, f64, bool)> = Vec::new();
        if let Some(fps) = r.fps {
            metrics.push(("fps".into(), fps, false));
        }
        for t in &r.timings {
            metrics.push((t.name.clone(), t.median_ms, true));
        }
        for (metric, value, higher_is_worse) in metrics {
            let past: Vec<f64> = history
                .trend(
                    &metric,
                    &TrendFilter {
                        scene: Some(&r.scene),
                        adapter: Some(adapter),
                        adapter_contains: None,
                        config: Some(config),
                        before: Some(run),
                        finished_only: true,
                        limit: policy.window,
                    },
                )?
                .into_iter()
                .map(|p| p.value)
                .collect();
            if let Some((median, mad, bound, true)) = judge(value, &past, higher_is_worse, policy) {
                found.push(Regression {
                    scene: r.scene.clone(),
                    metric,
                    value,
                    median,
                    mad,
                    bound,
                    runs: past.len(),
                    ratio: value / median,
                });
            }
        }
    }
    Ok(found)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slowdown_beyond_the_noise_is_flagged_and_noise_is_not() {
        let p = Performance::default();
        // Stage times with about 2 % noise.
        let past = [10.0, 10.2, 9.9, 10.1, 9.8, 10.3, 10.0];
        let (m, mad, bound, crossed) = judge(10.4, &past, true, &p).unwrap();
        assert_eq!(m, 10.0);
        assert!((mad - 0.1).abs() < 1e-12);
        assert!(!crossed, "10.4 ms is within the noise (bound {bound})");
        let (_, _, _, crossed) = judge(12.0, &past, true, &p).unwrap();
        assert!(crossed, "a 20 % slowdown must be flagged");
        // FPS: lower is worse.
        let fps = [30.0, 31.0, 29.5, 30.5];
        assert!(judge(24.0, &fps, false, &p).unwrap().3);
        assert!(!judge(36.0, &fps, false, &p).unwrap().3);
    }

    #[test]
    fn a_steady_history_still_needs_the_relative_floor_to_be_crossed() {
        let p = Performance::default();
        let past = [5.0; 6];
        // MAD is 0: without the floor every change would be flagged.
        assert!(!judge(5.3, &past, true, &p).unwrap().3);
        assert!(judge(5.6, &past, true, &p).unwrap().3);
    }

    #[test]
    fn one_wild_run_does_not_widen_the_bound() {
        let p = Performance::default();
        let past = [10.0, 10.1, 9.9, 10.0, 50.0];
        let (m, _, bound, _) = judge(10.0, &past, true, &p).unwrap();
        assert_eq!(m, 10.0);
        assert!(bound < 11.5, "bound {bound}");
    }

    #[test]
    fn too_little_history_flags_nothing() {
        let p = Performance::default();
        assert!(judge(100.0, &[1.0, 1.0], true, &p).is_none());
        assert!(judge(f64::NAN, &[1.0, 1.0, 1.0], true, &p).is_none());
    }
}
