//! Artifacts in an object store (`--artifacts s3://bucket/prefix`): the
//! content-addressed images go to any S3 API (AWS, GCS's interoperability
//! API, MinIO, SeaweedFS, Ceph) as `<prefix>/<sha256>.png`, and the history
//! keeps only their names, hashes, sizes and the store's address. A fleet
//! whose images outgrow its database keeps them there.
//!
//! The endpoint and credentials come from the usual `AWS_*` variables
//! (`AWS_ENDPOINT`, `AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY`,
//! `AWS_REGION`, `AWS_ALLOW_HTTP`, `AWS_SKIP_SIGNATURE` for an anonymous
//! store), read by the Arrow project's `object_store` client.
//!
//! The history's callers are synchronous: their requests run on a runtime of
//! this module's own, one thread, and the caller waits for the answer. The
//! server streams an image with [`Objects::get`] from its own async code.

use super::HistoryError;
use futures_util::StreamExt;
use object_store::path::Path as ObjectPath;
use object_store::{ObjectStore, ObjectStoreExt, PutPayload};
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

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

fn failed(url: &str, what: &str, e: impl std::fmt::Display) -> HistoryError {
    HistoryError::Objects {
        url: url.to_owned(),
        detail: format!("{what}: {e}"),
    }
}

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
        let rest = url
            .strip_prefix("s3://")
            .ok_or_else(|| failed(url, "the address", "an object store is s3://bucket/prefix"))?;
        let (bucket, prefix) = rest.split_once('/').unwrap_or((rest, ""));
        let prefix = prefix.trim_matches('/');
        let plain = |s: &str| {
            s.chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.' | '/'))
        };
        if bucket.is_empty() || !plain(bucket) || bucket.contains('/') || !plain(prefix) {
            return Err(failed(
                url,
                "the address",
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
        let built = object_store::aws::AmazonS3Builder::from_env()
            .with_bucket_name(&self.bucket)
            .build()
            .map_err(|e| failed(&self.url, "configuring the S3 client (AWS_* variables)", e))?;
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
    /// when it was written.
    pub fn put(&self, sha256: &str, bytes: Vec<u8>) -> Result<bool, HistoryError> {
        let (store, path) = (self.client()?, self.path(sha256));
        let written = wait(async move {
            match store.head(&path).await {
                Ok(_) => Ok(false),
                Err(object_store::Error::NotFound { .. }) => store
                    .put(&path, PutPayload::from(bytes))
                    .await
                    .map(|_| true),
                Err(e) => Err(e),
            }
        });
        written.map_err(|e| failed(&self.url, &format!("storing {sha256}.png"), e))
    }

    /// Deletes an image; one already gone is not an error.
    pub fn delete(&self, sha256: &str) -> Result<(), HistoryError> {
        let (store, path) = (self.client()?, self.path(sha256));
        match wait(async move { store.delete(&path).await }) {
            Ok(()) | Err(object_store::Error::NotFound { .. }) => Ok(()),
            Err(e) => Err(failed(&self.url, &format!("deleting {sha256}.png"), e)),
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
        listed.map_err(|e| failed(&self.url, "listing the images", e))
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
            Err(e) => Err(failed(&self.url, &format!("reading {sha256}.png"), e)),
        }
    }
}
