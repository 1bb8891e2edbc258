//! The accept loop: HTTP/1.1 connections with a header-read (and keep-alive
//! idle) timeout, a cap on open connections below the process's file limit,
//! and a small overflow lane past the cap that still answers health checks.
//!
//! `axum::serve` has neither timeout nor cap: idle sockets could hold every
//! file descriptor until `accept` failed with EMFILE and health checks timed
//! out. Here a connection past the cap is still accepted, answered at once
//! (health checks as usual, anything else 503 with `Connection: close`), and
//! closed; past the overflow lane's own small cap it is closed unanswered.

use super::error::ApiError;
use super::AppState;
use axum::routing::get;
use axum::Router;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::server::graceful::GracefulShutdown;
use hyper_util::service::TowerToHyperService;
use std::sync::Arc;
use std::time::Duration;
use tokio::net::TcpListener;
use tokio::sync::Semaphore;

/// Connection limits of `serve`.
#[derive(Clone, Debug)]
pub struct ConnLimits {
    /// Open connections served in full; `None`: from the file limit.
    pub max_connections: Option<usize>,
    /// Time a client has to send a request's head, counted from when the
    /// connection opens or its previous answer was written (so it bounds
    /// keep-alive idle time too).
    pub header_timeout: Duration,
    /// After SIGTERM, how long the answers being worked on have to finish
    /// before their connections are cut and the server returns.
    pub shutdown_grace: Duration,
}

impl Default for ConnLimits {
    fn default() -> Self {
        ConnLimits {
            max_connections: None,
            header_timeout: Duration::from_secs(10),
            shutdown_grace: DEFAULT_SHUTDOWN_GRACE,
        }
    }
}

/// The grace answers in progress get at shutdown unless told otherwise:
/// within the 30 s an orchestrator commonly waits after SIGTERM.
pub const DEFAULT_SHUTDOWN_GRACE: Duration = Duration::from_secs(10);

/// File descriptors kept free for everything but client sockets: the
/// history database and its journal, the GPU driver, the suite's files,
/// the overflow lane, logging.
const RESERVED_FDS: u64 = 64;
/// Connections answered past the cap (health checks, 503s) at one time.
const OVERFLOW: usize = 16;
/// The default cap where the file limit allows it.
const DEFAULT_MAX_CONNECTIONS: u64 = 1024;
/// Largest request head (request line and headers) read; past it the
/// answer is 431 from the HTTP layer. The API's own limits (see
/// `head_limits`) are far below it, so they answer first, in JSON.
pub const MAX_HEAD_BYTES: usize = 64 << 10;
/// Most header fields parsed; past it the answer is 431 from the HTTP layer
/// (the API answers 431 in JSON from `edge::MAX_HEADER_FIELDS` on).
pub const MAX_HEAD_FIELDS: usize = 1000;

/// The soft limit on open files of this process (None where the platform
/// has no such limit to read, or it is unlimited).
#[cfg(not(unix))]
pub fn open_file_limit() -> Option<u64> {
    None
}

/// The soft limit on open files of this process.
#[cfg(unix)]
pub fn open_file_limit() -> Option<u64> {
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes one `rlimit` through a valid pointer.
    let rc = unsafe { libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim) };
    (rc == 0 && lim.rlim_cur != libc::RLIM_INFINITY).then_some(lim.rlim_cur)
}

/// The cap in effect: the one asked for, or 1024, and never more than the
/// file limit leaves after the reserve and the overflow lane.
pub fn connection_cap(asked: Option<usize>, file_limit: Option<u64>) -> Result<usize, String> {
    let room = file_limit.map(|n| n.saturating_sub(RESERVED_FDS + OVERFLOW as u64));
    if room == Some(0) {
        return Err(format!(
            "the open-file limit ({}) leaves no room for connections; raise it (ulimit -n) above {}",
            file_limit.unwrap_or(0),
            RESERVED_FDS + OVERFLOW as u64 + 1
        ));
    }
    let want = asked.map_or(DEFAULT_MAX_CONNECTIONS, |n| n as u64);
    if want == 0 {
        return Err("--max-connections: must be at least 1".into());
    }
    match room {
        Some(r) if want > r => {
            if asked.is_some() {
                tracing::warn!(
                    "--max-connections {want} is more than the open-file limit allows; using {r}"
                );
            }
            Ok(r as usize)
        }
        _ => Ok(want as usize),
    }
}

async fn over_capacity() -> ApiError {
    ApiError::unavailable(
        "busy",
        "the server has as many connections open as it serves (serve --max-connections); try again",
        1,
    )
    .closing()
}

/// What a connection past the cap gets: health checks, and 503 for the rest.
fn overflow_router(st: Arc<AppState>) -> Router {
    Router::new()
        .route("/healthz", get(super::health::healthz))
        .route("/api/v1/healthz", get(super::health::healthz))
        .fallback(over_capacity)
        .with_state(st)
}

fn is_out_of_files(e: &std::io::Error) -> bool {
    matches!(
        e.raw_os_error(),
        Some(libc::EMFILE | libc::ENFILE | libc::ENOBUFS | libc::ENOMEM)
    )
}

/// Serves `app` on `listener` until `shutdown` resolves, then waits for the
/// answers in flight.
pub async fn serve(
    listener: TcpListener,
    app: Router,
    st: Arc<AppState>,
    limits: &ConnLimits,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let cap =
        connection_cap(limits.max_connections, open_file_limit()).map_err(std::io::Error::other)?;
    tracing::info!(
        "serving up to {cap} connections (header timeout {} s)",
        limits.header_timeout.as_secs_f64()
    );
    let full = Arc::new(Semaphore::new(cap));
    let spare = Arc::new(Semaphore::new(OVERFLOW));
    let overflow = overflow_router(st.clone());
    let graceful = GracefulShutdown::new();
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new())
        .header_read_timeout(limits.header_timeout)
        .max_buf_size(MAX_HEAD_BYTES)
        .max_headers(MAX_HEAD_FIELDS);
    let mut brief = http.clone();
    brief
        .keep_alive(false)
        .header_read_timeout(limits.header_timeout.min(Duration::from_secs(2)));
    tokio::pin!(shutdown);
    let mut warned = false;
    loop {
        let accepted = tokio::select! {
            () = &mut shutdown => break,
            a = listener.accept() => a,
        };
        let (stream, peer) = match accepted {
            Ok((stream, peer)) => (stream, peer),
            Err(e) if is_out_of_files(&e) => {
                // Only another process can be holding them (our own sockets
                // stay under the cap); wait for some to close.
                if !warned {
                    tracing::warn!("accept: {e}; waiting for file descriptors");
                    warned = true;
                }
                tokio::time::sleep(Duration::from_millis(50)).await;
                continue;
            }
            // A connection that died before it was accepted.
            Err(_) => continue,
        };
        warned = false;
        let _ = stream.set_nodelay(true);
        let (permit, builder, service) = if let Ok(p) = full.clone().try_acquire_owned() {
            (p, &http, app.clone())
        } else if let Ok(p) = spare.clone().try_acquire_owned() {
            st.requests.note_over_capacity();
            (p, &brief, overflow.clone())
        } else {
            st.requests.note_over_capacity();
            continue; // dropped: closed unanswered
        };
        // Each request knows its connection's peer (uploads are bounded per
        // client).
        let service = service.layer(axum::Extension(super::uploads::Peer(peer.ip())));
        let conn =
            builder.serve_connection(TokioIo::new(stream), TowerToHyperService::new(service));
        let conn = graceful.watch(conn);
        tokio::spawn(async move {
            // Errors here are the client's (reset, timeout, bad head): the
            // HTTP layer has answered what could be answered.
            let _ = conn.await;
            drop(permit);
        });
    }
    drop(listener);
    // Uploads still arriving are cut off (answered 503, connection closed)
    // rather than waited for; answers being worked on finish.
    st.closing.send_replace(true);
    // Bounded: work that outlasts the grace is cut with its connection
    // (blocking work still running is left to the process's exit).
    if tokio::time::timeout(limits.shutdown_grace, graceful.shutdown())
        .await
        .is_err()
    {
        tracing::warn!(
            "shutdown: answers still in progress after {} s were cut",
            limits.shutdown_grace.as_secs_f64()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::StatusCode;

    #[test]
    fn the_cap_stays_below_the_file_limit() {
        assert_eq!(connection_cap(None, None), Ok(1024));
        assert_eq!(connection_cap(None, Some(1 << 20)), Ok(1024));
        assert_eq!(connection_cap(None, Some(256)), Ok(256 - 64 - 16));
        assert_eq!(connection_cap(Some(10), Some(256)), Ok(10));
        assert_eq!(connection_cap(Some(5000), Some(256)), Ok(176));
        assert!(connection_cap(Some(0), Some(256)).is_err());
        let e = connection_cap(None, Some(60)).unwrap_err();
        assert!(e.contains("open-file limit (60)"), "{e}");
    }

    #[test]
    fn the_overflow_answer_closes_the_connection() {
        use axum::response::IntoResponse;
        let r = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap()
            .block_on(over_capacity())
            .into_response();
        assert_eq!(r.status(), StatusCode::SERVICE_UNAVAILABLE);
        assert_eq!(r.headers()["connection"], "close");
        assert!(r.headers().contains_key("retry-after"));
    }
}
