//! Reading the history: run lists and per-scene metric trends.

use super::{History, HistoryError, RunKind, RunStatus};
use rusqlite::{params, OptionalExtension};
use serde::Serialize;

/// One run as the run list shows it.
#[derive(Clone, Debug, Serialize, utoipa::ToSchema)]
pub struct RunRow {
    pub id: i64,
    pub kind: RunKind,
    pub status: RunStatus,
    pub started_at: String,
    pub ended_at: Option<String>,
    pub tonegate_version: String,
    pub git_commit: Option<String>,
    pub suite: Option<String>,
    pub suite_hash: Option<String>,
    pub adapter: Option<String>,
    pub backend: Option<String>,
    pub driver: Option<String>,
    pub driver_info: Option<String>,
    pub host: String,
    pub detail: Option<String>,
    pub scenes: i64,
    pub scenes_failed: i64,
    pub regressions: i64,
}

/// One configuration a tradeoff run measured.
#[derive(Clone, Debug, Serialize, utoipa::ToSchema)]
pub struct TradeoffRow {
    pub scene: String,
    pub label: String,
    #[schema(value_type = Object)]
    pub config: serde_json::Value,
    pub ms: f64,
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub psnr: f64,
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub ssim: f64,
    pub log_average_rel_error: Option<f64>,
    pub pareto: bool,
}

/// One value of a metric for one scene in one run.
#[derive(Clone, Debug, Serialize, utoipa::ToSchema)]
pub struct TrendPoint {
    pub run_id: i64,
    pub started_at: String,
    pub status: RunStatus,
    pub adapter: Option<String>,
    pub scene: String,
    #[serde(with = "crate::metrics::json::extended_f64")]
    pub value: f64,
    /// Whether this run flagged this metric of this scene as a regression.
    pub regression: bool,
    /// Where E-Divisive (`changepoint`) finds that this (scene, adapter)
    /// series shifted level at this run: the new level over the old one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub change: Option<f64>,
}

/// Marks each (scene, adapter) series' change points (`TrendPoint::change`),
/// the series in run order. Runs on different adapters are different series:
/// a fleet's mix of GPUs is not a level shift.
fn mark_changes(points: &mut [TrendPoint]) {
    let mut keys: Vec<(String, Option<String>)> = points
        .iter()
        .map(|p| (p.scene.clone(), p.adapter.clone()))
        .collect();
    keys.sort();
    keys.dedup();
    for (scene, adapter) in keys {
        let mut idx: Vec<usize> = (0..points.len())
            .filter(|&i| points[i].scene == scene && points[i].adapter == adapter)
            .collect();
        idx.sort_by_key(|&i| points[i].run_id);
        let series: Vec<f64> = idx.iter().map(|&i| points[i].value).collect();
        let options = crate::changepoint::Options::default();
        for c in crate::changepoint::e_divisive(&series, &options) {
            points[idx[c.index]].change = Some(c.ratio);
        }
    }
}

/// How one metric of a scene is read out of a run: worst frame for image
/// metrics, the scene's FPS, or a stage's median time.
fn metric_sql(metric: &str) -> Result<String, HistoryError> {
    let frame = |agg: &str, col: &str| {
        format!("(SELECT {agg}({col}) FROM frame_metrics f WHERE f.run_id = s.run_id AND f.scene = s.scene)")
    };
    Ok(match metric {
        "psnr" | "ssim" | "snr" => frame("MIN", metric),
        "mse" | "rmse" | "max_abs_diff" | "mean_abs_diff" | "fraction_over_1lsb"
        | "flip_mean" => frame("MAX", metric),
        "fps" => "s.fps".into(),
        // A stage's median time; the metric name is bound as ?7.
        stage if stage.chars().all(|c| c.is_ascii_lowercase() || c == '_') && !stage.is_empty() => {
            "(SELECT median_ms FROM stage_timings t WHERE t.run_id = s.run_id AND t.scene = s.scene AND t.stage = ?7)"
                .into()
        }
        other => {
            return Err(HistoryError::Invalid(format!(
                "unknown metric {other:?}: use psnr, ssim, snr, mse, rmse, max_abs_diff, mean_abs_diff, fraction_over_1lsb, flip_mean, fps or a stage name"
            )))
        }
    })
}

/// Filters of a trend query; None matches everything.
#[derive(Clone, Debug, Default)]
pub struct TrendFilter<'a> {
    pub scene: Option<&'a str>,
    pub adapter: Option<&'a str>,
    /// Only runs before this id (exclusive).
    pub before: Option<i64>,
    /// Only runs with exactly this renderer configuration (JSON as recorded).
    pub config: Option<&'a str>,
    /// Only finished check runs (passed or failed), as regression baselines need.
    pub finished_only: bool,
    /// Newest runs kept.
    pub limit: u32,
}

impl History {
    /// The newest `limit` runs, newest first.
    pub fn runs(&self, limit: u32) -> Result<Vec<RunRow>, HistoryError> {
        self.select_runs("ORDER BY r.id DESC LIMIT ?1", limit as i64)
    }

    /// One run, when it exists.
    pub fn run(&self, id: i64) -> Result<Option<RunRow>, HistoryError> {
        Ok(self.select_runs("WHERE r.id = ?1", id)?.pop())
    }

    /// The full JSON report a finished run stored (None while running, or
    /// when the run ended in an error).
    pub fn report(&self, id: i64) -> Result<Option<String>, HistoryError> {
        self.conn()
            .query_row("SELECT report FROM runs WHERE id = ?1", [id], |r| r.get(0))
            .optional()
            .map(Option::flatten)
            .map_err(|e| self.err(e))
    }

    /// How many runs there are of each status.
    pub fn status_counts(&self) -> Result<Vec<(RunStatus, i64)>, HistoryError> {
        let mut stmt = self
            .conn()
            .prepare("SELECT status, COUNT(*) FROM runs GROUP BY status ORDER BY status")
            .map_err(|e| self.err(e))?;
        let rows = stmt
            .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
            .and_then(|rows| rows.collect())
            .map_err(|e| self.err(e))?;
        Ok(rows)
    }

    /// The points a tradeoff run stored, in the order they were measured.
    pub fn tradeoff_points(&self, run: i64) -> Result<Vec<TradeoffRow>, HistoryError> {
        let mut stmt = self
            .conn()
            .prepare(
                "SELECT scene, label, config, ms, psnr, ssim, log_average_rel_error, pareto
                 FROM tradeoff_points WHERE run_id = ?1 ORDER BY rowid",
            )
            .map_err(|e| self.err(e))?;
        let rows = stmt
            .query_map([run], |r| {
                let config: String = r.get(2)?;
                Ok(TradeoffRow {
                    scene: r.get(0)?,
                    label: r.get(1)?,
                    config: serde_json::from_str(&config)
                        .unwrap_or(serde_json::Value::String(config)),
                    ms: r.get(3)?,
                    psnr: r.get::<_, Option<f64>>(4)?.unwrap_or(f64::NAN),
                    ssim: r.get::<_, Option<f64>>(5)?.unwrap_or(f64::NAN),
                    log_average_rel_error: r.get(6)?,
                    pareto: r.get(7)?,
                })
            })
            .and_then(|rows| rows.collect())
            .map_err(|e| self.err(e))?;
        Ok(rows)
    }

    fn select_runs(&self, tail: &str, arg: i64) -> Result<Vec<RunRow>, HistoryError> {
        let mut stmt = self
            .conn()
            .prepare(&format!(
                "SELECT r.id, r.kind, r.status, r.started_at, r.ended_at, r.tonegate_version,
                        r.git_commit, r.suite, r.suite_hash, r.adapter, r.backend, r.driver,
                        r.driver_info, r.host, r.detail,
                        (SELECT COUNT(*) FROM scene_results s WHERE s.run_id = r.id),
                        (SELECT COUNT(*) FROM scene_results s WHERE s.run_id = r.id AND NOT s.passed),
                        (SELECT COUNT(*) FROM regressions g WHERE g.run_id = r.id)
                 FROM runs r {tail}"
            ))
            .map_err(|e| self.err(e))?;
        let rows = stmt
            .query_map([arg], |r| {
                Ok(RunRow {
                    id: r.get(0)?,
                    kind: r.get(1)?,
                    status: r.get(2)?,
                    started_at: r.get(3)?,
                    ended_at: r.get(4)?,
                    tonegate_version: r.get(5)?,
                    git_commit: r.get(6)?,
                    suite: r.get(7)?,
                    suite_hash: r.get(8)?,
                    adapter: r.get(9)?,
                    backend: r.get(10)?,
                    driver: r.get(11)?,
                    driver_info: r.get(12)?,
                    host: r.get(13)?,
                    detail: r.get(14)?,
                    scenes: r.get(15)?,
                    scenes_failed: r.get(16)?,
                    regressions: r.get(17)?,
                })
            })
            .and_then(|rows| rows.collect())
            .map_err(|e| self.err(e))?;
        Ok(rows)
    }

    /// `metric` of every scene (or one) over check runs, oldest first.
    pub fn trend(
        &self,
        metric: &str,
        filter: &TrendFilter,
    ) -> Result<Vec<TrendPoint>, HistoryError> {
        let value = metric_sql(metric)?;
        let sql = format!(
            "SELECT * FROM (
               SELECT r.id, r.started_at, r.status, r.adapter, s.scene, {value},
                      EXISTS (SELECT 1 FROM regressions g WHERE g.run_id = r.id AND g.scene = s.scene AND g.metric = ?7)
               FROM runs r JOIN scene_results s ON s.run_id = r.id
               WHERE r.kind = 'check'
                 AND (?1 IS NULL OR s.scene = ?1)
                 AND (?2 IS NULL OR r.adapter = ?2)
                 AND (?3 IS NULL OR r.id < ?3)
                 AND (?4 = 0 OR r.status IN ('passed', 'failed'))
                 AND (?8 IS NULL OR r.config = ?8)
                 AND ({value}) IS NOT NULL
               ORDER BY r.id DESC LIMIT ?5 * (CASE WHEN ?1 IS NULL THEN ?6 ELSE 1 END)
             ) ORDER BY 1 ASC, 5 ASC"
        );
        // With no scene filter the limit counts runs, so it is scaled by the
        // number of scenes a run can have.
        let scenes_per_run: i64 = self
            .conn()
            .query_row(
                "SELECT COALESCE(MAX(n), 1) FROM (SELECT COUNT(*) AS n FROM scene_results GROUP BY run_id)",
                [],
                |r| r.get(0),
            )
            .map_err(|e| self.err(e))?;
        let mut stmt = self.conn().prepare(&sql).map_err(|e| self.err(e))?;
        let rows = stmt
            .query_map(
                params![
                    filter.scene,
                    filter.adapter,
                    filter.before,
                    filter.finished_only,
                    filter.limit as i64,
                    scenes_per_run,
                    metric,
                    filter.config
                ],
                |r| {
                    Ok(TrendPoint {
                        run_id: r.get(0)?,
                        started_at: r.get(1)?,
                        status: r.get(2)?,
                        adapter: r.get(3)?,
                        scene: r.get(4)?,
                        value: r.get(5)?,
                        regression: r.get(6)?,
                        change: None,
                    })
                },
            )
            .and_then(|rows| rows.collect())
            .map_err(|e| self.err(e))?;
        let mut rows: Vec<TrendPoint> = rows;
        mark_changes(&mut rows);
        Ok(rows)
    }

    /// The scene names the history knows, sorted.
    pub fn scenes(&self) -> Result<Vec<String>, HistoryError> {
        let mut stmt = self
            .conn()
            .prepare("SELECT DISTINCT scene FROM scene_results ORDER BY scene")
            .map_err(|e| self.err(e))?;
        let rows = stmt
            .query_map([], |r| r.get(0))
            .and_then(|rows| rows.collect())
            .map_err(|e| self.err(e))?;
        Ok(rows)
    }

    /// The stage names timed for `scene` in run `run`.
    pub fn stages(&self, run: i64, scene: &str) -> Result<Vec<String>, HistoryError> {
        let mut stmt = self
            .conn()
            .prepare(
                "SELECT stage FROM stage_timings WHERE run_id = ?1 AND scene = ?2 ORDER BY rowid",
            )
            .map_err(|e| self.err(e))?;
        let rows = stmt
            .query_map(params![run, scene], |r| r.get(0))
            .and_then(|rows| rows.collect())
            .map_err(|e| self.err(e))?;
        Ok(rows)
    }
}
