//! What the history stores, as plain data its callers fill in, and the
//! writes: a run's start, its scenes, regressions, trade-off points, its end.

use super::backend::args;
use super::{host_name, now, process_start, History, HistoryError};
use super::{RunKind, RunStatus};
use crate::metrics::Metrics;
use crate::perf::TimingSummary;
use serde::Serialize;

/// What is known about a run when it starts.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RunMeta {
    pub suite: Option<String>,
    pub suite_hash: Option<String>,
    pub git_commit: Option<String>,
}

/// The adapter a run used, filled in once the device is open.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RunAdapter {
    pub name: String,
    pub backend: String,
    pub driver: String,
    pub driver_info: String,
    /// The renderer's knobs as JSON (intermediates, reduction, filter, spp).
    pub config: String,
}

/// One frame's metrics against its golden.
#[derive(Clone, Debug)]
pub struct FrameRecord {
    pub frame: u32,
    pub metrics: Metrics,
}

/// One check's outcome.
#[derive(Clone, Debug)]
pub struct CheckRecord {
    /// The check as people read it (`PSNR >= 50 dB [llvmpipe]`).
    pub label: String,
    /// None when the check did not apply.
    pub passed: Option<bool>,
    pub detail: String,
    pub adapter: Option<String>,
    pub set_by: Option<String>,
}

/// One scene of a check run.
#[derive(Clone, Debug)]
pub struct SceneRecord {
    pub scene: String,
    /// `static` or `moving`.
    pub test: String,
    pub passed: bool,
    pub fps: Option<f64>,
    pub frames: Vec<FrameRecord>,
    pub timings: Vec<TimingSummary>,
    pub checks: Vec<CheckRecord>,
    /// The whole scene result as JSON, served back as stored.
    pub result_json: String,
}

/// A value flagged as slower than its history.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Regression {
    pub scene: String,
    /// "fps" or a stage name (median ms).
    pub metric: String,
    pub value: f64,
    /// Median of the previous runs.
    pub median: f64,
    /// Median absolute deviation of the previous runs.
    pub mad: f64,
    /// The value beyond which this metric is flagged.
    pub bound: f64,
    /// How many previous runs the median is over.
    pub runs: usize,
    /// value / median.
    pub ratio: f64,
}

/// One configuration a trade-off sweep measured.
#[derive(Clone, Debug)]
pub struct TradeoffRecord {
    pub scene: String,
    pub label: String,
    /// The configuration's knobs as JSON.
    pub config: String,
    pub ms: f64,
    pub psnr: f64,
    pub ssim: f64,
    pub log_average_rel_error: f64,
    pub pareto: bool,
}

impl History {
    /// Inserts a `running` run owned by this process; returns its id.
    pub fn start_run(&self, kind: RunKind, meta: &RunMeta) -> Result<i64, HistoryError> {
        let pid = std::process::id();
        let row = self.db().query_opt(
            "INSERT INTO runs (kind, status, started_at, tonegate_version, git_commit, suite,
                               suite_hash, host, pid, pid_start)
             VALUES ($1, 'running', $2, $3, $4, $5, $6, $7, $8, $9)
             RETURNING id",
            args![
                kind.as_str(),
                now(),
                env!("CARGO_PKG_VERSION"),
                &meta.git_commit,
                &meta.suite,
                &meta.suite_hash,
                host_name(),
                pid,
                process_start(pid),
            ],
        )?;
        row.ok_or_else(|| HistoryError::Invalid("inserting a run returned no id".into()))?
            .int(0)
    }

    /// Records the suite's hash once the suite has been read.
    pub fn set_suite_hash(&self, run: i64, hash: &str) -> Result<(), HistoryError> {
        self.db().execute(
            "UPDATE runs SET suite_hash = $2 WHERE id = $1",
            args![run, hash],
        )?;
        Ok(())
    }

    /// Records the adapter (or CPU reference) once it is known.
    pub fn set_adapter(&self, run: i64, a: &RunAdapter) -> Result<(), HistoryError> {
        self.db().execute(
            "UPDATE runs SET adapter = $2, backend = $3, driver = $4, driver_info = $5, config = $6
             WHERE id = $1",
            args![
                run,
                &a.name,
                &a.backend,
                &a.driver,
                &a.driver_info,
                &a.config
            ],
        )?;
        Ok(())
    }

    /// Records one scene's result, frames, timings and checks in one transaction.
    pub fn record_scene(&mut self, run: i64, r: &SceneRecord) -> Result<(), HistoryError> {
        self.db().transaction(&mut |tx| {
            tx.execute(
                "INSERT INTO scene_results (run_id, scene, test, passed, fps, frames, result)
                 VALUES ($1, $2, $3, $4, $5, $6, $7)",
                args![run, &r.scene, &r.test, r.passed, r.fps, r.frames.len(), &r.result_json],
            )?;
            for f in &r.frames {
                let m = &f.metrics;
                tx.execute(
                    "INSERT INTO frame_metrics (run_id, scene, frame, mse, rmse, psnr, snr, ssim,
                                                max_abs_diff, fraction_over_1lsb, mean_abs_diff,
                                                flip_mean)
                     VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12)",
                    args![
                        run,
                        &r.scene,
                        f.frame,
                        m.mse,
                        m.rmse,
                        m.psnr,
                        m.snr,
                        m.ssim,
                        i64::from(m.max_abs_diff),
                        m.fraction_over_1lsb,
                        m.mean_abs_diff,
                        m.flip_mean
                    ],
                )?;
            }
            for t in &r.timings {
                tx.execute(
                    "INSERT INTO stage_timings (run_id, scene, stage, median_ms, p95_ms)
                     VALUES ($1, $2, $3, $4, $5)",
                    args![run, &r.scene, &t.name, t.median_ms, t.p95_ms],
                )?;
            }
            for (i, c) in r.checks.iter().enumerate() {
                tx.execute(
                    "INSERT INTO check_results (run_id, scene, idx, label, passed, detail, adapter, set_by)
                     VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
                    args![run, &r.scene, i, &c.label, c.passed, &c.detail, &c.adapter, &c.set_by],
                )?;
            }
            Ok(())
        })
    }

    /// Records the regressions flagged for a run.
    pub fn record_regressions(
        &mut self,
        run: i64,
        found: &[Regression],
    ) -> Result<(), HistoryError> {
        self.db().transaction(&mut |tx| {
            for g in found {
                tx.execute(
                    "INSERT INTO regressions (run_id, scene, metric, value, median, mad, bound, runs)
                     VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
                    args![run, &g.scene, &g.metric, g.value, g.median, g.mad, g.bound, g.runs],
                )?;
            }
            Ok(())
        })
    }

    /// Records a trade-off sweep's points (every scene's, in one transaction).
    pub fn record_tradeoff(
        &mut self,
        run: i64,
        points: &[TradeoffRecord],
    ) -> Result<(), HistoryError> {
        self.db().transaction(&mut |tx| {
            for p in points {
                tx.execute(
                    "INSERT INTO tradeoff_points (run_id, scene, label, config, ms, psnr, ssim,
                                                  log_average_rel_error, pareto)
                     VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9)",
                    args![
                        run,
                        &p.scene,
                        &p.label,
                        &p.config,
                        p.ms,
                        p.psnr,
                        p.ssim,
                        p.log_average_rel_error,
                        p.pareto
                    ],
                )?;
            }
            Ok(())
        })
    }

    /// Ends a run: its status, an optional message and the full JSON report.
    /// A run already ended (aborted because its runner was declared lost
    /// while it went on) keeps its end: the job's next claim is its run.
    pub fn finish_run(
        &self,
        run: i64,
        status: RunStatus,
        detail: Option<&str>,
        report: Option<&str>,
    ) -> Result<(), HistoryError> {
        self.db().execute(
            "UPDATE runs SET status = $2, ended_at = $3, detail = $4, report = $5
             WHERE id = $1 AND status = 'running'",
            args![run, status.as_str(), now(), detail, report],
        )?;
        Ok(())
    }
}
