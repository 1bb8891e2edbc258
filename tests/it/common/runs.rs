//! Runs written straight into a history through its own writer, with the
//! figures a test needs (an FPS series, a red-after-green pattern), so that
//! what alerts find does not depend on how fast this machine renders.

/// Twelve finished runs of scene `fps-probe`, commits `p01`…`p12`, on one
/// adapter: about 60 FPS for six runs, then about 20 (a fixed ±1 pattern
/// around each level, so the series is not flat).
pub fn record_fps_series(db: &std::path::Path) {
    use tonegate::history::{History, RunAdapter, RunKind, RunMeta, RunStatus, SceneRecord};
    let mut h = History::open(db).unwrap();
    for run in 1..=12u32 {
        let level = if run <= 6 { 60.0 } else { 20.0 };
        let fps = level + [0.0, 1.0, -1.0][run as usize % 3];
        let id = h
            .start_run(
                RunKind::Check,
                &RunMeta {
                    suite: Some("fps-probe".into()),
                    suite_hash: None,
                    git_commit: Some(format!("p{run:02}")),
                },
            )
            .unwrap();
        h.set_adapter(
            id,
            &RunAdapter {
                name: "probe adapter".into(),
                backend: "Vulkan".into(),
                config: "{}".into(),
                ..RunAdapter::default()
            },
        )
        .unwrap();
        h.record_scene(
            id,
            &SceneRecord {
                scene: "fps-probe".into(),
                test: "moving".into(),
                passed: true,
                fps: Some(fps),
                frames: Vec::new(),
                timings: Vec::new(),
                checks: Vec::new(),
                result_json: "{}".into(),
            },
        )
        .unwrap();
        h.finish_run(id, RunStatus::Passed, None, None).unwrap();
    }
}

/// Six finished check runs of one suite and adapter, passing and failing in
/// turn: three red-after-green events.
pub fn record_red_after_green(db: &std::path::Path) {
    use tonegate::history::{History, RunAdapter, RunKind, RunMeta, RunStatus};
    let h = History::open(db).unwrap();
    for run in 1..=6u32 {
        let id = h
            .start_run(
                RunKind::Check,
                &RunMeta {
                    suite: Some("stuck-suite".into()),
                    suite_hash: None,
                    git_commit: Some(format!("s{run:02}")),
                },
            )
            .unwrap();
        h.set_adapter(
            id,
            &RunAdapter {
                name: "probe adapter".into(),
                config: "{}".into(),
                ..RunAdapter::default()
            },
        )
        .unwrap();
        let status = if run % 2 == 0 {
            RunStatus::Failed
        } else {
            RunStatus::Passed
        };
        h.finish_run(id, status, None, None).unwrap();
    }
}
