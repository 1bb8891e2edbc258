//! What people say of submitted frames: labelling digests (one, several,
//! every one a submission left untriaged, never overriding a decision in
//! bulk), promoting a branch into the main line, the triage log, and the
//! rules that ignore a test's failures until they expire.

use super::backend::{args, Sql};
use super::frames::{Label, MAIN, MAX_PATTERN_CHARS};
use super::{now, History, HistoryError};
use serde::Serialize;

/// One triage action.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TriageEntry {
    pub at: String,
    /// The branch it was on ([`MAIN`] for the main line).
    pub branch: String,
    pub test: String,
    pub digest: String,
    pub label: Label,
    pub who: String,
    pub why: String,
}

impl History {
    /// Labels `digest` of `test` on `branch` (a digest a submission of
    /// that test had, on any branch), and logs who did it and why; refused
    /// for a digest the test never had.
    pub fn triage(
        &self,
        branch: &str,
        test: &str,
        digest: &str,
        label: Label,
        (who, why): (&str, &str),
    ) -> Result<(), HistoryError> {
        self.triage_many(branch, &[(test, digest, label)], (who, why))
    }

    /// Labels several digests at once, each logged: all of them or, when
    /// one cannot be (a digest its test never had), none.
    pub fn triage_many(
        &self,
        branch: &str,
        actions: &[(&str, &str, Label)],
        (who, why): (&str, &str),
    ) -> Result<(), HistoryError> {
        self.db().transaction(&mut |tx| {
            for &(test, digest, label) in actions {
                label_digest(tx, branch, test, digest, label, who, why)?;
            }
            Ok(())
        })
    }

    /// Labels each of `digests` (test, digest) `label` on `branch` where
    /// it is untriaged now, each logged, in one transaction; a digest
    /// someone has said positive or negative of since (on the branch, or
    /// on the main line it falls back to) keeps that label: a bulk action
    /// never overrides a decision, which takes a per-digest one. Returns
    /// (labelled, kept).
    pub fn triage_untriaged(
        &self,
        branch: &str,
        digests: &[(&str, &str)],
        label: Label,
        (who, why): (&str, &str),
    ) -> Result<(usize, usize), HistoryError> {
        let mut counts = (0, 0);
        self.db().transaction(&mut |tx| {
            counts = (0, 0);
            for &(test, digest) in digests {
                if current_label(tx, branch, test, digest)? == Label::Untriaged {
                    label_digest(tx, branch, test, digest, label, who, why)?;
                    counts.0 += 1;
                } else {
                    counts.1 += 1;
                }
            }
            Ok(())
        })?;
        Ok(counts)
    }

    /// Copies `branch`'s positive and negative labels into the main line
    /// (the branch landed), each logged; returns how many.
    pub fn promote(&self, branch: &str, who: &str, why: &str) -> Result<usize, HistoryError> {
        if branch == MAIN {
            return Err(HistoryError::Invalid(
                "the main line is promoted into, not from".into(),
            ));
        }
        let mut promoted = 0;
        self.db().transaction(&mut |tx| {
            promoted = 0;
            let said = tx.query(
                "SELECT test, sha256, label FROM digest_labels
                 WHERE branch = $1 AND label <> 'untriaged' ORDER BY test, sha256",
                args![branch],
            )?;
            if said.is_empty() {
                let any = tx.query_opt(
                    "SELECT 1 FROM digest_labels WHERE branch = $1",
                    args![branch],
                )?;
                return Err(HistoryError::Invalid(match any {
                    Some(_) => format!("branch {branch:?} has no positive or negative to promote"),
                    None => format!("no branch {branch:?}: nothing was ever triaged on it"),
                }));
            }
            let why = format!("promoted from {branch}: {why}");
            for r in said {
                let (test, sha) = (r.text(0)?, r.text(1)?);
                let label = Label::parse(&r.text(2)?)?;
                // A label the main line has already is not said again
                // (promoting twice logged every label twice).
                let same = tx
                    .query_opt(
                        "SELECT 1 FROM digest_labels
                         WHERE branch = $1 AND test = $2 AND sha256 = $3 AND label = $4",
                        args![MAIN, &test, &sha, label.as_str()],
                    )?
                    .is_some();
                if !same {
                    label_digest(tx, MAIN, &test, &sha, label, who, &why)?;
                    promoted += 1;
                }
            }
            Ok(())
        })?;
        Ok(promoted)
    }

    /// Adds a rule that ignores failures of the tests `pattern` (at most
    /// [`MAX_PATTERN_CHARS`] characters) matches in
    /// submissions with every one of `keys` (JSON object text), for
    /// `lasting` from now; returns it.
    pub fn add_ignore_rule(
        &self,
        pattern: &str,
        keys: &str,
        lasting: std::time::Duration,
        (who, reason): (&str, &str),
    ) -> Result<IgnoreRule, HistoryError> {
        // Bounded as a rules file's patterns are: each is matched against
        // every failing frame.
        let chars = pattern.chars().count();
        let most = MAX_PATTERN_CHARS;
        if pattern.is_empty() || chars > most {
            return Err(HistoryError::Invalid(format!(
                "an ignore rule's pattern of {chars} characters: 1 to {most}"
            )));
        }
        let expires_at = super::stamps::later(lasting);
        let id = self
            .db()
            .query_opt(
                "INSERT INTO ignore_rules (pattern, keys, created_at, expires_at, who, reason)
                 VALUES ($1, $2, $3, $4, $5, $6) RETURNING id",
                args![pattern, keys, &now(), &expires_at, who, reason],
            )?
            .ok_or_else(|| HistoryError::Invalid("an ignore rule without an id".into()))?
            .int(0)?;
        Ok(IgnoreRule {
            id,
            pattern: pattern.to_owned(),
            keys: keys.to_owned(),
            expires_at,
            who: who.to_owned(),
            reason: reason.to_owned(),
        })
    }

    /// The ignore rules that have not expired, oldest first.
    pub fn active_ignore_rules(&self) -> Result<Vec<IgnoreRule>, HistoryError> {
        self.db()
            .query(
                "SELECT id, pattern, keys, expires_at, who, reason FROM ignore_rules
                 WHERE expires_at > $1 ORDER BY id",
                args![&now()],
            )?
            .iter()
            .map(|r| {
                Ok(IgnoreRule {
                    id: r.int(0)?,
                    pattern: r.text(1)?,
                    keys: r.text(2)?,
                    expires_at: r.text(3)?,
                    who: r.text(4)?,
                    reason: r.text(5)?,
                })
            })
            .collect()
    }

    /// The triage actions, oldest first; of one test when given.
    pub fn triage_log(&self, test: Option<&str>) -> Result<Vec<TriageEntry>, HistoryError> {
        let columns = "SELECT at, branch, test, sha256, label, who, why FROM triage_log";
        let rows = match test {
            Some(t) => self
                .db()
                .query(&format!("{columns} WHERE test = $1 ORDER BY id"), args![t])?,
            None => self.db().query(&format!("{columns} ORDER BY id"), &[])?,
        };
        rows.iter()
            .map(|r| {
                Ok(TriageEntry {
                    at: r.text(0)?,
                    branch: r.text(1)?,
                    test: r.text(2)?,
                    digest: r.text(3)?,
                    label: Label::parse(&r.text(4)?)?,
                    who: r.text(5)?,
                    why: r.text(6)?,
                })
            })
            .collect()
    }
}

/// A rule that ignores failures of matching tests until it expires.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct IgnoreRule {
    pub id: i64,
    /// The tests it covers (`frames::rules::matches`).
    pub pattern: String,
    /// The submission keys it needs, as a JSON object's text (served as
    /// the object itself).
    #[serde(serialize_with = "as_json_object")]
    pub keys: String,
    pub expires_at: String,
    pub who: String,
    pub reason: String,
}

/// Writes JSON text as the value it holds (`{}` when it holds none).
fn as_json_object<S: serde::Serializer>(text: &str, s: S) -> Result<S::Ok, S::Error> {
    let value: serde_json::Value =
        serde_json::from_str(text).unwrap_or_else(|_| serde_json::json!({}));
    value.serialize(s)
}

/// Sets the label of `digest` of `test` on `branch` and logs it, inside a
/// transaction.
fn label_digest(
    tx: &dyn Sql,
    branch: &str,
    test: &str,
    digest: &str,
    label: Label,
    who: &str,
    why: &str,
) -> Result<(), HistoryError> {
    let seen = tx
        .query_opt(
            "SELECT 1 FROM digest_labels WHERE test = $1 AND sha256 = $2",
            args![test, digest],
        )?
        .is_some();
    if !seen {
        return Err(HistoryError::Invalid(format!(
            "test {test:?} has no digest {digest}: only a digest a submission of the test had can be triaged"
        )));
    }
    tx.execute(
        "INSERT INTO digest_labels (branch, test, sha256, label) VALUES ($1, $2, $3, $4)
         ON CONFLICT (branch, test, sha256) DO UPDATE SET label = excluded.label",
        args![branch, test, digest, label.as_str()],
    )?;
    tx.execute(
        "INSERT INTO triage_log (at, branch, test, sha256, label, who, why)
         VALUES ($1, $2, $3, $4, $5, $6, $7)",
        args![&now(), branch, test, digest, label.as_str(), who, why],
    )?;
    Ok(())
}

/// `digest`'s label for `test` on `branch` now: the branch's own where it
/// said positive or negative, else the main line's; untriaged when nobody
/// said anything.
fn current_label(
    tx: &dyn Sql,
    branch: &str,
    test: &str,
    digest: &str,
) -> Result<Label, HistoryError> {
    let mut own = None;
    let mut main = None;
    for r in tx.query(
        "SELECT branch, label FROM digest_labels
         WHERE test = $1 AND sha256 = $2 AND (branch = $3 OR branch = $4)",
        args![test, digest, branch, MAIN],
    )? {
        let label = Label::parse(&r.text(1)?)?;
        if r.text(0)? == branch {
            own = Some(label);
        } else {
            main = Some(label);
        }
    }
    Ok(match own {
        Some(l) if l != Label::Untriaged => l,
        _ => main.unwrap_or(Label::Untriaged),
    })
}
