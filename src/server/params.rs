//! What every endpoint parses the same way: query strings (unknown or bad
//! parameters refused by name), parameter names, run ids, limits, the
//! renderer; the history read off the async threads; JSON and 202 answers.

use super::error::ApiError;
use super::AppState;
use crate::history::{History, HistoryError};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Parses a query string, answering 400 with the parameter's name when it is unknown or bad.
pub fn query<T: DeserializeOwned>(q: Option<String>) -> Result<T, ApiError> {
    from_pairs(q.as_deref().unwrap_or("").as_bytes())
}

/// Deserialises urlencoded pairs; a bad value's error names its parameter.
pub fn from_pairs<T: DeserializeOwned>(encoded: &[u8]) -> Result<T, ApiError> {
    check_names(form_urlencoded::parse(encoded).map(|(k, _)| k))?;
    let de = serde_urlencoded::Deserializer::new(form_urlencoded::parse(encoded));
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        if path == "." || path.is_empty() {
            ApiError::bad(format!("query: {}", e.inner()))
        } else {
            ApiError::bad(format!("{path}: {}", e.inner()))
        }
    })
}

/// The longest parameter name anyone means: longer ones are refused without
/// being echoed back whole.
pub const MAX_NAME: usize = 64;

/// Refuses parameter names longer than [`MAX_NAME`].
pub fn check_names<S: AsRef<str>>(names: impl IntoIterator<Item = S>) -> Result<(), ApiError> {
    for name in names {
        let name = name.as_ref();
        if name.chars().count() > MAX_NAME {
            return Err(ApiError::bad(format!(
                "a parameter name of {}; names are at most {MAX_NAME} characters",
                super::error::clip(name)
            )));
        }
    }
    Ok(())
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

/// A `renderer` parameter: gpu (the default) or cpu, as whether it is the CPU.
pub fn renderer_is_cpu(given: Option<&str>) -> Result<bool, ApiError> {
    match given {
        None | Some("gpu") => Ok(false),
        Some("cpu") => Ok(true),
        Some(other) => Err(ApiError::bad(format!(
            "renderer: expected gpu or cpu, got {}",
            super::error::clip(other)
        ))),
    }
}

/// 202 Accepted with `body`, and a `Location` header pointing at `url`.
pub fn accepted(body: impl Serialize, url: &str) -> Response {
    let mut r = (StatusCode::ACCEPTED, axum::Json(body)).into_response();
    if let Ok(v) = HeaderValue::from_str(url) {
        r.headers_mut().insert(header::LOCATION, v);
    }
    r
}
