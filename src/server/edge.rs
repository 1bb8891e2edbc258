//! The edge of the API, where requests that reach no handler are answered:
//! unknown paths and methods, over-long targets and heads, paths that do not
//! decode. Every answer here is the same JSON error as the handlers give.

use super::error::{clip, ApiError};
use axum::extract::{FromRequestParts, Request};
use axum::http::request::Parts;
use axum::http::StatusCode;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use serde::de::DeserializeOwned;

/// Longest request target (path and query) answered; longer is 414.
pub const MAX_TARGET_BYTES: usize = 8 << 10;
/// Most header bytes (names, values, separators) answered; more is 431.
pub const MAX_HEADER_BYTES: usize = 32 << 10;
/// Most header fields answered; more is 431.
pub const MAX_HEADER_FIELDS: usize = 100;

pub async fn not_found(uri: axum::http::Uri) -> ApiError {
    ApiError::not_found(format!(
        "no endpoint {}; see /api/v1/openapi.json",
        clip(uri.path())
    ))
}

pub async fn method_not_allowed(method: axum::http::Method, uri: axum::http::Uri) -> ApiError {
    ApiError::new(
        StatusCode::METHOD_NOT_ALLOWED,
        "method_not_allowed",
        format!(
            "{} does not take {}; see /api/v1/openapi.json",
            clip(uri.path()),
            clip(method.as_str())
        ),
    )
}

/// Middleware: refuses over-long targets (414) and heads (431) in JSON,
/// well below the HTTP layer's own buffer (`listen::MAX_HEAD_BYTES`), whose
/// answers past it have no body.
pub async fn head_limits(req: Request, next: Next) -> Response {
    let target = req.uri().path_and_query().map_or(0, |p| p.as_str().len());
    if target > MAX_TARGET_BYTES {
        return ApiError::new(
            StatusCode::URI_TOO_LONG,
            "uri_too_long",
            format!("the request target is {target} bytes; the limit is {MAX_TARGET_BYTES}"),
        )
        .closing()
        .into_response();
    }
    let fields = req.headers().len();
    let bytes: usize = req
        .headers()
        .iter()
        .map(|(k, v)| k.as_str().len() + v.len() + 4)
        .sum();
    if fields > MAX_HEADER_FIELDS || bytes > MAX_HEADER_BYTES {
        return ApiError::new(
            StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
            "headers_too_large",
            format!(
                "the request has {fields} header fields in {bytes} bytes; the limits are \
                 {MAX_HEADER_FIELDS} fields and {MAX_HEADER_BYTES} bytes"
            ),
        )
        .closing()
        .into_response();
    }
    next.run(req).await
}

/// `axum::extract::Path` whose refusals (a segment that is not UTF-8 once
/// percent-decoded, a value of the wrong type) are JSON errors naming the path.
pub struct ApiPath<T>(pub T);

impl<T, S> FromRequestParts<S> for ApiPath<T>
where
    T: DeserializeOwned + Send,
    S: Send + Sync,
{
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, ApiError> {
        match axum::extract::Path::<T>::from_request_parts(parts, state).await {
            Ok(axum::extract::Path(t)) => Ok(ApiPath(t)),
            Err(e) => Err(ApiError::bad(format!(
                "the path {}: {}",
                clip(parts.uri.path()),
                e.body_text()
            ))),
        }
    }
}

/// Reads a request's body after the request was accepted (the token and
/// the declared length checked first, so nothing is read, and no
/// `100 Continue` sent, for a request that is refused): at most `limit`
/// bytes, within `timeout`, and given up at once when the server starts
/// stopping, so a stalled upload holds neither memory past the limit nor a
/// shutdown. Every refusal closes the connection (the rest of the body is
/// still coming).
pub async fn read_body(
    st: &super::AppState,
    body: axum::body::Body,
    limit: usize,
    timeout: std::time::Duration,
) -> Result<axum::body::Bytes, ApiError> {
    let read = async {
        match tokio::time::timeout(timeout, axum::body::to_bytes(body, limit)).await {
            Ok(Ok(bytes)) => Ok(bytes),
            Ok(Err(e)) => Err(body_error(&e, limit, "")),
            Err(_) => Err(ApiError::new(
                StatusCode::REQUEST_TIMEOUT,
                "timeout",
                format!("the body did not arrive within {} s", timeout.as_secs_f64()),
            )),
        }
    };
    unless_stopping(st, read).await
}

/// Reads a body with `read`, cut off (503 `shutting_down`) when the server
/// starts stopping; any refusal closes the connection, as the rest of the
/// body may still be coming.
pub async fn unless_stopping<T>(
    st: &super::AppState,
    read: impl std::future::Future<Output = Result<T, ApiError>>,
) -> Result<T, ApiError> {
    let mut closing = st.closing.subscribe();
    let out = tokio::select! {
        r = read => r,
        _ = closing.wait_for(|c| *c) => Err(stopping()),
    };
    out.map_err(ApiError::closing)
}

/// The answer to a request cut off by the server's shutdown.
pub fn stopping() -> ApiError {
    ApiError::unavailable(
        "shutting_down",
        "the server is stopping; send the request again to it or another",
        5,
    )
}

/// A declared length over `limit` (413, before reading).
pub fn declared_too_large(headers: &axum::http::HeaderMap, limit: usize) -> Result<(), ApiError> {
    let declared = headers
        .get(axum::http::header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<u64>().ok());
    match declared {
        Some(len) if len > limit as u64 => Err(ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "too_large",
            format!("the body is {len} bytes; the limit is {limit} bytes"),
        )
        .closing()),
        _ => Ok(()),
    }
}

/// How reading a body failed: over the limit is 413 (`flag` says how to
/// raise it, if one does), anything else 400.
pub fn body_error(e: &axum::Error, limit: usize, flag: &str) -> ApiError {
    let text = e.to_string();
    if text.contains("length limit") {
        ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "too_large",
            format!("the body is over the limit of {limit} bytes{flag}"),
        )
    } else {
        ApiError::bad(format!("reading the body: {text}"))
    }
}
