//! Artifacts in an object store, in a build without the `s3` feature: an
//! `s3://` address is refused when it is given, so no [`Objects`] exists
//! and the history keeps every image in its own table.

use super::HistoryError;
use std::convert::Infallible;
use std::sync::Arc;

/// An object store the history keeps images in: none can be opened in this
/// build.
#[derive(Debug)]
pub struct Objects {
    /// `s3://bucket/prefix`, as given and as stored beside each image.
    pub url: String,
    never: Infallible,
}

fn unbuilt(url: &str) -> HistoryError {
    HistoryError::Objects {
        url: url.to_owned(),
        detail: "this tonegate was built without the `s3` feature".into(),
        transient: false,
    }
}

/// Refuses an object store; `None` keeps the images in the history's table.
pub fn set_artifact_store(url: Option<&str>) -> Result<(), HistoryError> {
    url.map_or(Ok(()), |u| Err(unbuilt(u)))
}

/// The store new images go to: never one in this build.
pub fn artifact_store() -> Option<Arc<Objects>> {
    None
}

/// Why an image is pending: never, in this build (no store takes one).
pub fn pending_reason(_e: &HistoryError) -> String {
    "this tonegate was built without the `s3` feature".into()
}

/// When the store last came back: never, in this build.
pub fn store_last_recovery() -> Option<std::time::Instant> {
    None
}

/// Whether `s` names an object store rather than a folder.
pub fn is_store_url(s: &str) -> bool {
    s.starts_with("s3://")
}

impl Objects {
    /// Refuses the store at `url`: this build has no S3 client.
    pub fn open(url: &str) -> Result<Arc<Objects>, HistoryError> {
        Err(unbuilt(url))
    }

    pub fn put(&self, _sha256: &str, _bytes: Vec<u8>) -> Result<bool, HistoryError> {
        match self.never {}
    }

    pub fn delete(&self, _sha256: &str) -> Result<(), HistoryError> {
        match self.never {}
    }

    pub fn get_bytes(&self, _sha256: &str) -> Result<Option<Vec<u8>>, HistoryError> {
        match self.never {}
    }

    pub fn list(&self) -> Result<Vec<(String, chrono::DateTime<chrono::Utc>)>, HistoryError> {
        match self.never {}
    }

    #[allow(clippy::type_complexity)]
    pub async fn get(
        &self,
        _sha256: &str,
    ) -> Result<
        Option<(
            u64,
            futures_util::stream::BoxStream<'static, Result<bytes::Bytes, std::io::Error>>,
        )>,
        HistoryError,
    > {
        match self.never {}
    }
}
