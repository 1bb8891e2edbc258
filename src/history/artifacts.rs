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
    /// Frames submissions dropped (older than the keep), and the untriaged
    /// digests only they had. Positive and negative digests stay, with
    /// their images.
    pub submissions: i64,
    pub untriaged_digests: i64,
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

/// What [`History::store_artifacts`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Kept {
    /// Images new to the history.
    pub new: usize,
    /// The names whose images the object store did not take: kept in the
    /// history instead, marked pending with the reason.
    pub pending: Vec<PendingName>,
}

/// An artifact of a run whose image waits for its object store.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct PendingName {
    pub name: String,
    /// Why the store does not have it, in words that name no address.
    pub reason: String,
}

/// An image the history keeps for an object store that did not take it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PendingImage {
    pub sha256: String,
    pub size: i64,
    /// The store it belongs in, `s3://bucket/prefix`.
    pub store: String,
    pub reason: String,
    /// The runs that name it.
    pub runs: Vec<i64>,
    /// The frames submissions that hold it.
    pub submissions: Vec<i64>,
}

/// What `history pending --upload` or `--drop` did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PendingDone {
    /// Images now in their store (uploaded) or gone (dropped).
    pub images: i64,
    pub bytes: i64,
    /// Artifact names dropped with their images.
    pub names: i64,
    /// Images still pending: their store refused or did not answer again.
    pub still_pending: i64,
}

impl History {
    /// Stores a run's artifacts (name, PNG bytes), each image once by its
    /// SHA-256.
    ///
    /// With an object store set (`set_artifact_store`), an image the history
    /// does not hold yet is written there first, and the history keeps its
    /// hash, size and the store's address. An image the store does not take
    /// (down past the retry budget, or refusing) is kept in the history's
    /// own table, marked pending with the reason, and served from there
    /// until `history pending --upload` moves it: a store outage costs a
    /// run none of its results.
    pub fn store_artifacts(
        &self,
        run: i64,
        files: &[(String, Vec<u8>)],
    ) -> Result<Kept, HistoryError> {
        let hashed: Vec<(&String, &Vec<u8>, String)> = files
            .iter()
            .map(|(name, bytes)| (name, bytes, hex::encode(Sha256::digest(bytes))))
            .collect();
        let objects = super::artifact_store();
        // The hashes the store did not take, and why.
        let mut refused: std::collections::HashMap<String, String> = Default::default();
        if let Some(o) = objects.as_ref().filter(|_| !hashed.is_empty()) {
            // The images the history holds and the store has, in one query
            // (a pending one is offered to the store again).
            let marks: Vec<String> = (1..=hashed.len()).map(|i| format!("${i}")).collect();
            let shas: Vec<Value> = hashed.iter().map(|(_, _, s)| Value::from(s)).collect();
            let known: std::collections::HashSet<String> = self
                .db()
                .query(
                    &format!(
                        "SELECT sha256 FROM blobs WHERE sha256 IN ({}) AND pending IS NULL",
                        marks.join(", ")
                    ),
                    &shas,
                )?
                .iter()
                .map(|r| r.text(0))
                .collect::<Result<_, _>>()?;
            for (_, bytes, sha) in &hashed {
                if known.contains(sha) || refused.contains_key(sha) {
                    continue;
                }
                if let Err(e) = o.put(sha, bytes.to_vec()) {
                    if !matches!(e, HistoryError::Objects { .. }) {
                        return Err(e);
                    }
                    tracing::warn!("{e}: the image is kept in the history, pending");
                    refused.insert(sha.clone(), super::objects::pending_reason(&e));
                }
            }
        }
        let store = objects.as_ref().map(|o| o.url.clone());
        let mut kept = Kept::default();
        self.db().transaction(&mut |tx| {
            kept = Kept::default();
            for (name, bytes, sha) in &hashed {
                let existed = tx
                    .query_opt("SELECT 1 FROM blobs WHERE sha256 = $1", args![sha])?
                    .is_some();
                let pending = refused.get(sha);
                let data: &[u8] = if store.is_some() && pending.is_none() {
                    &[]
                } else {
                    bytes
                };
                // Touching stored_at of an image already there keeps a
                // concurrent prune (which spares recent images) off it; a
                // pending image that its store has now taken gives up its
                // bytes and its mark.
                tx.execute(
                    "INSERT INTO blobs (sha256, size, data, stored_at, store, pending)
                     VALUES ($1, $2, $3, $4, $5, $6)
                     ON CONFLICT (sha256) DO UPDATE SET stored_at = excluded.stored_at,
                       data = CASE WHEN blobs.pending IS NOT NULL AND excluded.pending IS NULL
                              THEN excluded.data ELSE blobs.data END,
                       store = CASE WHEN blobs.pending IS NOT NULL AND excluded.pending IS NULL
                              THEN excluded.store ELSE blobs.store END,
                       pending = CASE WHEN excluded.pending IS NULL THEN NULL
                              ELSE blobs.pending END",
                    args![sha, bytes.len(), data, now(), store.as_deref(), pending],
                )?;
                tx.execute(
                    "INSERT INTO run_artifacts (run_id, name, sha256) VALUES ($1, $2, $3)
                     ON CONFLICT (run_id, name) DO UPDATE SET sha256 = excluded.sha256",
                    args![run, *name, sha],
                )?;
                kept.new += usize::from(!existed);
                if let Some(reason) = pending {
                    kept.pending.push(PendingName {
                        name: (*name).clone(),
                        reason: reason.clone(),
                    });
                }
            }
            Ok(())
        })?;
        Ok(kept)
    }

    /// The images kept in the history for an object store that did not
    /// take them, oldest first.
    pub fn pending_artifacts(&self) -> Result<Vec<PendingImage>, HistoryError> {
        let mut out = Vec::new();
        for r in self.db().query(
            "SELECT sha256, size, store, pending FROM blobs
             WHERE pending IS NOT NULL ORDER BY stored_at, sha256",
            &[],
        )? {
            let sha256 = r.text(0)?;
            let runs = self
                .db()
                .query(
                    "SELECT DISTINCT run_id FROM run_artifacts WHERE sha256 = $1 ORDER BY run_id",
                    args![&sha256],
                )?
                .iter()
                .map(|r| r.int(0))
                .collect::<Result<_, _>>()?;
            let submissions = self
                .db()
                .query(
                    "SELECT DISTINCT submission_id FROM submitted_frames WHERE sha256 = $1
                     ORDER BY submission_id",
                    args![&sha256],
                )?
                .iter()
                .map(|r| r.int(0))
                .collect::<Result<_, _>>()?;
            out.push(PendingImage {
                sha256,
                size: r.int(1)?,
                store: r.opt_text(2)?.unwrap_or_default(),
                reason: r.text(3)?,
                runs,
                submissions,
            });
        }
        Ok(out)
    }

    /// Sends each pending image to its object store, one at a time; those
    /// it takes leave the history's table. An image the store still does
    /// not take stays pending (with the new reason).
    pub fn upload_pending(&self) -> Result<PendingDone, HistoryError> {
        let mut done = PendingDone::default();
        for p in self.pending_artifacts()? {
            let Some(row) = self.db().query_opt(
                "SELECT data FROM blobs WHERE sha256 = $1 AND pending IS NOT NULL",
                args![&p.sha256],
            )?
            else {
                continue;
            };
            let bytes = row.blob(0)?;
            let put = super::Objects::open(&p.store).and_then(|o| o.put(&p.sha256, bytes));
            match put {
                Ok(_) => {
                    let moved = self.db().execute(
                        "UPDATE blobs SET data = $2, pending = NULL
                         WHERE sha256 = $1 AND pending IS NOT NULL",
                        args![&p.sha256, &[] as &[u8]],
                    )?;
                    if moved > 0 {
                        done.images += 1;
                        done.bytes += p.size;
                    }
                }
                Err(e @ HistoryError::Objects { .. }) => {
                    tracing::warn!("{e}: still pending");
                    self.db().execute(
                        "UPDATE blobs SET pending = $2 WHERE sha256 = $1 AND pending IS NOT NULL",
                        args![&p.sha256, super::objects::pending_reason(&e)],
                    )?;
                    done.still_pending += 1;
                }
                Err(e) => return Err(e),
            }
        }
        Ok(done)
    }

    /// Drops every pending image and the artifact names of the runs that
    /// named it (their metrics, checks and reports stay).
    pub fn drop_pending(&self) -> Result<PendingDone, HistoryError> {
        let mut done = PendingDone::default();
        self.db().transaction(&mut |tx| {
            done = PendingDone::default();
            done.names = tx.execute(
                "DELETE FROM run_artifacts WHERE sha256 IN
                   (SELECT sha256 FROM blobs WHERE pending IS NOT NULL)",
                &[],
            )? as i64;
            if let Some(r) = tx.query_opt(
                "SELECT COUNT(*), CAST(COALESCE(SUM(size), 0) AS BIGINT) FROM blobs
                 WHERE pending IS NOT NULL",
                &[],
            )? {
                done.bytes = r.int(1)?;
            }
            done.images = tx.execute("DELETE FROM blobs WHERE pending IS NOT NULL", &[])? as i64;
            Ok(())
        })?;
        Ok(done)
    }

    /// One artifact of a run, if the history has it: its bytes, or where
    /// an object store keeps them.
    pub fn artifact(&self, run: i64, name: &str) -> Result<Option<StoredArtifact>, HistoryError> {
        self.db()
            .query_opt(
                "SELECT b.data, b.store, b.sha256, b.size, b.pending FROM run_artifacts a
                 JOIN blobs b ON b.sha256 = a.sha256
                 WHERE a.run_id = $1 AND a.name = $2",
                args![run, name],
            )?
            .map(|r| {
                // A pending image is served from the history's own table.
                let pending = r.opt_text(4)?.is_some();
                Ok(match r.opt_text(1)?.filter(|_| !pending) {
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
    /// ago (their metrics, checks and reports stay) and the frames
    /// submissions made before then, then deletes the images no run,
    /// submission or labelled digest names any more and that nothing stored
    /// within `keep`.
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
            // Submissions older than the keep, their frames, and the
            // untriaged digests no kept submission has.
            tx.execute(
                "DELETE FROM submitted_frames WHERE submission_id IN (
                   SELECT id FROM frame_submissions WHERE submitted_at < $1)",
                args![&cutoff],
            )?;
            out.submissions = tx.execute(
                "DELETE FROM frame_submissions WHERE submitted_at < $1",
                args![&cutoff],
            )? as i64;
            out.untriaged_digests = tx.execute(
                "DELETE FROM digest_labels WHERE label = 'untriaged' AND NOT EXISTS (
                   SELECT 1 FROM submitted_frames f
                   WHERE f.test = digest_labels.test AND f.sha256 = digest_labels.sha256)",
                &[],
            )? as i64;
            let orphans = "FROM blobs WHERE stored_at < $1
                 AND NOT EXISTS (SELECT 1 FROM run_artifacts a WHERE a.sha256 = blobs.sha256)
                 AND NOT EXISTS (SELECT 1 FROM submitted_frames f WHERE f.sha256 = blobs.sha256)
                 AND NOT EXISTS (SELECT 1 FROM digest_labels l WHERE l.sha256 = blobs.sha256)";
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
