//! What people said of a digest is not undone behind their backs: "every
//! untriaged digest positive" on a submission labels only those still
//! untriaged when it runs (a digest marked negative since keeps its label,
//! and the answer counts it as kept), and an ignore rule never passes a
//! negative. Before, the bulk action relabelled by the verdicts the
//! submission was given, and an ignore rule passed any failure.

use crate::common;
use crate::common::server::start;
use crate::frames::frame8;
use crate::frames_api::{form, png, SUBMIT, TRIAGE};
use reqwest::StatusCode;
use serde_json::{json, Value};

/// `frames_api`'s JSON POST, to a path of the server `s`.
async fn post(
    s: &common::server::Running,
    path: &str,
    token: &str,
    body: Value,
) -> (StatusCode, Value) {
    crate::frames_api::post_json(&s.client, format!("{}{path}", s.base), token, body).await
}

async fn submit(s: &common::server::Running, files: &[(String, Vec<u8>)]) -> Value {
    let r = s
        .client
        .post(format!("{}/api/v1/frames/submissions", s.base))
        .bearer_auth(SUBMIT)
        .multipart(form(files, &["device=ci-a"]))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::OK);
    r.json().await.unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bulk_action_or_an_ignore_rule_never_undoes_a_negative() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| {
        o.scoped.submit = Some(SUBMIT.into());
        o.scoped.triage = Some(TRIAGE.into());
    })
    .await;
    let files: Vec<(String, Vec<u8>)> = (0..3)
        .map(|i| (format!("ui/panel{i}.png"), png(&frame8(i * 7))))
        .collect();
    let first = submit(&s, &files).await;
    assert_eq!(first["untriaged"], 3, "{first}");
    let id = first["submission"].as_i64().unwrap();
    let digest_of = |test: &str| -> String {
        first["frames"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["test"] == test)
            .unwrap()["digest"]
            .as_str()
            .unwrap()
            .to_owned()
    };
    let bad = digest_of("ui/panel1");
    // Someone looks at panel1 first and says it is wrong.
    let (st, body) = post(
        &s,
        "/api/v1/frames/triage",
        TRIAGE,
        json!({"who": "bo", "why": "the border is cut", "actions": [
            {"test": "ui/panel1", "digest": bad, "label": "negative"}
        ]}),
    )
    .await;
    assert_eq!(st, StatusCode::OK, "{body}");
    // Then someone else, on the page as it was, marks every untriaged
    // digest of the submission positive.
    let (st, body) = post(
        &s,
        &format!("/api/v1/frames/submissions/{id}/triage"),
        TRIAGE,
        json!({"label": "positive", "who": "ana", "why": "new panels"}),
    )
    .await;
    assert_eq!(st, StatusCode::OK, "{body}");
    assert_eq!(
        (body["labelled"].clone(), body["kept"].clone()),
        (json!(2), json!(1)),
        "{body}"
    );
    let (_, digests) = s.json("/api/v1/frames/digests?test=ui/panel1").await;
    let label = digests
        .as_array()
        .unwrap()
        .iter()
        .find(|d| d["digest"] == bad.as_str())
        .unwrap_or_else(|| panic!("{digests}"))["label"]
        .clone();
    assert_eq!(label, "negative", "{digests}");
    let (_, log) = s.json("/api/v1/frames/log?test=ui/panel1").await;
    assert_eq!(log.as_array().unwrap().len(), 1, "only bo's action: {log}");

    // An ignore rule over every panel: the negative still fails.
    let (st, body) = post(
        &s,
        "/api/v1/frames/ignore",
        TRIAGE,
        json!({"test": "ui/**", "hours": 24, "who": "ana", "reason": "panels are being redone",
               "keys": {"device": "ci-a"}}),
    )
    .await;
    assert_eq!(st, StatusCode::OK, "{body}");
    // Its keys come back as the object they were sent as, here and in the
    // list (they were a JSON string).
    assert_eq!(body["keys"], json!({"device": "ci-a"}), "{body}");
    let (_, rules) = s.json("/api/v1/frames/ignores").await;
    assert_eq!(rules[0]["keys"], json!({"device": "ci-a"}), "{rules}");
    let again = submit(&s, &files).await;
    assert_eq!(again["passed"], false, "{again}");
    let panel1 = again["frames"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["test"] == "ui/panel1")
        .unwrap();
    assert_eq!(panel1["status"], "negative", "{panel1}");
    assert_eq!(panel1["passed"], false, "{panel1}");
}

/// An idempotency key names one submission's contents: a retry with the
/// same frames and keys gets the first answer and stores nothing; the
/// same key with a changed frame, or other keys, is refused with 409
/// naming the difference (it was answered with the first report, its
/// frames and keys dropped without a word).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_idempotency_key_reused_for_other_contents_is_refused_by_the_difference() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| o.scoped.submit = Some(SUBMIT.into())).await;
    let files: Vec<(String, Vec<u8>)> = (0..2)
        .map(|i| (format!("ui/panel{i}.png"), png(&frame8(i * 7))))
        .collect();
    let send = |files: Vec<(String, Vec<u8>)>, keys: &'static [&'static str]| {
        let s = &s;
        async move {
            let r = s
                .client
                .post(format!("{}/api/v1/frames/submissions", s.base))
                .bearer_auth(SUBMIT)
                .header("Idempotency-Key", "ci-run-41")
                .multipart(form(&files, keys))
                .send()
                .await
                .unwrap();
            let status = r.status();
            (status, r.json::<Value>().await.unwrap())
        }
    };
    let (st, first) = send(files.clone(), &["device=ci-a"]).await;
    assert_eq!(st, StatusCode::OK, "{first}");
    let (st, again) = send(files.clone(), &["device=ci-a"]).await;
    assert_eq!(st, StatusCode::OK, "{again}");
    assert_eq!(again["submission"], first["submission"]);
    let mut changed = files.clone();
    changed[0].1 = png(&frame8(50));
    let (st, body) = send(changed, &["device=ci-a"]).await;
    assert_eq!(st, StatusCode::CONFLICT, "{body}");
    let detail = body["detail"].as_str().unwrap();
    assert!(detail.contains("ui/panel0's frame was"), "{detail}");
    let (st, body) = send(files.clone(), &["device=ci-b"]).await;
    assert_eq!(st, StatusCode::CONFLICT, "{body}");
    assert!(
        body["detail"]
            .as_str()
            .unwrap()
            .contains("keys were [device=ci-a]"),
        "{body}"
    );
    let (st, body) = send(files[..1].to_vec(), &["device=ci-a"]).await;
    assert_eq!(st, StatusCode::CONFLICT, "{body}");
    assert!(
        body["detail"]
            .as_str()
            .unwrap()
            .contains("ui/panel1 is missing"),
        "{body}"
    );
}

/// The submissions are listed a page at a time: `before` gives those older
/// than an id, newest first.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn submissions_are_listed_a_page_at_a_time() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| o.scoped.submit = Some(SUBMIT.into())).await;
    let files = vec![("ui/a.png".to_string(), png(&frame8(1)))];
    for _ in 0..5 {
        submit(&s, &files).await;
    }
    let (_, first) = s.json("/api/v1/frames/submissions?limit=2").await;
    let ids: Vec<i64> = first
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["id"].as_i64().unwrap())
        .collect();
    assert_eq!(ids, [5, 4]);
    let (_, next) = s.json("/api/v1/frames/submissions?limit=2&before=4").await;
    let ids: Vec<i64> = next
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["id"].as_i64().unwrap())
        .collect();
    assert_eq!(ids, [3, 2]);
}
