//! Run history: an embedded SQLite file (WAL mode, versioned migrations) that
//! records every `check` and `tradeoff` run, per-frame metrics, per-stage
//! timings and FPS.
//!
//! A run is inserted as `running` before anything is rendered and finished in
//! one statement at the end; everything in between is written a scene at a
//! time, each in its own transaction. A process killed mid-run therefore
//! leaves a consistent file with the run still `running`, and the next open
//! marks it `aborted` when the process that owned it is gone.

pub mod query;
pub mod regress;

pub use query::{RunRow, TradeoffRow, TrendFilter, TrendPoint};
pub use regress::{find_regressions, Regression};

use crate::suite::SceneResult;
use rusqlite::{params, Connection, OptionalExtension};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Debug, thiserror::Error)]
pub enum HistoryError {
    /// The database file could not be opened, read or written.
    #[error("history database {path}: {source}")]
    Sqlite {
        path: PathBuf,
        source: rusqlite::Error,
    },
    /// The file was written by a newer tonegate whose schema this build does not know.
    #[error("history database {path} has schema version {found}; this tonegate knows up to {known}: use a newer tonegate or another --db")]
    NewerSchema {
        path: PathBuf,
        found: i64,
        known: i64,
    },
    /// The folder for the database could not be created.
    #[error("history database {path}: {source}")]
    Folder {
        path: PathBuf,
        source: std::io::Error,
    },
    /// A query asked for something that does not exist.
    #[error("{0}")]
    Invalid(String),
}

/// The schema, one migration per version. Never edit a released migration:
/// add a new one. `PRAGMA user_version` holds how many have been applied.
const MIGRATIONS: &[&str] = &[
    // 1: runs, scene results, per-frame metrics, stage timings, checks,
    //    regressions and trade-off points.
    r#"
    CREATE TABLE runs (
        id               INTEGER PRIMARY KEY,
        kind             TEXT NOT NULL CHECK (kind IN ('check', 'tradeoff')),
        status           TEXT NOT NULL CHECK (status IN ('running', 'passed', 'failed', 'error', 'aborted')),
        started_at       TEXT NOT NULL,
        ended_at         TEXT,
        tonegate_version TEXT NOT NULL,
        git_commit       TEXT,
        suite            TEXT,
        suite_hash       TEXT,
        adapter          TEXT,
        backend          TEXT,
        driver           TEXT,
        driver_info      TEXT,
        config           TEXT,
        host             TEXT NOT NULL,
        pid              INTEGER NOT NULL,
        pid_start        TEXT,
        detail           TEXT,
        report           TEXT
    );
    CREATE INDEX runs_by_adapter ON runs (kind, adapter, id);
    CREATE TABLE scene_results (
        run_id  INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene   TEXT NOT NULL,
        test    TEXT NOT NULL,
        passed  INTEGER NOT NULL,
        fps     REAL,
        frames  INTEGER NOT NULL,
        result  TEXT NOT NULL,
        PRIMARY KEY (run_id, scene)
    );
    CREATE TABLE frame_metrics (
        run_id       INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene        TEXT NOT NULL,
        frame        INTEGER NOT NULL,
        mse          REAL,
        rmse         REAL,
        psnr         REAL,
        snr          REAL,
        ssim         REAL,
        max_abs_diff INTEGER,
        fraction_over_1lsb REAL,
        PRIMARY KEY (run_id, scene, frame)
    );
    CREATE TABLE stage_timings (
        run_id    INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene     TEXT NOT NULL,
        stage     TEXT NOT NULL,
        median_ms REAL NOT NULL,
        p95_ms    REAL NOT NULL,
        PRIMARY KEY (run_id, scene, stage)
    );
    CREATE TABLE check_results (
        run_id  INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene   TEXT NOT NULL,
        idx     INTEGER NOT NULL,
        label   TEXT NOT NULL,
        passed  INTEGER,
        detail  TEXT NOT NULL,
        adapter TEXT,
        set_by  TEXT,
        PRIMARY KEY (run_id, scene, idx)
    );
    CREATE TABLE regressions (
        run_id  INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene   TEXT NOT NULL,
        metric  TEXT NOT NULL,
        value   REAL NOT NULL,
        median  REAL NOT NULL,
        mad     REAL NOT NULL,
        bound   REAL NOT NULL,
        runs    INTEGER NOT NULL,
        PRIMARY KEY (run_id, scene, metric)
    );
    CREATE TABLE tradeoff_points (
        run_id  INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
        scene   TEXT NOT NULL,
        label   TEXT NOT NULL,
        config  TEXT NOT NULL,
        ms      REAL NOT NULL,
        psnr    REAL,
        ssim    REAL,
        log_average_rel_error REAL,
        pareto  INTEGER NOT NULL,
        PRIMARY KEY (run_id, scene, label)
    );
    "#,
];

/// The schema version this build writes.
pub const SCHEMA_VERSION: i64 = MIGRATIONS.len() as i64;

/// What a run is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RunKind {
    Check,
    Tradeoff,
}

impl RunKind {
    fn as_str(self) -> &'static str {
        match self {
            RunKind::Check => "check",
            RunKind::Tradeoff => "tradeoff",
        }
    }
}

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    Running,
    Passed,
    Failed,
    /// The run could not happen (no adapter, missing golden, bad suite file).
    Error,
    /// The process died before finishing (found by the next open).
    Aborted,
}

impl RunStatus {
    pub fn as_str(self) -> &'static str {
        match self {
            RunStatus::Running => "running",
            RunStatus::Passed => "passed",
            RunStatus::Failed => "failed",
            RunStatus::Error => "error",
            RunStatus::Aborted => "aborted",
        }
    }
}

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

/// An open history file.
pub struct History {
    conn: Connection,
    path: PathBuf,
}

/// The current UTC time, RFC 3339 with milliseconds (sorts as text).
pub fn now() -> String {
    chrono::Utc::now().to_rfc3339_opts(chrono::SecondsFormat::Millis, true)
}

/// This machine's name, for telling whose `running` rows may be judged dead.
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_owned())
        .ok()
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "unknown".into())
}

/// The start time of process `pid` in clock ticks since boot (field 22 of
/// /proc/PID/stat): with the pid it names one process even after pid reuse.
fn process_start(pid: u32) -> Option<String> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name (field 2) is in parentheses and may contain spaces.
    let after = &stat[stat.rfind(')')? + 2..];
    after.split_whitespace().nth(19).map(str::to_owned)
}

/// The commit of the working tree at `dir`, from CI variables or git.
pub fn git_commit(dir: &Path) -> Option<String> {
    for var in [
        "TONEGATE_COMMIT",
        "GITHUB_SHA",
        "CI_COMMIT_SHA",
        "GIT_COMMIT",
    ] {
        if let Ok(v) = std::env::var(var) {
            if !v.trim().is_empty() {
                return Some(v.trim().to_owned());
            }
        }
    }
    let out = std::process::Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(["rev-parse", "HEAD"])
        .stderr(std::process::Stdio::null())
        .output()
        .ok()?;
    let s = String::from_utf8(out.stdout).ok()?;
    (out.status.success() && !s.trim().is_empty()).then(|| s.trim().to_owned())
}

/// Maps a rusqlite error to one that names the file; owned, so it can be used
/// while a transaction borrows the connection.
fn sqlite_error(path: PathBuf) -> impl Fn(rusqlite::Error) -> HistoryError {
    move |source| HistoryError::Sqlite {
        path: path.clone(),
        source,
    }
}

impl History {
    /// Opens (creating when absent) the history at `path`, migrates it to
    /// this build's schema and marks dead runs `aborted`.
    pub fn open(path: &Path) -> Result<History, HistoryError> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| HistoryError::Folder {
                path: dir.to_owned(),
                source,
            })?;
        }
        let conn = Connection::open(path).map_err(|source| HistoryError::Sqlite {
            path: path.to_owned(),
            source,
        })?;
        let mut h = History {
            conn,
            path: path.to_owned(),
        };
        h.configure()?;
        h.migrate()?;
        h.mark_aborted()?;
        Ok(h)
    }

    /// Opens an existing history for reading only (no migration, no abort
    /// marking): `history` and the API must not change what they show.
    pub fn open_read_only(path: &Path) -> Result<History, HistoryError> {
        let conn = Connection::open_with_flags(path, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
            .map_err(|source| HistoryError::Sqlite {
                path: path.to_owned(),
                source,
            })?;
        let h = History {
            conn,
            path: path.to_owned(),
        };
        h.conn
            .busy_timeout(Duration::from_secs(5))
            .map_err(|e| h.err(e))?;
        let version = h.schema_version()?;
        if version > SCHEMA_VERSION {
            return Err(HistoryError::NewerSchema {
                path: path.to_owned(),
                found: version,
                known: SCHEMA_VERSION,
            });
        }
        if version < SCHEMA_VERSION {
            return Err(HistoryError::Invalid(format!(
                "history database {} has schema version {version}, older than this tonegate's {SCHEMA_VERSION}: run `tonegate check` once to migrate it",
                path.display()
            )));
        }
        Ok(h)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    fn err(&self, source: rusqlite::Error) -> HistoryError {
        HistoryError::Sqlite {
            path: self.path.clone(),
            source,
        }
    }

    fn configure(&self) -> Result<(), HistoryError> {
        let c = &self.conn;
        c.busy_timeout(Duration::from_secs(10))
            .map_err(|e| self.err(e))?;
        // WAL: readers (the dashboard) never block the writer, and a killed
        // writer leaves the last committed transaction intact. NORMAL sync is
        // durable against process death; only a power cut can lose the last
        // transaction, never corrupt the file.
        c.pragma_update_and_check(None, "journal_mode", "WAL", |_| Ok(()))
            .map_err(|e| self.err(e))?;
        c.pragma_update(None, "synchronous", "NORMAL")
            .map_err(|e| self.err(e))?;
        c.pragma_update(None, "foreign_keys", "ON")
            .map_err(|e| self.err(e))?;
        Ok(())
    }

    pub fn schema_version(&self) -> Result<i64, HistoryError> {
        self.conn
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .map_err(|e| self.err(e))
    }

    fn migrate(&mut self) -> Result<(), HistoryError> {
        let version = self.schema_version()?;
        if version > SCHEMA_VERSION {
            return Err(HistoryError::NewerSchema {
                path: self.path.clone(),
                found: version,
                known: SCHEMA_VERSION,
            });
        }
        for (i, sql) in MIGRATIONS.iter().enumerate().skip(version as usize) {
            let err = sqlite_error(self.path.clone());
            // Each migration and its version bump commit together.
            let tx = self.conn.transaction().map_err(&err)?;
            tx.execute_batch(sql).map_err(&err)?;
            tx.pragma_update(None, "user_version", (i + 1) as i64)
                .map_err(&err)?;
            tx.commit().map_err(&err)?;
        }
        Ok(())
    }

    /// Marks `running` runs of this host whose process is gone as `aborted`;
    /// returns how many. Runs of other hosts are left alone: their process
    /// cannot be looked at from here.
    pub fn mark_aborted(&self) -> Result<usize, HistoryError> {
        let host = host_name();
        let mut stmt = self
            .conn
            .prepare("SELECT id, pid, pid_start FROM runs WHERE status = 'running' AND host = ?1")
            .map_err(|e| self.err(e))?;
        let rows: Vec<(i64, i64, Option<String>)> = stmt
            .query_map([&host], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
            .and_then(|rows| rows.collect())
            .map_err(|e| self.err(e))?;
        let mut n = 0;
        for (id, pid, start) in rows {
            let alive = u32::try_from(pid)
                .ok()
                .and_then(process_start)
                .is_some_and(|s| Some(s) == start);
            if !alive {
                n += self
                    .conn
                    .execute(
                        "UPDATE runs SET status = 'aborted', ended_at = ?2,
                         detail = 'the process ended before the run finished (crash or kill); found ' || ?2
                         WHERE id = ?1 AND status = 'running'",
                        params![id, now()],
                    )
                    .map_err(|e| self.err(e))?;
            }
        }
        Ok(n)
    }

    /// Inserts a `running` run owned by this process; returns its id.
    pub fn start_run(&self, kind: RunKind, meta: &RunMeta) -> Result<i64, HistoryError> {
        let pid = std::process::id();
        self.conn
            .execute(
                "INSERT INTO runs (kind, status, started_at, tonegate_version, git_commit, suite,
                                   suite_hash, host, pid, pid_start)
                 VALUES (?1, 'running', ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
                params![
                    kind.as_str(),
                    now(),
                    env!("CARGO_PKG_VERSION"),
                    meta.git_commit,
                    meta.suite,
                    meta.suite_hash,
                    host_name(),
                    pid as i64,
                    process_start(pid),
                ],
            )
            .map_err(|e| self.err(e))?;
        Ok(self.conn.last_insert_rowid())
    }

    /// Records the suite's hash once the suite has been read.
    pub fn set_suite_hash(&self, run: i64, hash: &str) -> Result<(), HistoryError> {
        self.conn
            .execute(
                "UPDATE runs SET suite_hash = ?2 WHERE id = ?1",
                params![run, hash],
            )
            .map_err(|e| self.err(e))?;
        Ok(())
    }

    /// Records the adapter (or CPU reference) once it is known.
    pub fn set_adapter(&self, run: i64, a: &RunAdapter) -> Result<(), HistoryError> {
        self.conn
            .execute(
                "UPDATE runs SET adapter = ?2, backend = ?3, driver = ?4, driver_info = ?5, config = ?6
                 WHERE id = ?1",
                params![run, a.name, a.backend, a.driver, a.driver_info, a.config],
            )
            .map_err(|e| self.err(e))?;
        Ok(())
    }

    /// Records one scene's result, frames, timings and checks in one transaction.
    pub fn record_scene(&mut self, run: i64, r: &SceneResult) -> Result<(), HistoryError> {
        let err = sqlite_error(self.path.clone());
        let json = serde_json::to_string(r).map_err(|e| HistoryError::Invalid(e.to_string()))?;
        let tx = self.conn.transaction().map_err(&err)?;
        tx.execute(
            "INSERT INTO scene_results (run_id, scene, test, passed, fps, frames, result)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)",
            params![
                run,
                r.scene,
                serde_json::to_value(r.test)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_owned)),
                r.passed(),
                r.fps,
                r.frames.len() as i64,
                json
            ],
        )
        .map_err(&err)?;
        {
            let mut frame = tx
                .prepare(
                    "INSERT INTO frame_metrics (run_id, scene, frame, mse, rmse, psnr, snr, ssim,
                                                max_abs_diff, fraction_over_1lsb)
                     VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)",
                )
                .map_err(&err)?;
            for f in &r.frames {
                let m = &f.metrics;
                frame
                    .execute(params![
                        run,
                        r.scene,
                        f.frame,
                        m.mse,
                        m.rmse,
                        m.psnr,
                        m.snr,
                        m.ssim,
                        m.max_abs_diff,
                        m.fraction_over_1lsb
                    ])
                    .map_err(&err)?;
            }
            let mut stage = tx
                .prepare(
                    "INSERT INTO stage_timings (run_id, scene, stage, median_ms, p95_ms)
                     VALUES (?1, ?2, ?3, ?4, ?5)",
                )
                .map_err(&err)?;
            for t in &r.timings {
                stage
                    .execute(params![run, r.scene, t.name, t.median_ms, t.p95_ms])
                    .map_err(&err)?;
            }
            let mut check = tx
                .prepare(
                    "INSERT INTO check_results (run_id, scene, idx, label, passed, detail, adapter, set_by)
                     VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)",
                )
                .map_err(&err)?;
            for (i, c) in r.checks.iter().enumerate() {
                check
                    .execute(params![
                        run,
                        r.scene,
                        i as i64,
                        crate::suite::check_label(&c.spec),
                        c.passed,
                        c.detail,
                        c.spec.adapter,
                        c.spec.set_by
                    ])
                    .map_err(&err)?;
            }
        }
        tx.commit().map_err(&err)
    }

    /// Records the regressions flagged for a run.
    pub fn record_regressions(
        &mut self,
        run: i64,
        found: &[Regression],
    ) -> Result<(), HistoryError> {
        let err = sqlite_error(self.path.clone());
        let tx = self.conn.transaction().map_err(&err)?;
        for g in found {
            tx.execute(
                "INSERT INTO regressions (run_id, scene, metric, value, median, mad, bound, runs)
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)",
                params![
                    run,
                    g.scene,
                    g.metric,
                    g.value,
                    g.median,
                    g.mad,
                    g.bound,
                    g.runs as i64
                ],
            )
            .map_err(&err)?;
        }
        tx.commit().map_err(&err)
    }

    /// Records a trade-off sweep's points (every scene's, in one transaction).
    pub fn record_tradeoff(
        &mut self,
        run: i64,
        points: &[crate::tradeoff::Point],
    ) -> Result<(), HistoryError> {
        let err = sqlite_error(self.path.clone());
        let tx = self.conn.transaction().map_err(&err)?;
        for p in points {
            let knobs = serde_json::to_string(&p.knobs).unwrap_or_default();
            tx.execute(
                "INSERT INTO tradeoff_points (run_id, scene, label, config, ms, psnr, ssim,
                                              log_average_rel_error, pareto)
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
                params![
                    run,
                    p.scene,
                    p.label,
                    knobs,
                    p.ms,
                    p.psnr,
                    p.ssim,
                    p.log_average_rel_error,
                    p.pareto
                ],
            )
            .map_err(&err)?;
        }
        tx.commit().map_err(&err)
    }

    /// Ends a run: its status, an optional message and the full JSON report.
    pub fn finish_run(
        &self,
        run: i64,
        status: RunStatus,
        detail: Option<&str>,
        report: Option<&str>,
    ) -> Result<(), HistoryError> {
        self.conn
            .execute(
                "UPDATE runs SET status = ?2, ended_at = ?3, detail = ?4, report = ?5 WHERE id = ?1",
                params![run, status.as_str(), now(), detail, report],
            )
            .map_err(|e| self.err(e))?;
        Ok(())
    }

    /// The status of run `id`, if it exists.
    pub fn status(&self, id: i64) -> Result<Option<String>, HistoryError> {
        self.conn
            .query_row("SELECT status FROM runs WHERE id = ?1", [id], |r| r.get(0))
            .optional()
            .map_err(|e| self.err(e))
    }

    /// `PRAGMA integrity_check`: "ok" for a sound file.
    pub fn integrity(&self) -> Result<String, HistoryError> {
        self.conn
            .query_row("PRAGMA integrity_check", [], |r| r.get(0))
            .map_err(|e| self.err(e))
    }

    pub(crate) fn conn(&self) -> &Connection {
        &self.conn
    }
}
