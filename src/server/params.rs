//! What every endpoint parses the same way: query strings (unknown or bad
//! parameters refused by name), parameter names, run ids, limits, the
//! renderer; the history read off the async threads; JSON and 202 answers.

use super::error::ApiError;
use super::AppState;
use crate::history::{History, HistoryError};
pub use crate::request::params::{check_names, from_pairs, renderer_is_cpu, MAX_NAME};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Parses a query string, answering 400 with the parameter's name when it is unknown or bad.
pub fn query<T: DeserializeOwned>(q: Option<String>) -> Result<T, ApiError> {
    from_pairs(q.as_deref().unwrap_or("").as_bytes())
}

/// A run id from the path: a positive integer.
pub fn run_id(s: &str) -> Result<i64, ApiError> {
    s.parse::<i64>().ok().filter(|&v| v > 0).ok_or_else(|| {
        ApiError::bad(format!(
            "run id: expected a positive integer, got {}",
            super::error::clip(s)
        ))
    })
}

/// Runs `f` on the history, opened read-only, off the async threads.
pub async fn read<T: Send + 'static>(
    st: &AppState,
    f: impl FnOnce(&History) -> Result<T, HistoryError> + Send + 'static,
) -> Result<T, ApiError> {
    let db = st.db.clone();
    tokio::task::spawn_blocking(move || {
        let h = History::open_read_only(&db).map_err(|e| ApiError::of_history(&e))?;
        f(&h).map_err(|e| match e {
            HistoryError::Invalid(d) => ApiError::bad(d),
            e => ApiError::of_history(&e),
        })
    })
    .await
    .map_err(|e| ApiError::internal(e.to_string()))?
}

/// Runs `f` on the history opened for writing, off the async threads; a
/// history that cannot be written is 503 `history_read_only` with why.
pub async fn write<T: Send + 'static>(
    st: &AppState,
    f: impl FnOnce(&History) -> Result<T, HistoryError> + Send + 'static,
) -> Result<T, ApiError> {
    write_with(st, move |h| {
        f(h).map_err(|e| match e {
            HistoryError::Invalid(d) => ApiError::bad(d),
            e => ApiError::of_history(&e),
        })
    })
    .await
}

/// [`write()`] for work whose errors say more than the history's (they are
/// answered as `f` makes them).
pub async fn write_with<T: Send + 'static>(
    st: &AppState,
    f: impl FnOnce(&History) -> Result<T, ApiError> + Send + 'static,
) -> Result<T, ApiError> {
    if let Some(problem) = st.history_problem().await {
        return Err(ApiError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "history_read_only",
            problem,
        ));
    }
    let db = st.db.clone();
    tokio::task::spawn_blocking(move || {
        let h = History::open(&db).map_err(|e| ApiError::of_history(&e))?;
        f(&h)
    })
    .await
    .map_err(|e| ApiError::internal(e.to_string()))?
}

/// The `Idempotency-Key` header, when there is one: 1 to 255 visible
/// ASCII characters.
pub fn idempotency_key(headers: &axum::http::HeaderMap) -> Result<Option<String>, ApiError> {
    headers
        .get("idempotency-key")
        .map(|v| {
            v.to_str()
                .ok()
                .filter(|k| !k.is_empty() && k.len() <= 255)
                .map(str::to_owned)
                .ok_or_else(|| ApiError::bad("Idempotency-Key: 1 to 255 visible ASCII characters"))
        })
        .transpose()
}

/// Serialises with serde_json's text writer, which keeps `1e999` for +∞.
pub fn json_text(v: &impl Serialize) -> Result<Response, ApiError> {
    let s = serde_json::to_string(v).map_err(|e| ApiError::internal(e.to_string()))?;
    Ok(([(header::CONTENT_TYPE, "application/json")], s).into_response())
}

/// A `limit` parameter: `default` when absent, else within 1..=`max`.
pub fn limit(given: Option<u32>, default: u32, max: u32) -> Result<u32, ApiError> {
    let limit = given.unwrap_or(default);
    if !(1..=max).contains(&limit) {
        return Err(ApiError::bad(format!(
            "limit: must be 1 to {max}, got {limit}"
        )));
    }
    Ok(limit)
}

/// 202 Accepted with `body`, and a `Location` header pointing at `url`.
pub fn accepted(body: impl Serialize, url: &str) -> Response {
    let mut r = (StatusCode::ACCEPTED, axum::Json(body)).into_response();
    if let Ok(v) = HeaderValue::from_str(url) {
        r.headers_mut().insert(header::LOCATION, v);
    }
    r
}
