//! `/api/v1/queue` and `/api/v1/runners`: a shared history's jobs and the
//! runners that take them.

use super::error::{ApiError, ErrorBody};
use super::params::{limit, query, read};
use super::AppState;
use crate::history::{JobRow, RunnerRow};
use axum::extract::{RawQuery, State};
use axum::http::HeaderMap;
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::Arc;
use utoipa::{IntoParams, ToSchema};

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct QueueQuery {
    /// queued, claimed, done or aborted.
    state: Option<String>,
    /// One job.
    job: Option<i64>,
    /// Newest jobs returned (default 100, at most 1000).
    limit: Option<u32>,
}

/// The fleet's queue: jobs, newest first, and how many are in each state.
#[derive(Serialize, ToSchema)]
pub struct Queue {
    pub counts: BTreeMap<String, i64>,
    pub jobs: Vec<JobRow>,
    /// Fewer jobs than asked for: the listing reached its 1 MiB bound (ask
    /// again with a smaller `limit`, or by `state` or `job`).
    pub truncated: bool,
}

/// The most bytes of jobs one listing carries: each job shows at most
/// `LISTED_SCENES` names of 200 characters, and the listing stops here.
pub const MAX_LISTING_BYTES: usize = 1 << 20;

/// The fleet's queue (a shared history's jobs; empty on a SQLite one).
#[utoipa::path(get, path = "/api/v1/queue", tag = "fleet", params(QueueQuery),
    responses((status = 200, description = "OK", body = Queue), (status = 400, description = "Unknown or bad parameter", body = ErrorBody)))]
pub async fn queue(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: QueueQuery = query(q)?;
    let limit = limit(q.limit, 100, 1000)?;
    if let Some(s) = q.state.as_deref() {
        if !["queued", "claimed", "done", "aborted"].contains(&s) {
            return Err(ApiError::bad(format!(
                "state: expected queued, claimed, done or aborted, got {}",
                super::error::clip(s)
            )));
        }
    }
    if let Some(id) = q.job.filter(|id| *id < 1) {
        return Err(ApiError::bad(format!(
            "job: a job id is 1 or more, got {id}"
        )));
    }
    let (state, job) = (q.state, q.job);
    let out = read(st.as_ref(), move |h| {
        let jobs = match job {
            Some(id) => h
                .job(id)?
                .into_iter()
                .filter(|j| state.as_deref().is_none_or(|s| j.state == s))
                .collect(),
            None => h.jobs(state.as_deref(), limit)?,
        };
        // Newest first until the listing's bytes are spent.
        let mut listed = Vec::with_capacity(jobs.len());
        let mut bytes = 0;
        let mut truncated = false;
        for j in jobs {
            bytes += serde_json::to_vec(&j).map_or(0, |v| v.len());
            if bytes > MAX_LISTING_BYTES && !listed.is_empty() {
                truncated = true;
                break;
            }
            listed.push(j);
        }
        Ok(Queue {
            counts: h.job_counts()?.into_iter().collect(),
            jobs: listed,
            truncated,
        })
    })
    .await?;
    Ok(axum::Json(out).into_response())
}

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct RunnersQuery {
    /// Stopped and lost runners too (default: only live ones).
    all: Option<bool>,
}

/// The fleet's runners: adapter, labels, last heartbeat, current job.
#[utoipa::path(get, path = "/api/v1/runners", tag = "fleet", params(RunnersQuery),
    responses((status = 200, description = "OK", body = Vec<RunnerRow>), (status = 400, description = "Unknown or bad parameter", body = ErrorBody)))]
pub async fn runners(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: RunnersQuery = query(q)?;
    let all = q.all.unwrap_or(false);
    let out = read(st.as_ref(), move |h| h.runners(all)).await?;
    Ok(axum::Json(out).into_response())
}
