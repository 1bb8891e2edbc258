//! `GET /metrics`: Prometheus text format, every name prefixed `tonegate_`.
//! Request counters are kept here; run figures are read from the history at
//! scrape time (the latest finished check run's per-scene numbers).

use super::AppState;
use crate::history::{RunKind, RunStatus};
use axum::extract::{MatchedPath, Request, State};
use axum::http::header;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use std::collections::BTreeMap;
use std::fmt::Write;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

#[derive(Default)]
pub struct Requests {
    /// (route, method, status) → count.
    counts: Mutex<BTreeMap<(String, String, u16), u64>>,
    /// route → (seconds summed, count).
    seconds: Mutex<BTreeMap<String, (f64, u64)>>,
    /// Connections accepted past the cap (answered briefly or closed).
    over_capacity: std::sync::atomic::AtomicU64,
}

impl Requests {
    pub fn note_over_capacity(&self) {
        self.over_capacity.fetch_add(1, Ordering::Relaxed);
    }
}

/// Middleware: counts every answer by route template, method and status.
pub async fn track(State(st): State<Arc<AppState>>, req: Request, next: Next) -> Response {
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map(|p| p.as_str().to_owned())
        .unwrap_or_else(|| "unmatched".into());
    let method = method_label(req.method()).to_owned();
    let start = std::time::Instant::now();
    let r = next.run(req).await;
    let secs = start.elapsed().as_secs_f64();
    let status = r.status().as_u16();
    if let Ok(mut c) = st.requests.counts.lock() {
        *c.entry((route.clone(), method, status)).or_default() += 1;
    }
    if let Ok(mut s) = st.requests.seconds.lock() {
        let e = s.entry(route).or_default();
        e.0 += secs;
        e.1 += 1;
    }
    r
}

/// The method as a label: the standard ones by name, anything a client made
/// up as `other`, so a label set can never grow with what clients send.
fn method_label(m: &axum::http::Method) -> &'static str {
    use axum::http::Method;
    match *m {
        Method::GET => "GET",
        Method::POST => "POST",
        Method::PUT => "PUT",
        Method::DELETE => "DELETE",
        Method::HEAD => "HEAD",
        Method::OPTIONS => "OPTIONS",
        Method::PATCH => "PATCH",
        Method::CONNECT => "CONNECT",
        Method::TRACE => "TRACE",
        _ => "other",
    }
}

fn esc(v: &str) -> String {
    v.replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

fn head(out: &mut String, name: &str, kind: &str, help: &str) {
    let _ = writeln!(out, "# HELP tonegate_{name} {help}");
    let _ = writeln!(out, "# TYPE tonegate_{name} {kind}");
}

/// The process's resident memory, from /proc (Linux).
pub fn resident_bytes() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096)
}

/// The metrics hold run results, so under `--private-reads` they need the token.
pub async fn metrics(
    State(st): State<Arc<AppState>>,
    headers: axum::http::HeaderMap,
) -> Result<Response, super::error::ApiError> {
    st.authorize_read(&headers)?;
    let mut out = String::new();
    head(
        &mut out,
        "http_requests_total",
        "counter",
        "HTTP answers by route, method and status.",
    );
    if let Ok(c) = st.requests.counts.lock() {
        for ((route, method, status), n) in c.iter() {
            let _ = writeln!(
                out,
                "tonegate_http_requests_total{{route=\"{}\",method=\"{method}\",status=\"{status}\"}} {n}",
                esc(route)
            );
        }
    }
    head(
        &mut out,
        "connections_over_capacity_total",
        "counter",
        "Connections accepted past serve --max-connections (health checks and 503s only).",
    );
    let _ = writeln!(
        out,
        "tonegate_connections_over_capacity_total {}",
        st.requests.over_capacity.load(Ordering::Relaxed)
    );
    head(
        &mut out,
        "http_request_duration_seconds",
        "summary",
        "Time to answer, by route.",
    );
    if let Ok(s) = st.requests.seconds.lock() {
        for (route, (sum, n)) in s.iter() {
            let r = esc(route);
            let _ = writeln!(
                out,
                "tonegate_http_request_duration_seconds_sum{{route=\"{r}\"}} {sum}"
            );
            let _ = writeln!(
                out,
                "tonegate_http_request_duration_seconds_count{{route=\"{r}\"}} {n}"
            );
        }
    }
    for (name, kind, help, get) in [
        (
            "tonemap_queue_depth",
            "gauge",
            "Tone-map jobs queued or running.",
            0,
        ),
        (
            "tonemap_queue_capacity",
            "gauge",
            "Tone-map jobs the queue holds before answering 503.",
            1,
        ),
        (
            "tonemap_accepted_total",
            "counter",
            "Tone-map requests given a place in the queue.",
            2,
        ),
        (
            "tonemap_rejected_total",
            "counter",
            "Tone-map requests answered 503 because the queue was full.",
            3,
        ),
        (
            "tonemap_succeeded_total",
            "counter",
            "Tone-map jobs that produced an image.",
            4,
        ),
        (
            "tonemap_failed_total",
            "counter",
            "Tone-map jobs that ended in an error (bad image, GPU error).",
            5,
        ),
        (
            "tonemap_abandoned_total",
            "counter",
            "Tone-map jobs stopped (before they started or between stages) because the request timed out or the client left.",
            6,
        ),
        (
            "tonemap_busy_seconds_total",
            "counter",
            "Time the tone-map worker spent on jobs.",
            7,
        ),
    ] {
        head(&mut out, name, kind, help);
        for q in [&st.gpu, &st.cpu] {
            let s = &q.stats;
            let v = match get {
                0 => q.depth() as f64,
                1 => q.capacity() as f64,
                2 => s.accepted.load(Ordering::Relaxed) as f64,
                3 => s.rejected.load(Ordering::Relaxed) as f64,
                4 => s.succeeded.load(Ordering::Relaxed) as f64,
                5 => s.failed.load(Ordering::Relaxed) as f64,
                6 => s.abandoned.load(Ordering::Relaxed) as f64,
                _ => s.busy_us.load(Ordering::Relaxed) as f64 / 1e6,
            };
            let _ = writeln!(out, "tonegate_{name}{{queue=\"{}\"}} {v}", q.name);
        }
    }
    let (open, held) = st.uploads.now();
    for (name, kind, help, v) in [
        (
            "tonemap_uploads",
            "gauge",
            "Tone-map bodies being received.",
            open as f64,
        ),
        (
            "tonemap_upload_bytes",
            "gauge",
            "Bytes the tone-map bodies being received hold.",
            held as f64,
        ),
        (
            "tonemap_uploads_refused_total",
            "counter",
            "Tone-map bodies refused (503) for serve --max-uploads or --upload-budget-mib.",
            st.uploads.refused.load(Ordering::Relaxed) as f64,
        ),
    ] {
        head(&mut out, name, kind, help);
        let _ = writeln!(out, "tonegate_{name} {v}");
    }
    if let Some(rss) = resident_bytes() {
        head(
            &mut out,
            "process_resident_memory_bytes",
            "gauge",
            "Resident memory of the server process.",
        );
        let _ = writeln!(out, "tonegate_process_resident_memory_bytes {rss}");
    }
    match super::params::read(&st, history_metrics).await {
        Ok(text) => out.push_str(&text),
        Err(e) => {
            let _ = writeln!(out, "# history unreadable: {}", esc(&e.detail));
        }
    }
    Ok((
        [(
            header::CONTENT_TYPE,
            "text/plain; version=0.0.4; charset=utf-8",
        )],
        out,
    )
        .into_response())
}

/// Run counts, and the latest finished check run's scene figures.
fn history_metrics(h: &crate::history::History) -> Result<String, crate::history::HistoryError> {
    let mut out = String::new();
    head(&mut out, "runs", "gauge", "Runs in the history, by status.");
    for (status, n) in h.status_counts()? {
        let _ = writeln!(out, "tonegate_runs{{status=\"{status}\"}} {n}");
    }
    head(
        &mut out,
        "jobs",
        "gauge",
        "Queued check runs of a fleet, by state.",
    );
    for (state, n) in h.job_counts()? {
        let _ = writeln!(out, "tonegate_jobs{{state=\"{}\"}} {n}", esc(&state));
    }
    head(
        &mut out,
        "runners",
        "gauge",
        "The fleet's registered runners, by state.",
    );
    let mut by_state = std::collections::BTreeMap::<String, usize>::new();
    for r in h.runners(true)? {
        *by_state.entry(r.state).or_default() += 1;
    }
    for (state, n) in by_state {
        let _ = writeln!(out, "tonegate_runners{{state=\"{}\"}} {n}", esc(&state));
    }
    let Some(last) = h.runs(200)?.into_iter().find(|r| {
        r.kind == RunKind::Check && matches!(r.status, RunStatus::Passed | RunStatus::Failed)
    }) else {
        return Ok(out);
    };
    let adapter = esc(last.adapter.as_deref().unwrap_or(""));
    head(
        &mut out,
        "last_run_id",
        "gauge",
        "The latest finished check run.",
    );
    let _ = writeln!(out, "tonegate_last_run_id {}", last.id);
    head(
        &mut out,
        "last_run_passed",
        "gauge",
        "1 when the latest finished check run passed.",
    );
    let _ = writeln!(
        out,
        "tonegate_last_run_passed{{adapter=\"{adapter}\"}} {}",
        u8::from(last.status == RunStatus::Passed)
    );
    for (metric, name, help) in [
        (
            "fps",
            "scene_fps",
            "Frames per second with readback, latest run.",
        ),
        (
            "psnr",
            "scene_worst_psnr_db",
            "Worst frame's PSNR against the golden, latest run (+Inf when identical).",
        ),
        (
            "ssim",
            "scene_worst_ssim",
            "Worst frame's SSIM against the golden, latest run.",
        ),
    ] {
        head(&mut out, name, "gauge", help);
        let points = h.trend(
            metric,
            &crate::history::TrendFilter {
                before: Some(last.id + 1),
                limit: 1,
                ..Default::default()
            },
        )?;
        for p in points.iter().filter(|p| p.run_id == last.id) {
            let v = if p.value == f64::INFINITY {
                "+Inf".to_string()
            } else {
                p.value.to_string()
            };
            let _ = writeln!(
                out,
                "tonegate_{name}{{scene=\"{}\",adapter=\"{adapter}\"}} {v}",
                esc(&p.scene)
            );
        }
    }
    Ok(out)
}
