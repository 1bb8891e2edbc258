//! `/api/v1/matrix`: scene × adapter over the newest check run of each
//! adapter, the view a driver or engine team opens first.

use super::error::{ApiError, ErrorBody};
use super::params::{json_text, limit, query, read};
use super::AppState;
use crate::history::matrix::Matrix;
use axum::extract::{RawQuery, State};
use axum::http::HeaderMap;
use axum::response::Response;
use serde::Deserialize;
use std::sync::Arc;
use utoipa::IntoParams;

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct MatrixQuery {
    /// Adapters (columns), the most recently run first (default 50, at most 500).
    limit: Option<u32>,
}

/// For the newest finished check run of each (adapter, backend): every
/// scene's verdict, worst PSNR and FLIP, FPS, and whether the adapter
/// flushes subnormals; `split` lists the scenes that pass on one adapter
/// and fail on another.
#[utoipa::path(get, path = "/api/v1/matrix", tag = "runs", params(MatrixQuery),
    responses((status = 200, description = "OK", body = Matrix), (status = 400, description = "Unknown or bad parameter", body = ErrorBody)))]
pub async fn matrix(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: MatrixQuery = query(q)?;
    let limit = limit(q.limit, 50, 500)?;
    let m = read(&st, move |h| h.matrix(limit)).await?;
    json_text(&m)
}
