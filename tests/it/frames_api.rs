//! `/api/v1/frames` on a real server and a real SQLite history: a CI job's
//! submit token may submit and not triage, a person's triage token the
//! other way round; a submission through the API is judged as the command
//! line judges one, bulk triage labels everything a submission left
//! untriaged, the same frames then pass, a retry under its idempotency key
//! stores nothing twice, the triage page's images and maps decode, and
//! hostile forms are refused by the part they are about with nothing stored.

use crate::common;
use crate::common::server::{start, TOKEN};
use crate::frames::frame8;
use reqwest::multipart::{Form, Part};
use reqwest::StatusCode;
use serde_json::{json, Value};
use tonegate::history::History;
use tonegate::image::{Frame, Image, Rgb8Image};

pub const SUBMIT: &str = "submit-token-0123456789";
pub const TRIAGE: &str = "triage-token-0123456789";

pub fn png(img: &Rgb8Image) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.png");
    tonegate::io::write_frame_png(&path, &Frame::Rgb8(img.clone())).unwrap();
    std::fs::read(path).unwrap()
}

/// A form of `(name, bytes)` files and `key` parts.
pub fn form(files: &[(String, Vec<u8>)], keys: &[&str]) -> Form {
    let mut f = Form::new();
    for (name, bytes) in files {
        f = f.part(
            "file",
            Part::bytes(bytes.clone())
                .file_name(name.clone())
                .mime_str("image/png")
                .unwrap(),
        );
    }
    for k in keys {
        f = f.text("key", k.to_string());
    }
    f
}

async fn post_form(
    client: &reqwest::Client,
    base: &str,
    token: Option<&str>,
    form: Form,
    key: Option<&str>,
) -> (StatusCode, Value) {
    let mut r = client
        .post(format!("{base}/api/v1/frames/submissions"))
        .multipart(form);
    if let Some(t) = token {
        r = r.bearer_auth(t);
    }
    if let Some(k) = key {
        r = r.header("Idempotency-Key", k);
    }
    let r = r.send().await.unwrap();
    let status = r.status();
    let text = r.text().await.unwrap();
    (
        status,
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}")),
    )
}

pub(crate) async fn post_json(
    client: &reqwest::Client,
    url: String,
    token: &str,
    body: Value,
) -> (StatusCode, Value) {
    let r = client
        .post(url)
        .bearer_auth(token)
        .json(&body)
        .send()
        .await
        .unwrap();
    let status = r.status();
    (status, r.json().await.unwrap())
}

fn count(db: &std::path::Path, table: &str) -> i64 {
    let c = rusqlite::Connection::open(db).unwrap();
    c.query_row(&format!("SELECT COUNT(*) FROM {table}"), [], |r| r.get(0))
        .unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn frames_are_submitted_and_triaged_through_the_api_under_their_own_scopes() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| {
        o.scoped.submit = Some(SUBMIT.into());
        o.scoped.triage = Some(TRIAGE.into());
    })
    .await;
    let files: Vec<(String, Vec<u8>)> = (0..6)
        .map(|i| (format!("ui/panel{i}.png"), png(&frame8(i * 7))))
        .collect();
    let keys = ["device=ci-a", "commit=c1"];

    // Scopes: no token, the triage token, then the submit token. (A
    // refusal is answered before the body is read and closes the
    // connection, so the refused forms are small enough to be sent whole.)
    let one = &files[..1];
    let (st, body) = post_form(&s.client, &s.base, None, form(one, &keys), None).await;
    assert_eq!(st, StatusCode::UNAUTHORIZED, "{body}");
    let (st, body) = post_form(&s.client, &s.base, Some(TRIAGE), form(one, &keys), None).await;
    assert_eq!(st, StatusCode::FORBIDDEN, "{body}");
    assert!(
        body["detail"].as_str().unwrap().contains("may only triage"),
        "{body}"
    );
    let (st, first) = post_form(&s.client, &s.base, Some(SUBMIT), form(&files, &keys), None).await;
    assert_eq!(st, StatusCode::OK, "{first}");
    assert_eq!(first["passed"], false);
    assert_eq!(first["untriaged"], 6);
    let id = first["submission"].as_i64().unwrap();

    // The submit token cannot triage; the triage token labels the whole
    // submission at once, logged with who and why.
    let bulk = format!("{}/api/v1/frames/submissions/{id}/triage", s.base);
    let said = json!({"label": "positive", "who": "ana", "why": "first frames of the new panel"});
    let (st, body) = post_json(&s.client, bulk.clone(), SUBMIT, said.clone()).await;
    assert_eq!(st, StatusCode::FORBIDDEN, "{body}");
    let (st, body) = post_json(&s.client, bulk, TRIAGE, said).await;
    assert_eq!(st, StatusCode::OK, "{body}");
    assert_eq!(body["labelled"], 6);
    let (_, log) = s.json("/api/v1/frames/log?test=ui/panel3").await;
    assert_eq!(log.as_array().unwrap().len(), 1, "{log}");
    assert_eq!(log[0]["who"], "ana");
    assert!(log[0]["why"]
        .as_str()
        .unwrap()
        .contains("first frames of the new panel"));

    // The same frames now pass; a retry under the key answers the first
    // report and stores nothing.
    let (st, second) = post_form(
        &s.client,
        &s.base,
        Some(SUBMIT),
        form(&files, &keys),
        Some("ci-run-2"),
    )
    .await;
    assert_eq!(st, StatusCode::OK);
    assert_eq!(second["passed"], true, "{second}");
    let stored = count(&seeded.db, "frame_submissions");
    let (_, retry) = post_form(
        &s.client,
        &s.base,
        Some(SUBMIT),
        form(&files, &keys),
        Some("ci-run-2"),
    )
    .await;
    assert_eq!(retry["submission"], second["submission"]);
    assert_eq!(count(&seeded.db, "frame_submissions"), stored);
    assert_eq!(count(&seeded.db, "blobs"), 6, "one blob an image");

    // A frame that moved: untriaged, judged against its closest positive;
    // the page's images and maps are PNGs of its size.
    let moved = vec![("ui/panel0.png".to_string(), png(&frame8(3)))];
    let (_, third) = post_form(&s.client, &s.base, Some(SUBMIT), form(&moved, &keys), None).await;
    assert_eq!(third["passed"], false);
    let frame = &third["frames"][0];
    let (ours, theirs) = (
        frame["digest"].as_str().unwrap(),
        frame["closest"]["digest"].as_str().unwrap(),
    );
    for path in [
        format!("/api/v1/frames/images/{ours}"),
        format!("/api/v1/frames/compare/{ours}/{theirs}?map=diff"),
        format!("/api/v1/frames/compare/{ours}/{theirs}?map=ssim"),
        format!("/api/v1/frames/compare/{ours}/{theirs}?map=flip"),
    ] {
        let r = s.get(&path).await;
        assert_eq!(r.status(), StatusCode::OK, "{path}");
        let bytes = r.bytes().await.unwrap();
        let img = image::load_from_memory(&bytes).unwrap_or_else(|e| panic!("{path}: {e}"));
        assert_eq!((img.width(), img.height()), (64, 40), "{path}");
    }
    // The diff map is not black: the square moved.
    let diff = s
        .get(&format!("/api/v1/frames/compare/{ours}/{theirs}?map=diff"))
        .await
        .bytes()
        .await
        .unwrap();
    let diff = image::load_from_memory(&diff).unwrap().to_rgb8();
    assert!(diff.pixels().any(|p| p.0 != [0, 0, 0]));
    let (st, body) = s
        .json(&format!("/api/v1/frames/compare/{ours}/{theirs}?map=sobel"))
        .await;
    assert_eq!(st, StatusCode::BAD_REQUEST);
    assert!(body["detail"].as_str().unwrap().contains("map"), "{body}");

    // Single triage by digest, with the digests' labels read back.
    let (st, body) = post_json(
        &s.client,
        format!("{}/api/v1/frames/triage", s.base),
        TRIAGE,
        json!({"who": "ana", "why": "the square moves on purpose",
               "actions": [{"test": "ui/panel0", "digest": ours, "label": "positive"}]}),
    )
    .await;
    assert_eq!(st, StatusCode::OK, "{body}");
    let (_, labels) = s.json("/api/v1/frames/digests?test=ui/panel0").await;
    assert_eq!(labels.as_array().unwrap().len(), 2, "{labels}");
    assert!(labels
        .as_array()
        .unwrap()
        .iter()
        .all(|l| l["label"] == "positive"));
    let (_, list) = s.json("/api/v1/frames/submissions").await;
    assert_eq!(list.as_array().unwrap().len(), 3, "{list}");
    let (_, one) = s.json(&format!("/api/v1/frames/submissions/{id}")).await;
    assert_eq!(one["frames"].as_array().unwrap().len(), 6);
    assert_eq!(one["report"]["untriaged"], 6);
    // The server's own token may do both.
    let (st, _) = post_json(
        &s.client,
        format!("{}/api/v1/frames/ignore", s.base),
        TOKEN,
        json!({"test": "ui/**", "hours": 1.0, "who": "ana", "reason": "driver update"}),
    )
    .await;
    assert_eq!(st, StatusCode::OK);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hostile_submissions_are_refused_by_the_part_they_are_about_and_store_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| o.scoped.submit = Some(SUBMIT.into())).await;
    let good = png(&frame8(0));
    // A history with a submission in it, which must survive every refusal.
    let fine = vec![("fine.png".to_string(), good.clone())];
    let (st, _) = post_form(&s.client, &s.base, Some(SUBMIT), form(&fine, &[]), None).await;
    assert_eq!(st, StatusCode::OK);
    let before = (
        count(&seeded.db, "frame_submissions"),
        count(&seeded.db, "blobs"),
    );

    let mut lying = good.clone();
    // IHDR's width and height: 1e5 × 1e5.
    lying[16..20].copy_from_slice(&100_000u32.to_be_bytes());
    lying[20..24].copy_from_slice(&100_000u32.to_be_bytes());
    // 16-bit codes whose PNG says nothing of PQ.
    let plain16 = {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("p.png");
        let img: tonegate::image::Rgb16Image =
            Image::from_fn(16, 8, |x, y| [(x * 900) as u16, (y * 1500) as u16, 30000]);
        tonegate::io::write_png16(&p, &img).unwrap();
        std::fs::read(p).unwrap()
    };
    // A 16-bit frame whose cICP says HLG (transfer 18): its codes would be
    // read as PQ by a tool that trusted the depth alone.
    let hlg16 = {
        let mut out = Vec::new();
        let mut e = png::Encoder::new(&mut out, 16, 8);
        e.set_color(png::ColorType::Rgb);
        e.set_depth(png::BitDepth::Sixteen);
        let mut w = e.write_header().unwrap();
        w.write_chunk(png::chunk::ChunkType(*b"cICP"), &[9, 18, 0, 1])
            .unwrap();
        w.write_image_data(&vec![0x40u8; 16 * 8 * 6]).unwrap();
        w.finish().unwrap();
        out
    };
    let tiny: Vec<(String, Vec<u8>)> = (0..10_000)
        .map(|i| (format!("t{i:05}.png"), good[..64].to_vec()))
        .collect();
    type Files = Vec<(String, Vec<u8>)>;
    let cases: Vec<(&str, Files, StatusCode, &str)> = vec![
        (
            "escape",
            vec![("../../etc/evil.png".into(), good.clone())],
            StatusCode::BAD_REQUEST,
            "../../etc/evil.png",
        ),
        (
            "absolute",
            vec![("/abs.png".into(), good.clone())],
            StatusCode::BAD_REQUEST,
            "/abs.png",
        ),
        (
            "duplicate",
            vec![
                ("a/b.png".into(), good.clone()),
                ("a/b.exr".into(), good.clone()),
            ],
            StatusCode::BAD_REQUEST,
            "are both frames of test \"a/b\"",
        ),
        (
            "lying size",
            vec![("ok.png".into(), good.clone()), ("huge.png".into(), lying)],
            StatusCode::PAYLOAD_TOO_LARGE,
            "huge.png needs 76294 MiB to decode and judge",
        ),
        (
            "cicp",
            vec![("plain16.png".into(), plain16)],
            StatusCode::UNPROCESSABLE_ENTITY,
            "plain16.png",
        ),
        (
            "cicp says hlg",
            vec![("hlg16.png".into(), hlg16)],
            StatusCode::UNPROCESSABLE_ENTITY,
            "hlg16.png",
        ),
        (
            "ten thousand",
            tiny,
            StatusCode::BAD_REQUEST,
            "a submission takes at most 4096",
        ),
        (
            "not an image",
            vec![("notes.txt".into(), b"hello".to_vec())],
            StatusCode::BAD_REQUEST,
            "notes.txt",
        ),
        (
            "right-to-left override",
            vec![("ui/\u{202E}gnp.evil.png".into(), good.clone())],
            StatusCode::BAD_REQUEST,
            "U+202E",
        ),
        (
            "a 10 KB name keeps its reason",
            vec![(format!("{}/x.txt", "d".repeat(10_000)), good.clone())],
            StatusCode::BAD_REQUEST,
            "not an image extension",
        ),
    ];
    for (name, files, status, says) in cases {
        let (st, body) = post_form(&s.client, &s.base, Some(SUBMIT), form(&files, &[]), None).await;
        assert_eq!(st, status, "{name}: {body}");
        assert!(
            body["detail"].as_str().unwrap_or("").contains(says),
            "{name}: {body}"
        );
    }
    // A file name that is not UTF-8 (raw bytes in the part's header) is
    // said as such, not as a part without a name.
    let boundary = "tonegate-boundary-1";
    let mut raw =
        format!("--{boundary}\r\nContent-Disposition: form-data; name=\"file\"; filename=\"")
            .into_bytes();
    raw.extend_from_slice(b"ui/\xff\xfe.png");
    raw.extend_from_slice(b"\"\r\nContent-Type: image/png\r\n\r\n");
    raw.extend_from_slice(&good);
    raw.extend_from_slice(format!("\r\n--{boundary}--\r\n").as_bytes());
    let r = s
        .client
        .post(format!("{}/api/v1/frames/submissions", s.base))
        .bearer_auth(SUBMIT)
        .header(
            "content-type",
            format!("multipart/form-data; boundary={boundary}"),
        )
        .body(raw)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::BAD_REQUEST);
    let body: Value = r.json().await.unwrap();
    assert!(
        body["detail"].as_str().unwrap().contains("not UTF-8"),
        "{body}"
    );
    // Bad keys and rules, named.
    let (st, body) = post_form(
        &s.client,
        &s.base,
        Some(SUBMIT),
        form(&fine, &["no equals sign"]),
        None,
    )
    .await;
    assert_eq!(st, StatusCode::BAD_REQUEST);
    assert!(
        body["detail"].as_str().unwrap().contains("no equals sign"),
        "{body}"
    );
    // Keys and rules beyond their bounds, refused as they arrive, the
    // detail quoting no more than a clip of what was sent.
    let many: Vec<String> = (0..33).map(|i| format!("k{i}=v")).collect();
    let many: Vec<&str> = many.iter().map(String::as_str).collect();
    let long_value = format!("device={}", "x".repeat(300));
    let long_name = format!("{}=1", "n".repeat(5000));
    let big_rules = format!("# {}\n", "r".repeat(2 << 20));
    let bounded: Vec<(&str, reqwest::multipart::Form, &str)> = vec![
        ("33 keys", form(&fine, &many), "more than 32 `key` parts"),
        (
            "a long value",
            form(&fine, &[long_value.as_str()]),
            "key device: a value of 300 bytes: at most 256",
        ),
        (
            "a long part",
            form(&fine, &[long_name.as_str()]),
            "a `key` part is longer than 321 bytes",
        ),
        (
            "big rules",
            form(&fine, &[]).text("rules", big_rules),
            "the `rules` part is longer than 1048576 bytes",
        ),
    ];
    for (name, f, says) in bounded {
        let (st, body) = post_form(&s.client, &s.base, Some(SUBMIT), f, None).await;
        assert_eq!(st, StatusCode::BAD_REQUEST, "{name}: {body}");
        let detail = body["detail"].as_str().unwrap_or("");
        assert!(detail.contains(says), "{name}: {body}");
        assert!(
            detail.len() < 400,
            "{name}: a detail of {} bytes",
            detail.len()
        );
    }
    let rules = form(&fine, &[]).text("rules", "[[tests]]\npattern = \"*\"\nmin_psnr = 3\n");
    let (st, body) = post_form(&s.client, &s.base, Some(SUBMIT), rules, None).await;
    assert_eq!(st, StatusCode::BAD_REQUEST);
    assert!(
        body["detail"].as_str().unwrap().contains("the rules part"),
        "{body}"
    );
    let (st, body) = post_form(
        &s.client,
        &s.base,
        Some(SUBMIT),
        form(&fine, &[]).text("colour", "red"),
        None,
    )
    .await;
    assert_eq!(st, StatusCode::BAD_REQUEST);
    assert!(
        body["detail"].as_str().unwrap().contains("colour"),
        "{body}"
    );
    assert_eq!(
        (
            count(&seeded.db, "frame_submissions"),
            count(&seeded.db, "blobs")
        ),
        before,
        "a refused submission stored something"
    );
    // The history still answers for what it held.
    let h = History::open_read_only(&seeded.db).unwrap();
    assert_eq!(h.submissions(10).unwrap().len(), 1);
}
