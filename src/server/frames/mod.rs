//! `/api/v1/frames`: a renderer's own frames through the gate
//! (docs/frames.md, docs/api.md): submissions (under the submit scope),
//! triage, promotion and ignore rules (under the triage scope), and the
//! reads the dashboard's triage page is made of — the submissions, the
//! digests of a test, the log, the images and their comparison maps.

mod images;
mod submit;

pub use images::{__path_compare, __path_image, compare, image};
pub use submit::{__path_submit, submit};

use super::edge::{declared_too_large, read_body, ApiPath as Path};
use super::error::{ApiError, ErrorBody};
use super::params::{json_text, limit, query, read, write};
use super::{AppState, Scope};
use crate::history::{Label, SubmissionRow, SubmittedFrame, TriageEntry, MAIN};
use axum::extract::{RawQuery, Request, State};
use axum::http::HeaderMap;
use axum::response::Response;
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use std::sync::Arc;
use std::time::Duration;
use utoipa::{IntoParams, ToSchema};

/// The largest JSON body a triage request may have.
const JSON_LIMIT: usize = 1 << 20;
/// The most digests one triage request labels.
pub const MAX_ACTIONS: usize = 4096;

/// A submission's id from the path.
fn submission_id(s: &str) -> Result<i64, ApiError> {
    s.parse::<i64>().ok().filter(|&v| v > 0).ok_or_else(|| {
        ApiError::bad(format!(
            "submission id: expected a positive integer, got {}",
            super::error::clip(s)
        ))
    })
}

/// A JSON body of at most [`JSON_LIMIT`] bytes, unknown fields refused
/// by name.
async fn json_body<T: DeserializeOwned>(st: &AppState, req: Request) -> Result<T, ApiError> {
    declared_too_large(req.headers(), JSON_LIMIT)?;
    let body = read_body(st, req.into_body(), JSON_LIMIT, Duration::from_secs(30)).await?;
    let de = &mut serde_json::Deserializer::from_slice(&body);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let at = e.path().to_string();
        ApiError::bad(format!("body: {at}: {}", e.inner()))
    })
}

/// A person's name and reason, as every triage action needs.
fn said(who: &str, why: &str) -> Result<(), ApiError> {
    for (name, v) in [("who", who), ("why", why)] {
        if v.trim().is_empty() || v.len() > 1000 {
            return Err(ApiError::bad(format!("{name}: 1 to 1000 characters")));
        }
    }
    Ok(())
}

/// The history's name of a branch: the main line is `""`.
fn branch_key(branch: Option<&str>, main: &str) -> String {
    branch
        .filter(|b| *b != main && !b.is_empty())
        .unwrap_or(MAIN)
        .to_owned()
}

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct ListQuery {
    /// Newest submissions returned (default 50, at most 1000).
    limit: Option<u32>,
    /// Only those older than this submission id: the next page, from the
    /// last id of the one before.
    before: Option<i64>,
}

/// The submissions, newest first.
#[utoipa::path(get, path = "/api/v1/frames/submissions", tag = "frames", params(ListQuery),
    responses((status = 200, description = "OK", body = Vec<SubmissionRow>), (status = 400, description = "Bad parameter", body = ErrorBody)))]
pub async fn list(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: ListQuery = query(q)?;
    let limit = limit(q.limit, 50, 1000)?;
    let before = q.before.unwrap_or(i64::MAX);
    let rows = read(&st, move |h| h.submissions_before(before, limit)).await?;
    // Newest first until the listing's bytes are spent, as the queue's.
    let (mut listed, mut bytes, mut truncated) = (Vec::with_capacity(rows.len()), 0, false);
    for r in rows {
        bytes += serde_json::to_vec(&r).map_or(0, |v| v.len());
        if bytes > super::fleet::MAX_LISTING_BYTES && !listed.is_empty() {
            truncated = true;
            break;
        }
        listed.push(r);
    }
    let mut answer = json_text(&listed)?;
    if truncated {
        answer.headers_mut().insert(
            "x-tonegate-truncated",
            axum::http::HeaderValue::from_static("true"),
        );
    }
    Ok(answer)
}

/// One submission: its row, the report it answered, and its frames as
/// stored.
#[derive(Serialize, ToSchema)]
pub struct SubmissionDetail {
    pub submission: SubmissionRow,
    /// The report `submit` answered (docs/frames.md#report).
    #[schema(value_type = Object)]
    pub report: serde_json::Value,
    pub frames: Vec<SubmittedFrame>,
}

/// One submission.
#[utoipa::path(get, path = "/api/v1/frames/submissions/{id}", tag = "frames",
    params(("id" = i64, Path, description = "Submission id")),
    responses((status = 200, description = "OK", body = SubmissionDetail), (status = 404, description = "Not found", body = ErrorBody)))]
pub async fn get(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let id = submission_id(&id)?;
    let (found, frames) = read(&st, move |h| {
        Ok((h.submission(id)?, h.submission_frames(id, None)?))
    })
    .await?;
    let (submission, report) =
        found.ok_or_else(|| ApiError::not_found(format!("there is no submission {id}")))?;
    json_text(&SubmissionDetail {
        submission,
        report: serde_json::from_str(&report).unwrap_or_default(),
        frames,
    })
}

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct DigestsQuery {
    /// The test.
    test: String,
    /// The branch (its labels over the main line's); the main line when
    /// left out.
    branch: Option<String>,
    /// The main branch's name (default "main").
    main_branch: Option<String>,
}

/// A digest of a test and what people said of it.
#[derive(Serialize, ToSchema)]
pub struct DigestLabel {
    pub digest: String,
    /// positive, negative or untriaged.
    pub label: Label,
}

/// Every digest a test has had, with its label on the branch.
#[utoipa::path(get, path = "/api/v1/frames/digests", tag = "frames", params(DigestsQuery),
    responses((status = 200, description = "OK", body = Vec<DigestLabel>), (status = 400, description = "Bad parameter", body = ErrorBody)))]
pub async fn digests(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: DigestsQuery = query(q)?;
    let main = q.main_branch.as_deref().unwrap_or("main");
    let branch = branch_key(q.branch.as_deref(), main);
    let labels = read(&st, move |h| h.digest_labels(&branch, &q.test)).await?;
    json_text(
        &labels
            .into_iter()
            .map(|(digest, label)| DigestLabel { digest, label })
            .collect::<Vec<_>>(),
    )
}

#[derive(Deserialize, IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct LogQuery {
    /// Only this test's actions.
    test: Option<String>,
}

/// The triage actions, oldest first: who said what of which digest, why.
#[utoipa::path(get, path = "/api/v1/frames/log", tag = "frames", params(LogQuery),
    responses((status = 200, description = "OK", body = Vec<Object>), (status = 400, description = "Bad parameter", body = ErrorBody)))]
pub async fn log(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
    RawQuery(q): RawQuery,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    let q: LogQuery = query(q)?;
    let entries: Vec<TriageEntry> = read(&st, move |h| h.triage_log(q.test.as_deref())).await?;
    json_text(&entries)
}

/// One digest to label.
#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Action {
    pub test: String,
    pub digest: String,
    pub label: Label,
}

/// `POST /frames/triage`: digests to label together, all or none.
#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TriageBody {
    /// The branch the labels are on; the main line when left out or when
    /// it is `main_branch`.
    #[serde(default)]
    pub branch: Option<String>,
    /// The main branch's name (default "main").
    #[serde(default)]
    pub main_branch: Option<String>,
    pub who: String,
    pub why: String,
    pub actions: Vec<Action>,
}

/// What a triage request did.
#[derive(Serialize, ToSchema)]
pub struct Triaged {
    /// How many digests were labelled.
    pub labelled: usize,
    /// The branch they were labelled on (`""` the main line).
    pub branch: String,
}

/// Labels digests positive, negative or untriaged, each logged with who
/// and why; all of them or, when one cannot be, none.
#[utoipa::path(post, path = "/api/v1/frames/triage", tag = "frames", request_body = TriageBody,
    security(("bearer" = [])),
    responses((status = 200, description = "Labelled", body = Triaged), (status = 400, description = "Bad body, or a digest its test never had", body = ErrorBody),
        (status = 401, description = "No token", body = ErrorBody), (status = 403, description = "Not a triage token", body = ErrorBody)))]
pub async fn triage(State(st): State<Arc<AppState>>, req: Request) -> Result<Response, ApiError> {
    st.authorize(req.headers(), Scope::Triage)?;
    let b: TriageBody = json_body(&st, req).await?;
    said(&b.who, &b.why)?;
    if b.actions.is_empty() || b.actions.len() > MAX_ACTIONS {
        return Err(ApiError::bad(format!(
            "actions: 1 to {MAX_ACTIONS} digests a request, got {}",
            b.actions.len()
        )));
    }
    let branch = branch_key(
        b.branch.as_deref(),
        b.main_branch.as_deref().unwrap_or("main"),
    );
    let n = b.actions.len();
    let on = branch.clone();
    write(&st, move |h| {
        let actions: Vec<(&str, &str, Label)> = b
            .actions
            .iter()
            .map(|a| (a.test.as_str(), a.digest.as_str(), a.label))
            .collect();
        h.triage_many(&on, &actions, (&b.who, &b.why))
    })
    .await?;
    json_text(&Triaged {
        labelled: n,
        branch,
    })
}

/// `POST /frames/submissions/{id}/triage`: every digest of one submission
/// with the given verdicts, labelled together.
#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct BulkBody {
    pub label: Label,
    pub who: String,
    pub why: String,
    /// The frames' verdicts to take (default: untriaged only).
    #[serde(default)]
    pub verdicts: Option<Vec<String>>,
}

/// Bulk triage: labels every digest of a submission (by default, those it
/// left untriaged: everything a single change produced), on its branch.
#[utoipa::path(post, path = "/api/v1/frames/submissions/{id}/triage", tag = "frames", request_body = BulkBody,
    params(("id" = i64, Path, description = "Submission id")), security(("bearer" = [])),
    responses((status = 200, description = "Labelled", body = BulkTriaged), (status = 400, description = "Bad body", body = ErrorBody),
        (status = 403, description = "Not a triage token", body = ErrorBody), (status = 404, description = "No such submission", body = ErrorBody)))]
pub async fn bulk(
    State(st): State<Arc<AppState>>,
    Path(id): Path<String>,
    req: Request,
) -> Result<Response, ApiError> {
    st.authorize(req.headers(), Scope::Triage)?;
    let id = submission_id(&id)?;
    let b: BulkBody = json_body(&st, req).await?;
    said(&b.who, &b.why)?;
    let verdicts = b.verdicts.unwrap_or_else(|| vec!["untriaged".into()]);
    const KNOWN: [&str; 5] = ["positive", "matched", "negative", "untriaged", "ignored"];
    if let Some(v) = verdicts.iter().find(|v| !KNOWN.contains(&v.as_str())) {
        return Err(ApiError::bad(format!(
            "verdicts: {v:?} is none of {}",
            KNOWN.join(", ")
        )));
    }
    let done = write(&st, move |h| {
        let Some((row, _)) = h.submission(id)? else {
            return Ok(None);
        };
        let mut frames = Vec::new();
        for v in &verdicts {
            frames.extend(h.submission_frames(id, Some(v))?);
        }
        let digests: Vec<(&str, &str)> = frames
            .iter()
            .map(|f| (f.test.as_str(), f.digest.as_str()))
            .collect();
        let why = format!("{} (every digest of submission {id})", b.why);
        let (labelled, kept) =
            h.triage_untriaged(&row.branch, &digests, b.label, (&b.who, &why))?;
        Ok(Some((labelled, kept, row.branch)))
    })
    .await?;
    let (labelled, kept, branch) =
        done.ok_or_else(|| ApiError::not_found(format!("there is no submission {id}")))?;
    json_text(&BulkTriaged {
        labelled,
        kept,
        branch,
    })
}

/// What a bulk triage did.
#[derive(Serialize, ToSchema)]
pub struct BulkTriaged {
    /// Digests labelled: those untriaged when the action ran.
    pub labelled: usize,
    /// Digests left as they were: someone had said positive or negative
    /// of them since the submission (a bulk action never overrides that).
    pub kept: usize,
    /// The submission's branch (`""`: the main line).
    pub branch: String,
}

/// `POST /frames/promote`.
#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PromoteBody {
    /// The branch that landed.
    pub branch: String,
    pub who: String,
    pub why: String,
}

/// A branch landed: its positives and negatives become the main line's.
#[utoipa::path(post, path = "/api/v1/frames/promote", tag = "frames", request_body = PromoteBody,
    security(("bearer" = [])),
    responses((status = 200, description = "Promoted", body = Triaged), (status = 400, description = "Bad body", body = ErrorBody),
        (status = 403, description = "Not a triage token", body = ErrorBody)))]
pub async fn promote(State(st): State<Arc<AppState>>, req: Request) -> Result<Response, ApiError> {
    st.authorize(req.headers(), Scope::Triage)?;
    let b: PromoteBody = json_body(&st, req).await?;
    said(&b.who, &b.why)?;
    if b.branch.is_empty() {
        return Err(ApiError::bad("branch: the branch that landed"));
    }
    let n = write(&st, move |h| h.promote(&b.branch, &b.who, &b.why)).await?;
    json_text(&Triaged {
        labelled: n,
        branch: MAIN.into(),
    })
}

/// `POST /frames/ignore`.
#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct IgnoreBody {
    /// The tests it covers: a name, `*` any characters but `/`, `**` any.
    pub test: String,
    /// Only in submissions with every one of these keys.
    #[serde(default)]
    pub keys: std::collections::BTreeMap<String, String>,
    /// How long it lasts, in hours (more than 0, at most a year).
    pub hours: f64,
    pub who: String,
    pub reason: String,
}

/// The longest an ignore rule may last: a year.
pub const MOST_HOURS: f64 = 24.0 * 366.0;

/// Ignores failures of matching tests until the rule expires.
#[utoipa::path(post, path = "/api/v1/frames/ignore", tag = "frames", request_body = IgnoreBody,
    security(("bearer" = [])),
    responses((status = 200, description = "The rule", body = Object), (status = 400, description = "Bad body", body = ErrorBody),
        (status = 403, description = "Not a triage token", body = ErrorBody)))]
pub async fn ignore(State(st): State<Arc<AppState>>, req: Request) -> Result<Response, ApiError> {
    st.authorize(req.headers(), Scope::Triage)?;
    let b: IgnoreBody = json_body(&st, req).await?;
    said(&b.who, &b.reason)?;
    if !(b.hours > 0.0 && b.hours <= MOST_HOURS) {
        return Err(ApiError::bad(format!(
            "hours: more than 0 and at most {MOST_HOURS}, got {}",
            b.hours
        )));
    }
    if b.test.is_empty() {
        return Err(ApiError::bad("test: a test name or pattern"));
    }
    let pairs: Vec<String> = b.keys.iter().map(|(k, v)| format!("{k}={v}")).collect();
    crate::frames::parse_keys(&pairs).map_err(|e| ApiError::bad(format!("keys: {e}")))?;
    let keys = serde_json::to_string(&b.keys).unwrap_or_default();
    let lasting = Duration::from_secs_f64(b.hours * 3600.0);
    let rule = write(&st, move |h| {
        h.add_ignore_rule(&b.test, &keys, lasting, (&b.who, &b.reason))
    })
    .await?;
    json_text(&rule)
}

/// The ignore rules in force, oldest first.
#[utoipa::path(get, path = "/api/v1/frames/ignores", tag = "frames",
    responses((status = 200, description = "OK", body = Vec<Object>)))]
pub async fn ignores(
    State(st): State<Arc<AppState>>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    st.authorize_read(&headers)?;
    json_text(&read(&st, |h| h.active_ignore_rules()).await?)
}
