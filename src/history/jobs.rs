//! The fleet's queue: a check run queued as a job (`JobSpec`, checked when
//! queued, at most `MAX_QUEUED_JOBS` waiting), and the listings of jobs,
//! bounded in size whatever was queued. Runners take them in `fleet`.

use super::backend::{args, Value};
use super::{now, History, HistoryError};
use serde::{Deserialize, Serialize};

/// How many jobs may wait in the queue by default (`serve
/// --max-queued-jobs`, `enqueue --max-queued`): past it a submission is
/// refused (503 `queue_full`), so a client cannot grow the queue without
/// bound.
pub const MAX_QUEUED_JOBS: u64 = 10_000;

/// How many of a job's scene names a listing shows (`scenes_total` says how
/// many it has): a listing's size does not grow with the names queued.
pub const LISTED_SCENES: usize = 20;

/// The longest detail a listing shows, in characters.
const LISTED_DETAIL: usize = 400;

/// What a queued check run asks for.
#[derive(Clone, Debug, Default, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
pub struct JobSpec {
    /// The suite file, as the runners see it (relative to their folder).
    pub suite: String,
    /// Only these scenes (empty: the whole suite).
    #[serde(default)]
    pub scenes: Vec<String>,
    /// Render with the CPU reference instead of the runner's GPU.
    #[serde(default)]
    pub cpu: bool,
    /// Only a runner whose adapter name contains this (case-insensitive).
    #[serde(default)]
    pub adapter: Option<String>,
    /// Only a runner with this label.
    #[serde(default)]
    pub label: Option<String>,
}

impl JobSpec {
    /// The rules a queued job's selectors follow, in the words both the
    /// API (a 400) and `tonegate enqueue` (exit 2) refuse with: a label of
    /// [`valid_label`]'s characters; an adapter substring of 1 to 200
    /// characters; at most 1000 scene names of 1 to 200 characters; no
    /// control characters (a NUL reached PostgreSQL, which refused the
    /// statement, and the client got a 500).
    pub fn check(&self) -> Result<(), String> {
        let shown = |s: &str| {
            let n = s.chars().count();
            let head: String = s.chars().take(48).collect();
            if n <= 48 {
                format!("{head:?}")
            } else {
                format!("{head:?}… ({n} characters)")
            }
        };
        let plain = |s: &str, most: usize| {
            !s.is_empty() && s.chars().count() <= most && !s.chars().any(char::is_control)
        };
        if let Some(l) = self.label.as_deref().filter(|l| !valid_label(l)) {
            return Err(format!(
                "label: use letters, digits, '-', '_', '.' or ':' (at most 64), got {}",
                shown(l)
            ));
        }
        if let Some(a) = self.adapter.as_deref().filter(|a| !plain(a, 200)) {
            return Err(format!(
                "adapter: a name substring of 1 to 200 characters, no control characters, got {}",
                shown(a)
            ));
        }
        if self.scenes.len() > 1000 {
            return Err(format!(
                "scenes: at most 1000 names, got {}",
                self.scenes.len()
            ));
        }
        if let Some(bad) = self.scenes.iter().find(|s| !plain(s, 200)) {
            return Err(format!(
                "scenes: names of 1 to 200 characters, no control characters, got {}",
                shown(bad)
            ));
        }
        Ok(())
    }
}

/// A queued, running or finished job.
#[derive(Clone, Debug, Serialize, utoipa::ToSchema)]
pub struct JobRow {
    pub id: i64,
    /// queued, claimed, done or aborted.
    pub state: String,
    pub suite: String,
    /// The first [`LISTED_SCENES`] scene names (empty: the whole suite).
    pub scenes: Vec<String>,
    /// How many scene names the job has.
    pub scenes_total: usize,
    pub cpu: bool,
    pub want_adapter: Option<String>,
    pub want_label: Option<String>,
    pub queued_at: String,
    pub claimed_at: Option<String>,
    pub finished_at: Option<String>,
    pub runner_id: Option<i64>,
    /// The run of its latest claim.
    pub run_id: Option<i64>,
    pub attempts: i64,
    pub detail: Option<String>,
}

fn scenes_json(scenes: &[String]) -> String {
    serde_json::to_string(scenes).unwrap_or_else(|_| "[]".into())
}

pub(super) fn scenes_of(text: &str) -> Vec<String> {
    serde_json::from_str(text).unwrap_or_default()
}

/// A label: letters, digits, `-`, `_`, `.` and `:` (no commas, which
/// separate them in storage).
pub fn valid_label(l: &str) -> bool {
    !l.is_empty()
        && l.len() <= 64
        && l.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.' | ':'))
}
impl History {
    /// Queues a check run; returns the job's id. Refused when
    /// [`MAX_QUEUED_JOBS`] are waiting (`enqueue_within` sets the limit).
    pub fn enqueue(&self, spec: &JobSpec) -> Result<i64, HistoryError> {
        self.enqueue_within(spec, MAX_QUEUED_JOBS)
    }

    /// Queues a check run unless `max_queued` jobs are waiting already
    /// (`HistoryError::QueueFull`); returns the job's id.
    pub fn enqueue_within(&self, spec: &JobSpec, max_queued: u64) -> Result<i64, HistoryError> {
        self.enqueue_keyed(spec, max_queued, None)
    }

    /// [`History::enqueue_within`] under an idempotency key: a job queued
    /// under `key` before is answered with its id and nothing is queued. The
    /// key is stored with the job in the same statement, so a statement sent
    /// again after a lost connection (the history's own retry, or the
    /// client's) finds it rather than queueing the run twice.
    pub fn enqueue_keyed(
        &self,
        spec: &JobSpec,
        max_queued: u64,
        key: Option<&str>,
    ) -> Result<i64, HistoryError> {
        spec.check().map_err(HistoryError::Invalid)?;
        // Without the caller's key, one of this call's own: the history's
        // retry of the insert after a lost connection still finds its job.
        let given = key;
        let own;
        let key = match key {
            Some(k) => Some(k),
            None => {
                own = own_key();
                Some(own.as_str())
            }
        };
        let by_key = |k: &str| -> Result<Option<i64>, HistoryError> {
            self.db()
                .query_opt("SELECT id FROM jobs WHERE idempotency_key = $1", args![k])?
                .map(|r| r.int(0))
                .transpose()
        };
        if let Some(id) = given.map(by_key).transpose()?.flatten() {
            return Ok(id);
        }
        let queued = self
            .db()
            .query_opt("SELECT COUNT(*) FROM jobs WHERE state = 'queued'", &[])?
            .map_or(Ok(0), |r| r.int(0))?;
        if u64::try_from(queued).unwrap_or(0) >= max_queued {
            return Err(HistoryError::QueueFull {
                queued,
                limit: max_queued,
            });
        }
        let inserted = self.db().query_opt(
            "INSERT INTO jobs (state, suite, scenes, renderer, want_adapter, want_label,
                               queued_at, attempts, idempotency_key)
             VALUES ('queued', $1, $2, $3, $4, $5, $6, 0, $7)
             ON CONFLICT (idempotency_key) DO NOTHING RETURNING id",
            args![
                &spec.suite,
                scenes_json(&spec.scenes),
                if spec.cpu { "cpu" } else { "gpu" },
                spec.adapter.as_deref(),
                spec.label.as_deref(),
                now(),
                key
            ],
        )?;
        match (inserted, key) {
            (Some(r), _) => r.int(0),
            // Queued under the key already: by another request, or by this
            // statement before its connection was lost.
            (None, Some(k)) => by_key(k)?.ok_or_else(|| {
                HistoryError::Invalid(format!("idempotency key {k:?}: its job is gone"))
            }),
            (None, None) => Err(HistoryError::Invalid(
                "queueing a job returned no id".into(),
            )),
        }
    }

    /// The newest `limit` jobs, newest first (`state` filters), each with
    /// its first [`LISTED_SCENES`] scene names and its detail cut to 400
    /// characters.
    pub fn jobs(&self, state: Option<&str>, limit: u32) -> Result<Vec<JobRow>, HistoryError> {
        self.job_rows(
            "FROM jobs WHERE (CAST($1 AS TEXT) IS NULL OR state = $1) ORDER BY id DESC LIMIT $2",
            args![state, limit],
        )
    }

    /// One job, as `jobs` lists it.
    pub fn job(&self, id: i64) -> Result<Option<JobRow>, HistoryError> {
        Ok(self
            .job_rows("FROM jobs WHERE id = $1", args![id])?
            .into_iter()
            .next())
    }

    fn job_rows(&self, from: &str, args: &[Value]) -> Result<Vec<JobRow>, HistoryError> {
        self.db()
            .query(
                &format!(
                    "SELECT id, state, suite, scenes, renderer, want_adapter, want_label, queued_at,
                            claimed_at, finished_at, runner_id, run_id, attempts, detail {from}"
                ),
                args,
            )?
            .iter()
            .map(|r| {
                let mut scenes = scenes_of(&r.text(3)?);
                let scenes_total = scenes.len();
                scenes.truncate(LISTED_SCENES);
                let detail = r.opt_text(13)?.map(|mut d| {
                    if let Some((cut, _)) = d.char_indices().nth(LISTED_DETAIL) {
                        d.truncate(cut);
                        d.push('…');
                    }
                    d
                });
                Ok(JobRow {
                    id: r.int(0)?,
                    state: r.text(1)?,
                    suite: r.text(2)?,
                    scenes,
                    scenes_total,
                    cpu: r.text(4)? == "cpu",
                    want_adapter: r.opt_text(5)?,
                    want_label: r.opt_text(6)?,
                    queued_at: r.text(7)?,
                    claimed_at: r.opt_text(8)?,
                    finished_at: r.opt_text(9)?,
                    runner_id: r.opt_int(10)?,
                    run_id: r.opt_int(11)?,
                    attempts: r.int(12)?,
                    detail,
                })
            })
            .collect()
    }

    /// How many jobs are in each state.
    pub fn job_counts(&self) -> Result<Vec<(String, i64)>, HistoryError> {
        self.db()
            .query(
                "SELECT state, COUNT(*) FROM jobs GROUP BY state ORDER BY state",
                &[],
            )?
            .iter()
            .map(|r| Ok((r.text(0)?, r.int(1)?)))
            .collect()
    }
}

/// A key no other enqueue has: this host, process, time and a counter.
fn own_key() -> String {
    static COUNT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let t = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default()
        .as_nanos();
    format!(
        "tonegate:{}:{}:{t}:{n}",
        super::host_name(),
        std::process::id()
    )
}
