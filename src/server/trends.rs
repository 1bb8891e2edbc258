//! `/api/v1/trends` and `/api/v1/tradeoff/{run}`: a metric over runs, and
//! a tradeoff run's error against run time.

use super::edge::ApiPath as Path;
use super::error::{ApiError, ErrorBody};
use super::params::{json_text, limit, query, read, run_id};
use super::AppState;
use crate::history::{RunKind, RunRow, TradeoffRow, TrendFilter, TrendPoint};
use axum::extract::{RawQuery, State};
use axum::http::HeaderMap;
use axum::response::Response;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use utoipa::{IntoParams, ToSchema};

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct TrendsQuery {
    /// One scene (default: every scene).
    scene: Option<String>,
    /// psnr (default), ssim, snr, mse, rmse, max_abs_diff, mean_abs_diff, fraction_over_1lsb, flip_mean, fps, or a stage name (median ms).
    metric: Option<String>,
    /// A substring of the adapter name, any case (as `/runs` takes it).
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
    let limit = limit(q.limit, 200, 5000)?;
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
                adapter_contains: q.adapter.as_deref(),
                limit,
                ..Default::default()
            },
        )
    })
    .await?;
    json_text(&points)
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
