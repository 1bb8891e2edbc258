//! The API's errors without the server: a status, a stable machine-readable
//! code and a sentence for people. The parsers of `request` answer with
//! them; `server` writes them as JSON `{ "error": code, "detail": … }`.

use http::StatusCode;

/// What a client sent, cut to a length fit to quote in an error: the first
/// 48 characters and how long it was.
pub fn clip(s: &str) -> String {
    const KEEP: usize = 48;
    let n = s.chars().count();
    if n <= KEEP {
        format!("{s:?}")
    } else {
        let start: String = s.chars().take(KEEP).collect();
        format!("{start:?}… ({n} characters)")
    }
}

/// The longest detail an error answer carries, in characters: room for
/// the unknown-parameter answer's list of every name `POST /tonemap` takes
/// (about 540 characters, 2026-11-27; a test holds it under this), while
/// what a client sent is echoed clipped to 48 characters ([`clip`]).
pub const MAX_DETAIL: usize = 1024;

/// What a 503 for an unreachable history asks the client to wait, in
/// seconds: about what a PostgreSQL restart takes.
pub const HISTORY_RETRY_AFTER_S: u64 = 2;

/// What a 503 for an artifact store that does not answer asks the client
/// to wait, in seconds: about what an object store's restart takes.
pub const STORE_RETRY_AFTER_S: u64 = 5;

#[derive(Debug)]
pub struct ApiError {
    pub status: StatusCode,
    pub code: &'static str,
    pub detail: String,
    /// Seconds for `Retry-After` (503 answers).
    pub retry_after: Option<u64>,
    /// Answered before the request's body was read: the connection cannot be
    /// reused (its unread body is still coming), so it says `Connection: close`.
    pub close: bool,
}

impl ApiError {
    /// An error answer; a detail over [`MAX_DETAIL`] characters (a message
    /// of a library that quoted what the client sent) is cut there.
    pub fn new(status: StatusCode, code: &'static str, detail: impl Into<String>) -> Self {
        let mut detail = detail.into();
        if let Some((cut, _)) = detail.char_indices().nth(MAX_DETAIL) {
            detail.truncate(cut);
            detail.push('…');
        }
        ApiError {
            status,
            code,
            detail,
            retry_after: None,
            close: false,
        }
    }

    /// The same error, answered with `Connection: close`.
    pub fn closing(self) -> Self {
        ApiError {
            close: true,
            ..self
        }
    }
    pub fn bad(detail: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, "bad_parameter", detail)
    }

    pub fn not_found(detail: impl Into<String>) -> Self {
        Self::new(StatusCode::NOT_FOUND, "not_found", detail)
    }
    pub fn internal(detail: impl Into<String>) -> Self {
        Self::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", detail)
    }
    /// 503 with `Retry-After`: the designed answer to overload.
    pub fn unavailable(code: &'static str, detail: impl Into<String>, retry_after: u64) -> Self {
        ApiError {
            retry_after: Some(retry_after.max(1)),
            ..Self::new(StatusCode::SERVICE_UNAVAILABLE, code, detail)
        }
    }

    /// How an image could not be read, as a status: too large 413, not an HDR
    /// format 415, anything wrong inside the file 422.
    pub fn of_image(e: &crate::io::HdrIoError) -> Self {
        use crate::io::HdrIoError as E;
        let (status, code) = match e {
            E::TooLarge { .. } | E::TooLargeForDevice { .. } => {
                (StatusCode::PAYLOAD_TOO_LARGE, "too_large")
            }
            E::UnknownFormat { .. } | E::UnsupportedExtension { .. } => {
                (StatusCode::UNSUPPORTED_MEDIA_TYPE, "unsupported_media_type")
            }
            E::Io { .. } => (StatusCode::INTERNAL_SERVER_ERROR, "internal"),
            _ => (StatusCode::UNPROCESSABLE_ENTITY, "bad_image"),
        };
        Self::new(status, code, e.to_string())
    }

    /// GPU failures: no adapter is the server's set-up (503), a refused size
    /// is the request's (413), anything else is the device's (500).
    #[cfg(feature = "gpu")]
    pub fn of_gpu(e: &crate::gpu::GpuError) -> Self {
        use crate::gpu::GpuError as G;
        match e {
            G::NoAdapter | G::AdapterNotFound { .. } | G::NoHardwareAdapter { .. } => {
                Self::unavailable("no_adapter", e.to_string(), 60)
            }
            G::TooLarge { .. } | G::FrameTooLarge { .. } | G::EnvironmentTooLarge { .. } => {
                Self::new(StatusCode::PAYLOAD_TOO_LARGE, "too_large", e.to_string())
            }
            _ => Self::new(
                StatusCode::INTERNAL_SERVER_ERROR,
                "gpu_error",
                e.to_string(),
            ),
        }
    }

    pub fn of_crate(e: &crate::Error) -> Self {
        match e {
            crate::Error::HdrIo(e) => Self::of_image(e),
            #[cfg(feature = "gpu")]
            crate::Error::Gpu(e) => Self::of_gpu(e),
            crate::Error::Invalid(d) => Self::bad(d.clone()),
            other => Self::internal(other.to_string()),
        }
    }

    /// A history that cannot be reached (down or restarting, past the
    /// server's retry budget) is 503 `history_unavailable` with
    /// `Retry-After`: nothing was done and the same request may be sent
    /// again. Anything else is 500.
    #[cfg(feature = "history")]
    pub fn of_history(e: &crate::history::HistoryError) -> Self {
        // The full error (with the database's or the store's address) goes
        // to the log; an answer names no address.
        if e.unavailable() {
            tracing::warn!("{e}");
            return Self::unavailable(
                "history_unavailable",
                "the history database does not answer (down or restarting); nothing was \
                 stored, send the request again",
                HISTORY_RETRY_AFTER_S,
            );
        }
        if let crate::history::HistoryError::Objects { transient, .. } = e {
            tracing::warn!("{e}");
            return Self::unavailable(
                "artifact_store_unavailable",
                if *transient {
                    "the artifact store does not answer (down, unreachable or overloaded); \
                     send the request again"
                } else {
                    "the artifact store refused the request (its credentials or \
                     configuration; the server's log has its answer); send the request again"
                },
                STORE_RETRY_AFTER_S,
            );
        }
        tracing::error!("{e}");
        Self::internal(format!("history: {}", e.without_address()))
    }
}
