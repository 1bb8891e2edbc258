//! `GET /api/v1/alerts`: the alerts raised, newest first, with each
//! delivery's state and every attempt (docs/alerts.md).

use super::error::{ApiError, ErrorBody};
use super::params::{json_text, limit, query, read};
use super::AppState;
use crate::history::AlertRow;
use axum::extract::{RawQuery, State};
use axum::http::HeaderMap;
use axum::response::Response;
use serde::Deserialize;
use std::sync::Arc;
use utoipa::IntoParams;

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct AlertsQuery {
    /// Newest alerts returned (default 100, at most 1000).
    limit: Option<u32>,
}

/// The alerts, newest first, with their deliveries.
#[utoipa::path(get, path = "/api/v1/alerts", tag = "alerts", params(AlertsQuery),
    responses((status = 200, description = "OK", body = Vec<AlertRow>), (status = 400, description = "Bad parameter", body = ErrorBody)))]
pub async fn alerts(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: AlertsQuery = query(q)?;
    let limit = limit(q.limit, 100, 1000)?;
    json_text(&read(&st, move |h| h.alerts(limit)).await?)
}
