//! Artifacts in an object store (`--artifacts s3://bucket/prefix`): the
//! content-addressed images go to any S3 API (AWS, GCS's interoperability
//! API, MinIO, SeaweedFS, Ceph) as `<prefix>/<sha256>.png`, and the history
//! keeps only their names, hashes, sizes and the store's address. A fleet
//! whose images outgrow its database keeps them there.
//!
//! The endpoint and credentials come from the usual `AWS_*` variables
//! (`AWS_ENDPOINT`, `AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY`,
//! `AWS_REGION`, `AWS_ALLOW_HTTP`, `AWS_SKIP_SIGNATURE` for an anonymous
//! store), read by the Arrow project's `object_store` client. Without any of
//! them the client would ask the cloud's instance-metadata service
//! (169.254.169.254) for credentials; that happens only when
//! `TONEGATE_S3_INSTANCE_METADATA=1` asks for it, and is refused otherwise.
//!
//! The store is a fault domain like the database: a write the store does
//! not take (down, restarting, overloaded) is tried again with back-off for
//! the process's retry budget (`set_retry_budget`: 600 s for a runner), and
//! what it still does not take is kept in the history, marked pending with
//! the reason (`History::store_artifacts`).
//!
//! The history's callers are synchronous: their requests run on a runtime of
//! this module's own, one thread, and the caller waits for the answer. The
//! server streams an image with [`Objects::get`] from its own async code.

use super::HistoryError;
use futures_util::StreamExt;
use object_store::path::Path as ObjectPath;
use object_store::{ObjectStore, ObjectStoreExt, PutPayload};
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

/// An object store the history keeps images in.
#[derive(Debug)]
pub struct Objects {
    /// The client, built on first use: a runner whose images the history
    /// already holds never needs one (building it loads the TLS roots).
    store: OnceLock<Arc<dyn ObjectStore>>,
    bucket: String,
    prefix: String,
    /// `s3://bucket/prefix`, as given and as stored beside each image.
    pub url: String,
}

/// The process's store for new images (`set_artifact_store`), if any.
static STORE: Mutex<Option<Arc<Objects>>> = Mutex::new(None);

/// Stores opened by address, so each is built (and its connections pooled)
/// once per process.
static OPENED: Mutex<Option<HashMap<String, Arc<Objects>>>> = Mutex::new(None);

/// Makes `url` (`s3://bucket/prefix`) where this process stores the images
/// it keeps from now on; `None` puts them back into the history's own table.
pub fn set_artifact_store(url: Option<&str>) -> Result<(), HistoryError> {
    let store = url.map(Objects::open).transpose()?;
    // A store that cannot be used as configured is said now, before any work.
    if let (Some(o), Some(why)) = (&store, no_credentials()) {
        return Err(HistoryError::Objects {
            url: o.url.clone(),
            detail: why,
            transient: false,
        });
    }
    *STORE.lock().unwrap_or_else(|p| p.into_inner()) = store;
    Ok(())
}

/// The store new images go to, if one was set.
pub fn artifact_store() -> Option<Arc<Objects>> {
    STORE.lock().unwrap_or_else(|p| p.into_inner()).clone()
}

/// Whether `s` names an object store rather than a folder.
pub fn is_store_url(s: &str) -> bool {
    s.starts_with("s3://")
}

fn failed(url: &str, what: &str, e: &object_store::Error) -> HistoryError {
    HistoryError::Objects {
        url: url.to_owned(),
        detail: format!("{what}: {e}"),
        transient: transient(e),
    }
}

/// Whether a store's error may pass if the request is sent again: the store
/// unreachable, timing out or answering 5xx or 429 (all `Generic` once the
/// client's own retries are spent), as opposed to a refusal (no such
/// object, no permission, bad credentials, a bad request).
fn transient(e: &object_store::Error) -> bool {
    matches!(e, object_store::Error::Generic { .. })
}

/// The variables that give the client credentials (or say it needs none)
/// without the instance-metadata service.
const CREDENTIALS: [&str; 5] = [
    "AWS_ACCESS_KEY_ID",
    "AWS_SKIP_SIGNATURE",
    "AWS_WEB_IDENTITY_TOKEN_FILE",
    "AWS_CONTAINER_CREDENTIALS_RELATIVE_URI",
    "AWS_CONTAINER_CREDENTIALS_FULL_URI",
];

/// The variable that allows asking the instance-metadata service.
pub const INSTANCE_METADATA: &str = "TONEGATE_S3_INSTANCE_METADATA";

/// Why the client may not be built as the environment stands: no
/// credentials, and the metadata service not asked for.
fn no_credentials() -> Option<String> {
    let set = |v: &str| std::env::var_os(v).is_some_and(|x| !x.is_empty());
    let asked = std::env::var(INSTANCE_METADATA).is_ok_and(|v| v == "1" || v == "true");
    (!asked && !CREDENTIALS.iter().any(|v| set(v))).then(|| {
        format!(
            "no credentials: set AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY, \
             AWS_SKIP_SIGNATURE=true for an anonymous store, or {INSTANCE_METADATA}=1 \
             to ask the cloud's instance-metadata service"
        )
    })
}

/// Why an image is pending, for a report or an answer: what happened, in
/// words that name no address (the full error goes to the log).
pub fn pending_reason(e: &HistoryError) -> String {
    match e {
        HistoryError::Objects {
            transient: true, ..
        } => format!(
            "the artifact store did not answer (down, unreachable or overloaded) \
             within the retry budget of {} s",
            super::reconnect::retry_budget().as_secs()
        ),
        HistoryError::Objects { detail, .. } if detail.starts_with("no credentials") => {
            "the artifact store has no credentials configured".into()
        }
        _ => "the artifact store refused the image (permissions, credentials or \
              configuration; the log has its answer)"
            .into(),
    }
}

/// When a write last went through after the store had not answered it.
static RECOVERED: Mutex<Option<std::time::Instant>> = Mutex::new(None);

/// When this process last had the artifact store take an image after it
/// had stopped answering, if it ever did (a runner says so).
pub fn store_last_recovery() -> Option<std::time::Instant> {
    *RECOVERED.lock().unwrap_or_else(|p| p.into_inner())
}

/// Set when a write used up the retry budget without the store answering:
/// later writes try once each (and clear it when one goes through) rather
/// than each waiting out a budget of its own.
static GAVE_UP: AtomicBool = AtomicBool::new(false);

/// Runs `f` to its end on this module's runtime and waits for it: callable
/// from plain threads and from a server's blocking tasks alike.
fn wait<T: Send + 'static>(f: impl std::future::Future<Output = T> + Send + 'static) -> T {
    static RUNTIME: OnceLock<tokio::runtime::Runtime> = OnceLock::new();
    let rt = RUNTIME.get_or_init(|| {
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("object-store")
            .enable_all()
            .build()
            .expect("the object store's runtime starts")
    });
    let (tx, rx) = std::sync::mpsc::channel();
    rt.spawn(async move {
        let _ = tx.send(f.await);
    });
    rx.recv().expect("the object store's runtime answers")
}

impl Objects {
    /// The store at `url` (`s3://bucket` or `s3://bucket/prefix`), opened
    /// once per process.
    pub fn open(url: &str) -> Result<Arc<Objects>, HistoryError> {
        let mut opened = OPENED.lock().unwrap_or_else(|p| p.into_inner());
        let opened = opened.get_or_insert_with(HashMap::new);
        if let Some(o) = opened.get(url) {
            return Ok(o.clone());
        }
        let bad = |detail: &str| HistoryError::Objects {
            url: url.to_owned(),
            detail: format!("the address: {detail}"),
            transient: false,
        };
        let rest = url
            .strip_prefix("s3://")
            .ok_or_else(|| bad("an object store is s3://bucket/prefix"))?;
        let (bucket, prefix) = rest.split_once('/').unwrap_or((rest, ""));
        let prefix = prefix.trim_matches('/');
        let plain = |s: &str| {
            s.chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.' | '/'))
        };
        if bucket.is_empty() || !plain(bucket) || bucket.contains('/') || !plain(prefix) {
            return Err(bad(
                "use s3://bucket/prefix with letters, digits, '-', '_', '.' and '/'",
            ));
        }
        let o = Arc::new(Objects {
            store: OnceLock::new(),
            bucket: bucket.to_owned(),
            prefix: prefix.to_owned(),
            url: url.to_owned(),
        });
        opened.insert(url.to_owned(), o.clone());
        Ok(o)
    }

    fn client(&self) -> Result<Arc<dyn ObjectStore>, HistoryError> {
        if let Some(c) = self.store.get() {
            return Ok(c.clone());
        }
        if let Some(why) = no_credentials() {
            return Err(HistoryError::Objects {
                url: self.url.clone(),
                detail: why,
                transient: false,
            });
        }
        // The client's own retries stay short (within a request's signing
        // window); `put` tries again over the process's budget.
        let retry = object_store::RetryConfig {
            max_retries: 4,
            retry_timeout: super::reconnect::retry_budget().min(Duration::from_secs(10)),
            ..Default::default()
        };
        let built = object_store::aws::AmazonS3Builder::from_env()
            .with_bucket_name(&self.bucket)
            .with_retry(retry)
            .build()
            .map_err(|e| {
                let mut e = failed(&self.url, "configuring the S3 client (AWS_* variables)", &e);
                if let HistoryError::Objects { transient, .. } = &mut e {
                    *transient = false;
                }
                e
            })?;
        Ok(self.store.get_or_init(|| Arc::new(built)).clone())
    }

    fn path(&self, sha256: &str) -> ObjectPath {
        if self.prefix.is_empty() {
            ObjectPath::from(format!("{sha256}.png"))
        } else {
            ObjectPath::from(format!("{}/{sha256}.png", self.prefix))
        }
    }

    /// Stores an image under its hash, unless it is there already; true
    /// when it was written. A store that does not answer is tried again,
    /// backing off with jitter, until the process's retry budget is spent
    /// (once per outage: after a write gave up, the next tries once).
    pub fn put(&self, sha256: &str, bytes: Vec<u8>) -> Result<bool, HistoryError> {
        let store = self.client()?;
        let bytes = bytes::Bytes::from(bytes);
        let mut backoff = super::reconnect::Backoff::new();
        let mut failed_tries = 0u32;
        loop {
            let (store, path, bytes) = (store.clone(), self.path(sha256), bytes.clone());
            let tried = wait(async move {
                match store.head(&path).await {
                    Ok(_) => Ok(false),
                    Err(object_store::Error::NotFound { .. }) => store
                        .put(&path, PutPayload::from_bytes(bytes))
                        .await
                        .map(|_| true),
                    Err(e) => Err(e),
                }
            });
            match tried {
                Ok(written) => {
                    if GAVE_UP.swap(false, Ordering::Relaxed) || failed_tries > 0 {
                        *RECOVERED.lock().unwrap_or_else(|p| p.into_inner()) =
                            Some(std::time::Instant::now());
                        tracing::info!("artifact store {} takes images again", self.url);
                    }
                    return Ok(written);
                }
                Err(e) if transient(&e) && !GAVE_UP.load(Ordering::Relaxed) && backoff.wait() => {
                    failed_tries += 1;
                    tracing::debug!("artifact store {}: {e}; trying again", self.url);
                }
                Err(e) => {
                    if transient(&e) {
                        GAVE_UP.store(true, Ordering::Relaxed);
                    }
                    return Err(failed(&self.url, &format!("storing {sha256}.png"), &e));
                }
            }
        }
    }

    /// Deletes an image; one already gone is not an error.
    pub fn delete(&self, sha256: &str) -> Result<(), HistoryError> {
        let (store, path) = (self.client()?, self.path(sha256));
        match wait(async move { store.delete(&path).await }) {
            Ok(()) | Err(object_store::Error::NotFound { .. }) => Ok(()),
            Err(e) => Err(failed(&self.url, &format!("deleting {sha256}.png"), &e)),
        }
    }

    /// Every image under the prefix: its hash and when it was written.
    pub fn list(&self) -> Result<Vec<(String, chrono::DateTime<chrono::Utc>)>, HistoryError> {
        let store = self.client()?;
        let prefix = (!self.prefix.is_empty()).then(|| ObjectPath::from(self.prefix.as_str()));
        let listed = wait(async move {
            let mut out = Vec::new();
            let mut items = store.list(prefix.as_ref());
            while let Some(item) = items.next().await {
                let meta = item?;
                if let Some(sha) = meta
                    .location
                    .filename()
                    .and_then(|f| f.strip_suffix(".png"))
                    .filter(|s| s.len() == 64 && s.bytes().all(|b| b.is_ascii_hexdigit()))
                {
                    out.push((sha.to_owned(), meta.last_modified));
                }
            }
            Ok::<_, object_store::Error>(out)
        });
        listed.map_err(|e| failed(&self.url, "listing the images", &e))
    }

    /// An image's bytes, whole; `None` when the store has no such image.
    pub fn get_bytes(&self, sha256: &str) -> Result<Option<Vec<u8>>, HistoryError> {
        let (store, path) = (self.client()?, self.path(sha256));
        let got = wait(async move {
            match store.get(&path).await {
                Ok(got) => got.bytes().await.map(|b| Some(b.to_vec())),
                Err(object_store::Error::NotFound { .. }) => Ok(None),
                Err(e) => Err(e),
            }
        });
        got.map_err(|e| failed(&self.url, &format!("reading {sha256}.png"), &e))
    }

    /// An image as a stream of byte chunks and its length, for an answer
    /// that never holds the whole file. `None` when the store has no such
    /// image.
    pub async fn get(
        &self,
        sha256: &str,
    ) -> Result<
        Option<(
            u64,
            futures_util::stream::BoxStream<'static, Result<bytes::Bytes, object_store::Error>>,
        )>,
        HistoryError,
    > {
        match self.client()?.get(&self.path(sha256)).await {
            Ok(got) => {
                let size = got.meta.size;
                Ok(Some((size, got.into_stream())))
            }
            Err(object_store::Error::NotFound { .. }) => Ok(None),
            Err(e) => Err(failed(&self.url, &format!("reading {sha256}.png"), &e)),
        }
    }
}
