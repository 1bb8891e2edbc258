//! A fleet on one history: runners register and heartbeat, check runs are
//! queued as jobs (`jobs`), and a runner claims the oldest queued job its adapter and
//! labels match. On PostgreSQL the claim is `SELECT … FOR UPDATE SKIP
//! LOCKED`, so runners never wait on, or take, each other's job; on SQLite the
//! database's single writer serialises the same statement.
//!
//! A runner whose heartbeat is older than the lost-after time is marked
//! `lost` by whichever runner looks next; its job's run is marked aborted and
//! the job queued again, once (a job claimed twice and lost twice is
//! aborted, so a job that kills its runner cannot take the fleet down).

use super::backend::args;
use super::jobs::{scenes_of, valid_label};
use super::{ago, host_name, now, History, HistoryError};
use serde::Serialize;
use std::time::Duration;

/// How many times a job may be claimed: the first claim and one requeue.
pub const MAX_ATTEMPTS: i64 = 2;

/// A registered runner.
#[derive(Clone, Debug, Serialize, utoipa::ToSchema)]
pub struct RunnerRow {
    pub id: i64,
    pub name: String,
    pub host: String,
    pub pid: i64,
    pub adapter: String,
    pub driver: String,
    pub labels: Vec<String>,
    pub started_at: String,
    pub heartbeat: String,
    /// idle, busy, stopped or lost.
    pub state: String,
    /// The job it is running.
    pub job_id: Option<i64>,
}

/// What a runner says of itself when it registers.
#[derive(Clone, Debug, Default)]
pub struct RunnerInfo {
    pub name: String,
    pub adapter: String,
    pub driver: String,
    pub labels: Vec<String>,
}

/// A job as a runner receives it.
#[derive(Clone, Debug)]
pub struct ClaimedJob {
    pub id: i64,
    pub suite: String,
    pub scenes: Vec<String>,
    pub cpu: bool,
    pub attempt: i64,
}

/// What an expiry pass did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Expired {
    pub runners: Vec<i64>,
    pub requeued: Vec<i64>,
    pub aborted: Vec<i64>,
}

fn labels_of(text: &str) -> Vec<String> {
    text.split(',')
        .filter(|l| !l.is_empty())
        .map(str::to_owned)
        .collect()
}

impl History {
    /// Registers a runner of this process; returns its id.
    pub fn register_runner(&self, r: &RunnerInfo) -> Result<i64, HistoryError> {
        let n = r.name.chars().count();
        if n == 0 || n > 128 || r.name.chars().any(char::is_control) {
            let head: String = r.name.chars().take(48).collect();
            return Err(HistoryError::Invalid(format!(
                "runner name: 1 to 128 characters, no control characters, got {head:?}{}",
                if n > 48 {
                    format!("… ({n} characters)")
                } else {
                    String::new()
                }
            )));
        }
        if let Some(l) = r.labels.iter().find(|l| !valid_label(l)) {
            return Err(HistoryError::Invalid(format!(
                "label {l:?}: use letters, digits, '-', '_', '.' or ':' (at most 64)"
            )));
        }
        let at = now();
        self.db()
            .query_opt(
                "INSERT INTO runners (name, host, pid, adapter, driver, labels, started_at,
                                      heartbeat, state)
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $7, 'idle') RETURNING id",
                args![
                    &r.name,
                    host_name(),
                    std::process::id(),
                    &r.adapter,
                    &r.driver,
                    r.labels.join(","),
                    at
                ],
            )?
            .ok_or_else(|| HistoryError::Invalid("registering a runner returned no id".into()))?
            .int(0)
    }

    /// Says the runner is alive. False when it was already declared lost
    /// (its job has gone back to the queue): it must stop and register anew.
    pub fn heartbeat(&self, runner: i64) -> Result<bool, HistoryError> {
        Ok(self.db().execute(
            "UPDATE runners SET heartbeat = $2 WHERE id = $1 AND state IN ('idle', 'busy')",
            args![runner, now()],
        )? == 1)
    }

    /// Claims the oldest queued job this runner matches, if any: its
    /// adapter name contains the job's `want_adapter` (case-insensitive) and
    /// its labels include the job's `want_label`, both as plain text (a `%`
    /// or `_` in them matches only itself).
    pub fn claim(
        &self,
        runner: i64,
        adapter: &str,
        labels: &[String],
    ) -> Result<Option<ClaimedJob>, HistoryError> {
        let sql = format!(
            "UPDATE jobs SET state = 'claimed', runner_id = $1, claimed_at = $2,
                             attempts = attempts + 1, finished_at = NULL, run_id = NULL
             WHERE state = 'queued' AND id = (
               SELECT id FROM jobs
               WHERE state = 'queued'
                 AND (want_adapter IS NULL
                      OR LOWER($3) LIKE '%' || {adapter} || '%' ESCAPE '!')
                 AND (want_label IS NULL OR ',' || $4 || ',' LIKE '%,' || {label} || ',%' ESCAPE '!')
               ORDER BY id LIMIT 1{skip}
             )
             RETURNING id, suite, scenes, renderer, attempts",
            adapter = like_literal("LOWER(want_adapter)"),
            label = like_literal("want_label"),
            skip = self.db().dialect().skip_locked()
        );
        let mut claimed = None;
        let mut tries = 0;
        self.db().transaction(&mut |tx| {
            claimed = None;
            tries += 1;
            // Run again (the connection was lost): a job this runner holds
            // and has not started was claimed by the try whose COMMIT went
            // through but whose answer was lost; it is returned again rather
            // than left held by nobody at work on it.
            let held = if tries > 1 {
                tx.query_opt(
                    "SELECT id, suite, scenes, renderer, attempts FROM jobs
                     WHERE runner_id = $1 AND state = 'claimed' AND run_id IS NULL
                     ORDER BY id LIMIT 1",
                    args![runner],
                )?
            } else {
                None
            };
            let row = match held {
                Some(row) => row,
                None => {
                    match tx.query_opt(&sql, args![runner, now(), adapter, labels.join(",")])? {
                        Some(row) => row,
                        None => return Ok(()),
                    }
                }
            };
            let job = ClaimedJob {
                id: row.int(0)?,
                suite: row.text(1)?,
                scenes: scenes_of(&row.text(2)?),
                cpu: row.text(3)? == "cpu",
                attempt: row.int(4)?,
            };
            tx.execute(
                "UPDATE runners SET state = 'busy', job_id = $2, heartbeat = $3 WHERE id = $1",
                args![runner, job.id, now()],
            )?;
            claimed = Some(job);
            Ok(())
        })?;
        Ok(claimed)
    }

    /// Links a claimed job and the run it started.
    pub fn job_started(&self, job: i64, run: i64) -> Result<(), HistoryError> {
        self.db().transaction(&mut |tx| {
            tx.execute("UPDATE jobs SET run_id = $2 WHERE id = $1", args![job, run])?;
            tx.execute("UPDATE runs SET job_id = $2 WHERE id = $1", args![run, job])?;
            Ok(())
        })
    }

    /// Ends a job this runner holds (`done`, with what the run said). False
    /// when the runner no longer holds it (declared lost and requeued): its
    /// result is then not the job's.
    pub fn finish_job(&self, runner: i64, job: i64, detail: &str) -> Result<bool, HistoryError> {
        let mut held = false;
        let mut tries = 0;
        self.db().transaction(&mut |tx| {
            tries += 1;
            held = tx.execute(
                "UPDATE jobs SET state = 'done', finished_at = $3, detail = $4
                 WHERE id = $1 AND runner_id = $2 AND state = 'claimed'",
                args![job, runner, now(), detail],
            )? == 1
                // Run again (the connection was lost) and done by this
                // runner already: the try whose COMMIT went through but
                // whose answer was lost.
                || tries > 1
                    && tx
                    .query_opt(
                        "SELECT 1 FROM jobs WHERE id = $1 AND runner_id = $2 AND state = 'done'",
                        args![job, runner],
                    )?
                    .is_some();
            tx.execute(
                "UPDATE runners SET state = 'idle', job_id = NULL
                 WHERE id = $1 AND state = 'busy'",
                args![runner],
            )?;
            Ok(())
        })?;
        Ok(held)
    }

    /// Marks a runner stopped (it exits on purpose).
    pub fn stop_runner(&self, runner: i64) -> Result<(), HistoryError> {
        self.db().execute(
            "UPDATE runners SET state = 'stopped', job_id = NULL, heartbeat = $2
             WHERE id = $1 AND state IN ('idle', 'busy')",
            args![runner, now()],
        )?;
        Ok(())
    }

    /// Declares runners silent for longer than `lost_after` lost: each job
    /// one held is queued again (or aborted once it has had its
    /// [`MAX_ATTEMPTS`]), and the run it had started is marked aborted.
    ///
    /// A process that has just had its database back after losing it
    /// declares nobody lost until `lost_after` has passed since: the other
    /// runners could not heartbeat through the outage either.
    pub fn expire_runners(&self, lost_after: Duration) -> Result<Expired, HistoryError> {
        if super::last_recovery().is_some_and(|at| at.elapsed() < lost_after) {
            return Ok(Expired::default());
        }
        let cutoff = ago(lost_after);
        let mut out = Expired::default();
        self.db().transaction(&mut |tx| {
            out = Expired::default();
            let silent = tx.query(
                "SELECT id, name, heartbeat FROM runners
                 WHERE state IN ('idle', 'busy') AND heartbeat < $1",
                args![&cutoff],
            )?;
            for r in silent {
                let (id, name, beat) = (r.int(0)?, r.text(1)?, r.text(2)?);
                // Another runner may have declared it first.
                if tx.execute(
                    "UPDATE runners SET state = 'lost', job_id = NULL
                     WHERE id = $1 AND state IN ('idle', 'busy') AND heartbeat < $2",
                    args![id, &cutoff],
                )? != 1
                {
                    continue;
                }
                out.runners.push(id);
                let held = tx.query(
                    "SELECT id, run_id, attempts FROM jobs WHERE runner_id = $1 AND state = 'claimed'",
                    args![id],
                )?;
                for j in held {
                    let (job, run, attempts) = (j.int(0)?, j.opt_int(1)?, j.int(2)?);
                    let why = format!(
                        "runner {name} (id {id}) stopped heartbeating (last {beat}); declared lost at {}",
                        now()
                    );
                    if let Some(run) = run {
                        tx.execute(
                            "UPDATE runs SET status = 'aborted', ended_at = $2, detail = $3
                             WHERE id = $1 AND status = 'running'",
                            args![run, now(), &why],
                        )?;
                    }
                    let again = attempts < MAX_ATTEMPTS;
                    tx.execute(
                        "UPDATE jobs SET state = $2, runner_id = NULL, detail = $3,
                                         finished_at = $4
                         WHERE id = $1",
                        args![
                            job,
                            if again { "queued" } else { "aborted" },
                            &why,
                            (!again).then(now)
                        ],
                    )?;
                    if again {
                        out.requeued.push(job);
                    } else {
                        out.aborted.push(job);
                    }
                }
            }
            Ok(())
        })?;
        Ok(out)
    }

    /// Every registered runner, newest first; stopped and lost ones only
    /// when `all`.
    pub fn runners(&self, all: bool) -> Result<Vec<RunnerRow>, HistoryError> {
        self.db()
            .query(
                "SELECT id, name, host, pid, adapter, driver, labels, started_at, heartbeat,
                        state, job_id
                 FROM runners WHERE $1 = 1 OR state IN ('idle', 'busy')
                 ORDER BY id DESC LIMIT 1000",
                args![all],
            )?
            .iter()
            .map(|r| {
                Ok(RunnerRow {
                    id: r.int(0)?,
                    name: r.text(1)?,
                    host: r.text(2)?,
                    pid: r.int(3)?,
                    adapter: r.text(4)?,
                    driver: r.text(5)?,
                    labels: labels_of(&r.text(6)?),
                    started_at: r.text(7)?,
                    heartbeat: r.text(8)?,
                    state: r.text(9)?,
                    job_id: r.opt_int(10)?,
                })
            })
            .collect()
    }
}

/// SQL for `expr` with LIKE's wildcards (`%`, `_`) and the escape character
/// `!` escaped, for a pattern that uses `ESCAPE '!'`: the same text in
/// SQLite and PostgreSQL (`!` needs no quoting in either).
fn like_literal(expr: &str) -> String {
    format!("REPLACE(REPLACE(REPLACE({expr}, '!', '!!'), '%', '!%'), '_', '!_')")
}
