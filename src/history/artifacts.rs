//! Artifacts kept in the history itself, content-addressed: an image is
//! stored once under its SHA-256 however many runs (and runners) made it,
//! and each run keeps its names for them. The server then serves any
//! runner's images from the shared history, and repeated runs of a
//! deterministic renderer cost no space for what did not change.

use super::backend::args;
use super::{ago, now, History, HistoryError};
use serde::Serialize;
use sha2::{Digest, Sha256};
use std::time::Duration;

/// What `history prune` removed.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Pruned {
    /// Runs whose artifacts were dropped (their metrics stay).
    pub runs: Vec<i64>,
    /// Names dropped.
    pub names: i64,
    /// Images no kept run names any more, deleted.
    pub blobs: i64,
    pub bytes: i64,
}

/// How much the artifact store holds.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ArtifactStats {
    /// Names over all runs.
    pub names: i64,
    /// Distinct images stored.
    pub blobs: i64,
    pub bytes: i64,
}

impl History {
    /// Stores a run's artifacts (name, PNG bytes), each image once by its
    /// SHA-256; returns how many were new to the store.
    pub fn store_artifacts(
        &self,
        run: i64,
        files: &[(String, Vec<u8>)],
    ) -> Result<usize, HistoryError> {
        let mut new = 0;
        self.db().transaction(&mut |tx| {
            new = 0;
            for (name, bytes) in files {
                let sha = hex::encode(Sha256::digest(bytes));
                let existed = tx
                    .query_opt("SELECT 1 FROM blobs WHERE sha256 = $1", args![&sha])?
                    .is_some();
                // Touching stored_at of an image already there keeps a
                // concurrent prune (which spares recent images) off it.
                tx.execute(
                    "INSERT INTO blobs (sha256, size, data, stored_at) VALUES ($1, $2, $3, $4)
                     ON CONFLICT (sha256) DO UPDATE SET stored_at = excluded.stored_at",
                    args![&sha, bytes.len(), bytes.as_slice(), now()],
                )?;
                tx.execute(
                    "INSERT INTO run_artifacts (run_id, name, sha256) VALUES ($1, $2, $3)
                     ON CONFLICT (run_id, name) DO UPDATE SET sha256 = excluded.sha256",
                    args![run, name, &sha],
                )?;
                new += usize::from(!existed);
            }
            Ok(())
        })?;
        Ok(new)
    }

    /// One artifact of a run, if the history has it.
    pub fn artifact(&self, run: i64, name: &str) -> Result<Option<Vec<u8>>, HistoryError> {
        self.db()
            .query_opt(
                "SELECT b.data FROM run_artifacts a JOIN blobs b ON b.sha256 = a.sha256
                 WHERE a.run_id = $1 AND a.name = $2",
                args![run, name],
            )?
            .map(|r| r.blob(0))
            .transpose()
    }

    /// The names of a run's stored artifacts, sorted.
    pub fn artifact_names(&self, run: i64) -> Result<Vec<String>, HistoryError> {
        self.db()
            .query(
                "SELECT name FROM run_artifacts WHERE run_id = $1 ORDER BY name",
                args![run],
            )?
            .iter()
            .map(|r| r.text(0))
            .collect()
    }

    pub fn artifact_stats(&self) -> Result<ArtifactStats, HistoryError> {
        let names = self
            .db()
            .query_opt("SELECT COUNT(*) FROM run_artifacts", &[])?
            .map_or(Ok(0), |r| r.int(0))?;
        let (blobs, bytes) = match self.db().query_opt(
            "SELECT COUNT(*), CAST(COALESCE(SUM(size), 0) AS BIGINT) FROM blobs",
            &[],
        )? {
            Some(r) => (r.int(0)?, r.int(1)?),
            None => (0, 0),
        };
        Ok(ArtifactStats {
            names,
            blobs,
            bytes,
        })
    }

    /// Drops the artifacts of finished runs that started more than `keep`
    /// ago (their metrics, checks and reports stay), then deletes the images
    /// no run names any more and that nothing stored within `keep`.
    pub fn prune_artifacts(&self, keep: Duration) -> Result<Pruned, HistoryError> {
        let cutoff = ago(keep);
        let mut out = Pruned::default();
        self.db().transaction(&mut |tx| {
            out = Pruned::default();
            for r in tx.query(
                "SELECT DISTINCT a.run_id FROM run_artifacts a JOIN runs r ON r.id = a.run_id
                 WHERE r.started_at < $1 AND r.status <> 'running' ORDER BY a.run_id",
                args![&cutoff],
            )? {
                out.runs.push(r.int(0)?);
            }
            out.names = tx.execute(
                "DELETE FROM run_artifacts WHERE run_id IN (
                   SELECT id FROM runs WHERE started_at < $1 AND status <> 'running')",
                args![&cutoff],
            )? as i64;
            let orphans = "FROM blobs WHERE stored_at < $1
                 AND NOT EXISTS (SELECT 1 FROM run_artifacts a WHERE a.sha256 = blobs.sha256)";
            if let Some(r) = tx.query_opt(
                &format!("SELECT COUNT(*), CAST(COALESCE(SUM(size), 0) AS BIGINT) {orphans}"),
                args![&cutoff],
            )? {
                out.bytes = r.int(1)?;
            }
            out.blobs = tx.execute(&format!("DELETE {orphans}"), args![&cutoff])? as i64;
            Ok(())
        })?;
        Ok(out)
    }
}
