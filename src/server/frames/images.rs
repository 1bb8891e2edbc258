//! The images of the triage page: a stored image for display, and the
//! difference, SSIM and FLIP maps of one image against another. An 8-bit
//! PNG is served as stored; a 16-bit PQ PNG or an HDR file is tone-mapped
//! for display with the operator the page chose (PQ light divided by
//! 203 cd/m², BT.2408's reference white, so that white is 1.0 as an
//! operator expects). Maps of two PNG frames are the check's own (of the
//! 8-bit codes, or of the PQ frames: HDR-FLIP of their light); of two HDR
//! files the difference and SSIM are of the display images and the FLIP
//! map is HDR-FLIP's.

use super::super::error::{ApiError, ErrorBody};
use super::super::params::{query, read};
use super::super::AppState;
use crate::frames::{decode_bytes, Decoded};
use crate::image::{Frame, HdrImage, Rgb8Image};
use crate::metrics::frames::{frame_diff_heatmap, frame_flip, frame_ssim, pq16_light};
use crate::metrics::{diff_heatmap, ssim_map_image};
use axum::extract::{RawQuery, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;
use std::sync::Arc;
use utoipa::IntoParams;

/// BT.2408's HDR reference white, cd/m²: PQ light over it is what an
/// operator takes as scene light (1.0 white).
const REFERENCE_WHITE: f32 = 203.0;

/// The operator HDR images are shown with unless the page asks.
const DEFAULT_OPERATOR: &str = crate::operators::AGX;

fn digest(s: &str) -> Result<String, ApiError> {
    if s.len() == 64 && s.bytes().all(|b| b.is_ascii_hexdigit()) {
        Ok(s.to_ascii_lowercase())
    } else {
        Err(ApiError::bad(format!(
            "digest: 64 hex digits (the SHA-256 a submission reports), got {}",
            super::super::error::clip(s)
        )))
    }
}

async fn bytes_of(st: &AppState, d: String) -> Result<Vec<u8>, ApiError> {
    let shown = d.clone();
    read(st, move |h| h.blob(&d))
        .await?
        .ok_or_else(|| ApiError::not_found(format!("there is no image {shown}")))
}

fn tone(img: &HdrImage, operator: &str) -> Result<Rgb8Image, ApiError> {
    let settings = crate::toning::ToneSettings::for_operator(operator, &[]);
    let resolved = settings.resolve().map_err(|e| ApiError::of_crate(&e))?;
    let toned = crate::toning::tone_map(
        img,
        &resolved.pipeline(),
        None,
        crate::toning::OutputKind::Encoded,
    )
    .map_err(|e| ApiError::of_crate(&e))?;
    toned
        .image
        .encoded()
        .cloned()
        .ok_or_else(|| ApiError::internal("the tone-map made no 8-bit image"))
}

fn decoded(bytes: &[u8], name: &str) -> Result<Decoded, ApiError> {
    decode_bytes(bytes, name, crate::frames::rules::DEFAULT_ALPHA)
        .map_err(|e| ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, "bad_image", e.to_string()))
}

/// What a person is shown of an image.
fn display(image: &Decoded, operator: &str) -> Result<Rgb8Image, ApiError> {
    match image {
        Decoded::Frame(Frame::Rgb8(f)) => Ok(f.clone()),
        Decoded::Frame(Frame::Pq16(f)) => {
            let light = pq16_light(f).map(|p| p.map(|c| c / REFERENCE_WHITE));
            tone(&light, operator)
        }
        Decoded::Hdr(img) => tone(img, operator),
    }
}

fn png(img: &Rgb8Image) -> Result<Response, ApiError> {
    let bytes = crate::io::encode_png8(img).map_err(|e| ApiError::internal(e.to_string()))?;
    Ok(png_bytes(bytes))
}

fn png_bytes(bytes: Vec<u8>) -> Response {
    (
        [
            (header::CONTENT_TYPE, "image/png"),
            // A digest's image never changes.
            (header::CACHE_CONTROL, "public, max-age=31536000, immutable"),
        ],
        bytes,
    )
        .into_response()
}

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct ImageQuery {
    /// The operator a PQ PNG or an HDR file is tone-mapped with for
    /// display (default agx; GET /api/v1/operators lists them).
    operator: Option<String>,
}

/// A stored image as a PNG to look at.
#[utoipa::path(get, path = "/api/v1/frames/images/{digest}", tag = "frames", params(ImageQuery,
    ("digest" = String, Path, description = "The image's SHA-256")),
    responses((status = 200, description = "PNG", content_type = "image/png"), (status = 404, description = "No such image", body = ErrorBody)))]
pub async fn image(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    super::Path(d): super::Path<String>,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: ImageQuery = query(q)?;
    let d = digest(&d)?;
    let bytes = bytes_of(&st, d.clone()).await?;
    let operator = q.operator.unwrap_or_else(|| DEFAULT_OPERATOR.into());
    tokio::task::spawn_blocking(move || {
        let image = decoded(&bytes, &d)?;
        if let Decoded::Frame(Frame::Rgb8(_)) = image {
            return Ok(png_bytes(bytes));
        }
        png(&display(&image, &operator)?)
    })
    .await
    .map_err(|e| ApiError::internal(e.to_string()))?
}

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct CompareQuery {
    /// diff (the largest channel difference, as a heat map), ssim (grey:
    /// white is identical) or flip (magma: FLIP, or HDR-FLIP for HDR).
    map: String,
    /// The operator HDR images are shown with (default agx).
    operator: Option<String>,
}

/// A map of one stored image against another (the frame, then the
/// positive it is held to).
#[utoipa::path(get, path = "/api/v1/frames/compare/{digest}/{against}", tag = "frames", params(CompareQuery,
    ("digest" = String, Path, description = "The frame's SHA-256"),
    ("against" = String, Path, description = "The positive's SHA-256")),
    responses((status = 200, description = "PNG", content_type = "image/png"), (status = 400, description = "Bad parameter, or images that cannot be compared", body = ErrorBody),
        (status = 404, description = "No such image", body = ErrorBody)))]
pub async fn compare(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    super::Path((a, b)): super::Path<(String, String)>,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: CompareQuery = query(q)?;
    if !["diff", "ssim", "flip"].contains(&q.map.as_str()) {
        return Err(ApiError::bad(format!(
            "map: diff, ssim or flip, got {}",
            super::super::error::clip(&q.map)
        )));
    }
    let (a, b) = (digest(&a)?, digest(&b)?);
    let ours = bytes_of(&st, a.clone()).await?;
    let theirs = bytes_of(&st, b.clone()).await?;
    let operator = q.operator.unwrap_or_else(|| DEFAULT_OPERATOR.into());
    tokio::task::spawn_blocking(move || {
        let (x, y) = (decoded(&ours, &a)?, decoded(&theirs, &b)?);
        let bad = |e: crate::metrics::MetricsError| ApiError::bad(format!("{a} against {b}: {e}"));
        let map = match (&x, &y) {
            (Decoded::Frame(f), Decoded::Frame(g)) => match q.map.as_str() {
                "diff" => frame_diff_heatmap(f, g).map_err(bad)?,
                "ssim" => ssim_map_image(&frame_ssim(f, g).map_err(bad)?),
                _ => frame_flip(f, g).map_err(bad)?.magma_image(),
            },
            (Decoded::Hdr(f), Decoded::Hdr(g)) => match q.map.as_str() {
                "flip" => {
                    let opts = crate::metrics::hdr::HdrOptions::default();
                    crate::metrics::hdr::compare_hdr(f, g, &opts)
                        .map_err(bad)?
                        .flip
                        .magma_image()
                }
                kind => {
                    let (f, g) = (display(&x, &operator)?, display(&y, &operator)?);
                    if kind == "diff" {
                        diff_heatmap(f.raster(), g.raster()).map_err(bad)?
                    } else {
                        ssim_map_image(&crate::metrics::ssim(f.raster(), g.raster()).map_err(bad)?)
                    }
                }
            },
            _ => {
                return Err(ApiError::bad(format!(
                    "{a} against {b}: one is a PNG frame and the other an HDR file"
                )))
            }
        };
        png(&map)
    })
    .await
    .map_err(|e| ApiError::internal(e.to_string()))?
}
