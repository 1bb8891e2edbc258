//! `/api/v1/runs`: the run list, one run, and starting a run (on this
//! server, or queued for a fleet's runners).

use super::edge::{declared_too_large, read_body, ApiPath as Path};
use super::error::{ApiError, ErrorBody};
use super::params::{accepted, limit, query, read, renderer_is_cpu, run_id};
use super::AppState;
use crate::history::{History, HistoryError, JobSpec, RunKind, RunRow, RunStatus};
use crate::request::runs::{parse_run_request, RunRequest};
use axum::extract::{RawQuery, State};
use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use utoipa::{IntoParams, ToSchema};

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct RunsQuery {
    /// passed, failed, error, aborted or running.
    status: Option<RunStatus>,
    /// check or tradeoff.
    kind: Option<RunKind>,
    /// A substring of the adapter name, any case.
    adapter: Option<String>,
    /// Newest runs returned (default 100, at most 1000).
    limit: Option<u32>,
}

/// The run list, newest first.
#[utoipa::path(get, path = "/api/v1/runs", tag = "runs", params(RunsQuery),
    responses((status = 200, description = "OK", body = Vec<RunRow>), (status = 400, description = "Unknown or bad parameter", body = ErrorBody)))]
pub async fn list_runs(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: RunsQuery = query(q)?;
    let limit = limit(q.limit, 100, 1000)?;
    let rows = read(&st, move |h| {
        h.runs_where(&crate::history::RunsFilter {
            status: q.status,
            kind: q.kind,
            adapter: q.adapter.as_deref(),
            limit,
        })
    })
    .await?;
    Ok(axum::Json(rows).into_response())
}

/// How a run looks in `GET /runs/{id}` (documentation of the shape).
#[derive(Serialize, ToSchema)]
pub struct RunDetail {
    pub run: RunRow,
    /// The full report of a finished run: scenes, per-frame metrics, checks,
    /// timings, regressions, artifacts. Null while the run is going or when
    /// it ended in an error (see `run.detail`). Infinite PSNR is `1e999`.
    #[schema(value_type = Option<Object>)]
    pub report: Option<serde_json::Value>,
}

/// One run: status, per-frame metrics, timings and checks.
#[utoipa::path(get, path = "/api/v1/runs/{id}", tag = "runs",
    params(("id" = i64, Path, description = "Run id")),
    responses((status = 200, description = "OK", body = RunDetail), (status = 404, description = "Not found", body = ErrorBody)))]
pub async fn get_run(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let id = run_id(&id)?;
    let (row, report) = read(&st, move |h| Ok((h.run(id)?, h.report(id)?))).await?;
    let row = row.ok_or_else(|| ApiError::not_found(format!("there is no run {id}")))?;
    // The stored report is served as stored: it may hold 1e999 (infinite
    // PSNR), which serde_json's Value cannot hold but JSON.parse reads.
    let run = serde_json::to_string(&row).map_err(|e| ApiError::internal(e.to_string()))?;
    let body = format!(
        "{{\"run\":{run},\"report\":{}}}",
        report.as_deref().unwrap_or("null")
    );
    Ok(([(header::CONTENT_TYPE, "application/json")], body).into_response())
}

/// What a `POST /runs` body asks for, as a queued job (a shared history).
pub fn job_request(body: &[u8], suite: &std::path::Path) -> Result<JobSpec, ApiError> {
    let req = parse_run_request(body)?;
    if req.spp.is_some() {
        return Err(ApiError::bad(
            "spp: a queued run renders at the scenes' defaults; leave spp out",
        ));
    }
    let cpu = renderer_is_cpu(req.renderer.as_deref())?;
    let scenes = req.scenes.unwrap_or_default();
    let spec = JobSpec {
        suite: suite.display().to_string(),
        scenes,
        cpu,
        adapter: req.adapter,
        label: req.label,
    };
    spec.check().map_err(ApiError::bad)?;
    Ok(spec)
}

/// Checks a job's scenes against the server's own suite, now rather than in
/// a runner later (an unknown name was queued, 202, and became an `error`
/// run). Reads files: call it off the async workers.
fn check_queued_scenes(spec: &JobSpec, suite: &std::path::Path) -> Result<(), ApiError> {
    let known = crate::suite::load_suite_file(suite)
        .map_err(|e| ApiError::internal(format!("the server's suite {}: {e}", suite.display())))?;
    if !spec.scenes.is_empty() {
        known
            .select(&spec.scenes)
            .map_err(|m| ApiError::bad(format!("scenes: {m}")))?;
    }
    Ok(())
}

/// What a `POST /runs` body asks for, checked: empty means the defaults.
pub fn run_request(
    body: &[u8],
    adapter: &crate::gpu::AdapterChoice,
    config: crate::gpu::GpuConfig,
) -> Result<(crate::render::Renderer, Option<u32>), ApiError> {
    let own = crate::request::runs::own_run(body)?;
    let renderer = match own.cpu {
        true => crate::render::Renderer::Cpu,
        false => crate::render::Renderer::Gpu {
            adapter: adapter.clone(),
            config,
        },
    };
    Ok((renderer, own.spp))
}

#[derive(Serialize, ToSchema)]
pub struct RunStarted {
    pub id: i64,
    pub status: RunStatus,
    /// Where to follow it.
    pub url: String,
}

/// Start a run of the server's suite in the background (needs the token).
#[utoipa::path(post, path = "/api/v1/runs", tag = "runs",
    request_body(content = Option<RunRequest>, content_type = "application/json"),
    security(("bearer" = [])),
    responses((status = 202, description = "Started", body = RunStarted), (status = 400, description = "Unknown or bad parameter", body = ErrorBody),
        (status = 401, description = "No bearer token", body = ErrorBody), (status = 403, description = "Wrong bearer token", body = ErrorBody),
        (status = 409, description = "A run is already going", body = ErrorBody),
        (status = 503, description = "The history cannot be written (the detail names the file and folder), is unreachable, or the fleet's queue is full", body = ErrorBody)))]
pub async fn post_run(
    State(st): State<Arc<AppState>>,
    req: axum::extract::Request,
) -> Result<Response, ApiError> {
    // The token and the declared length first: a refused request has
    // nothing of its body read (and no `100 Continue`).
    st.authorize_write(req.headers())
        .map_err(ApiError::closing)?;
    declared_too_large(req.headers(), RUN_BODY_LIMIT)?;
    let key = super::params::idempotency_key(req.headers())?;
    let body = read_body(&st, req.into_body(), RUN_BODY_LIMIT, RUN_BODY_TIMEOUT).await?;
    if crate::history::is_url(&st.db.to_string_lossy()) {
        return queue_run(&st, &body, key).await;
    }
    let (renderer, spp) = run_request(&body, &st.adapter, st.gpu_config)?;
    if let Some(problem) = st.history_problem().await {
        return Err(ApiError::unavailable("history_read_only", problem, 60));
    }
    let id = super::start_run(st.clone(), renderer, spp).await?;
    let url = format!("/api/v1/runs/{id}");
    let body = RunStarted {
        id,
        status: RunStatus::Running,
        url: url.clone(),
    };
    Ok(accepted(body, &url))
}

/// The largest `POST /runs` body: a selector of 1000 scene names of 200
/// characters (the most `JobSpec::check` allows) with room to spare.
pub const RUN_BODY_LIMIT: usize = 256 << 10;

/// How long a `POST /runs` body may take to arrive.
pub const RUN_BODY_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(10);

/// What `POST /runs` answers when it queued the run for the fleet.
#[derive(Serialize, ToSchema)]
pub struct RunQueued {
    pub job: i64,
    /// Always `queued`.
    pub status: String,
    /// Where to follow it.
    pub url: String,
}

/// Queues a check run of the server's suite for the fleet's runners.
async fn queue_run(
    st: &Arc<AppState>,
    body: &[u8],
    key: Option<String>,
) -> Result<Response, ApiError> {
    let spec = job_request(body, &st.suite)?;
    let db = st.db.clone();
    let suite = st.suite.clone();
    let most = st.limits.max_queued_jobs;
    let job = tokio::task::spawn_blocking(move || {
        check_queued_scenes(&spec, &suite)?;
        History::open(&db)
            .and_then(|h| h.enqueue_keyed(&spec, most, key.as_deref()))
            .map_err(|e| match e {
                HistoryError::Invalid(d) => ApiError::bad(d),
                e @ HistoryError::QueueFull { .. } => {
                    ApiError::unavailable("queue_full", e.to_string(), 30)
                }
                e => ApiError::of_history(&e),
            })
    })
    .await
    .map_err(|e| ApiError::internal(e.to_string()))??;
    let url = format!("/api/v1/queue?job={job}");
    let body = RunQueued {
        job,
        status: "queued".into(),
        url: url.clone(),
    };
    Ok(accepted(body, &url))
}
