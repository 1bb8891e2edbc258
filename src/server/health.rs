//! `/healthz` and `/api/v1/healthz`: liveness and readiness.

use super::error::{ApiError, ErrorBody};
use super::params::read;
use super::{AppState, RunSlot};
use axum::extract::State;
use axum::http::HeaderMap;
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use std::sync::Arc;
use utoipa::ToSchema;

#[derive(Serialize, ToSchema)]
pub struct QueueHealth {
    pub depth: usize,
    pub capacity: usize,
}

/// What `healthz` says. Under `--private-reads`, a request without the
/// token sees `status` and `version` only: a liveness probe needs no token,
/// and learns nothing about the runs.
#[derive(Serialize, ToSchema)]
pub struct Health {
    pub status: String,
    pub version: String,
    #[serde(flatten)]
    pub detail: Option<HealthDetail>,
}

#[derive(Serialize, ToSchema)]
pub struct HealthDetail {
    pub schema_version: i64,
    pub runs: i64,
    /// The run going now, if any.
    pub active_run: Option<i64>,
    /// Whether runs can be recorded; when not, why (and `POST /runs` says so too).
    pub history_writable: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub history_problem: Option<String>,
    pub gpu_queue: QueueHealth,
    pub cpu_queue: QueueHealth,
}

/// Liveness and readiness: the history answers, the queues' depths.
#[utoipa::path(get, path = "/api/v1/healthz", tag = "service",
    responses((status = 200, description = "OK", body = Health), (status = 503, description = "Unavailable", body = ErrorBody)))]
pub async fn healthz(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let (schema, runs) = read(&st, |h| {
        Ok((
            h.schema_version()?,
            h.status_counts()?.iter().map(|(_, n)| n).sum::<i64>(),
        ))
    })
    .await
    .map_err(|e| ApiError::unavailable("unhealthy", e.detail, 5))?;
    let active = match *st.slot.lock().unwrap_or_else(|p| p.into_inner()) {
        RunSlot::Running(id) => Some(id),
        _ => None,
    };
    let problem = st.history_problem().await;
    let detail = st.may_read(&headers).then(|| HealthDetail {
        schema_version: schema,
        runs,
        active_run: active,
        history_writable: problem.is_none(),
        history_problem: problem,
        gpu_queue: QueueHealth {
            depth: st.gpu.depth(),
            capacity: st.gpu.capacity(),
        },
        cpu_queue: QueueHealth {
            depth: st.cpu.depth(),
            capacity: st.cpu.capacity(),
        },
    });
    Ok(axum::Json(Health {
        status: "ok".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        detail,
    })
    .into_response())
}
