//! What a check run hands the history: a scene's record, and the metrics
//! the history can trend.

use crate::check::SceneResult;
use crate::history::{CheckRecord, FrameRecord, HistoryError, SceneRecord};

/// A scene's result as the history stores it.
pub fn scene_record(r: &SceneResult) -> Result<SceneRecord, HistoryError> {
    let result_json = serde_json::to_string(r).map_err(|e| HistoryError::Invalid(e.to_string()))?;
    Ok(SceneRecord {
        scene: r.scene.clone(),
        test: r.test.name().into(),
        passed: r.passed(),
        fps: r.fps,
        frames: r
            .frames
            .iter()
            .map(|f| FrameRecord {
                frame: f.frame,
                metrics: f.metrics.clone(),
            })
            .collect(),
        timings: r.timings.clone(),
        checks: r
            .checks
            .iter()
            .map(|c| CheckRecord {
                label: c.spec.label(),
                passed: c.passed,
                detail: c.detail.clone(),
                adapter: c.spec.adapter.clone(),
                set_by: c.spec.set_by.clone(),
            })
            .collect(),
        result_json,
    })
}

/// The metrics the gate records per scene and the history can trend: every
/// per-frame figure, FPS, and each stage's median time.
pub fn recorded_metrics() -> Vec<&'static str> {
    let mut all: Vec<&'static str> = crate::check::FRAME_METRICS.iter().map(|m| m.name).collect();
    all.push("fps");
    all.extend(crate::plan::Stage::NAMES);
    all
}

/// Whether `name` is one of [`recorded_metrics`].
pub fn is_recorded_metric(name: &str) -> bool {
    recorded_metrics().contains(&name)
}
