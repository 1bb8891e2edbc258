//! The HTTP API against a real server on loopback: every endpoint, every
//! error status, the token, path traversal, oversize bodies and images, the
//! full queue's 503 and the timeout.

use crate::common;
use crate::common::server as harness;

use harness::{expect_error, hold_workers, start, TOKEN};
use reqwest::StatusCode;
use std::sync::{Arc, RwLock};
use std::time::Duration;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_read_endpoint_answers_on_a_seeded_history() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed(dir.path());
    let s = start(&seeded, |_| {}).await;

    let (st, runs) = s.json("/api/v1/runs").await;
    assert_eq!(st, StatusCode::OK);
    let runs = runs.as_array().unwrap();
    assert_eq!(runs.len(), 3);
    assert_eq!(runs[0]["id"], seeded.tradeoff, "newest first");
    let (_, failed) = s.json("/api/v1/runs?status=failed").await;
    assert_eq!(failed.as_array().unwrap().len(), 1);
    assert_eq!(failed[0]["id"], seeded.failed);
    assert_eq!(failed[0]["scenes_failed"], 2);
    let (_, tr) = s.json("/api/v1/runs?kind=tradeoff&adapter=llvmpipe").await;
    assert_eq!(tr[0]["id"], seeded.tradeoff);
    for bad in ["status=great", "limit=0", "limit=x", "colour=red"] {
        let d = expect_error(
            s.get(&format!("/api/v1/runs?{bad}")).await,
            StatusCode::BAD_REQUEST,
            "bad_parameter",
        )
        .await;
        let name = bad.split('=').next().unwrap();
        assert!(d.contains(name), "{bad}: {d}");
    }

    // One run: status, per-frame metrics, timings, checks.
    let (st, run) = s.json(&format!("/api/v1/runs/{}", seeded.failed)).await;
    assert_eq!(st, StatusCode::OK);
    assert_eq!(run["run"]["status"], "failed");
    let scenes = run["report"]["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 2);
    let sky = scenes
        .iter()
        .find(|s| s["scene"] == "sky-reinhard-global")
        .unwrap();
    assert_eq!(sky["frames"].as_array().unwrap().len(), 8);
    assert!(sky["frames"][0]["metrics"]["psnr"].as_f64().unwrap() < 50.0);
    assert!(sky["checks"]
        .as_array()
        .unwrap()
        .iter()
        .any(|c| c["passed"] == false));
    assert!(sky["timings"][0]["median_ms"].as_f64().unwrap() > 0.0);
    expect_error(
        s.get("/api/v1/runs/999").await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;
    expect_error(
        s.get("/api/v1/runs/abc").await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    expect_error(
        s.get("/api/v1/runs/-1").await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;

    // Artifacts: listed ones are served as PNG; a passing run keeps each
    // scene's worst frame too.
    let names: Vec<String> = run["report"]["artifacts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_owned())
        .collect();
    assert!(
        names
            .iter()
            .any(|n| n.starts_with("sky-reinhard-global-000-") && n.ends_with("-diff.png")),
        "{names:?}"
    );
    let r = s
        .get(&format!(
            "/api/v1/runs/{}/artifacts/{}",
            seeded.failed, names[0]
        ))
        .await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.headers()["content-type"], "image/png");
    let png = r.bytes().await.unwrap();
    let img = image::load_from_memory(&png).unwrap();
    assert_eq!((img.width(), img.height()), (320, 180));
    let (_, ok_run) = s.json(&format!("/api/v1/runs/{}", seeded.passed)).await;
    let kept = ok_run["report"]["artifacts"].as_array().unwrap();
    assert_eq!(
        kept.len(),
        2 * 5,
        "one worst frame per scene, five images each: {kept:?}"
    );
    // Path traversal and names that are not this run's are refused.
    for bad in [
        "..%2F..%2Fhistory.sqlite",
        "..%2Fhistory.sqlite",
        "%2e%2e%2Fmini.toml",
        "a%00.png",
        "x%5C..%5Cy.png",
        ".hidden.png",
        "token",
    ] {
        expect_error(
            s.get(&format!("/api/v1/runs/{}/artifacts/{bad}", seeded.failed))
                .await,
            StatusCode::BAD_REQUEST,
            "bad_parameter",
        )
        .await;
    }
    let r = s
        .get(&format!(
            "/api/v1/runs/{}/artifacts/../../history.sqlite",
            seeded.failed
        ))
        .await;
    assert!(r.status().is_client_error(), "{}", r.status());
    assert_ne!(r.headers()["content-type"], "application/octet-stream");
    // Valid names the run does not list: another run's image, an unknown one.
    let other = kept[0].as_str().unwrap();
    if !names.iter().any(|n| n == other) {
        expect_error(
            s.get(&format!("/api/v1/runs/{}/artifacts/{other}", seeded.failed))
                .await,
            StatusCode::NOT_FOUND,
            "not_found",
        )
        .await;
    }
    expect_error(
        s.get(&format!(
            "/api/v1/runs/{}/artifacts/nope-000-x-diff.png",
            seeded.failed
        ))
        .await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;

    // Trends: per scene, regressions marked, metric names checked.
    let (st, fps) = s.json("/api/v1/trends?metric=fps&scene=grid-static").await;
    assert_eq!(st, StatusCode::OK);
    let fps = fps.as_array().unwrap();
    assert_eq!(fps.len(), 2);
    assert!(fps
        .iter()
        .all(|p| p["value"].as_f64().unwrap() > 0.0 && p["regression"] == false));
    let (_, stage) = s.json("/api/v1/trends?metric=sphere").await;
    assert_eq!(stage.as_array().unwrap().len(), 4, "two runs x two scenes");
    let (_, psnr) = s.json("/api/v1/trends?scene=sky-reinhard-global").await;
    assert!(
        psnr[0]["value"].as_f64().unwrap() > psnr[1]["value"].as_f64().unwrap(),
        "the faulty run is worse"
    );
    expect_error(
        s.get("/api/v1/trends?metric=DROP").await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    expect_error(
        s.get("/api/v1/trends?sceen=x").await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;

    // Tradeoff points with a Pareto front; a check run is not one.
    let (st, t) = s
        .json(&format!("/api/v1/tradeoff/{}", seeded.tradeoff))
        .await;
    assert_eq!(st, StatusCode::OK);
    let points = t["points"].as_array().unwrap();
    assert!(points.len() >= 8, "{}", points.len());
    assert!(points.iter().any(|p| p["pareto"] == true));
    assert!(points.iter().all(|p| p["ms"].as_f64().unwrap() > 0.0));
    expect_error(
        s.get(&format!("/api/v1/tradeoff/{}", seeded.passed)).await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;
    expect_error(
        s.get("/api/v1/tradeoff/77").await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;

    // Health, OpenAPI, metrics, unknown endpoints and methods.
    let (st, health) = s.json("/api/v1/healthz").await;
    assert_eq!(st, StatusCode::OK);
    assert_eq!(health["status"], "ok");
    assert_eq!(health["runs"], 3);
    let (_, doc) = s.json("/api/v1/openapi.json").await;
    for path in [
        "/api/v1/runs",
        "/api/v1/runs/{id}",
        "/api/v1/runs/{id}/artifacts/{name}",
        "/api/v1/trends",
        "/api/v1/tradeoff/{run}",
        "/api/v1/healthz",
        "/api/v1/tonemap",
    ] {
        assert!(
            doc["paths"].get(path).is_some(),
            "{path} missing from the OpenAPI document"
        );
    }
    assert!(doc["paths"]["/api/v1/runs"].get("post").is_some());
    // OpenAPI requires a description on every response (openapi-spec-validator
    // 0.9 refused the document without them).
    for (path, item) in doc["paths"].as_object().unwrap() {
        for (method, op) in item.as_object().unwrap() {
            for (status, resp) in op["responses"].as_object().unwrap() {
                assert!(
                    resp["description"].as_str().is_some_and(|d| !d.is_empty()),
                    "{method} {path} {status} has no description"
                );
            }
        }
    }
    let metrics = s.get("/metrics").await.text().await.unwrap();
    assert!(
        metrics.contains(
            "tonegate_http_requests_total{route=\"/api/v1/runs\",method=\"GET\",status=\"200\"}"
        ),
        "{metrics}"
    );
    assert!(
        metrics.contains("tonegate_scene_fps{scene=\"grid-static\""),
        "{metrics}"
    );
    assert!(metrics.contains("tonegate_last_run_passed"), "{metrics}");
    assert!(
        metrics.contains("tonegate_runs{status=\"failed\"} 1"),
        "{metrics}"
    );
    for line in metrics
        .lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
    {
        assert!(line.starts_with("tonegate_"), "{line}");
    }
    expect_error(
        s.get("/api/v1/nope").await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;
    let r = s
        .client
        .delete(format!("{}/api/v1/runs", s.base))
        .send()
        .await
        .unwrap();
    expect_error(r, StatusCode::METHOD_NOT_ALLOWED, "method_not_allowed").await;
    // The dashboard's files are embedded.
    let page = s.get("/").await;
    assert_eq!(page.status(), StatusCode::OK);
    assert!(page.text().await.unwrap().contains("/app.js"));
    for asset in ["/app.js", "/charts.js", "/style.css"] {
        assert_eq!(s.get(asset).await.status(), StatusCode::OK, "{asset}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tonemap_returns_the_reference_image_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| {
        o.limits.max_body = 64 << 10;
        o.limits.max_pixels = 100 * 80;
    })
    .await;
    let hdr = common::hdr_bytes(dir.path(), 96, 64);

    // CPU: exactly the reference's image; statistics in the headers.
    let r = s.tonemap("gpu=false&key=0.25&bloom=0.2", hdr.clone()).await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.headers()["content-type"], "image/png");
    assert_eq!(r.headers()["x-tonegate-adapter"], "cpu-reference");
    assert_eq!(r.headers()["x-tonegate-key"], "0.25");
    assert_eq!(r.headers()["x-tonegate-size"], "96x64");
    // Where the job's time went: its parts are within the whole.
    let header_ms = |name: &str| -> f64 {
        r.headers()[name]
            .to_str()
            .unwrap()
            .parse()
            .unwrap_or_else(|e| panic!("{name}: {e}"))
    };
    let parts: Vec<f64> = ["decode", "tonemap", "png"]
        .iter()
        .map(|p| header_ms(&format!("x-tonegate-{p}-ms")))
        .collect();
    let whole = header_ms("x-tonegate-render-ms");
    assert!(
        parts.iter().all(|&p| p > 0.0) && parts.iter().sum::<f64>() <= whole + 0.01,
        "{parts:?} of {whole}"
    );
    let cpu_png = r.bytes().await.unwrap();
    let settings = tonegate::toning::ToneSettings {
        bloom: 0.2,
        ..tonegate::toning::ToneSettings::for_operator("reinhard-global", &[("key", "0.25")])
    };
    let (img, _) = tonegate::io::decode_hdr(&hdr, "x", &Default::default()).unwrap();
    let resolved = settings.resolve().unwrap();
    let want = tonegate::toning::tone_map(
        &img,
        &resolved.pipeline(),
        None,
        tonegate::toning::OutputKind::Encoded,
    )
    .unwrap();
    let want_frame = want
        .image
        .encoded()
        .expect("a frame when the encoded output is asked for");
    let got = image::load_from_memory(&cpu_png).unwrap().to_rgb8();
    assert_eq!(
        got.as_raw().as_slice(),
        want_frame.as_bytes(),
        "the API's CPU path is the reference"
    );

    // GPU: a different render of the same settings, within 2 LSB of the CPU
    // (the GPU-vs-CPU bound measured on lavapipe, docs/tolerances.md).
    let r = s.tonemap("key=0.25&bloom=0.2", hdr.clone()).await;
    assert_eq!(r.status(), StatusCode::OK);
    assert!(r.headers()["x-tonegate-adapter"]
        .to_str()
        .unwrap()
        .contains("llvmpipe"));
    let gpu = image::load_from_memory(&r.bytes().await.unwrap())
        .unwrap()
        .to_rgb8();
    let worst = gpu
        .as_raw()
        .iter()
        .zip(want_frame.as_bytes())
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    assert!(worst <= 2, "GPU vs CPU {worst} LSB");

    // JSON with the image inline, and multipart with form fields.
    let r = s
        .tonemap(
            "gpu=false&format=json&operator=seed001&key=auto",
            hdr.clone(),
        )
        .await;
    let v: serde_json::Value = r.json().await.unwrap();
    assert_eq!(v["width"], 96);
    assert!(v["tone"]["key"].as_f64().unwrap() > 0.0);
    use base64::Engine as _;
    let png = base64::engine::general_purpose::STANDARD
        .decode(v["image"]["base64"].as_str().unwrap())
        .unwrap();
    assert_eq!(image::load_from_memory(&png).unwrap().width(), 96);
    // The settings echoed are those in effect: a bloom's refinements left
    // out are its defaults, not nulls; without a bloom they stay null.
    let r = s
        .tonemap("gpu=false&format=json&bloom=0.5&bloom_sigma=2", hdr.clone())
        .await;
    let v: serde_json::Value = r.json().await.unwrap();
    assert_eq!(v["settings"]["bloom_radius"], 6, "{}", v["settings"]);
    assert_eq!(v["settings"]["bloom_sigma"], 2.0);
    assert_eq!(v["settings"]["bloom_pass"], "scaled");
    assert!(v["settings"]["bloom_radius"].is_number());
    let form = reqwest::multipart::Form::new()
        .text("operator", "reinhard02")
        .text("white", "4")
        .part(
            "file",
            reqwest::multipart::Part::bytes(hdr.clone()).file_name("sky.hdr"),
        );
    let r = s
        .client
        .post(format!("{}/api/v1/tonemap?gpu=false", s.base))
        .multipart(form)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::OK);
    let white: f64 = r.headers()["x-tonegate-white"]
        .to_str()
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(white, 4.0);
    assert_eq!(r.headers()["x-tonegate-operator"], "reinhard02");

    // OpenEXR bodies too (ZIP-compressed f32).
    let img =
        tonegate::image::HdrImage::from_fn(40, 20, |x, y| [x as f32 * 0.1, y as f32 * 0.2, 1.0]);
    let exr = dir.path().join("in.exr");
    tonegate::io::write_image_hdr(&exr, &img).unwrap();
    let r = s.tonemap("gpu=false", std::fs::read(&exr).unwrap()).await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.headers()["x-tonegate-size"], "40x20");

    // Parameters: unknown, bad value, twice.
    let d = expect_error(
        s.tonemap("kee=0.2", hdr.clone()).await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    assert!(d.contains("kee"), "{d}");
    let d = expect_error(
        s.tonemap("white_fraction=2", hdr.clone()).await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    assert!(d.contains("white_fraction"), "{d}");
    expect_error(
        s.tonemap("key=1&key=2", hdr.clone()).await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    expect_error(
        s.tonemap("gpu=maybe", hdr.clone()).await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    expect_error(
        s.tonemap("bloom_radius=0", hdr.clone()).await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    // A bloom refinement without a bloom was accepted and did nothing.
    let detail = expect_error(
        s.tonemap("bloom_radius=9", hdr.clone()).await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    assert!(detail.contains("bloom_radius: refines a bloom"), "{detail}");
    // Bodies: empty, not HDR, truncated, NaN, over the byte and pixel limits.
    expect_error(
        s.tonemap("gpu=false", vec![]).await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    expect_error(
        s.tonemap("gpu=false", b"GIF89a not an hdr file".to_vec())
            .await,
        StatusCode::UNSUPPORTED_MEDIA_TYPE,
        "unsupported_media_type",
    )
    .await;
    let d = expect_error(
        s.tonemap("gpu=false", hdr[..hdr.len() / 2].to_vec()).await,
        StatusCode::UNPROCESSABLE_ENTITY,
        "bad_image",
    )
    .await;
    assert!(d.contains("truncated") || d.contains("upload"), "{d}");
    let mut pfm = b"PF\n2 1\n-1.0\n".to_vec();
    for v in [1.0f32, f32::NAN, 1.0, 1.0, 1.0, 1.0] {
        pfm.extend_from_slice(&v.to_le_bytes());
    }
    expect_error(
        s.tonemap("gpu=false", pfm.clone()).await,
        StatusCode::UNPROCESSABLE_ENTITY,
        "bad_image",
    )
    .await;
    assert_eq!(
        s.tonemap("gpu=false&sanitize=true", pfm).await.status(),
        StatusCode::OK
    );
    let d = expect_error(
        s.tonemap("gpu=false", vec![0u8; 65 << 10]).await,
        StatusCode::PAYLOAD_TOO_LARGE,
        "too_large",
    )
    .await;
    assert!(d.contains("limit"), "{d}");
    // A 128x96 header (12288 px > 8000) is refused from the header alone.
    let big = common::hdr_bytes(dir.path(), 128, 96);
    assert!(big.len() < 64 << 10);
    let d = expect_error(
        s.tonemap("gpu=false", big).await,
        StatusCode::PAYLOAD_TOO_LARGE,
        "too_large",
    )
    .await;
    assert!(d.contains("12288") || d.contains("128"), "{d}");
    let metrics = s.get("/metrics").await.text().await.unwrap();
    assert!(
        metrics.contains("tonegate_tonemap_succeeded_total{queue=\"cpu\"}"),
        "{metrics}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_full_queue_answers_503_with_retry_after_and_a_slow_request_times_out() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let hold = Arc::new(RwLock::new(()));
    let s = Arc::new(
        start(&seeded, |o| {
            o.limits.queue = 2;
            o.limits.timeout = Duration::from_secs(30);
            o.hold_workers = Some(hold.clone());
        })
        .await,
    );
    let hdr = common::hdr_bytes(dir.path(), 32, 16);
    let guard = hold_workers(&hold);
    // With the worker held, one job runs and two wait: the rest are refused.
    let mut pending = Vec::new();
    for _ in 0..6 {
        let (s2, body) = (s.clone(), hdr.clone());
        pending.push(tokio::spawn(
            async move { s2.tonemap("gpu=false", body).await },
        ));
        tokio::time::sleep(Duration::from_millis(150)).await;
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    let (_, health) = s.json("/api/v1/healthz").await;
    assert_eq!(health["cpu_queue"]["depth"], 3, "{health}");
    drop(guard);
    let mut ok = 0;
    let mut busy = 0;
    for p in pending {
        let r = p.await.unwrap();
        match r.status() {
            StatusCode::OK => ok += 1,
            StatusCode::SERVICE_UNAVAILABLE => {
                let retry: u64 = r.headers()["retry-after"]
                    .to_str()
                    .unwrap()
                    .parse()
                    .unwrap();
                assert!(retry >= 1);
                expect_error(r, StatusCode::SERVICE_UNAVAILABLE, "busy").await;
                busy += 1;
            }
            other => panic!("unexpected {other}"),
        }
    }
    assert_eq!((ok, busy), (3, 3));
    let metrics = s.get("/metrics").await.text().await.unwrap();
    assert!(
        metrics.contains("tonegate_tonemap_rejected_total{queue=\"cpu\"} 3"),
        "{metrics}"
    );
    // The GPU queue is separate and was never full.
    assert!(
        metrics.contains("tonegate_tonemap_rejected_total{queue=\"gpu\"} 0"),
        "{metrics}"
    );

    // A request that cannot finish in time gets 503 "timeout"; the worker
    // skips its abandoned job.
    let s = start(&seeded, |o| {
        o.limits.timeout = Duration::from_secs(1);
        o.hold_workers = Some(hold.clone());
    })
    .await;
    let guard = hold_workers(&hold);
    let r = s.tonemap("gpu=false", hdr.clone()).await;
    let retry = r.headers().get("retry-after").cloned();
    expect_error(r, StatusCode::SERVICE_UNAVAILABLE, "timeout").await;
    assert!(retry.is_some());
    drop(guard);
    assert_eq!(s.tonemap("gpu=false", hdr).await.status(), StatusCode::OK);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn runs_need_the_token_and_go_one_at_a_time() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |_| {}).await;
    let post = |auth: Option<&str>, body: &str| {
        let mut r = s
            .client
            .post(format!("{}/api/v1/runs", s.base))
            .header("content-type", "application/json")
            .body(body.to_owned());
        if let Some(a) = auth {
            r = r.header("authorization", a);
        }
        r.send()
    };
    let r = post(None, "{}").await.unwrap();
    assert_eq!(r.headers()["www-authenticate"], "Bearer realm=\"tonegate\"");
    expect_error(r, StatusCode::UNAUTHORIZED, "unauthorized").await;
    expect_error(
        post(Some("Bearer wrong"), "{}").await.unwrap(),
        StatusCode::FORBIDDEN,
        "forbidden",
    )
    .await;
    let bearer = format!("Bearer {TOKEN}");
    for bad in [
        r#"{"spp": 0}"#,
        r#"{"sp": 1}"#,
        r#"{"renderer": "tpu"}"#,
        "{",
    ] {
        let r = post(Some(&bearer), bad).await.unwrap();
        expect_error(r, StatusCode::BAD_REQUEST, "bad_parameter").await;
    }
    let r = post(Some(&format!("Bearer {TOKEN}")), "").await.unwrap();
    assert_eq!(r.status(), StatusCode::ACCEPTED);
    let started: serde_json::Value = r.json().await.unwrap();
    let id = started["id"].as_i64().unwrap();
    expect_error(
        post(Some(&format!("Bearer {TOKEN}")), "{}").await.unwrap(),
        StatusCode::CONFLICT,
        "conflict",
    )
    .await;
    let mut status = String::new();
    for _ in 0..240 {
        let (_, v) = s.json(&format!("/api/v1/runs/{id}")).await;
        status = v["run"]["status"].as_str().unwrap().to_owned();
        if status != "running" {
            assert!(v["report"]["scenes"].as_array().unwrap().len() == 2);
            break;
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
    assert_eq!(status, "passed");
    // The slot is free again.
    let r = post(
        Some(&format!("Bearer {TOKEN}")),
        "{\"renderer\": \"cpu\", \"spp\": 16}",
    )
    .await
    .unwrap();
    assert_eq!(r.status(), StatusCode::ACCEPTED);

    // Reads can be closed too.
    let s = start(&seeded, |o| o.private_reads = true).await;
    expect_error(
        s.get("/api/v1/runs").await,
        StatusCode::UNAUTHORIZED,
        "unauthorized",
    )
    .await;
    let r = s
        .client
        .get(format!("{}/api/v1/runs", s.base))
        .bearer_auth(TOKEN)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::OK);
}

/// An image the GPU cannot hold is refused from its header, before it is
/// decoded: a 30 Mpx upload (over lavapipe's buffer limit) used to be
/// decoded for 2.2 s and then refused. The files here are headers whose
/// pixels never come, so an upload that was decoded would fail as truncated
/// (422), not 413.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_image_the_gpu_cannot_hold_is_refused_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| o.limits.max_pixels = 64 << 20).await;
    // The device opens with the first GPU job.
    let small = common::hdr_bytes(dir.path(), 16, 8);
    assert_eq!(s.tonemap("gpu=true", small).await.status(), StatusCode::OK);
    let header = |w: u32, h: u32| {
        format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes()
    };
    for (w, h) in [(6000, 5000), (40_000, 1)] {
        let r = s.tonemap("gpu=true", header(w, h)).await;
        let status = r.status();
        let text = r.text().await.unwrap();
        assert_eq!(status, StatusCode::PAYLOAD_TOO_LARGE, "{w}x{h}: {text}");
        assert!(
            text.contains("\"too_large\"") && text.contains("does not fit the GPU"),
            "{w}x{h}: {text}"
        );
        // On the CPU the same header is decoded, and found truncated.
        let r = s.tonemap("gpu=false", header(w, h)).await;
        assert_eq!(r.status(), StatusCode::UNPROCESSABLE_ENTITY, "{w}x{h}");
    }
}

/// The backticked words of `text`.
fn backticked(text: &str) -> Vec<String> {
    text.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_owned)
        .collect()
}

/// The text of docs/api.md's endpoint row for `endpoint`.
fn api_row(endpoint: &str) -> String {
    let doc = std::fs::read_to_string(common::repo().join("docs/api.md")).unwrap();
    doc.lines()
        .find(|l| l.starts_with(&format!("| `GET /api/v1/{endpoint}")))
        .unwrap_or_else(|| panic!("docs/api.md has no row for {endpoint}"))
        .to_owned()
}

/// The keys inside the parentheses that follow `after` in `row`, past a
/// `name:` label if there is one.
fn keys_after(row: &str, after: &str) -> Vec<String> {
    let start = row
        .find(after)
        .unwrap_or_else(|| panic!("no {after:?} in {row}"))
        + after.len();
    let inside = &row[start..start + row[start..].find(')').unwrap()];
    let inside = inside.split_once("`:").map_or(inside, |(_, rest)| rest);
    backticked(inside)
}

fn object_keys(v: &serde_json::Value) -> Vec<String> {
    let mut k: Vec<String> = v
        .as_object()
        .unwrap_or_else(|| panic!("not an object: {v}"))
        .keys()
        .cloned()
        .collect();
    k.sort();
    k
}

fn sorted(mut v: Vec<String>) -> Vec<String> {
    v.sort();
    v.dedup();
    v
}

/// The schema `name`'s property names in the OpenAPI document.
fn schema_keys(openapi: &serde_json::Value, name: &str) -> Vec<String> {
    object_keys(&openapi["components"]["schemas"][name]["properties"])
}

/// What docs/api.md says the matrix and the operator list hold is what they
/// hold: every key the page names is in the answer, the answer has no key
/// the page does not name, and the OpenAPI document declares the same.
#[tokio::test]
async fn the_api_page_names_exactly_the_keys_the_answers_have() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed(dir.path());
    let s = start(&seeded, |_| {}).await;
    let (_, openapi) = s.json("/api/v1/openapi.json").await;

    let row = api_row("matrix");
    let (st, m) = s.json("/api/v1/matrix").await;
    assert_eq!(st, StatusCode::OK);
    let column = sorted(keys_after(&row, "a column ("));
    let cell = sorted(keys_after(&row, "a cell ("));
    assert_eq!(object_keys(&m["adapters"][0]), column, "{row}");
    assert_eq!(object_keys(&m["cells"][0]), cell, "{row}");
    // The top level: the words outside the parentheses, and the column
    // list's own name, less the query parameter.
    let mut outside = String::new();
    let mut depth = 0;
    for c in row.split_once("| the adapter matrix").unwrap().1.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            _ if depth == 0 => outside.push(c),
            _ => {}
        }
    }
    let mut top = backticked(&outside);
    // A parenthesis that starts with "`name`:" names a key of the top level.
    for part in row.split("(`").skip(1) {
        if let Some((label, _)) = part.split_once("`:") {
            top.push(label.to_owned());
        }
    }
    top.retain(|k| k != "limit");
    assert_eq!(object_keys(&m), sorted(top), "{row}");
    for (schema, keys) in [
        ("Matrix", object_keys(&m)),
        ("MatrixAdapter", column),
        ("MatrixCell", cell),
    ] {
        assert_eq!(schema_keys(&openapi, schema), keys, "OpenAPI {schema}");
    }

    let row = api_row("operators");
    let (_, ops) = s.json("/api/v1/operators").await;
    let ops = ops.as_array().unwrap();
    let said = backticked(row.split_once("prints):").unwrap().1);
    let (op_keys, rest) = said.split_at(said.iter().position(|k| k == "params").unwrap() + 1);
    let param_keys: Vec<String> = rest
        .iter()
        .take_while(|k| *k != "hdr_output")
        .cloned()
        .collect();
    let mut op_keys = op_keys.to_vec();
    op_keys.push("hdr_output".into());
    for op in ops {
        let keys = object_keys(op);
        assert_eq!(keys, sorted(op_keys.clone()), "{}: {row}", op["name"]);
        for p in op["params"].as_array().unwrap() {
            // `range` or `words`, as the kind has.
            for k in object_keys(p) {
                assert!(
                    param_keys.contains(&k),
                    "{}.{}: {k} not on the page",
                    op["name"],
                    p["name"]
                );
            }
            for k in &param_keys {
                if k != "range" && k != "words" {
                    assert!(p.get(k).is_some(), "{}.{}: no {k}", op["name"], p["name"]);
                }
            }
        }
    }
}

/// As many clients as the queue has places, each sending its next request
/// the moment it has its answer, never meet a full queue: a place is free
/// before its answer leaves.
#[tokio::test]
async fn clients_up_to_the_capacity_never_get_busy() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = Arc::new(
        start(&seeded, |o| {
            o.limits.queue = 1;
        })
        .await,
    );
    let hdr = common::hdr_bytes(dir.path(), 8, 4);
    // queue = 1: one job waits besides the one running, so two places.
    let clients: Vec<_> = (0..2)
        .map(|_| {
            let (s, hdr) = (s.clone(), hdr.clone());
            tokio::spawn(async move {
                let mut codes = Vec::new();
                for _ in 0..60 {
                    codes.push(s.tonemap("gpu=false", hdr.clone()).await.status());
                }
                codes
            })
        })
        .collect();
    for c in clients {
        let codes = c.await.unwrap();
        let busy = codes.iter().filter(|c| **c != StatusCode::OK).count();
        assert_eq!(busy, 0, "{codes:?}");
    }
}

/// A job id is 1 or more: `job=-1` and `job=0` are refused as a huge id is,
/// not answered with an empty list.
#[tokio::test]
async fn a_job_id_below_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |_| {}).await;
    for bad in ["-1", "0"] {
        let d = expect_error(
            s.get(&format!("/api/v1/queue?job={bad}")).await,
            StatusCode::BAD_REQUEST,
            "bad_parameter",
        )
        .await;
        assert!(d.contains("job") && d.contains(bad), "{bad}: {d}");
    }
    let (st, _) = s.json("/api/v1/queue?job=1").await;
    assert_eq!(st, StatusCode::OK);
}
