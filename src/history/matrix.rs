//! The adapter matrix: for the newest finished check run of each adapter
//! (and backend) in the history, every scene's verdict and figures, so that
//! a scene that passes on one adapter and fails on another stands out.

use super::backend::args;
use super::{History, HistoryError};
use serde::Serialize;

/// One adapter's column: the run it comes from.
#[derive(Clone, Debug, Serialize, utoipa::ToSchema)]
pub struct MatrixAdapter {
    pub adapter: String,
    pub backend: Option<String>,
    pub driver: Option<String>,
    pub run_id: i64,
    pub started_at: String,
    /// As the subnormal probe measured it when the run opened the device;
    /// `None` for the CPU reference and for runs recorded before the probe.
    pub flushes_subnormals: Option<bool>,
}

/// One scene on one adapter.
#[derive(Clone, Debug, Serialize, utoipa::ToSchema)]
pub struct MatrixCell {
    pub scene: String,
    /// Index into `adapters`.
    pub column: usize,
    pub run_id: i64,
    pub passed: bool,
    /// The worst frame's PSNR against the golden, dB.
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub worst_psnr: f64,
    /// The worst frame's mean FLIP error (`None` where not measured).
    pub worst_flip: Option<f64>,
    pub fps: Option<f64>,
}

/// Scenes × adapters.
#[derive(Clone, Debug, Serialize, utoipa::ToSchema)]
pub struct Matrix {
    pub adapters: Vec<MatrixAdapter>,
    /// How many (adapter, backend) columns the history has in all; more
    /// than `adapters` holds when the limit cut them.
    pub adapters_total: i64,
    /// Every scene that any column has, sorted.
    pub scenes: Vec<String>,
    pub cells: Vec<MatrixCell>,
    /// Scenes that pass on some adapter and fail on another.
    pub split: Vec<String>,
}

impl History {
    /// The matrix over the newest finished check run of each (adapter,
    /// backend), at most `limit` adapters (the most recently run first).
    pub fn matrix(&self, limit: u32) -> Result<Matrix, HistoryError> {
        let adapters: Vec<MatrixAdapter> = self
            .db()
            .query(
                "SELECT r.id, r.adapter, r.backend, r.driver, r.started_at, r.config
                 FROM runs r
                 WHERE r.id IN (SELECT MAX(id) FROM runs
                                WHERE kind = 'check' AND status IN ('passed', 'failed')
                                  AND adapter IS NOT NULL
                                GROUP BY adapter, backend)
                 ORDER BY r.id DESC LIMIT $1",
                args![limit],
            )?
            .iter()
            .map(|r| {
                let config = r.opt_text(5)?;
                Ok(MatrixAdapter {
                    run_id: r.int(0)?,
                    adapter: r.text(1)?,
                    backend: r.opt_text(2)?,
                    driver: r.opt_text(3)?,
                    started_at: r.text(4)?,
                    flushes_subnormals: config
                        .and_then(|c| serde_json::from_str::<serde_json::Value>(&c).ok())
                        .and_then(|c| c.get("flushes_subnormals")?.as_bool()),
                })
            })
            .collect::<Result<_, HistoryError>>()?;
        let adapters_total = self
            .db()
            .query_opt(
                "SELECT COUNT(*) FROM (SELECT 1 FROM runs
                   WHERE kind = 'check' AND status IN ('passed', 'failed') AND adapter IS NOT NULL
                   GROUP BY adapter, backend) AS columns",
                &[],
            )?
            .map_or(Ok(0), |r| r.int(0))?;
        let mut cells = Vec::new();
        for (column, a) in adapters.iter().enumerate() {
            let rows = self.db().query(
                "SELECT s.scene, s.passed, s.fps,
                        (SELECT MIN(psnr) FROM frame_metrics f WHERE f.run_id = s.run_id AND f.scene = s.scene),
                        (SELECT MAX(flip_mean) FROM frame_metrics f WHERE f.run_id = s.run_id AND f.scene = s.scene)
                 FROM scene_results s WHERE s.run_id = $1",
                args![a.run_id],
            )?;
            for r in rows {
                cells.push(MatrixCell {
                    scene: r.text(0)?,
                    column,
                    run_id: a.run_id,
                    passed: r.bool(1)?,
                    fps: r.opt_real(2)?,
                    // No frames recorded (the scene could not render): null.
                    worst_psnr: r.opt_real(3)?.unwrap_or(f64::NAN),
                    worst_flip: r.opt_real(4)?,
                });
            }
        }
        let mut scenes: Vec<String> = cells.iter().map(|c| c.scene.clone()).collect();
        scenes.sort();
        scenes.dedup();
        let split = scenes
            .iter()
            .filter(|s| {
                let verdicts: Vec<bool> = cells
                    .iter()
                    .filter(|c| &c.scene == *s)
                    .map(|c| c.passed)
                    .collect();
                verdicts.contains(&true) && verdicts.contains(&false)
            })
            .cloned()
            .collect();
        Ok(Matrix {
            adapters,
            adapters_total,
            scenes,
            cells,
            split,
        })
    }
}
