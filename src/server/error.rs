//! The API's errors: a status, a stable machine-readable code and a sentence
//! for people, always as JSON `{ "error": code, "detail": … }`.

pub use crate::request::error::{clip, ApiError, HISTORY_RETRY_AFTER_S, MAX_DETAIL};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use utoipa::ToSchema;

/// The body of every error answer.
#[derive(Serialize, ToSchema)]
pub struct ErrorBody {
    /// Stable code: bad_parameter, unauthorized, forbidden, not_found,
    /// method_not_allowed, conflict, too_large, uri_too_long,
    /// headers_too_large, unsupported_media_type, bad_image, busy, timeout,
    /// history_read_only, history_unavailable, artifact_store_unavailable,
    /// queue_full, shutting_down, no_adapter, gpu_error, internal.
    pub error: String,
    /// What was wrong and where, for a person.
    pub detail: String,
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = ErrorBody {
            error: self.code.into(),
            detail: self.detail,
        };
        let mut r = (self.status, axum::Json(body)).into_response();
        if let Some(s) = self.retry_after {
            r.headers_mut()
                .insert(header::RETRY_AFTER, HeaderValue::from(s));
        }
        if self.close {
            r.headers_mut()
                .insert(header::CONNECTION, HeaderValue::from_static("close"));
        }
        if self.status == StatusCode::UNAUTHORIZED {
            r.headers_mut().insert(
                header::WWW_AUTHENTICATE,
                HeaderValue::from_static("Bearer realm=\"tonegate\""),
            );
        }
        r
    }
}
