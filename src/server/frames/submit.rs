//! `POST /api/v1/frames/submissions`: a multipart form of images, each a
//! part named `file` whose file name is its test's path (`ui/button.png`),
//! with `key` parts (`name=value`) and an optional `rules` part (the rules
//! file's TOML). Everything is received and checked before anything is
//! judged or stored: too many files, a name that is not a plain relative
//! path, two images of one test, a body over the limit — each refused with
//! the part it is about, and nothing stored.

use super::super::error::{ApiError, ErrorBody};
use super::super::{AppState, Scope};
use crate::frames::rules::Rules;
use crate::frames::{parse_keys, test_of_upload, FramesError, Input, Source, MAX_FRAMES};
use crate::request::tonemap::BodyError;
use axum::extract::{Request, State};
use axum::http::{header, StatusCode};
use axum::response::Response;
use std::collections::BTreeMap;
use std::sync::Arc;

/// The form, received.
struct Form {
    inputs: Vec<Input>,
    keys: Vec<String>,
    rules: Option<String>,
}

/// Answers a frames error: the image it names, 400 (422 for an image that
/// does not decode, as `POST /tonemap` answers one).
fn frames_error(e: FramesError) -> ApiError {
    match e {
        FramesError::History(h) => ApiError::of_history(&h),
        FramesError::Image(i) => {
            ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, "bad_image", i.to_string())
        }
        e @ FramesError::OverBudget { .. } => {
            ApiError::new(StatusCode::PAYLOAD_TOO_LARGE, "too_large", e.to_string())
        }
        FramesError::Busy { seconds } => {
            ApiError::unavailable("busy", FramesError::Busy { seconds }.to_string(), seconds)
        }
        e @ FramesError::KeyReused { .. } => ApiError::new(
            StatusCode::CONFLICT,
            "idempotency_key_reused",
            e.to_string(),
        ),
        other => ApiError::bad(other.to_string()),
    }
}

async fn read_form<S>(body: S, content_type: &str) -> Result<Form, ApiError>
where
    S: futures_util::Stream<Item = Result<axum::body::Bytes, BodyError>> + Send + 'static,
{
    let boundary = multer::parse_boundary(content_type).map_err(|_| {
        ApiError::bad(
            "the body is a multipart/form-data form: a `file` part an image, `key` parts, a `rules` part",
        )
    })?;
    let mut mp = multer::Multipart::new(body, boundary);
    let mut form = Form {
        inputs: Vec::new(),
        keys: Vec::new(),
        rules: None,
    };
    let mut tests: BTreeMap<String, String> = BTreeMap::new();
    while let Some(mut field) = mp
        .next_field()
        .await
        .map_err(|e| crate::request::tonemap::multipart_error(&e))?
    {
        let name = field.name().unwrap_or("").to_owned();
        match (name.as_str(), field.file_name().map(str::to_owned)) {
            ("file", Some(file)) => {
                if form.inputs.len() >= MAX_FRAMES {
                    return Err(ApiError::bad(format!(
                        "more than {MAX_FRAMES} files: a submission takes at most {MAX_FRAMES}"
                    )));
                }
                let test = test_of_upload(&file).map_err(frames_error)?;
                if let Some(first) = tests.insert(test.clone(), file.clone()) {
                    return Err(frames_error(FramesError::Duplicate {
                        test,
                        first,
                        second: file,
                    }));
                }
                let mut bytes = Vec::new();
                while let Some(chunk) = field
                    .chunk()
                    .await
                    .map_err(|e| crate::request::tonemap::multipart_error(&e))?
                {
                    bytes.extend_from_slice(&chunk);
                }
                if bytes.is_empty() {
                    return Err(ApiError::bad(format!("{file}: an empty file")));
                }
                form.inputs.push(Input {
                    test,
                    file,
                    source: Source::Bytes(bytes),
                });
            }
            ("file", None) => {
                // A file name that is there but not UTF-8 is said as such.
                let named = field
                    .headers()
                    .get(header::CONTENT_DISPOSITION)
                    .is_some_and(|v| {
                        v.as_bytes()
                            .windows(9)
                            .any(|w| w.eq_ignore_ascii_case(b"filename="))
                    });
                return Err(ApiError::bad(if named {
                    "a `file` part whose file name is not UTF-8 text: name it by the test's path (ui/button.png)"
                } else {
                    "a `file` part without a file name: its name is the test's path (ui/button.png)"
                }));
            }
            (_, Some(_)) => {
                return Err(ApiError::bad(format!(
                    "a file in the part named {}: images go in parts named \"file\"",
                    super::super::error::clip(&name)
                )))
            }
            ("key", None) => {
                // Refused as they come, before a 40 MB value or the
                // 20,000th key is read whole.
                let most = crate::frames::MAX_KEYS;
                if form.keys.len() == most {
                    return Err(ApiError::bad(format!("more than {most} `key` parts")));
                }
                let longest = crate::frames::MAX_KEY_NAME + 1 + crate::frames::MAX_KEY_VALUE;
                let text = bounded_text(field, longest, "a `key` part").await?;
                form.keys.push(text);
            }
            ("rules", None) => {
                if form.rules.is_some() {
                    return Err(ApiError::bad("two `rules` parts"));
                }
                let most = crate::io::MAX_SMALL_FILE_BYTES as usize;
                form.rules = Some(bounded_text(field, most, "the `rules` part").await?);
            }
            (other, None) => {
                return Err(ApiError::bad(format!(
                    "an unknown part {}: the form takes `file`, `key` and `rules`",
                    super::super::error::clip(other)
                )))
            }
        }
    }
    if form.inputs.is_empty() {
        return Err(ApiError::bad(
            "no images: send each as a `file` part named by its test's path (ui/button.png)",
        ));
    }
    Ok(form)
}

/// Submits frames: judged against their tests' positives and rules, and
/// stored (each image once) in one transaction. The answer is the report
/// `frames submit --json` writes; a retry with the same `Idempotency-Key`
/// stores nothing and answers the first's report.
#[utoipa::path(post, path = "/api/v1/frames/submissions", tag = "frames",
    request_body(content_type = "multipart/form-data", description = "`file` parts (the file name is the test's path: ui/button.png), `key` parts (name=value), an optional `rules` part (TOML)"),
    params(("Idempotency-Key" = Option<String>, Header, description = "A retry with the same key stores nothing and answers the first's report")),
    security(("bearer" = [])),
    responses((status = 200, description = "Judged and stored: the report (`passed` says whether the gate passed)", body = Object),
        (status = 400, description = "A bad form, name, key or rules (nothing stored)", body = ErrorBody),
        (status = 401, description = "No token", body = ErrorBody), (status = 403, description = "Not a submit token", body = ErrorBody),
        (status = 413, description = "Over the body limit", body = ErrorBody),
        (status = 422, description = "An image that does not decode (nothing stored)", body = ErrorBody)))]
pub async fn submit(State(st): State<Arc<AppState>>, req: Request) -> Result<Response, ApiError> {
    let headers = req.headers().clone();
    let limit = st.limits.max_body;
    let client = st.upload_client(req.extensions(), &headers);
    let mut upload = (|| {
        st.authorize(&headers, Scope::Submit)?;
        super::super::edge::declared_too_large(&headers, limit)?;
        st.uploads.begin_for(client)
    })()
    .map_err(ApiError::closing)?;
    let idempotency_key = super::super::params::idempotency_key(&headers)?;
    let content_type = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_owned();
    // The whole form is received before it is parsed (the images are all
    // held for judging anyway): a refusal is then answered to a client
    // that is listening, not one still writing into a closed connection.
    let timeout = st.limits.timeout;
    let read = async {
        tokio::time::timeout(timeout, async {
            let got =
                super::super::uploads::read_raw(req.into_body(), limit, None, &mut upload).await?;
            let whole = futures_util::stream::once(async move { Ok::<_, BodyError>(got) });
            read_form(whole, &content_type).await
        })
        .await
        .map_err(|_| {
            ApiError::new(
                StatusCode::REQUEST_TIMEOUT,
                "timeout",
                format!("the form took over {} s to arrive", timeout.as_secs()),
            )
        })
        .and_then(|r| r)
    };
    let form = super::super::edge::unless_stopping(&st, read)
        .await
        .map_err(ApiError::closing)?;
    let rules = match &form.rules {
        None => Rules::default(),
        Some(text) => Rules::parse(text, "the rules part").map_err(ApiError::bad)?,
    };
    let keys = parse_keys(&form.keys).map_err(frames_error)?;
    let report = super::super::params::write_with(&st, move |h| {
        crate::frames::submit(
            h,
            crate::frames::Submission {
                inputs: form.inputs,
                keys,
                idempotency_key: idempotency_key.as_deref(),
                rules: &rules,
                compare: None,
            },
        )
        .map_err(frames_error)
    })
    .await?;
    super::super::params::json_text(&report)
}

/// A text part of at most `most` bytes, read a chunk at a time and refused
/// as soon as it is longer.
async fn bounded_text(
    mut field: multer::Field<'_>,
    most: usize,
    what: &str,
) -> Result<String, ApiError> {
    let mut bytes = Vec::new();
    while let Some(chunk) = field
        .chunk()
        .await
        .map_err(|e| crate::request::tonemap::multipart_error(&e))?
    {
        if bytes.len() + chunk.len() > most {
            return Err(ApiError::bad(format!("{what} is longer than {most} bytes")));
        }
        bytes.extend_from_slice(&chunk);
    }
    String::from_utf8(bytes).map_err(|_| ApiError::bad(format!("{what} is not UTF-8 text")))
}
