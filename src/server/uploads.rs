//! The bodies `POST /tonemap` is receiving, bounded apart from the tone-map
//! queues: at most `max_uploads` at once, holding at most `upload_budget`
//! bytes together, each charged as its bytes arrive (a client that sends
//! slowly holds only what it has sent). A queue place is taken only once a
//! body is in, so clients that send slowly hold no worker and no place.

use super::error::ApiError;
use axum::body::Bytes;
use axum::http::StatusCode;
use futures_util::StreamExt;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;

/// What the server is receiving now.
pub struct Uploads {
    most: usize,
    budget: u64,
    open: AtomicUsize,
    held: AtomicU64,
    /// Uploads refused for either bound, for `/metrics`.
    pub refused: AtomicU64,
}

/// One body being received; its place and bytes are given back when it is
/// dropped (read, refused, cut off or timed out).
pub struct Upload {
    of: Arc<Uploads>,
    held: u64,
}

impl Uploads {
    pub fn new(most: usize, budget: usize) -> Arc<Uploads> {
        Arc::new(Uploads {
            most: most.max(1),
            budget: budget as u64,
            open: AtomicUsize::new(0),
            held: AtomicU64::new(0),
            refused: AtomicU64::new(0),
        })
    }

    /// Bodies being received now, and the bytes they hold.
    pub fn now(&self) -> (usize, u64) {
        (
            self.open.load(Ordering::Relaxed),
            self.held.load(Ordering::Relaxed),
        )
    }

    /// A place for one more body, or 503 `busy` when `max_uploads` are
    /// being received.
    pub fn begin(self: &Arc<Self>) -> Result<Upload, ApiError> {
        let taken = self
            .open
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| {
                (n < self.most).then_some(n + 1)
            });
        match taken {
            Ok(_) => Ok(Upload {
                of: self.clone(),
                held: 0,
            }),
            Err(n) => {
                self.refused.fetch_add(1, Ordering::Relaxed);
                Err(ApiError::unavailable(
                    "busy",
                    format!(
                        "{n} uploads are being received, the most at once (serve --max-uploads); \
                         send it again"
                    ),
                    1,
                ))
            }
        }
    }
}

impl Upload {
    /// Charges `n` more bytes of this body to the budget, or 503 `busy`
    /// when the uploads in progress hold it all.
    pub fn charge(&mut self, n: usize) -> Result<(), ApiError> {
        let n = n as u64;
        let budget = self.of.budget;
        let charged = self
            .of
            .held
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |h| {
                (h + n <= budget).then_some(h + n)
            });
        match charged {
            Ok(_) => {
                self.held += n;
                Ok(())
            }
            Err(h) => {
                self.of.refused.fetch_add(1, Ordering::Relaxed);
                Err(ApiError::unavailable(
                    "busy",
                    format!(
                        "the uploads in progress hold {:.1} MiB of the {:.1} MiB they may \
                         (serve --upload-budget-mib); send it again",
                        h as f64 / 1048576.0,
                        budget as f64 / 1048576.0
                    ),
                    1,
                ))
            }
        }
    }
}

impl Drop for Upload {
    fn drop(&mut self) {
        self.of.held.fetch_sub(self.held, Ordering::AcqRel);
        self.of.open.fetch_sub(1, Ordering::AcqRel);
    }
}

/// A raw body, at most `limit` bytes, each chunk charged to `upload` as it
/// arrives; when it is one image (`max_pixels` given), one whose header
/// states more than `max_pixels` is refused as soon as it does.
pub async fn read_raw(
    body: axum::body::Body,
    limit: usize,
    max_pixels: Option<u64>,
    upload: &mut Upload,
) -> Result<Bytes, ApiError> {
    let mut check = max_pixels.map(crate::request::head::HeadCheck::new);
    let mut stream = body.into_data_stream();
    let mut got = bytes::BytesMut::new();
    while let Some(chunk) = stream.next().await {
        let chunk = chunk.map_err(|e| ApiError::bad(format!("reading the body: {e}")))?;
        if got.len() + chunk.len() > limit {
            return Err(ApiError::new(
                StatusCode::PAYLOAD_TOO_LARGE,
                "too_large",
                format!("the body is over the limit of {limit} bytes (serve --max-body-mib)"),
            ));
        }
        upload.charge(chunk.len())?;
        if let Some(c) = check.as_mut() {
            c.feed(&chunk)?;
        }
        got.extend_from_slice(&chunk);
    }
    Ok(got.freeze())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn places_and_bytes_are_given_back_when_an_upload_ends() {
        let u = Uploads::new(2, 100);
        let mut a = u.begin().unwrap();
        let b = u.begin().unwrap();
        let Err(third) = u.begin() else {
            panic!("a third upload past the most of two")
        };
        assert_eq!((third.status.as_u16(), third.code), (503, "busy"));
        a.charge(60).unwrap();
        let mut b = b;
        let over = b.charge(41).unwrap_err();
        assert!(
            over.detail.contains("--upload-budget-mib"),
            "{}",
            over.detail
        );
        b.charge(40).unwrap();
        assert_eq!(u.now(), (2, 100));
        drop(a);
        assert_eq!(u.now(), (1, 40));
        let mut c = u.begin().unwrap();
        c.charge(60).unwrap();
        drop((b, c));
        assert_eq!(u.now(), (0, 0));
        assert_eq!(u.refused.load(Ordering::Relaxed), 2);
    }
}
