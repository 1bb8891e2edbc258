//! A webhook whose receiver never answers delays no other: deliveries go
//! out in tasks of their own, a few at a time per webhook. Three gate-red
//! events (runs recorded through the history's writer) reach a healthy
//! receiver while every request to the stuck one is still open, and the
//! stuck one's attempts are logged as timeouts once its limit passes.
//! When deliveries were made one after another, the first stuck request
//! held every other for its whole timeout.

use crate::common;
use axum::extract::State;
use axum::http::StatusCode;
use axum::routing::post;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

#[derive(Default)]
struct Seen {
    healthy: AtomicUsize,
    stuck_open: AtomicUsize,
}

async fn healthy(State(s): State<Arc<Seen>>) -> StatusCode {
    s.healthy.fetch_add(1, Ordering::SeqCst);
    StatusCode::NO_CONTENT
}

/// Holds the request open far past the alerts' timeout.
async fn stuck(State(s): State<Arc<Seen>>) -> StatusCode {
    s.stuck_open.fetch_add(1, Ordering::SeqCst);
    tokio::time::sleep(Duration::from_secs(600)).await;
    StatusCode::NO_CONTENT
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_receiver_that_never_answers_delays_no_other_webhook() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let seen = Arc::new(Seen::default());
    let app = axum::Router::new()
        .route("/healthy", post(healthy))
        .route("/stuck", post(stuck))
        .with_state(seen.clone());
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let hook = format!("http://{}", listener.local_addr().unwrap());
    tokio::spawn(async move { axum::serve(listener, app).await });
    std::fs::write(
        dir.path().join("hook.secret"),
        "stuck-test-secret-0123456789abcdef\n",
    )
    .unwrap();
    // The stuck receiver's requests time out after 8 s: far longer than the
    // healthy deliveries need, so the order below is not a race.
    let file = dir.path().join("alerts.toml");
    std::fs::write(
        &file,
        format!(
            "public_url = \"http://tonegate.test:8080\"\nscan_seconds = 0.2\ntimeout_seconds = 8\n\
             [retry]\nfirst_seconds = 60\nmost_attempts = 2\n\
             [[webhook]]\nname = \"stuck\"\nurl = \"{hook}/stuck\"\nsecret_file = \"hook.secret\"\n\
             [[webhook]]\nname = \"team\"\nurl = \"{hook}/healthy\"\nsecret_file = \"hook.secret\"\n"
        ),
    )
    .unwrap();
    let alerts = tonegate::alerts::Alerts::load(&file).unwrap();
    let s = common::server::start(&seeded, |o| o.alerts = Some(alerts)).await;
    // The first scan sets where alerts start.
    tokio::time::sleep(Duration::from_millis(600)).await;
    common::runs::record_red_after_green(&seeded.db);

    let deadline = Instant::now() + Duration::from_secs(120);
    while seen.healthy.load(Ordering::SeqCst) < 3 {
        assert!(Instant::now() < deadline, "the healthy webhook never got 3");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // Every event reached the healthy receiver while the stuck one still
    // held its requests: no stuck attempt has ended yet.
    let (_, log) = s.json("/api/v1/alerts").await;
    let stuck_attempts: usize = log
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|a| a["deliveries"].as_array().unwrap().iter())
        .filter(|d| d["webhook"] == "stuck")
        .map(|d| d["attempts"].as_array().unwrap().len())
        .sum();
    assert_eq!(stuck_attempts, 0, "{log:#}");
    assert!(seen.stuck_open.load(Ordering::SeqCst) >= 1);
    // Then the stuck attempts end, logged as timeouts.
    let timed_out = loop {
        let (_, log) = s.json("/api/v1/alerts").await;
        let errors: Vec<String> = log
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|a| a["deliveries"].as_array().unwrap().iter())
            .filter(|d| d["webhook"] == "stuck")
            .flat_map(|d| d["attempts"].as_array().unwrap().iter())
            .map(|a| a["error"].as_str().unwrap_or("").to_owned())
            .collect();
        if errors.len() >= 3 {
            break errors;
        }
        assert!(Instant::now() < deadline, "no stuck attempt ended: {log:#}");
        tokio::time::sleep(Duration::from_millis(200)).await;
    };
    assert!(
        timed_out.iter().all(|e| e.contains("timed out")),
        "{timed_out:?}"
    );
}
