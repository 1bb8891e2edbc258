//! Artifacts kept in the history itself, content-addressed: an image is
//! stored once under its SHA-256 however many runs (and runners) made it,
//! and each run keeps its names for them. The server then serves any
//! runner's images from the shared history, and repeated runs of a
//! deterministic renderer cost no space for what did not change.

use super::backend::{args, Value};
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
    /// Of those, the ones deleted from an object store, and the objects
    /// found there that no stored image named (left by a write that did not
    /// finish), deleted too.
    pub objects: i64,
    pub stray_objects: i64,
}

/// An object in a store that no stored image names is deleted by a prune
/// only once it is this old (and older than what the prune keeps): a runner
/// writes an image to the store just before it records it.
pub const STRAY_GRACE: Duration = Duration::from_secs(10);

/// Where a stored artifact's bytes are.
#[derive(Clone, Debug, PartialEq)]
pub enum StoredArtifact {
    /// In the history itself.
    Bytes(Vec<u8>),
    /// In an object store (`s3://bucket/prefix`), as `<sha256>.png`.
    Object {
        store: String,
        sha256: String,
        size: i64,
    },
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
    ///
    /// With an object store set (`set_artifact_store`), an image the history
    /// does not hold yet is written there first, and the history keeps its
    /// hash, size and the store's address.
    pub fn store_artifacts(
        &self,
        run: i64,
        files: &[(String, Vec<u8>)],
    ) -> Result<usize, HistoryError> {
        let hashed: Vec<(&String, &Vec<u8>, String)> = files
            .iter()
            .map(|(name, bytes)| (name, bytes, hex::encode(Sha256::digest(bytes))))
            .collect();
        let objects = super::artifact_store();
        if let Some(o) = objects.as_ref().filter(|_| !hashed.is_empty()) {
            // The images the history does not know yet, in one query.
            let marks: Vec<String> = (1..=hashed.len()).map(|i| format!("${i}")).collect();
            let shas: Vec<Value> = hashed.iter().map(|(_, _, s)| Value::from(s)).collect();
            let known: std::collections::HashSet<String> = self
                .db()
                .query(
                    &format!(
                        "SELECT sha256 FROM blobs WHERE sha256 IN ({})",
                        marks.join(", ")
                    ),
                    &shas,
                )?
                .iter()
                .map(|r| r.text(0))
                .collect::<Result<_, _>>()?;
            for (_, bytes, sha) in &hashed {
                if !known.contains(sha) {
                    o.put(sha, bytes.to_vec())?;
                }
            }
        }
        let store = objects.as_ref().map(|o| o.url.clone());
        let mut new = 0;
        self.db().transaction(&mut |tx| {
            new = 0;
            for (name, bytes, sha) in &hashed {
                let existed = tx
                    .query_opt("SELECT 1 FROM blobs WHERE sha256 = $1", args![sha])?
                    .is_some();
                let data: &[u8] = if store.is_some() { &[] } else { bytes };
                // Touching stored_at of an image already there keeps a
                // concurrent prune (which spares recent images) off it.
                tx.execute(
                    "INSERT INTO blobs (sha256, size, data, stored_at, store)
                     VALUES ($1, $2, $3, $4, $5)
                     ON CONFLICT (sha256) DO UPDATE SET stored_at = excluded.stored_at",
                    args![sha, bytes.len(), data, now(), store.as_deref()],
                )?;
                tx.execute(
                    "INSERT INTO run_artifacts (run_id, name, sha256) VALUES ($1, $2, $3)
                     ON CONFLICT (run_id, name) DO UPDATE SET sha256 = excluded.sha256",
                    args![run, *name, sha],
                )?;
                new += usize::from(!existed);
            }
            Ok(())
        })?;
        Ok(new)
    }

    /// One artifact of a run, if the history has it: its bytes, or where
    /// an object store keeps them.
    pub fn artifact(&self, run: i64, name: &str) -> Result<Option<StoredArtifact>, HistoryError> {
        self.db()
            .query_opt(
                "SELECT b.data, b.store, b.sha256, b.size FROM run_artifacts a
                 JOIN blobs b ON b.sha256 = a.sha256
                 WHERE a.run_id = $1 AND a.name = $2",
                args![run, name],
            )?
            .map(|r| {
                Ok(match r.opt_text(1)? {
                    Some(store) => StoredArtifact::Object {
                        store,
                        sha256: r.text(2)?,
                        size: r.int(3)?,
                    },
                    None => StoredArtifact::Bytes(r.blob(0)?),
                })
            })
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
        let mut gone: Vec<(String, String)> = Vec::new();
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
            gone.clear();
            for r in tx.query(
                &format!("SELECT sha256, store {orphans} AND store IS NOT NULL"),
                args![&cutoff],
            )? {
                gone.push((r.text(0)?, r.text(1)?));
            }
            out.blobs = tx.execute(&format!("DELETE {orphans}"), args![&cutoff])? as i64;
            Ok(())
        })?;
        // The rows are gone first: an object whose delete fails here is a
        // stray, found and deleted by the next prune.
        for (sha, store) in &gone {
            super::Objects::open(store)?.delete(sha)?;
            out.objects += 1;
        }
        // Objects nothing names: in every store the history uses, and the
        // process's own.
        let mut stores: Vec<String> = self
            .db()
            .query(
                "SELECT DISTINCT store FROM blobs WHERE store IS NOT NULL",
                &[],
            )?
            .iter()
            .map(|r| r.text(0))
            .collect::<Result<_, _>>()?;
        stores.extend(gone.into_iter().map(|(_, s)| s));
        stores.extend(super::artifact_store().map(|o| o.url.clone()));
        stores.sort();
        stores.dedup();
        // A keep longer than the calendar reaches back spares every object.
        let before = chrono::TimeDelta::from_std(keep.max(STRAY_GRACE))
            .ok()
            .and_then(|d| chrono::Utc::now().checked_sub_signed(d))
            .unwrap_or(chrono::DateTime::<chrono::Utc>::MIN_UTC);
        for url in stores {
            let o = super::Objects::open(&url)?;
            for (sha, written) in o.list()? {
                if written >= before {
                    continue;
                }
                let named = self
                    .db()
                    .query_opt("SELECT 1 FROM blobs WHERE sha256 = $1", args![&sha])?
                    .is_some();
                if !named {
                    o.delete(&sha)?;
                    out.stray_objects += 1;
                }
            }
        }
        Ok(out)
    }
}
