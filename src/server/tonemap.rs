//! `POST /api/v1/tonemap`: an HDR file in (raw body or multipart), a PNG out
//! with the statistics in `X-Tonegate-*` headers, or JSON with the PNG inline.

use super::edge::ApiPath as Path;
use super::error::{ApiError, ErrorBody};
use super::queue::{JobParams, ToneOutput};
use super::AppState;
use crate::request::params::query_pairs;
use crate::request::tonemap::parse_params;
use crate::toning::ToneSettings;
use axum::body::Bytes;
use axum::extract::{RawQuery, Request, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use base64::Engine as _;
use std::sync::Arc;

/// Tone-map an HDR image.
#[utoipa::path(
    post,
    path = "/api/v1/tonemap",
    tag = "tonemap",
    params(
        ("gpu" = Option<bool>, Query, description = "Render on the GPU (default true) or with the CPU reference"),
        ("format" = Option<String>, Query, description = "png (default) or json (the PNG inline, base64)"),
        ("operator" = Option<String>, Query, description = "The operator (the served document lists every one the registry holds)"),
        ("preset" = Option<String>, Query, description = "reinhard02: pfstmo_reinhard02's global operator"),
        ("bloom" = Option<f64>, Query, description = "Bloom strength (0 = none); bloom_pass, bloom_threshold, bloom_downsample, bloom_radius, bloom_sigma refine it"),
        ("brightness" = Option<f64>, Query), ("contrast" = Option<f64>, Query), ("saturation" = Option<f64>, Query),
        ("gamma" = Option<f64>, Query, description = "Encode with 1/gamma instead of the sRGB OETF"),
        ("display" = Option<String>, Query, description = "sdr (default: 8-bit PNG), pq or hlg (16-bit BT.2100 PNG with cICP; mDCV and cLLI for pq), for an operator that maps onto a display of known peak (bt2390); refused with the reason otherwise"),
        ("sanitize" = Option<bool>, Query, description = "Set NaN/Inf to 0 instead of refusing the file"),
    ),
    request_body(content = Vec<u8>, description = "The .hdr, .exr or .pfm file (raw, or multipart/form-data with a file field; form fields are parameters too)",
        content_type = "application/octet-stream"),
    responses(
        (status = 200, description = "The tone-mapped image; statistics in X-Tonegate-* headers", content_type = "image/png"),
        (status = 400, description = "Unknown or bad parameter", body = super::error::ErrorBody),
        (status = 413, description = "Body or pixel count over the limit", body = super::error::ErrorBody),
        (status = 415, description = "Not an HDR format", body = super::error::ErrorBody),
        (status = 422, description = "Corrupt, truncated or non-finite image", body = super::error::ErrorBody),
        (status = 503, description = "Queue full or timed out (Retry-After), or no GPU adapter", body = super::error::ErrorBody),
    )
)]
pub async fn tonemap(
    State(st): State<Arc<AppState>>,
    RawQuery(q): RawQuery,
    req: Request,
) -> Result<Response, ApiError> {
    let started = std::time::Instant::now();
    let headers = req.headers().clone();
    let client = st.upload_client(req.extensions(), &headers);
    let mut pairs = query_pairs(q.as_deref()).map_err(ApiError::closing)?;
    let is_multipart = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("multipart/form-data"));
    // Refuse early what cannot be accepted anyway: the query's parameters
    // (all of them for a raw body), the declared length, and a server
    // receiving as many bodies as it may, before reading a byte of the
    // body. Such an answer leaves the body unread on the connection, so it
    // closes the connection.
    let limit = st.limits.max_body;
    let (extra, settings, resolved, mut upload) = (|| {
        st.authorize_read(&headers)?;
        let (extra, settings) = parse_params(pairs.clone(), &headers)?;
        // A multipart form may add the parameters that make these valid
        // (`key=auto` in the query, `operator=reinhard-auto-key` in the form).
        let resolved = if is_multipart {
            None
        } else {
            Some(settings.resolve().map_err(|e| ApiError::of_crate(&e))?)
        };
        if let Some(len) = headers
            .get(header::CONTENT_LENGTH)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.parse::<u64>().ok())
        {
            if len > limit as u64 {
                return Err(too_large_body(len, limit));
            }
        }
        Ok((extra, settings, resolved, st.uploads.begin_for(client)?))
    })()
    .map_err(ApiError::closing)?;
    let queue = if extra.gpu { &st.gpu } else { &st.cpu };
    let (timeout, max_pixels) = (st.limits.timeout, st.limits.max_pixels);
    // The body is read under the request's timeout, charged to the uploads'
    // budget as it arrives, holding no queue place.
    let read = tokio::time::timeout(timeout, async {
        if is_multipart {
            read_multipart(req, &mut pairs, upload, max_pixels).await
        } else {
            super::uploads::read_raw(req.into_body(), limit, Some(max_pixels), &mut upload).await
        }
    });
    // An upload still arriving when the server starts stopping is cut off.
    let read = async { read.await.map_err(|_| timed_out(timeout)).and_then(|r| r) };
    // A refusal while the body still arrives (too large from its header,
    // the uploads' budget) leaves the rest unread: the connection closes.
    let body = super::edge::unless_stopping(&st, read)
        .await
        .map_err(ApiError::closing)?;
    if body.is_empty() {
        return Err(ApiError::bad(
            "the body is empty: POST the .hdr, .exr or .pfm file, raw or as a multipart file field",
        ));
    }
    // With a form, the whole set of parameters is parsed again.
    let (extra, settings, resolved) = if let Some(resolved) = resolved {
        (extra, settings, resolved)
    } else {
        let (all, settings) = parse_params(pairs, &headers)?;
        if all.gpu != extra.gpu {
            return Err(ApiError::bad(
                "gpu: give it in the query string, not in the form",
            ));
        }
        let resolved = settings.resolve().map_err(|e| ApiError::of_crate(&e))?;
        (all, settings, resolved)
    };
    let params = JobParams {
        resolved,
        load: crate::io::LoadOptions {
            sanitize: extra.sanitize,
            max_pixels: st.limits.max_pixels,
            device: None,
        },
        source_name: "upload".into(),
    };
    // A place in the queue once the body is in; freed when the job ends.
    let permit = queue.reserve()?;
    let rx = queue.submit(permit, body, params)?;
    let left = timeout.saturating_sub(started.elapsed());
    let out = tokio::time::timeout(left, rx)
        .await
        .map_err(|_| timed_out(timeout))?
        .map_err(|_| ApiError::internal("the tone-map worker dropped the job"))??;
    Ok(respond(out, extra.json, &settings.in_effect()))
}

/// Writes the operators the registry holds (built-in and registered, with
/// their other names) into the served document's `operator` parameter of
/// `POST /tonemap`, so the OpenAPI text cannot drift from the registry.
pub fn describe_operators(doc: &mut utoipa::openapi::OpenApi) {
    use utoipa::openapi::RefOr;
    let names: Vec<String> = crate::operators::all()
        .iter()
        .map(|o| {
            let aliases = o.aliases();
            if aliases.is_empty() {
                o.name().to_owned()
            } else {
                format!("{} (also {})", o.name(), aliases.join(", "))
            }
        })
        .collect();
    let text = format!(
        "The operator, default reinhard-global: {}. GET /api/v1/operators lists each with its \
         parameters, which are parameters of this request too",
        names.join(", ")
    );
    let operation = doc
        .paths
        .paths
        .get_mut("/api/v1/tonemap")
        .and_then(|p| p.post.as_mut());
    for p in operation
        .and_then(|o| o.parameters.as_mut())
        .into_iter()
        .flatten()
    {
        if let RefOr::T(p) = p {
            if p.name == "operator" {
                p.description = Some(text.clone());
            }
        }
    }
}

fn too_large_body(len: u64, limit: usize) -> ApiError {
    ApiError::new(
        StatusCode::PAYLOAD_TOO_LARGE,
        "too_large",
        format!("the body is {len} bytes; the limit is {limit} bytes (serve --max-body-mib)"),
    )
}

fn timed_out(t: std::time::Duration) -> ApiError {
    ApiError::unavailable(
        "timeout",
        format!(
            "the request took longer than {} s (serve --timeout)",
            t.as_secs()
        ),
        t.as_secs(),
    )
}

/// The file field of a multipart body, under the server's body limit; its
/// text fields join the parameters.
async fn read_multipart(
    req: Request,
    pairs: &mut Vec<(String, String)>,
    mut upload: super::uploads::Upload,
    max_pixels: u64,
) -> Result<Bytes, ApiError> {
    let content_type = req
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_owned();
    // The limit DefaultBodyLimit sets, as axum's own Multipart applies it.
    let body = axum::RequestExt::with_limited_body(req).into_body();
    use crate::request::tonemap::BodyError;
    // Each chunk charged to the uploads' budget as it arrives; the place
    // is given back when multer drops the stream.
    let stream = futures_util::StreamExt::map(body.into_data_stream(), move |r| match r {
        Ok(chunk) => upload
            .charge(chunk.len())
            .map(|()| chunk)
            .map_err(|e| BodyError::Busy(e.detail)),
        Err(e) => {
            let over = std::error::Error::source(&e)
                .is_some_and(|s| s.is::<http_body_util::LengthLimitError>());
            Err(if over {
                BodyError::TooLarge
            } else {
                BodyError::Read(e.to_string())
            })
        }
    });
    crate::request::tonemap::read_multipart(stream, &content_type, pairs, max_pixels).await
}

fn respond(out: ToneOutput, json: bool, settings: &ToneSettings) -> Response {
    let report = &out.report;
    if json {
        /// `?json=1`'s answer: the tone-map's report as the command line
        /// writes it, the job's timings and the PNG in base64.
        #[derive(serde::Serialize)]
        struct Answer<'a> {
            width: u32,
            height: u32,
            #[serde(flatten)]
            report: crate::toning::FileReport<'a>,
            settings: &'a ToneSettings,
            render_ms: f64,
            queue_ms: f64,
            decode_ms: f64,
            tonemap_ms: f64,
            png_ms: f64,
            image: serde_json::Value,
        }
        let body = Answer {
            width: out.width,
            height: out.height,
            report: crate::toning::FileReport {
                input: &out.input,
                toned: report,
            },
            settings,
            render_ms: out.render_ms,
            queue_ms: out.queue_ms,
            decode_ms: out.decode_ms,
            tonemap_ms: out.tonemap_ms,
            png_ms: out.png_ms,
            image: serde_json::json!({
                "content_type": "image/png",
                "base64": base64::engine::general_purpose::STANDARD.encode(&out.png),
            }),
        };
        return axum::Json(body).into_response();
    }
    let mut headers = Vec::new();
    let mut put = |name: &str, v: String| headers.push((name.to_owned(), v));
    // JSON's rendering of a number, "none" where JSON has none (an infinite
    // white point: nothing burns).
    let num = |v: f64| match serde_json::Value::from(v) {
        serde_json::Value::Null => "none".to_string(),
        v => v.to_string(),
    };
    let (tone, input) = (&report.tone, &out.input);
    put("x-tonegate-adapter", report.adapter.clone());
    put("x-tonegate-size", format!("{}x{}", out.width, out.height));
    put("x-tonegate-plan", report.plan.join(","));
    // The operator and what it resolved for this image, one header each
    // (`x-tonegate-log-average` for `log_average`).
    put("x-tonegate-operator", tone.operator.to_owned());
    for (name, v) in &tone.values {
        put(&format!("x-tonegate-{}", name.replace('_', "-")), num(*v));
    }
    if let Some(hdr) = &report.hdr {
        put("x-tonegate-display", hdr.display.as_str().to_owned());
        put("x-tonegate-max-cll", num(hdr.max_cll));
        put("x-tonegate-max-fall", num(hdr.max_fall));
    }
    put("x-tonegate-min-luminance", num(input.min_luminance));
    put("x-tonegate-max-luminance", num(input.max_luminance));
    put(
        "x-tonegate-dynamic-range-stops",
        num(input.dynamic_range_stops),
    );
    put("x-tonegate-render-ms", format!("{:.3}", out.render_ms));
    put("x-tonegate-queue-ms", format!("{:.3}", out.queue_ms));
    put("x-tonegate-decode-ms", format!("{:.3}", out.decode_ms));
    put("x-tonegate-tonemap-ms", format!("{:.3}", out.tonemap_ms));
    put("x-tonegate-png-ms", format!("{:.3}", out.png_ms));
    let mut r = (
        [(header::CONTENT_TYPE, HeaderValue::from_static("image/png"))],
        out.png,
    )
        .into_response();
    for (name, v) in headers {
        if let (Ok(name), Ok(v)) = (
            axum::http::HeaderName::try_from(name),
            HeaderValue::from_str(&v),
        ) {
            r.headers_mut().insert(name, v);
        }
    }
    r
}

/// Every operator the server knows (built-in and registered), with its
/// parameters, their types, ranges and defaults: what the tone-map page
/// builds its form from, made from the operators' definitions.
#[utoipa::path(get, path = "/api/v1/operators", tag = "tonemap",
    responses((status = 200, description = "A JSON array: name, aliases, summary, resolves (the values a report gives), params (name, doc, type: number, number_or_auto, flag or word; range or words; default, null when measured; expected)")))]
pub async fn operators(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    Ok(axum::Json(crate::operators::describe()).into_response())
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

/// `POST /tonemap`'s operator parameters, one query parameter each, from
/// the operators' definitions (a registered operator's included).
pub(crate) struct OperatorParams;

impl utoipa::Modify for OperatorParams {
    fn modify(&self, doc: &mut utoipa::openapi::OpenApi) {
        use utoipa::openapi::path::{ParameterBuilder, ParameterIn};
        use utoipa::openapi::schema::{ObjectBuilder, Type};
        use utoipa::openapi::Required;
        let Some(item) = doc.paths.paths.get_mut("/api/v1/tonemap") else {
            return;
        };
        let Some(op) = item.post.as_mut() else { return };
        let params = op.parameters.get_or_insert_with(Vec::new);
        for (p, by) in crate::operators::all_params() {
            let ty = match p.kind.schema_type() {
                "number" => Type::Number,
                "boolean" => Type::Boolean,
                _ => Type::String,
            };
            params.push(
                ParameterBuilder::new()
                    .name(p.name)
                    .parameter_in(ParameterIn::Query)
                    .required(Required::False)
                    .description(Some(format!(
                        "{} ({}; {})",
                        p.doc,
                        by.join(", "),
                        p.expected()
                    )))
                    .schema(Some(ObjectBuilder::new().schema_type(ty)))
                    .build()
                    .into(),
            );
        }
    }
}
