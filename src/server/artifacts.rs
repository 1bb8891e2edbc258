//! `/api/v1/runs/{id}/artifacts/{name}`: the images a run kept.

use super::edge::ApiPath as Path;
use super::error::{ApiError, ErrorBody};
use super::params::{read, run_id};
use super::AppState;
use crate::gate::StoredArtifacts;
use crate::history::{Objects, StoredArtifact};
use axum::extract::State;
use axum::http::{header, HeaderMap};
use axum::response::{IntoResponse, Response};
use std::sync::Arc;

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
    responses((status = 200, description = "OK", content_type = "image/png"), (status = 400, description = "Unknown or bad parameter", body = ErrorBody), (status = 404, description = "Not found", body = ErrorBody), (status = 503, description = "The artifact store (or the history) does not answer; Retry-After says when to try again", body = ErrorBody)))]
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
    let headers = [
        (header::CONTENT_TYPE, "image/png"),
        (header::CACHE_CONTROL, "public, max-age=86400, immutable"),
    ];
    let bytes = match stored {
        Some(StoredArtifact::Bytes(bytes)) => bytes,
        Some(StoredArtifact::Object { store, sha256, .. }) => {
            // Streamed from the store as it arrives: a large image is never
            // held whole here.
            let objects = Objects::open(&store).map_err(|e| ApiError::of_history(&e))?;
            let (size, stream) = objects
                .get(&sha256)
                .await
                .map_err(|e| ApiError::of_history(&e))?
                .ok_or_else(|| {
                    ApiError::not_found(format!(
                        "artifact {name:?} of run {id}: the store {store} has no {sha256}.png"
                    ))
                })?;
            let body = axum::body::Body::from_stream(stream);
            return Ok(
                (headers, [(header::CONTENT_LENGTH, size.to_string())], body).into_response(),
            );
        }
        None => {
            let dir = dir
                .or_else(|| crate::gate::artifacts_dir_of(&st.db, id))
                .ok_or_else(|| ApiError::not_found(format!("run {id} kept no artifact folder")))?;
            tokio::fs::read(dir.join(&name))
                .await
                .map_err(|e| ApiError::not_found(format!("artifact {name:?} of run {id}: {e}")))?
        }
    };
    Ok((headers, bytes).into_response())
}
