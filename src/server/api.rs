//! The read and run endpoints under `/api/v1`: runs, artifacts, trends,
//! tradeoff points, health.

use super::edge::ApiPath as Path;
use super::error::{ApiError, ErrorBody};
use super::{AppState, RunSlot};
use crate::gate::StoredArtifacts;
use crate::history::{
    History, HistoryError, JobRow, JobSpec, RunKind, RunRow, RunStatus, RunnerRow, TradeoffRow,
    TrendFilter, TrendPoint,
};
use axum::body::Bytes;
use axum::extract::{RawQuery, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::Arc;
use utoipa::{IntoParams, ToSchema};

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

fn run_id(s: &str) -> Result<i64, ApiError> {
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
    let limit = q.limit.unwrap_or(100);
    if !(1..=1000).contains(&limit) {
        return Err(ApiError::bad(format!(
            "limit: must be 1 to 1000, got {limit}"
        )));
    }
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

/// What `POST /runs` may ask for.
#[derive(Deserialize, ToSchema, Default)]
#[serde(deny_unknown_fields)]
pub struct RunRequest {
    /// gpu (default) or cpu (the reference itself, to check the gate).
    pub renderer: Option<String>,
    /// Samples per pixel (default: each scene's goldens' spp). Not with a
    /// fleet's queue: its runners render at the scenes' defaults.
    pub spp: Option<u32>,
    /// With a shared (PostgreSQL) history: only a runner whose adapter name
    /// contains this (case-insensitive) takes the run.
    pub adapter: Option<String>,
    /// With a shared history: only a runner with this label takes the run.
    pub label: Option<String>,
    /// With a shared history: only these scenes of the suite.
    pub scenes: Option<Vec<String>>,
}

/// What a `POST /runs` body asks for, as a queued job (a shared history).
pub fn job_request(body: &[u8], suite: &std::path::Path) -> Result<JobSpec, ApiError> {
    let req = parse_run_request(body)?;
    if req.spp.is_some() {
        return Err(ApiError::bad(
            "spp: a queued run renders at the scenes' defaults; leave spp out",
        ));
    }
    let cpu = match req.renderer.as_deref() {
        None | Some("gpu") => false,
        Some("cpu") => true,
        Some(other) => {
            return Err(ApiError::bad(format!(
                "renderer: expected gpu or cpu, got {}",
                super::error::clip(other)
            )))
        }
    };
    if let Some(l) = req
        .label
        .as_deref()
        .filter(|l| !crate::history::valid_label(l))
    {
        return Err(ApiError::bad(format!(
            "label: use letters, digits, '-', '_', '.' or ':' (at most 64), got {}",
            super::error::clip(l)
        )));
    }
    if let Some(a) = req
        .adapter
        .as_deref()
        .filter(|a| a.is_empty() || a.len() > 200)
    {
        return Err(ApiError::bad(format!(
            "adapter: a name substring of 1 to 200 characters, got {:?}",
            super::error::clip(a)
        )));
    }
    let scenes = req.scenes.unwrap_or_default();
    if scenes.len() > 1000 || scenes.iter().any(|s| s.is_empty() || s.len() > 200) {
        return Err(ApiError::bad(
            "scenes: at most 1000 names of 1 to 200 characters",
        ));
    }
    Ok(JobSpec {
        suite: suite.display().to_string(),
        scenes,
        cpu,
        adapter: req.adapter,
        label: req.label,
    })
}

fn parse_run_request(body: &[u8]) -> Result<RunRequest, ApiError> {
    if body.iter().all(|b| b.is_ascii_whitespace()) {
        Ok(RunRequest::default())
    } else {
        serde_json::from_slice(body).map_err(|e| ApiError::bad(format!("body: {e}")))
    }
}

/// What a `POST /runs` body asks for, checked: empty means the defaults.
pub fn run_request(
    body: &[u8],
    adapter: &crate::gpu::AdapterChoice,
    config: crate::gpu::GpuConfig,
) -> Result<crate::gate::Renderer, ApiError> {
    let req = parse_run_request(body)?;
    if req.adapter.is_some() || req.label.is_some() || req.scenes.is_some() {
        return Err(ApiError::bad(
            "adapter, label and scenes select a fleet's runner; this server's history is a SQLite file, so its runs are its own (serve --db postgres://... queues them)",
        ));
    }
    let spp = match req.spp {
        None => None,
        Some(n @ 1..=256) => Some(n),
        Some(n) => return Err(ApiError::bad(format!("spp: must be 1 to 256, got {n}"))),
    };
    Ok(match req.renderer.as_deref() {
        None | Some("gpu") => crate::gate::Renderer::Gpu {
            adapter: adapter.clone(),
            config,
            spp,
        },
        Some("cpu") => crate::gate::Renderer::Cpu { spp },
        Some(other) => {
            return Err(ApiError::bad(format!(
                "renderer: expected gpu or cpu, got {}",
                super::error::clip(other)
            )))
        }
    })
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
        (status = 503, description = "The history cannot be written (the detail names the file and folder)", body = ErrorBody)))]
pub async fn post_run(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    body: Bytes,
) -> Result<Response, ApiError> {
    st.authorize_write(&headers)?;
    if crate::history::is_url(&st.db.to_string_lossy()) {
        return queue_run(&st, &body).await;
    }
    let renderer = run_request(&body, &st.adapter, st.gpu_config)?;
    if let Some(problem) = st.history_problem().await {
        return Err(ApiError::unavailable("history_read_only", problem, 60));
    }
    let id = super::start_run(st.clone(), renderer).await?;
    let body = RunStarted {
        id,
        status: RunStatus::Running,
        url: format!("/api/v1/runs/{id}"),
    };
    let mut r = (StatusCode::ACCEPTED, axum::Json(body)).into_response();
    if let Ok(v) = HeaderValue::from_str(&format!("/api/v1/runs/{id}")) {
        r.headers_mut().insert(header::LOCATION, v);
    }
    Ok(r)
}

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
async fn queue_run(st: &Arc<AppState>, body: &[u8]) -> Result<Response, ApiError> {
    let spec = job_request(body, &st.suite)?;
    let db = st.db.clone();
    let job = tokio::task::spawn_blocking(move || History::open(&db)?.enqueue(&spec))
        .await
        .map_err(|e| ApiError::internal(e.to_string()))?
        .map_err(|e| match e {
            HistoryError::Invalid(d) => ApiError::bad(d),
            e => ApiError::of_history(&e),
        })?;
    let url = format!("/api/v1/queue?job={job}");
    let mut r = (
        StatusCode::ACCEPTED,
        axum::Json(RunQueued {
            job,
            status: "queued".into(),
            url: url.clone(),
        }),
    )
        .into_response();
    if let Ok(v) = HeaderValue::from_str(&url) {
        r.headers_mut().insert(header::LOCATION, v);
    }
    Ok(r)
}

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
}

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
    let limit = q.limit.unwrap_or(100);
    if !(1..=1000).contains(&limit) {
        return Err(ApiError::bad(format!(
            "limit: must be 1 to 1000, got {limit}"
        )));
    }
    if let Some(s) = q.state.as_deref() {
        if !["queued", "claimed", "done", "aborted"].contains(&s) {
            return Err(ApiError::bad(format!(
                "state: expected queued, claimed, done or aborted, got {}",
                super::error::clip(s)
            )));
        }
    }
    let (state, job) = (q.state, q.job);
    let out = read(st.as_ref(), move |h| {
        let jobs = h.jobs(
            state.as_deref(),
            if job.is_some() { 1_000_000 } else { limit },
        )?;
        let jobs = jobs
            .into_iter()
            .filter(|j| job.is_none_or(|id| j.id == id))
            .collect();
        Ok(Queue {
            counts: h.job_counts()?.into_iter().collect(),
            jobs,
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

/// Whether `name` can be an artifact's file name: letters, digits, '-', '_'
/// and '.', not starting with '.', ending in .png. Everything else (slashes,
/// "..", encoded separators, NUL) is refused before the file system is asked.
pub fn valid_artifact_name(name: &str) -> bool {
    name.len() <= 200
        && name.ends_with(".png")
        && !name.starts_with('.')
        && !name.contains("..")
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.'))
}

/// One artifact image of a run (golden, actual, diff or SSIM map).
#[utoipa::path(get, path = "/api/v1/runs/{id}/artifacts/{name}", tag = "runs",
    params(("id" = i64, Path), ("name" = String, Path, description = "<scene>-<frame>-<adapter>-<kind>.png")),
    responses((status = 200, description = "OK", content_type = "image/png"), (status = 400, description = "Unknown or bad parameter", body = ErrorBody), (status = 404, description = "Not found", body = ErrorBody)))]
pub async fn get_artifact(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    Path((id, name)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let id = run_id(&id)?;
    if !valid_artifact_name(&name) {
        return Err(ApiError::bad(format!(
            "artifact name {} is not a file name of this run (letters, digits, '-', '_', '.', ending .png)",
            super::error::clip(&name)
        )));
    }
    let wanted = name.clone();
    let (report, stored) =
        read(&st, move |h| Ok((h.report(id)?, h.artifact(id, &wanted)?))).await?;
    // Only files the run's report lists are served: from the history's
    // content-addressed store, or (runs recorded before it) from the folder
    // the report names.
    let listed = report
        .as_deref()
        .and_then(StoredArtifacts::of_report)
        .unwrap_or_default();
    let (dir, listed) = (listed.artifacts_dir, listed.artifacts);
    if !listed.iter().any(|a| a == &name) {
        return Err(ApiError::not_found(format!(
            "run {id} has no artifact {name:?}"
        )));
    }
    let bytes = match stored {
        Some(bytes) => bytes,
        None => {
            let dir = dir
                .or_else(|| crate::gate::artifacts_dir_of(&st.db, id))
                .ok_or_else(|| ApiError::not_found(format!("run {id} kept no artifact folder")))?;
            tokio::fs::read(dir.join(&name))
                .await
                .map_err(|e| ApiError::not_found(format!("artifact {name:?} of run {id}: {e}")))?
        }
    };
    Ok((
        [
            (header::CONTENT_TYPE, "image/png"),
            (header::CACHE_CONTROL, "public, max-age=86400, immutable"),
        ],
        bytes,
    )
        .into_response())
}

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct TrendsQuery {
    /// One scene (default: every scene).
    scene: Option<String>,
    /// psnr (default), ssim, snr, mse, rmse, max_abs_diff, mean_abs_diff, fraction_over_1lsb, flip_mean, fps, or a stage name (median ms).
    metric: Option<String>,
    /// Exact adapter name.
    adapter: Option<String>,
    /// Newest runs (default 200, at most 5000).
    limit: Option<u32>,
}

/// One metric per scene over check runs, oldest first; regressions marked.
#[utoipa::path(get, path = "/api/v1/trends", tag = "runs", params(TrendsQuery),
    responses((status = 200, description = "OK", body = Vec<TrendPoint>), (status = 400, description = "Unknown or bad parameter", body = ErrorBody)))]
pub async fn trends(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: TrendsQuery = query(q)?;
    let limit = q.limit.unwrap_or(200);
    if !(1..=5000).contains(&limit) {
        return Err(ApiError::bad(format!(
            "limit: must be 1 to 5000, got {limit}"
        )));
    }
    let metric = q.metric.unwrap_or_else(|| "psnr".into());
    if !crate::gate::is_recorded_metric(&metric) {
        return Err(ApiError::bad(format!(
            "metric: unknown metric {metric:?}; use {}",
            crate::gate::recorded_metrics().join(", ")
        )));
    }
    let points = read(&st, move |h| {
        h.trend(
            &metric,
            &TrendFilter {
                scene: q.scene.as_deref(),
                adapter: q.adapter.as_deref(),
                limit,
                ..Default::default()
            },
        )
    })
    .await?;
    json_text(&points)
}

/// Serialises with serde_json's text writer, which keeps `1e999` for +∞.
fn json_text(v: &impl Serialize) -> Result<Response, ApiError> {
    let s = serde_json::to_string(v).map_err(|e| ApiError::internal(e.to_string()))?;
    Ok(([(header::CONTENT_TYPE, "application/json")], s).into_response())
}

#[derive(Serialize, ToSchema)]
pub struct TradeoffResponse {
    pub run: RunRow,
    /// Every configuration measured; `scene` "suite" is the aggregate.
    pub points: Vec<TradeoffRow>,
}

/// The error-against-run-time points of a tradeoff run, Pareto front marked.
#[utoipa::path(get, path = "/api/v1/tradeoff/{run}", tag = "runs",
    params(("run" = i64, Path, description = "A tradeoff run's id")),
    responses((status = 200, description = "OK", body = TradeoffResponse), (status = 404, description = "Not found", body = ErrorBody)))]
pub async fn tradeoff(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    Path(run): Path<String>,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let id = run_id(&run)?;
    let (row, points) = read(&st, move |h| Ok((h.run(id)?, h.tradeoff_points(id)?))).await?;
    let row = row.ok_or_else(|| ApiError::not_found(format!("there is no run {id}")))?;
    if row.kind != RunKind::Tradeoff {
        return Err(ApiError::not_found(format!(
            "run {id} is a {} run, not a tradeoff run",
            row.kind
        )));
    }
    json_text(&TradeoffResponse { run: row, points })
}

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

/// A built-in environment as a Radiance .hdr (512×256), so the tone-map page
/// can be tried without a file of one's own.
#[utoipa::path(get, path = "/api/v1/samples/{name}", tag = "tonemap",
    params(("name" = String, Path, description = "sky.hdr, interior.hdr, night.hdr or grid.hdr")),
    responses((status = 200, description = "OK", content_type = "image/vnd.radiance"), (status = 404, description = "Not found", body = ErrorBody)))]
pub async fn sample(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    Path(name): Path<String>,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let env = name
        .strip_suffix(".hdr")
        .and_then(crate::env::BuiltinEnv::from_name)
        .ok_or_else(|| {
            ApiError::not_found(format!(
                "no sample {}: sky.hdr, interior.hdr, night.hdr or grid.hdr",
                super::error::clip(&name)
            ))
        })?;
    let bytes = tokio::task::spawn_blocking(move || {
        let img = env.generate(512, 256);
        let mut out = Vec::new();
        crate::io::radiance::encode(&mut out, &img).map(|_| out)
    })
    .await
    .map_err(|e| ApiError::internal(e.to_string()))?
    .map_err(|e| ApiError::internal(e.to_string()))?;
    Ok((
        [
            (header::CONTENT_TYPE, "image/vnd.radiance"),
            (header::CACHE_CONTROL, "public, max-age=86400"),
        ],
        bytes,
    )
        .into_response())
}
