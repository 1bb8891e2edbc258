//! Alerts in the history (docs/alerts.md): each event stored once under
//! its key (a second raise of the same key stores nothing, which is what
//! makes an alert fire once however often, and from however many servers,
//! the history is scanned), a delivery of it to each webhook that wants
//! it, every attempt, and the marks alerts start after. What the scan
//! reads to find events is here too: finished check runs, main-line
//! submissions and the digests they brought.

use super::backend::{args, Sql};
use super::{now, History, HistoryError};
use serde::Serialize;

/// A check run as alerts name it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RunBrief {
    pub id: i64,
    pub status: String,
    pub git_commit: Option<String>,
    pub suite: Option<String>,
    pub adapter: Option<String>,
}

/// A delivery that is due.
#[derive(Clone, Debug)]
pub struct DueDelivery {
    pub id: i64,
    pub event_id: i64,
    /// The event's key.
    pub key: String,
    pub webhook: String,
    pub attempts: i64,
    pub kind: String,
    pub summary: String,
    pub payload: String,
}

/// One attempt to deliver.
#[derive(Clone, Debug, PartialEq, Serialize, utoipa::ToSchema)]
pub struct AlertAttempt {
    pub at: String,
    /// The receiver's HTTP status; none when it could not be reached.
    pub status: Option<i64>,
    pub error: Option<String>,
}

/// An event's delivery to one webhook.
#[derive(Clone, Debug, PartialEq, Serialize, utoipa::ToSchema)]
pub struct AlertDelivery {
    pub webhook: String,
    /// pending, delivered or failed (every attempt used).
    pub state: String,
    pub delivered_at: Option<String>,
    /// When the next attempt is due (pending only).
    pub next_at: Option<String>,
    pub attempts: Vec<AlertAttempt>,
}

/// An alert and where its deliveries stand.
#[derive(Clone, Debug, PartialEq, Serialize, utoipa::ToSchema)]
pub struct AlertRow {
    pub id: i64,
    /// The event's key: one alert a key, ever.
    pub key: String,
    /// gate_red, untriaged or change_point.
    pub kind: String,
    pub created_at: String,
    pub summary: String,
    /// The body's `event` object (docs/alerts.md).
    #[schema(value_type = Object)]
    pub event: serde_json::Value,
    pub deliveries: Vec<AlertDelivery>,
}

/// The outcome of one attempt.
pub enum Attempted<'a> {
    /// Accepted, with this HTTP status (a 2xx).
    Delivered(i64),
    /// Refused or unreachable; tried again at `next_at`, or given up on
    /// when that is None.
    Failed {
        status: Option<i64>,
        error: &'a str,
        next_at: Option<String>,
    },
}

fn brief(r: &super::backend::Row) -> Result<RunBrief, HistoryError> {
    Ok(RunBrief {
        id: r.int(0)?,
        status: r.text(1)?,
        git_commit: r.opt_text(2)?,
        suite: r.opt_text(3)?,
        adapter: r.opt_text(4)?,
    })
}

const BRIEF: &str = "SELECT id, status, git_commit, suite, adapter FROM runs
    WHERE kind = 'check' AND status IN ('passed', 'failed')";

impl History {
    /// The value of mark `name`, setting it to `start` the first time it
    /// is asked for (the first scan: what was recorded before raises no
    /// alert).
    pub fn alert_mark(&self, name: &str, start: i64) -> Result<i64, HistoryError> {
        self.db().execute(
            "INSERT INTO alert_marks (name, value) VALUES ($1, $2) ON CONFLICT (name) DO NOTHING",
            args![name, start],
        )?;
        self.db()
            .query_opt("SELECT value FROM alert_marks WHERE name = $1", args![name])?
            .map_or(Ok(start), |r| r.int(0))
    }

    /// The newest run id and submission id (0 when there is none): where
    /// alerts start on a history that has not had them.
    pub fn alert_starts(&self) -> Result<(i64, i64), HistoryError> {
        let max = |sql: &str| -> Result<i64, HistoryError> {
            Ok(self
                .db()
                .query_opt(sql, &[])?
                .map(|r| r.opt_int(0))
                .transpose()?
                .flatten()
                .unwrap_or(0))
        };
        Ok((
            max("SELECT MAX(id) FROM runs")?,
            max("SELECT MAX(id) FROM frame_submissions")?,
        ))
    }

    /// Finished check runs after `since`, oldest first (at most `limit`,
    /// the newest).
    pub fn finished_runs_since(
        &self,
        since: i64,
        limit: u32,
    ) -> Result<Vec<RunBrief>, HistoryError> {
        let mut rows = self
            .db()
            .query(
                &format!("{BRIEF} AND id > $1 ORDER BY id DESC LIMIT $2"),
                args![since, limit],
            )?
            .iter()
            .map(brief)
            .collect::<Result<Vec<_>, _>>()?;
        rows.reverse();
        Ok(rows)
    }

    /// The finished check run of the same suite and adapter before `run`.
    pub fn previous_finished_run(&self, run: &RunBrief) -> Result<Option<RunBrief>, HistoryError> {
        self.db()
            .query_opt(
                &format!(
                    "{BRIEF} AND id < $1 AND suite IS NOT DISTINCT FROM $2
                     AND adapter IS NOT DISTINCT FROM $3 ORDER BY id DESC LIMIT 1"
                ),
                args![run.id, run.suite.as_deref(), run.adapter.as_deref()],
            )?
            .map(|r| brief(&r))
            .transpose()
    }

    /// A run's brief, finished or not.
    pub fn run_brief(&self, id: i64) -> Result<Option<RunBrief>, HistoryError> {
        self.db()
            .query_opt(
                "SELECT id, status, git_commit, suite, adapter FROM runs WHERE id = $1",
                args![id],
            )?
            .map(|r| brief(&r))
            .transpose()
    }

    /// Main-line submissions after `since`, oldest first: id and keys (JSON).
    pub fn main_submissions_since(
        &self,
        since: i64,
        limit: u32,
    ) -> Result<Vec<(i64, String)>, HistoryError> {
        let mut rows = self
            .db()
            .query(
                "SELECT id, keys FROM frame_submissions WHERE branch = '' AND id > $1
                 ORDER BY id DESC LIMIT $2",
                args![since, limit],
            )?
            .iter()
            .map(|r| Ok((r.int(0)?, r.text(1)?)))
            .collect::<Result<Vec<_>, HistoryError>>()?;
        rows.reverse();
        Ok(rows)
    }

    /// The frames of submission `id` judged untriaged whose digest no
    /// earlier submission of their test had: (test, digest).
    pub fn new_untriaged(&self, id: i64) -> Result<Vec<(String, String)>, HistoryError> {
        self.db()
            .query(
                "SELECT f.test, f.sha256 FROM submitted_frames f
                 WHERE f.submission_id = $1 AND f.verdict = 'untriaged'
                   AND NOT EXISTS (SELECT 1 FROM submitted_frames e
                                   WHERE e.test = f.test AND e.sha256 = f.sha256
                                     AND e.submission_id < f.submission_id)
                 ORDER BY f.test",
                args![id],
            )?
            .iter()
            .map(|r| Ok((r.text(0)?, r.text(1)?)))
            .collect()
    }

    /// The last main-line submission before `id` that passed on the same
    /// trace as `keys` (a submission's keys as stored): id and keys. A
    /// trace is every key but `commit`: a device's last good commit is its
    /// own, not another device's. The last `submissions::TRACE_SCAN`
    /// passing submissions are looked at.
    pub fn last_passing_main_submission(
        &self,
        id: i64,
        keys: &str,
    ) -> Result<Option<(i64, String)>, HistoryError> {
        use super::submissions::{trace_of, TRACE_SCAN};
        let trace = trace_of(keys);
        let rows = self.db().query(
            "SELECT id, keys FROM frame_submissions WHERE branch = '' AND id < $1 AND passed <> 0
             ORDER BY id DESC LIMIT $2",
            args![id, TRACE_SCAN],
        )?;
        for r in rows {
            let (found, theirs) = (r.int(0)?, r.text(1)?);
            if trace_of(&theirs) == trace {
                return Ok(Some((found, theirs)));
            }
        }
        Ok(None)
    }

    /// Stores an event under `key`, with a pending delivery to each of
    /// `webhooks`, in one transaction; None (and nothing stored) when the
    /// key already has one.
    pub fn raise_alert(
        &self,
        key: &str,
        kind: &str,
        summary: &str,
        payload: &str,
        webhooks: &[&str],
    ) -> Result<Option<i64>, HistoryError> {
        let mut raised = None;
        self.db().transaction(&mut |tx| {
            raised = None;
            let at = now();
            let Some(r) = tx.query_opt(
                "INSERT INTO alert_events (event_key, kind, created_at, summary, payload)
                 VALUES ($1, $2, $3, $4, $5) ON CONFLICT (event_key) DO NOTHING RETURNING id",
                args![key, kind, &at, summary, payload],
            )?
            else {
                return Ok(());
            };
            let id = r.int(0)?;
            for w in webhooks {
                tx.execute(
                    "INSERT INTO alert_deliveries (event_id, webhook, state, attempts, next_at)
                     VALUES ($1, $2, 'pending', 0, $3)",
                    args![id, *w, &at],
                )?;
            }
            raised = Some(id);
            Ok(())
        })?;
        Ok(raised)
    }

    /// Pending deliveries due now that no other server holds, oldest
    /// first; each is held for `hold` (so that two servers on one history
    /// do not both send it) until its attempt is recorded.
    pub fn claim_due_deliveries(
        &self,
        hold: std::time::Duration,
        limit: u32,
    ) -> Result<Vec<DueDelivery>, HistoryError> {
        let at = now();
        let until = super::stamps::later(hold);
        let due = self.db().query(
            "SELECT d.id, d.event_id, d.webhook, d.attempts, e.kind, e.summary, e.payload, e.event_key
             FROM alert_deliveries d JOIN alert_events e ON e.id = d.event_id
             WHERE d.state = 'pending' AND d.next_at <= $1
               AND (d.claimed_until IS NULL OR d.claimed_until < $1)
             ORDER BY d.next_at, d.id LIMIT $2",
            args![&at, limit],
        )?;
        let mut claimed = Vec::new();
        for r in due {
            let id = r.int(0)?;
            // Taken only if nobody took it since it was read.
            let took = self.db().execute(
                "UPDATE alert_deliveries SET claimed_until = $1
                 WHERE id = $2 AND state = 'pending' AND (claimed_until IS NULL OR claimed_until < $3)",
                args![&until, id, &at],
            )?;
            if took == 1 {
                claimed.push(DueDelivery {
                    id,
                    event_id: r.int(1)?,
                    webhook: r.text(2)?,
                    attempts: r.int(3)?,
                    kind: r.text(4)?,
                    summary: r.text(5)?,
                    payload: r.text(6)?,
                    key: r.text(7)?,
                });
            }
        }
        Ok(claimed)
    }

    /// Records an attempt of delivery `id` and where the delivery now stands.
    pub fn record_attempt(&self, id: i64, outcome: Attempted) -> Result<(), HistoryError> {
        self.db().transaction(&mut |tx| {
            let at = now();
            let (status, error) = match &outcome {
                Attempted::Delivered(status) => (Some(*status), None),
                Attempted::Failed { status, error, .. } => (*status, Some(*error)),
            };
            tx.execute(
                "INSERT INTO alert_attempts (delivery_id, at, status, error) VALUES ($1, $2, $3, $4)",
                args![id, &at, status, error],
            )?;
            match &outcome {
                Attempted::Delivered(_) => tx.execute(
                    "UPDATE alert_deliveries SET state = 'delivered', attempts = attempts + 1,
                     delivered_at = $1, claimed_until = NULL WHERE id = $2",
                    args![&at, id],
                )?,
                Attempted::Failed { next_at: Some(next), .. } => tx.execute(
                    "UPDATE alert_deliveries SET attempts = attempts + 1, next_at = $1,
                     claimed_until = NULL WHERE id = $2",
                    args![next.as_str(), id],
                )?,
                Attempted::Failed { next_at: None, .. } => tx.execute(
                    "UPDATE alert_deliveries SET state = 'failed', attempts = attempts + 1,
                     claimed_until = NULL WHERE id = $1",
                    args![id],
                )?,
            };
            Ok(())
        })
    }

    /// The newest `limit` alerts, newest first, with their deliveries
    /// and every attempt.
    pub fn alerts(&self, limit: u32) -> Result<Vec<AlertRow>, HistoryError> {
        let db = self.db();
        let mut out = Vec::new();
        for r in db.query(
            "SELECT id, event_key, kind, created_at, summary, payload FROM alert_events
             ORDER BY id DESC LIMIT $1",
            args![limit],
        )? {
            let id = r.int(0)?;
            out.push(AlertRow {
                id,
                key: r.text(1)?,
                kind: r.text(2)?,
                created_at: r.text(3)?,
                summary: r.text(4)?,
                event: serde_json::from_str(&r.text(5)?).unwrap_or_default(),
                deliveries: deliveries(db, id)?,
            });
        }
        Ok(out)
    }
}

fn deliveries(db: &dyn Sql, event: i64) -> Result<Vec<AlertDelivery>, HistoryError> {
    let mut out = Vec::new();
    for d in db.query(
        "SELECT id, webhook, state, delivered_at, next_at FROM alert_deliveries
         WHERE event_id = $1 ORDER BY webhook",
        args![event],
    )? {
        let attempts = db
            .query(
                "SELECT at, status, error FROM alert_attempts WHERE delivery_id = $1 ORDER BY id",
                args![d.int(0)?],
            )?
            .iter()
            .map(|a| {
                Ok(AlertAttempt {
                    at: a.text(0)?,
                    status: a.opt_int(1)?,
                    error: a.opt_text(2)?,
                })
            })
            .collect::<Result<Vec<_>, HistoryError>>()?;
        let state = d.text(2)?;
        out.push(AlertDelivery {
            next_at: (state == "pending").then(|| d.text(4)).transpose()?,
            webhook: d.text(1)?,
            state,
            delivered_at: d.opt_text(3)?,
            attempts,
        });
    }
    Ok(out)
}
