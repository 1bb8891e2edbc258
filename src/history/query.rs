//! Reading the history: run lists and per-scene metric trends.

use super::backend::args;
use super::{History, HistoryError, RunKind, RunStatus};
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
    /// Where E-Divisive (`changepoint`) finds that this (scene, adapter,
    /// renderer configuration) series shifted level at this run: the new
    /// level over the old one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub change: Option<f64>,
    /// The run's renderer configuration (JSON as recorded): series are split
    /// by it, not shown (it is long, and the same for most points).
    #[serde(skip)]
    pub config: Option<String>,
}

/// Marks each (scene, adapter, configuration) series' change points
/// (`TrendPoint::change`), the series in run order. Runs on different
/// adapters, or with different renderer knobs (f16, fused, the reduction),
/// are different series: a fleet's mix of GPUs and settings is not a level
/// shift.
fn mark_changes(points: &mut [TrendPoint]) {
    type Key = (String, Option<String>, Option<String>);
    let key = |p: &TrendPoint| -> Key {
        (
            p.scene.clone(),
            p.adapter.clone(),
            p.config.as_deref().map(series_config),
        )
    };
    let mut keys: Vec<Key> = points.iter().map(key).collect();
    keys.sort();
    keys.dedup();
    for k in keys {
        let mut idx: Vec<usize> = (0..points.len())
            .filter(|&i| key(&points[i]) == k)
            .collect();
        idx.sort_by_key(|&i| points[i].run_id);
        let series: Vec<f64> = idx.iter().map(|&i| points[i].value).collect();
        for (index, ratio) in change_points(&series) {
            points[idx[index]].change = Some(ratio);
        }
    }
}

/// The part of a run's renderer configuration that makes another series:
/// the knobs, without the injected faults (`fault_gain`, `taa_fault`: they
/// stand for a defect, which is what a level shift should show) and without
/// `adapter_chosen` (prose about the adapters present).
fn series_config(config: &str) -> String {
    match serde_json::from_str::<serde_json::Value>(config) {
        Ok(serde_json::Value::Object(mut m)) => {
            for k in [
                "fault_gain",
                "taa_fault",
                "fault_delay_ms",
                "adapter_chosen",
            ] {
                m.remove(k);
            }
            serde_json::Value::Object(m).to_string()
        }
        _ => config.to_owned(),
    }
}

/// E-Divisive's change points of a series (index, new level / old),
/// remembered by the series' values: a history only grows, so the dashboard
/// polling the same trend asks for the same series again and again, and its
/// permutation test (199 shuffles of an O(n²) scan when a shift is in view)
/// is paid once per new run instead of once per request.
fn change_points(series: &[f64]) -> Vec<(usize, f64)> {
    use std::collections::HashMap;
    use std::hash::{Hash, Hasher};
    use std::sync::Mutex;
    type Seen = HashMap<u64, (Vec<f64>, Vec<(usize, f64)>)>;
    static SEEN: Mutex<Option<Seen>> = Mutex::new(None);
    const KEEP: usize = 4096;
    let mut key = std::collections::hash_map::DefaultHasher::new();
    series.len().hash(&mut key);
    for v in series {
        v.to_bits().hash(&mut key);
    }
    let key = key.finish();
    // The series is kept beside its answer and compared, so a hash
    // collision recomputes instead of answering for another series.
    if let Some(found) = SEEN.lock().ok().and_then(|m| {
        m.as_ref()?
            .get(&key)
            .filter(|(s, _)| {
                s.len() == series.len()
                    && s.iter()
                        .zip(series)
                        .all(|(a, b)| a.to_bits() == b.to_bits())
            })
            .map(|(_, f)| f.clone())
    }) {
        return found;
    }
    let found: Vec<(usize, f64)> =
        crate::changepoint::e_divisive(series, &crate::changepoint::Options::default())
            .into_iter()
            .map(|c| (c.index, c.ratio))
            .collect();
    if let Ok(mut m) = SEEN.lock() {
        let m = m.get_or_insert_with(HashMap::new);
        if m.len() >= KEEP {
            m.clear();
        }
        m.insert(key, (series.to_vec(), found.clone()));
    }
    found
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
        // A stage's median time; the metric name is bound as $6.
        stage if stage.chars().all(|c| c.is_ascii_lowercase() || c == '_') && !stage.is_empty() => {
            "(SELECT median_ms FROM stage_timings t WHERE t.run_id = s.run_id AND t.scene = s.scene AND t.stage = $6)"
                .into()
        }
        other => {
            return Err(HistoryError::Invalid(format!(
                "unknown metric {other:?}: use psnr, ssim, snr, mse, rmse, max_abs_diff, mean_abs_diff, fraction_over_1lsb, flip_mean, fps or a stage name"
            )))
        }
    })
}

/// Filters of the run list; None matches everything.
#[derive(Clone, Debug, Default)]
pub struct RunsFilter<'a> {
    pub status: Option<RunStatus>,
    pub kind: Option<RunKind>,
    /// A substring of the adapter name, any case.
    pub adapter: Option<&'a str>,
    /// Newest runs kept.
    pub limit: u32,
}

/// A LIKE pattern (with `ESCAPE '\\'`) matching names that contain `a`, any
/// case: LIKE's own wildcards in `a` match only themselves.
fn substring_pattern(a: &str) -> String {
    let escaped = a
        .to_lowercase()
        .replace('\\', "\\\\")
        .replace('%', "\\%")
        .replace('_', "\\_");
    format!("%{escaped}%")
}

/// Filters of a trend query; None matches everything.
#[derive(Clone, Debug, Default)]
pub struct TrendFilter<'a> {
    pub scene: Option<&'a str>,
    /// The exact adapter name (regression baselines: one implementation's
    /// runs, never another's whose name contains it).
    pub adapter: Option<&'a str>,
    /// A substring of the adapter name, any case, as the run list takes it
    /// (the API's and the command line's `adapter`).
    pub adapter_contains: Option<&'a str>,
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
        self.runs_where(&RunsFilter {
            limit,
            ..Default::default()
        })
    }

    /// The newest runs the filter keeps, newest first (filtered in SQL).
    pub fn runs_where(&self, f: &RunsFilter) -> Result<Vec<RunRow>, HistoryError> {
        let pattern = f.adapter.map(substring_pattern);
        self.select_runs(
            "WHERE (CAST($1 AS TEXT) IS NULL OR r.status = $1)
               AND (CAST($2 AS TEXT) IS NULL OR r.kind = $2)
               AND (CAST($3 AS TEXT) IS NULL OR LOWER(r.adapter) LIKE $3 ESCAPE '\\')
             ORDER BY r.id DESC LIMIT $4",
            args![
                f.status.map(RunStatus::as_str),
                f.kind.map(RunKind::as_str),
                pattern,
                f.limit
            ],
        )
    }

    /// One run, when it exists.
    pub fn run(&self, id: i64) -> Result<Option<RunRow>, HistoryError> {
        Ok(self.select_runs("WHERE r.id = $1", args![id])?.pop())
    }

    /// The full JSON report a finished run stored (None while running, or
    /// when the run ended in an error).
    pub fn report(&self, id: i64) -> Result<Option<String>, HistoryError> {
        match self
            .db()
            .query_opt("SELECT report FROM runs WHERE id = $1", args![id])?
        {
            Some(r) => r.opt_text(0),
            None => Ok(None),
        }
    }

    /// How many runs there are of each status.
    pub fn status_counts(&self) -> Result<Vec<(RunStatus, i64)>, HistoryError> {
        self.db()
            .query(
                "SELECT status, COUNT(*) FROM runs GROUP BY status ORDER BY status",
                &[],
            )?
            .iter()
            .map(|r| Ok((r.word(0)?, r.int(1)?)))
            .collect()
    }

    /// The points a tradeoff run stored, in the order they were measured.
    pub fn tradeoff_points(&self, run: i64) -> Result<Vec<TradeoffRow>, HistoryError> {
        let sql = format!(
            "SELECT scene, label, config, ms, psnr, ssim, log_average_rel_error, pareto
             FROM tradeoff_points WHERE run_id = $1 ORDER BY {}",
            self.db().dialect().insertion_order()
        );
        self.db()
            .query(&sql, args![run])?
            .iter()
            .map(|r| {
                let config = r.text(2)?;
                Ok(TradeoffRow {
                    scene: r.text(0)?,
                    label: r.text(1)?,
                    config: serde_json::from_str(&config)
                        .unwrap_or(serde_json::Value::String(config)),
                    ms: r.real(3)?,
                    psnr: r.opt_real(4)?.unwrap_or(f64::NAN),
                    ssim: r.opt_real(5)?.unwrap_or(f64::NAN),
                    log_average_rel_error: r.opt_real(6)?,
                    pareto: r.bool(7)?,
                })
            })
            .collect()
    }

    fn select_runs(
        &self,
        tail: &str,
        args: &[super::backend::Value],
    ) -> Result<Vec<RunRow>, HistoryError> {
        let sql = format!(
            "SELECT r.id, r.kind, r.status, r.started_at, r.ended_at, r.tonegate_version,
                    r.git_commit, r.suite, r.suite_hash, r.adapter, r.backend, r.driver,
                    r.driver_info, r.host, r.detail,
                    (SELECT COUNT(*) FROM scene_results s WHERE s.run_id = r.id),
                    (SELECT COUNT(*) FROM scene_results s WHERE s.run_id = r.id AND s.passed = 0),
                    (SELECT COUNT(*) FROM regressions g WHERE g.run_id = r.id)
             FROM runs r {tail}"
        );
        self.db()
            .query(&sql, args)?
            .iter()
            .map(|r| {
                Ok(RunRow {
                    id: r.int(0)?,
                    kind: r.word(1)?,
                    status: r.word(2)?,
                    started_at: r.text(3)?,
                    ended_at: r.opt_text(4)?,
                    tonegate_version: r.text(5)?,
                    git_commit: r.opt_text(6)?,
                    suite: r.opt_text(7)?,
                    suite_hash: r.opt_text(8)?,
                    adapter: r.opt_text(9)?,
                    backend: r.opt_text(10)?,
                    driver: r.opt_text(11)?,
                    driver_info: r.opt_text(12)?,
                    host: r.text(13)?,
                    detail: r.opt_text(14)?,
                    scenes: r.int(15)?,
                    scenes_failed: r.int(16)?,
                    regressions: r.int(17)?,
                })
            })
            .collect()
    }

    /// `metric` of every scene (or one) over check runs, oldest first.
    pub fn trend(
        &self,
        metric: &str,
        filter: &TrendFilter,
    ) -> Result<Vec<TrendPoint>, HistoryError> {
        let value = metric_sql(metric)?;
        // The newest `limit` check runs the filters keep that have a value
        // (of the scene, when one is asked for), walked newest first on the
        // runs' key; then their scenes' values.
        let sql = format!(
            "WITH picked AS (
               SELECT r.id, r.started_at, r.status, r.adapter, r.config FROM runs r
               WHERE r.kind = 'check'
                 AND (CAST($2 AS TEXT) IS NULL OR r.adapter = $2)
                 AND (CAST($3 AS BIGINT) IS NULL OR r.id < $3)
                 AND ($4 = 0 OR r.status IN ('passed', 'failed'))
                 AND (CAST($7 AS TEXT) IS NULL OR r.config = $7)
                 AND (CAST($8 AS TEXT) IS NULL OR LOWER(r.adapter) LIKE $8 ESCAPE '\\')
                 AND EXISTS (SELECT 1 FROM scene_results s WHERE s.run_id = r.id
                               AND (CAST($1 AS TEXT) IS NULL OR s.scene = $1)
                               AND ({value}) IS NOT NULL)
               ORDER BY r.id DESC LIMIT $5
             )
             SELECT p.id, p.started_at, p.status, p.adapter, s.scene, {value},
                    CASE WHEN EXISTS (SELECT 1 FROM regressions g WHERE g.run_id = p.id AND g.scene = s.scene AND g.metric = $6) THEN 1 ELSE 0 END,
                    p.config
             FROM picked p JOIN scene_results s ON s.run_id = p.id
             WHERE (CAST($1 AS TEXT) IS NULL OR s.scene = $1)
               AND ({value}) IS NOT NULL
             ORDER BY p.id ASC, s.scene ASC"
        );
        let rows = self.db().query(
            &sql,
            args![
                filter.scene,
                filter.adapter,
                filter.before,
                filter.finished_only,
                filter.limit,
                metric,
                filter.config,
                filter.adapter_contains.map(substring_pattern)
            ],
        )?;
        let mut points = rows
            .iter()
            .map(|r| {
                Ok(TrendPoint {
                    run_id: r.int(0)?,
                    started_at: r.text(1)?,
                    status: r.word(2)?,
                    adapter: r.opt_text(3)?,
                    scene: r.text(4)?,
                    value: r.real(5)?,
                    regression: r.bool(6)?,
                    change: None,
                    config: r.opt_text(7)?,
                })
            })
            .collect::<Result<Vec<_>, HistoryError>>()?;
        mark_changes(&mut points);
        Ok(points)
    }

    /// The scene names the history knows, sorted.
    pub fn scenes(&self) -> Result<Vec<String>, HistoryError> {
        self.db()
            .query(
                "SELECT DISTINCT scene FROM scene_results ORDER BY scene",
                &[],
            )?
            .iter()
            .map(|r| r.text(0))
            .collect()
    }

    /// The stage names timed for `scene` in run `run`.
    pub fn stages(&self, run: i64, scene: &str) -> Result<Vec<String>, HistoryError> {
        let sql = format!(
            "SELECT stage FROM stage_timings WHERE run_id = $1 AND scene = $2 ORDER BY {}",
            self.db().dialect().insertion_order()
        );
        self.db()
            .query(&sql, args![run, scene])?
            .iter()
            .map(|r| r.text(0))
            .collect()
    }
}
