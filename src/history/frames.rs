//! Frames a user's own renderer wrote, in the history (docs/frames.md):
//! each submission whole or not at all, each image once by the SHA-256 of
//! its file (a blob, as a run's artifacts are), what people said of each
//! digest of a test on a branch (the main line is `MAIN`, which a branch
//! falls back to and is promoted into), every triage action in order, and
//! the rules that ignore a test's failures until they expire.

use super::backend::{args, Sql};
use super::{now, History, HistoryError};
use serde::Serialize;

/// The longest test pattern, in characters, of an ignore rule or a rules
/// file's `[[tests]]`: matching costs its length times the test name's.
pub const MAX_PATTERN_CHARS: usize = 256;

/// What people said of a digest of a test.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum Label {
    /// The test's image may look like this.
    Positive,
    /// It must not.
    Negative,
    /// Nobody has said yet.
    Untriaged,
}

impl Label {
    pub fn as_str(self) -> &'static str {
        match self {
            Label::Positive => "positive",
            Label::Negative => "negative",
            Label::Untriaged => "untriaged",
        }
    }

    /// The label a stored word names.
    pub fn parse(word: &str) -> Result<Label, HistoryError> {
        match word {
            "positive" => Ok(Label::Positive),
            "negative" => Ok(Label::Negative),
            "untriaged" => Ok(Label::Untriaged),
            other => Err(HistoryError::Invalid(format!(
                "digest label {other:?}: positive, negative or untriaged"
            ))),
        }
    }
}

/// The main line's branch in the history: what every other branch falls
/// back to.
pub const MAIN: &str = "";

/// A frame of a submission as stored: its test, its file's SHA-256 and
/// bytes, and the verdict it got.
pub struct NewFrame<'a> {
    pub test: &'a str,
    pub sha256: &'a str,
    pub bytes: &'a [u8],
    pub verdict: &'a str,
}

/// A submission to store: its idempotency key, branch (`MAIN` for the main
/// line), keys (a JSON object's text), verdict, report (JSON) and frames,
/// and the images the object store did not take, each with the reason
/// (`History::offer_new_images`).
pub struct NewSubmission<'a> {
    pub key: Option<&'a str>,
    pub branch: &'a str,
    pub keys: &'a str,
    pub passed: bool,
    pub report: &'a str,
    pub frames: &'a [NewFrame<'a>],
    pub refused: &'a std::collections::HashMap<String, String>,
}

/// A submission the history holds.
#[derive(Clone, Debug, PartialEq)]
pub struct StoredSubmission {
    pub id: i64,
    pub passed: bool,
    /// The report it answered with (JSON).
    pub report: String,
    /// False when the submission was already stored under its idempotency
    /// key, and this is that one.
    pub new: bool,
}

impl History {
    /// The submission stored under `key`, if any.
    pub fn submission_by_key(&self, key: &str) -> Result<Option<StoredSubmission>, HistoryError> {
        submission_by_key(self.db(), key)
    }

    /// Every digest of `test` seen on `branch` or the main line, in
    /// digest order, with its label there: the branch's where it said
    /// positive or negative, else the main line's.
    pub fn digest_labels(
        &self,
        branch: &str,
        test: &str,
    ) -> Result<Vec<(String, Label)>, HistoryError> {
        let mut labels: std::collections::BTreeMap<String, Label> = Default::default();
        // The main line's first, then the branch's said labels over them.
        for r in self.db().query(
            "SELECT sha256, label, branch FROM digest_labels
             WHERE test = $1 AND (branch = $2 OR branch = $3)
             ORDER BY CASE WHEN branch = $3 THEN 0 ELSE 1 END",
            args![test, branch, MAIN],
        )? {
            let (sha, label) = (r.text(0)?, Label::parse(&r.text(1)?)?);
            let on_branch = r.text(2)? != MAIN;
            match labels.get(&sha) {
                Some(_) if on_branch && label == Label::Untriaged => {}
                _ => {
                    labels.insert(sha, label);
                }
            }
        }
        Ok(labels.into_iter().collect())
    }

    /// The bytes of a stored image, by its SHA-256, from the history's
    /// table or the object store that keeps them; None when there is none.
    pub fn blob(&self, sha256: &str) -> Result<Option<Vec<u8>>, HistoryError> {
        let Some(r) = self.db().query_opt(
            "SELECT data, store, pending FROM blobs WHERE sha256 = $1",
            args![sha256],
        )?
        else {
            return Ok(None);
        };
        let data = r.blob(0)?;
        match r.opt_text(1)? {
            Some(store) if data.is_empty() && r.opt_text(2)?.is_none() => {
                super::Objects::open(&store)?
                    .get_bytes(sha256)?
                    .map(Some)
                    .ok_or_else(|| HistoryError::Objects {
                        url: store.clone(),
                        detail: format!("image {sha256} is not in the store"),
                        transient: false,
                    })
            }
            _ => Ok(Some(data)),
        }
    }

    /// Offers the images of `frames` new to the history to the object
    /// store, when there is one, and returns those it did not take, each
    /// with the reason (kept in the history, pending, by
    /// [`History::store_submission`]). After the first the store did not
    /// answer (down, past the retry budget), the rest are not offered: they
    /// are kept pending at once, so an outage costs a submission one retry
    /// budget, not one per image.
    pub fn offer_new_images(
        &self,
        frames: &[NewFrame],
    ) -> Result<std::collections::HashMap<String, String>, HistoryError> {
        let mut refused: std::collections::HashMap<String, String> = Default::default();
        let Some(o) = super::artifact_store() else {
            return Ok(refused);
        };
        let mut down: Option<String> = None;
        for f in frames {
            if refused.contains_key(f.sha256) {
                continue;
            }
            let known = self
                .db()
                .query_opt(
                    "SELECT 1 FROM blobs WHERE sha256 = $1 AND pending IS NULL",
                    args![f.sha256],
                )?
                .is_some();
            if known {
                continue;
            }
            if let Some(reason) = &down {
                refused.insert(f.sha256.to_owned(), reason.clone());
                continue;
            }
            if let Err(e) = o.put(f.sha256, f.bytes.to_vec()) {
                if !matches!(e, HistoryError::Objects { .. }) {
                    return Err(e);
                }
                tracing::warn!("{e}: the image is kept in the history, pending");
                let reason = super::objects::pending_reason(&e);
                if matches!(
                    e,
                    HistoryError::Objects {
                        transient: true,
                        ..
                    }
                ) {
                    down = Some(reason.clone());
                }
                refused.insert(f.sha256.to_owned(), reason);
            }
        }
        Ok(refused)
    }

    /// Stores a submission in one transaction: each image once, a row per
    /// frame, the digests new to their test as untriaged, and the report.
    /// Under an idempotency key already used it stores nothing and returns
    /// the submission stored then (`new` false).
    pub fn store_submission(&self, s: &NewSubmission) -> Result<StoredSubmission, HistoryError> {
        let NewSubmission {
            key,
            branch,
            keys,
            passed,
            report,
            frames,
            refused,
        } = *s;
        let objects = super::artifact_store();
        let store = objects.as_ref().map(|o| o.url.clone());
        let mut stored = None;
        self.db().transaction(&mut |tx| {
            if let Some(done) = key.map(|k| submission_by_key(tx, k)).transpose()?.flatten() {
                stored = Some(done);
                return Ok(());
            }
            let at = now();
            let id = tx
                .query_opt(
                    "INSERT INTO frame_submissions (idempotency_key, submitted_at, keys, passed, report, branch)
                     VALUES ($1, $2, $3, $4, $5, $6) RETURNING id",
                    args![key, &at, keys, passed, report, branch],
                )?
                .ok_or_else(|| HistoryError::Invalid("a submission without an id".into()))?
                .int(0)?;
            for f in frames {
                // An image the history holds is not written again (nor
                // touched: updating a row rewrites its whole blob); the
                // frame's row keeps it from a prune from now on.
                let held = tx
                    .query_opt("SELECT 1 FROM blobs WHERE sha256 = $1", args![f.sha256])?
                    .is_some();
                if !held {
                    let pending = refused.get(f.sha256);
                    let (data, store): (&[u8], Option<&str>) = match (&store, pending) {
                        (Some(s), None) => (&[], Some(s)),
                        (s, _) => (f.bytes, s.as_deref()),
                    };
                    tx.execute(
                        "INSERT INTO blobs (sha256, size, data, stored_at, store, pending)
                         VALUES ($1, $2, $3, $4, $5, $6)",
                        args![f.sha256, f.bytes.len(), data, &at, store, pending],
                    )?;
                }
                tx.execute(
                    "INSERT INTO submitted_frames (submission_id, test, sha256, verdict)
                     VALUES ($1, $2, $3, $4)",
                    args![id, f.test, f.sha256, f.verdict],
                )?;
                tx.execute(
                    "INSERT INTO digest_labels (branch, test, sha256, label)
                     VALUES ($1, $2, $3, 'untriaged')
                     ON CONFLICT (branch, test, sha256) DO NOTHING",
                    args![branch, f.test, f.sha256],
                )?;
            }
            stored = Some(StoredSubmission {
                id,
                passed,
                report: report.to_owned(),
                new: true,
            });
            Ok(())
        })?;
        stored.ok_or_else(|| HistoryError::Invalid("the submission was not stored".into()))
    }
}

fn submission_by_key(db: &dyn Sql, key: &str) -> Result<Option<StoredSubmission>, HistoryError> {
    db.query_opt(
        "SELECT id, passed, report FROM frame_submissions WHERE idempotency_key = $1",
        args![key],
    )?
    .map(|r| {
        Ok(StoredSubmission {
            id: r.int(0)?,
            passed: r.bool(1)?,
            report: r.text(2)?,
            new: false,
        })
    })
    .transpose()
}
