//! Run history: every `check` and `tradeoff` run, per-frame metrics,
//! per-stage timings and FPS, submitted frames and alerts, with versioned
//! migrations; in an embedded SQLite file (WAL mode; the default) or, for a
//! fleet, one PostgreSQL database (`--db postgres://…`): the same schema and
//! statements on both (`backend`). A run is inserted as `running` before
//! anything is rendered and finished in one statement at the end; in between
//! it is written a scene at a time, each in its own transaction, so a process
//! killed mid-run leaves a consistent file with the run still `running`, and
//! the next open marks it `aborted` when its process is gone.

mod address;
mod alerts;
mod artifacts;
pub(crate) mod backend;
mod fleet;
mod frames;
mod jobs;
pub mod matrix;
#[cfg(feature = "s3")]
pub mod objects;
#[cfg(not(feature = "s3"))]
#[path = "objects_unbuilt.rs"]
pub mod objects;
#[cfg(feature = "postgres")]
mod postgres;
pub mod query;
mod reconnect;
mod record;
mod schema;
mod sqlite;
mod stamps;
mod submissions;
mod triage;

pub use address::{is_url, redacted, without_host};
pub use alerts::{AlertAttempt, AlertDelivery, AlertRow, Attempted, DueDelivery, RunBrief};
pub use artifacts::{
    ArtifactStats, Kept, PendingDone, PendingImage, PendingName, Pruned, StoredArtifact,
    STRAY_GRACE,
};
use backend::{args, Backend};
pub use fleet::{ClaimedJob, Expired, RunnerInfo, RunnerRow, MAX_ATTEMPTS};
pub use frames::{Label, NewFrame, NewSubmission, StoredSubmission, MAIN, MAX_PATTERN_CHARS};
pub use jobs::{valid_label, JobRow, JobSpec, LISTED_SCENES, MAX_QUEUED_JOBS};
pub use objects::{artifact_store, is_store_url, set_artifact_store, store_last_recovery, Objects};
pub use query::{RunRow, RunsFilter, TradeoffRow, TrendFilter, TrendPoint};
pub use reconnect::{last_recovery, set_retry_budget};
pub use record::{
    CheckRecord, FrameRecord, Regression, RunAdapter, RunMeta, SceneRecord, TradeoffRecord,
};
use rusqlite::Connection;
use schema::MIGRATIONS;
pub use schema::SCHEMA_VERSION;
use stamps::{ago, process_start};
pub use stamps::{git_commit, host_name, now, write_problem};
pub use submissions::{SubmissionRow, SubmittedFrame};
pub use triage::{IgnoreRule, TriageEntry};

/// The schema's migrations, oldest first: for tests and tools that build a
/// history as an older tonegate wrote it.
pub fn migrations() -> &'static [&'static str] {
    MIGRATIONS
}
use serde::{Deserialize, Serialize};
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
    /// The PostgreSQL history could not be reached, read or written.
    #[cfg(feature = "postgres")]
    #[error("history database {url}: {}", postgres::describe(source))]
    Postgres {
        url: String,
        source: ::postgres::Error,
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
    /// The object store the artifacts are kept in failed: `transient` when
    /// it did not answer (down, restarting, overloaded) rather than refused.
    #[error("artifact store {url}: {detail}")]
    Objects {
        url: String,
        detail: String,
        transient: bool,
    },
    /// The fleet's queue already holds as many waiting jobs as allowed.
    #[error("the queue is full: {queued} jobs are waiting (at most {limit}); try again when runners have taken some")]
    QueueFull { queued: i64, limit: u64 },
}

impl HistoryError {
    /// Whether the database could not be reached (down, restarting, the
    /// connection lost) past the process's retry budget: a condition to wait
    /// out, not a fault of the request.
    pub fn unavailable(&self) -> bool {
        match self {
            #[cfg(feature = "postgres")]
            HistoryError::Postgres { source, .. } => reconnect::connection_lost(source),
            _ => false,
        }
    }

    /// The error as an answer to a client may say it: what failed, without
    /// the database's path or address or the store's endpoint.
    pub fn without_address(&self) -> String {
        match self {
            HistoryError::Sqlite { source, .. } => format!("history database: {source}"),
            #[cfg(feature = "postgres")]
            HistoryError::Postgres { source, .. } => {
                format!("history database: {}", postgres::describe(source))
            }
            HistoryError::NewerSchema { found, known, .. } => format!(
                "the history database has schema version {found}; this tonegate knows up to {known}"
            ),
            HistoryError::Folder { source, .. } => format!("history database folder: {source}"),
            HistoryError::Objects { .. } => "the artifact store failed".into(),
            HistoryError::Invalid(_) | HistoryError::QueueFull { .. } => self.to_string(),
        }
    }

    /// Whether the artifact store did not answer past the retry budget: a
    /// condition to wait out, like [`HistoryError::unavailable`].
    pub fn store_unavailable(&self) -> bool {
        matches!(
            self,
            HistoryError::Objects {
                transient: true,
                ..
            }
        )
    }
}

/// A value stored as one of a fixed set of words.
pub trait StoredWord: Sized {
    const WHAT: &'static str;
    fn parse(text: &str) -> Option<Self>;
}

/// What a run is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum RunKind {
    Check,
    Tradeoff,
}

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
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

/// The words a run kind or status is stored and shown as: the same as its
/// serde name, so the database, the JSON and the console agree.
macro_rules! stored_as_words {
    ($t:ident { $($v:ident => $s:literal),+ $(,)? }) => {
        impl $t {
            pub const ALL: &'static [$t] = &[$($t::$v),+];

            pub fn as_str(self) -> &'static str {
                match self {
                    $($t::$v => $s),+
                }
            }
        }

        impl std::fmt::Display for $t {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.pad(self.as_str())
            }
        }

        impl StoredWord for $t {
            const WHAT: &'static str = stringify!($t);

            fn parse(text: &str) -> Option<Self> {
                $t::ALL.iter().copied().find(|k| k.as_str() == text)
            }
        }
    };
}

stored_as_words!(RunKind {
    Check => "check",
    Tradeoff => "tradeoff",
});
stored_as_words!(RunStatus {
    Running => "running",
    Passed => "passed",
    Failed => "failed",
    Error => "error",
    Aborted => "aborted",
});

/// A connection to the PostgreSQL history at `url`.
#[cfg(feature = "postgres")]
fn postgres_backend(url: &str, read_only: bool) -> Result<Box<dyn Backend>, HistoryError> {
    Ok(Box::new(postgres::Postgres::connect(url, read_only)?))
}

/// A build without the `postgres` feature refuses a PostgreSQL history.
#[cfg(not(feature = "postgres"))]
fn postgres_backend(url: &str, _read_only: bool) -> Result<Box<dyn Backend>, HistoryError> {
    Err(HistoryError::Invalid(format!(
        "history database {}: this tonegate was built without the `postgres` feature",
        redacted(url)
    )))
}

/// An open history: a SQLite file or a PostgreSQL database.
pub struct History {
    db: Box<dyn Backend>,
    /// The file, or the database's address without its password.
    path: PathBuf,
}

impl History {
    /// Opens (creating when absent) the history at `path` (a SQLite file, or
    /// a `postgres://` address), migrates it to this build's schema and
    /// marks dead runs `aborted`.
    pub fn open(path: &Path) -> Result<History, HistoryError> {
        let url = path.to_string_lossy();
        if is_url(&url) {
            let h = History {
                db: postgres_backend(&url, false)?,
                path: redacted(&url).into(),
            };
            h.db.migrate(MIGRATIONS)?;
            h.mark_aborted()?;
            return Ok(h);
        }
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| HistoryError::Folder {
                path: dir.to_owned(),
                source,
            })?;
        }
        let existed = path.exists();
        let conn = Connection::open(path).map_err(|source| {
            if existed {
                HistoryError::Sqlite {
                    path: path.to_owned(),
                    source,
                }
            } else {
                // A file SQLite cannot create: the folder is the problem.
                let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
                HistoryError::Folder {
                    path: dir.to_owned(),
                    source: std::io::Error::other(format!(
                        "cannot create the history database {} in this folder ({source}); is it writable?",
                        path.display()
                    )),
                }
            }
        })?;
        let db = sqlite::Sqlite {
            conn,
            path: path.to_owned(),
        };
        configure(&db)?;
        let h = History {
            db: Box::new(db),
            path: path.to_owned(),
        };
        h.db.migrate(MIGRATIONS)?;
        h.mark_aborted()?;
        Ok(h)
    }

    /// Opens an existing history for reading only (no migration, no abort
    /// marking): `history` and the API must not change what they show.
    pub fn open_read_only(path: &Path) -> Result<History, HistoryError> {
        let url = path.to_string_lossy();
        if is_url(&url) {
            let h = History {
                db: postgres_backend(&url, true)?,
                path: redacted(&url).into(),
            };
            h.check_version()?;
            return Ok(h);
        }
        match Self::open_read_only_with(path, false) {
            // A WAL database whose folder this process cannot write (so
            // SQLite cannot make the -shm file) and that no writer has open
            // (else the -shm file would be there): read it as immutable.
            Err(HistoryError::Sqlite { source, .. })
                if source.sqlite_error_code() == Some(rusqlite::ErrorCode::ReadOnly) =>
            {
                Self::open_read_only_with(path, true)
            }
            other => other,
        }
    }

    fn open_read_only_with(path: &Path, immutable: bool) -> Result<History, HistoryError> {
        use rusqlite::OpenFlags;
        let conn = if immutable {
            let uri = format!(
                "file:{}?immutable=1",
                path.to_string_lossy()
                    .replace('%', "%25")
                    .replace('?', "%3f")
                    .replace('#', "%23")
            );
            Connection::open_with_flags(
                uri,
                OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_URI,
            )
        } else {
            Connection::open_with_flags(path, OpenFlags::SQLITE_OPEN_READ_ONLY)
        }
        .map_err(|source| HistoryError::Sqlite {
            path: path.to_owned(),
            source,
        })?;
        let db = sqlite::Sqlite {
            conn,
            path: path.to_owned(),
        };
        db.conn
            .busy_timeout(Duration::from_secs(5))
            .map_err(|e| db.err(e))?;
        let h = History {
            db: Box::new(db),
            path: path.to_owned(),
        };
        h.check_version()?;
        Ok(h)
    }

    /// Refuses a history whose schema is not exactly this build's.
    fn check_version(&self) -> Result<(), HistoryError> {
        let version = self.schema_version()?;
        if version > SCHEMA_VERSION {
            return Err(HistoryError::NewerSchema {
                path: self.path.clone(),
                found: version,
                known: SCHEMA_VERSION,
            });
        }
        if version < SCHEMA_VERSION {
            return Err(HistoryError::Invalid(format!(
                "history database {} has schema version {version}, older than this tonegate's {SCHEMA_VERSION}: run `tonegate check` once to migrate it",
                self.path.display()
            )));
        }
        Ok(())
    }

    /// The file, or the database's address without its password.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether this history is a shared PostgreSQL database.
    pub fn is_shared(&self) -> bool {
        self.db.dialect() == backend::Dialect::Postgres
    }

    pub fn schema_version(&self) -> Result<i64, HistoryError> {
        self.db.schema_version()
    }

    /// Marks `running` runs of this host whose process is gone as `aborted`;
    /// returns how many. Runs of other hosts are left alone: their process
    /// cannot be looked at from here.
    pub fn mark_aborted(&self) -> Result<usize, HistoryError> {
        let rows = self.db.query(
            "SELECT id, pid, pid_start FROM runs WHERE status = 'running' AND host = $1",
            args![host_name()],
        )?;
        let mut n = 0;
        for row in rows {
            let (id, pid, start) = (row.int(0)?, row.int(1)?, row.opt_text(2)?);
            let alive = u32::try_from(pid)
                .ok()
                .and_then(process_start)
                .is_some_and(|s| Some(s) == start);
            if !alive {
                let at = now();
                let detail = format!(
                    "the process ended before the run finished (crash or kill); found {at}"
                );
                n += self.db.execute(
                    "UPDATE runs SET status = 'aborted', ended_at = $2, detail = $3
                     WHERE id = $1 AND status = 'running'",
                    args![id, at, detail],
                )? as usize;
            }
        }
        Ok(n)
    }

    /// Marks a run that is still `running` aborted, saying why; false when
    /// it had already ended.
    pub fn abort_run(&self, id: i64, why: &str) -> Result<bool, HistoryError> {
        let at = now();
        Ok(self.db.execute(
            "UPDATE runs SET status = 'aborted', ended_at = $2, detail = $3
             WHERE id = $1 AND status = 'running'",
            args![id, &at, format!("{why}; at {at}")],
        )? == 1)
    }

    /// The status of run `id`, if it exists.
    pub fn status(&self, id: i64) -> Result<Option<RunStatus>, HistoryError> {
        self.db
            .query_opt("SELECT status FROM runs WHERE id = $1", args![id])?
            .map(|r| r.word(0))
            .transpose()
    }

    /// `PRAGMA integrity_check` of a SQLite history: "ok" for a sound file.
    pub fn integrity(&self) -> Result<String, HistoryError> {
        self.db.integrity()
    }

    pub(crate) fn db(&self) -> &dyn Backend {
        &*self.db
    }
}

fn configure(db: &sqlite::Sqlite) -> Result<(), HistoryError> {
    let c = &db.conn;
    c.busy_timeout(Duration::from_secs(10))
        .map_err(|e| db.err(e))?;
    // WAL: readers (the dashboard) never block the writer, and a killed
    // writer leaves the last committed transaction intact. NORMAL sync is
    // durable against process death; only a power cut can lose the last
    // transaction, never corrupt the file.
    c.pragma_update_and_check(None, "journal_mode", "WAL", |_| Ok(()))
        .map_err(|e| db.err(e))?;
    c.pragma_update(None, "synchronous", "NORMAL")
        .map_err(|e| db.err(e))?;
    c.pragma_update(None, "foreign_keys", "ON")
        .map_err(|e| db.err(e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stored_words_are_the_serde_names() {
        // The database, the JSON and the console must say the same word.
        for k in RunKind::ALL {
            assert_eq!(serde_json::to_value(k).unwrap(), k.as_str());
            assert_eq!(format!("{k:<9}|"), format!("{:<9}|", k.as_str()));
        }
        for s in RunStatus::ALL {
            assert_eq!(serde_json::to_value(s).unwrap(), s.as_str());
        }
    }
}
