//! Reading submitted frames back: the submissions newest first, one
//! submission's frames, and the digests a submission left untriaged (what
//! bulk triage labels together).

use super::backend::args;
use super::{History, HistoryError};
use serde::Serialize;

/// A submission in the list.
#[derive(Clone, Debug, PartialEq, Serialize, utoipa::ToSchema)]
pub struct SubmissionRow {
    pub id: i64,
    pub submitted_at: String,
    /// The branch its frames were judged on (`""` the main line).
    pub branch: String,
    /// Its keys (device, backend, branch, commit, …).
    #[schema(value_type = Object)]
    pub keys: serde_json::Value,
    pub passed: bool,
    pub frames: i64,
    /// Frames whose verdict was `untriaged`.
    pub untriaged: i64,
}

/// A frame of a stored submission.
#[derive(Clone, Debug, PartialEq, Serialize, utoipa::ToSchema)]
pub struct SubmittedFrame {
    pub test: String,
    pub digest: String,
    /// positive, matched, negative, untriaged or ignored.
    pub verdict: String,
}

const ROW: &str = "SELECT s.id, s.submitted_at, s.branch, s.keys, s.passed,
        (SELECT COUNT(*) FROM submitted_frames f WHERE f.submission_id = s.id),
        (SELECT COUNT(*) FROM submitted_frames f WHERE f.submission_id = s.id AND f.verdict = 'untriaged')
    FROM frame_submissions s";

fn row(r: &super::backend::Row) -> Result<SubmissionRow, HistoryError> {
    Ok(SubmissionRow {
        id: r.int(0)?,
        submitted_at: r.text(1)?,
        branch: r.text(2)?,
        keys: serde_json::from_str(&r.text(3)?).unwrap_or_default(),
        passed: r.bool(4)?,
        frames: r.int(5)?,
        untriaged: r.int(6)?,
    })
}

impl History {
    /// The newest `limit` submissions, newest first.
    pub fn submissions(&self, limit: u32) -> Result<Vec<SubmissionRow>, HistoryError> {
        self.submissions_before(i64::MAX, limit)
    }

    /// The newest `limit` submissions older than submission `before`,
    /// newest first: the next page of a listing.
    pub fn submissions_before(
        &self,
        before: i64,
        limit: u32,
    ) -> Result<Vec<SubmissionRow>, HistoryError> {
        self.db()
            .query(
                &format!("{ROW} WHERE s.id < $1 ORDER BY s.id DESC LIMIT $2"),
                args![before, limit],
            )?
            .iter()
            .map(row)
            .collect()
    }

    /// One submission, with the report it answered.
    pub fn submission(&self, id: i64) -> Result<Option<(SubmissionRow, String)>, HistoryError> {
        let Some(r) = self
            .db()
            .query_opt(&format!("{ROW} WHERE s.id = $1"), args![id])?
        else {
            return Ok(None);
        };
        let report = self
            .db()
            .query_opt(
                "SELECT report FROM frame_submissions WHERE id = $1",
                args![id],
            )?
            .map(|r| r.text(0))
            .transpose()?
            .unwrap_or_default();
        Ok(Some((row(&r)?, report)))
    }

    /// A submission's frames in test order; only those with `verdict`
    /// when given.
    pub fn submission_frames(
        &self,
        id: i64,
        verdict: Option<&str>,
    ) -> Result<Vec<SubmittedFrame>, HistoryError> {
        let sql = "SELECT test, sha256, verdict FROM submitted_frames
                   WHERE submission_id = $1 AND ($2 = '' OR verdict = $2) ORDER BY test";
        self.db()
            .query(sql, args![id, verdict.unwrap_or("")])?
            .iter()
            .map(|r| {
                Ok(SubmittedFrame {
                    test: r.text(0)?,
                    digest: r.text(1)?,
                    verdict: r.text(2)?,
                })
            })
            .collect()
    }

    /// The last submission on `branch` (`''` for the main line) of the
    /// same trace as `keys` (a submission's keys as stored; its trace is
    /// every key but `commit`), among the last `TRACE_SCAN` (1,000): its id.
    pub fn last_of_trace(&self, branch: &str, keys: &str) -> Result<Option<i64>, HistoryError> {
        let trace = trace_of(keys);
        let rows = self.db().query(
            "SELECT id, keys FROM frame_submissions WHERE branch = $1 ORDER BY id DESC LIMIT $2",
            args![branch, TRACE_SCAN],
        )?;
        for r in rows {
            if trace_of(&r.text(1)?) == trace {
                return Ok(Some(r.int(0)?));
            }
        }
        Ok(None)
    }
}

/// How many submissions a search for one of the same trace looks back
/// through.
pub const TRACE_SCAN: i64 = 1000;

/// A submission's trace: its keys (JSON, as stored) without `commit`.
pub(super) fn trace_of(keys: &str) -> std::collections::BTreeMap<String, serde_json::Value> {
    let mut map: std::collections::BTreeMap<String, serde_json::Value> =
        serde_json::from_str(keys).unwrap_or_default();
    map.remove("commit");
    map
}
