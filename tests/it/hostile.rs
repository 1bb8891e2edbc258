//! The server against a hostile but fair client: each test here is one of
//! the defects such a client found on a4e9bd9 (2026-11-21), and fails without
//! its fix. Servers run in-process on loopback, or as the real binary where
//! the process's own limits (open files, user) are the point.

use crate::common;
use crate::common::server as harness;

use harness::{expect_error, hold_workers, start, TOKEN};
use reqwest::StatusCode;
use std::io::{BufRead, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, RwLock};
use std::time::{Duration, Instant};

/// `tonegate serve` as a child process, killed on drop.
pub(crate) struct Served {
    pub(crate) child: Child,
    pub(crate) addr: SocketAddr,
    pub(crate) log: PathBuf,
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `--db` and `--suite` of a seeded history, then `more`.
pub(crate) fn history_args<'a>(seeded: &'a common::Seeded, more: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "--db",
        seeded.db.to_str().unwrap(),
        "--suite",
        seeded.suite.to_str().unwrap(),
    ];
    args.extend_from_slice(more);
    args
}

/// How to start the binary.
#[derive(Default)]
pub(crate) struct Launch<'a> {
    pub(crate) args: Vec<&'a str>,
    /// Soft and hard limit on open files.
    pub(crate) nofile: Option<u64>,
    /// Run as `nobody` (when the tests run as root, where permissions bind nobody).
    pub(crate) as_nobody: bool,
    /// RUST_LOG for the server (default "warn").
    pub(crate) log: Option<&'a str>,
}

const AS_NOBODY: [&str; 3] = ["--reuid=65534", "--regid=65534", "--clear-groups"];

/// The binary as `nobody` can run it: in place when every folder above it
/// lets others through, else a copy in `dir`.
fn binary_for_nobody(dir: &Path) -> PathBuf {
    let bin = PathBuf::from(env!("CARGO_BIN_EXE_tonegate"));
    let runs = Command::new("setpriv")
        .args(AS_NOBODY)
        .arg(&bin)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if runs {
        return bin;
    }
    let copy = dir.join("tonegate-for-nobody");
    if !copy.exists() {
        std::fs::copy(&bin, &copy).unwrap();
        chmod(&copy, 0o755);
    }
    copy
}

fn command(launch: &Launch<'_>, dir: &Path) -> Command {
    let bin = env!("CARGO_BIN_EXE_tonegate");
    let mut cmd = if launch.as_nobody {
        let mut c = Command::new("setpriv");
        c.args(AS_NOBODY).arg(binary_for_nobody(dir));
        c
    } else {
        Command::new(bin)
    };
    cmd.arg("serve")
        .args(["--bind", "127.0.0.1:0"])
        .args(&launch.args)
        .current_dir(dir)
        .env_remove("TONEGATE_DB")
        .env("RUST_LOG", launch.log.unwrap_or("warn"));
    if let Some(n) = launch.nofile {
        use std::os::unix::process::CommandExt;
        // SAFETY: only setrlimit, which is async-signal-safe, runs between
        // fork and exec.
        unsafe {
            cmd.pre_exec(move || {
                let lim = libc::rlimit {
                    rlim_cur: n,
                    rlim_max: n,
                };
                if libc::setrlimit(libc::RLIMIT_NOFILE, &lim) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
    }
    cmd
}

/// Starts the binary and waits for its "serving http://ADDR/" line; the
/// error is the exit status and the log when it stops instead.
pub(crate) fn serve(launch: &Launch<'_>, dir: &Path) -> Result<Served, (i32, String)> {
    let log = dir.join(format!("serve-{}.log", std::process::id()));
    let mut child = command(launch, dir)
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .expect("tonegate serve starts");
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = std::io::BufReader::new(stdout).read_line(&mut line);
        let _ = tx.send(line);
    });
    let line = rx.recv_timeout(Duration::from_secs(60)).unwrap_or_default();
    let addr = line
        .split("http://")
        .nth(1)
        .and_then(|s| s.split('/').next())
        .and_then(|s| s.parse().ok());
    match addr {
        Some(addr) => Ok(Served { child, addr, log }),
        None => {
            let _ = child.kill();
            let status = child.wait().unwrap();
            Err((
                status.code().unwrap_or(-1),
                std::fs::read_to_string(&log).unwrap_or_default(),
            ))
        }
    }
}

/// One request on a fresh connection; the status line, the headers (lower
/// case) and the body, or the I/O error.
fn raw(addr: SocketAddr, request: &str) -> std::io::Result<(String, String, String)> {
    let mut s = TcpStream::connect(addr)?;
    s.set_read_timeout(Some(Duration::from_secs(10)))?;
    s.write_all(request.as_bytes())?;
    let mut text = Vec::new();
    s.read_to_end(&mut text)?;
    let text = String::from_utf8_lossy(&text).into_owned();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    let (status, headers) = head.split_once("\r\n").unwrap_or((head, ""));
    Ok((status.into(), headers.to_lowercase(), body.into()))
}

fn get(addr: SocketAddr, path: &str) -> std::io::Result<(String, String, String)> {
    raw(
        addr,
        &format!("GET {path} HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n"),
    )
}

fn running_as_root() -> bool {
    // SAFETY: geteuid has no preconditions.
    unsafe { libc::geteuid() == 0 }
}

fn chmod(path: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
}

/// Defect 1: with `ulimit -n 256`, 300 idle sockets made accept fail with
/// EMFILE and health checks time out. Now the cap stays under the file
/// limit, health checks are answered past it, and idle sockets are closed
/// after the header timeout.
#[test]
fn idle_sockets_past_the_file_limit_do_not_stop_health_checks() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let launch = Launch {
        args: history_args(&seeded, &["--header-timeout", "4"]),
        nofile: Some(256),
        ..Default::default()
    };
    let s = serve(&launch, dir.path()).unwrap_or_else(|e| panic!("{e:?}"));
    let idle: Vec<TcpStream> = (0..300)
        .map(|_| TcpStream::connect(s.addr).unwrap())
        .collect();
    // The overflow lane holds a silent socket at most 2 s.
    std::thread::sleep(Duration::from_millis(2500));
    let started = Instant::now();
    let (status, _, body) = get(s.addr, "/healthz").expect("healthz answers at the cap");
    assert!(status.contains(" 200 "), "{status} {body}");
    assert!(started.elapsed() < Duration::from_secs(2));
    let (status, headers, body) = get(s.addr, "/api/v1/runs").unwrap();
    assert!(status.contains(" 503 "), "{status} {body}");
    assert!(headers.contains("connection: close"), "{headers}");
    assert!(
        body.contains("\"busy\"") && body.contains("max-connections"),
        "{body}"
    );
    // Past the header timeout the idle sockets are closed by the server ...
    std::thread::sleep(Duration::from_secs(3));
    let mut closed = 0;
    for mut sock in idle {
        sock.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let mut b = [0u8; 64];
        if matches!(sock.read(&mut b), Ok(0) | Err(_)) {
            closed += 1;
        }
    }
    assert_eq!(closed, 300);
    // ... and the API is back.
    let (status, _, body) = get(s.addr, "/api/v1/runs").unwrap();
    assert!(status.contains(" 200 "), "{status} {body}");
    let log = std::fs::read_to_string(&s.log).unwrap();
    assert!(!log.contains("Too many open files"), "{log}");
}

/// Defect 1, the in-process half: a connection that sends nothing is closed
/// after the header timeout, and the cap asked for is the cap in effect.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_silent_connection_is_closed_and_the_cap_holds() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| {
        o.conn.max_connections = Some(4);
        o.conn.header_timeout = Duration::from_secs(1);
    })
    .await;
    let addr: SocketAddr = s.base.trim_start_matches("http://").parse().unwrap();
    let outcome = tokio::task::spawn_blocking(move || {
        let held: Vec<TcpStream> = (0..4).map(|_| TcpStream::connect(addr).unwrap()).collect();
        std::thread::sleep(Duration::from_millis(200));
        let (over, headers, _) = get(addr, "/api/v1/runs").unwrap();
        let (health, _, _) = get(addr, "/api/v1/healthz").unwrap();
        let started = Instant::now();
        let mut first = &held[0];
        first
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        let n = first.read(&mut [0u8; 8]).unwrap_or(0);
        let closed_after = started.elapsed();
        drop(held);
        std::thread::sleep(Duration::from_millis(1200));
        let (after, _, _) = get(addr, "/api/v1/runs").unwrap();
        (over, headers, health, n, closed_after, after)
    })
    .await
    .unwrap();
    let (over, headers, health, n, closed_after, after) = outcome;
    assert!(over.contains(" 503 "), "{over}");
    assert!(headers.contains("connection: close"), "{headers}");
    assert!(health.contains(" 200 "), "{health}");
    assert_eq!(n, 0, "the silent connection got bytes");
    assert!(closed_after < Duration::from_secs(3), "{closed_after:?}");
    assert!(after.contains(" 200 "), "{after}");
    let metrics = s.get("/metrics").await.text().await.unwrap();
    assert!(
        metrics.contains("tonegate_connections_over_capacity_total 2"),
        "{metrics}"
    );
}

/// Defect 2: every made-up method became a label of its own.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn made_up_methods_and_paths_do_not_grow_the_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |_| {}).await;
    let before = s.get("/metrics").await.text().await.unwrap().len();
    for i in 0..200 {
        let method =
            reqwest::Method::from_bytes(format!("MADEUP{i:04}{}", "X".repeat(200)).as_bytes())
                .unwrap();
        let r = s
            .client
            .request(method, format!("{}/api/v1/runs/no-such-{i}", s.base))
            .send()
            .await
            .unwrap();
        assert!(r.status().is_client_error(), "{}", r.status());
    }
    let metrics = s.get("/metrics").await.text().await.unwrap();
    assert!(
        !metrics.contains("MADEUP"),
        "a client's method became a label"
    );
    assert!(
        !metrics.contains("no-such"),
        "a client's path became a label"
    );
    assert!(metrics.contains("method=\"other\""), "{metrics}");
    // One new series for the made-up requests, a few for the scrapes.
    assert!(
        metrics.len() < before + 1024,
        "{before} -> {}",
        metrics.len()
    );
}

/// healthz says the history at `db` is not writable, naming it, and
/// `POST /runs` is refused with 503 `history_read_only`, naming it too.
fn assert_served_read_only(addr: SocketAddr, db: &Path) {
    let (status, _, body) = get(addr, "/api/v1/healthz").unwrap();
    assert!(status.contains(" 200 "), "{status} {body}");
    let health: serde_json::Value = serde_json::from_str(&body).unwrap();
    assert_eq!(health["history_writable"], false, "{health}");
    let db = db.display().to_string();
    assert!(
        health["history_problem"].as_str().unwrap().contains(&db),
        "{health}"
    );
    let (status, _, body) = raw(
        addr,
        &format!(
            "POST /api/v1/runs HTTP/1.1\r\nHost: t\r\nAuthorization: Bearer {TOKEN}\r\n\
             Content-Type: application/json\r\nContent-Length: 2\r\nConnection: close\r\n\r\n{{}}"
        ),
    )
    .unwrap();
    assert!(status.contains(" 503 "), "{status} {body}");
    assert!(
        body.contains("history_read_only") && body.contains(&db),
        "{body}"
    );
}

/// Defect 3: a read-only history file was only found when a run failed
/// with a 500; a read-only folder gave an error not naming it.
#[test]
fn a_read_only_history_is_reported_and_runs_are_refused_with_the_path() {
    let root = running_as_root();
    let dir = tempfile::tempdir().unwrap();
    chmod(dir.path(), 0o755);
    let seeded = common::seed_empty(dir.path());
    // Make the history (an empty one) as the owner, then serve it as
    // someone who may only read it.
    tonegate::history::History::open(&seeded.db).unwrap();
    assert!(seeded.db.exists());
    let token = dir.path().join("token");
    std::fs::write(&token, TOKEN).unwrap();
    chmod(&token, 0o644);
    if !root {
        chmod(&seeded.db, 0o444);
        chmod(dir.path(), 0o555);
    }
    let launch = Launch {
        args: history_args(&seeded, &["--token-file", token.to_str().unwrap()]),
        as_nobody: root,
        ..Default::default()
    };
    let s = serve(&launch, dir.path()).unwrap_or_else(|e| panic!("{e:?}"));
    assert_served_read_only(s.addr, &seeded.db);
    drop(s);

    // A folder the history cannot be created in: the message names it.
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    chmod(&locked, 0o555);
    let fresh = locked.join("history.sqlite");
    let launch = Launch {
        args: vec![
            "--db",
            fresh.to_str().unwrap(),
            "--suite",
            seeded.suite.to_str().unwrap(),
            "--token-file",
            token.to_str().unwrap(),
        ],
        as_nobody: root,
        ..Default::default()
    };
    let Err((code, log)) = serve(&launch, dir.path()) else {
        panic!("serve started on a history it cannot create");
    };
    assert_eq!(code, 2, "{log}");
    assert!(log.contains(&locked.display().to_string()), "{log}");
    chmod(&locked, 0o755);
    chmod(dir.path(), 0o755);
}

/// A read-only history file in a folder the server may write: healthz said
/// `history_writable: true` and `POST /runs` answered 500 (SQLite opens a
/// file it may not write read-only, silently); with a leftover `running`
/// row, serve exited 2 trying to mark it aborted. Now it is served
/// read-only, says so, and refuses runs with the path.
#[test]
fn a_read_only_history_file_in_a_writable_folder_is_served_read_only() {
    let root = running_as_root();
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let h = tonegate::history::History::open(&seeded.db).unwrap();
    let run = h
        .start_run(tonegate::history::RunKind::Check, &Default::default())
        .unwrap();
    drop(h);
    // The run's process is gone: a crash left it `running`.
    let mut gone = Command::new("true").spawn().unwrap();
    let dead = gone.id();
    gone.wait().unwrap();
    let c = rusqlite::Connection::open(&seeded.db).unwrap();
    c.execute("UPDATE runs SET pid = ?1 WHERE id = ?2", (dead, run))
        .unwrap();
    c.execute_batch("PRAGMA wal_checkpoint(TRUNCATE);").unwrap();
    drop(c);
    let token = dir.path().join("token");
    std::fs::write(&token, TOKEN).unwrap();
    chmod(&token, 0o644);
    if root {
        // Served as nobody: the file stays root's, the folder is anyone's.
        chmod(&seeded.db, 0o644);
        chmod(dir.path(), 0o777);
    } else {
        chmod(&seeded.db, 0o444);
        chmod(dir.path(), 0o755);
    }
    let launch = Launch {
        args: history_args(&seeded, &["--token-file", token.to_str().unwrap()]),
        as_nobody: root,
        ..Default::default()
    };
    let s = serve(&launch, dir.path()).unwrap_or_else(|e| panic!("serve stopped: {e:?}"));
    assert_served_read_only(s.addr, &seeded.db);
    // Reads work, the leftover run among them.
    let (status, _, body) = get(s.addr, &format!("/api/v1/runs/{run}")).unwrap();
    assert!(status.contains(" 200 "), "{status} {body}");
    drop(s);
    chmod(&seeded.db, 0o644);
    chmod(dir.path(), 0o755);
}

/// Defect 4: under private reads, /metrics (which holds run results) and
/// the health details were open. Now: /metrics needs the token; health
/// answers everyone (a liveness probe) but its details only with the token;
/// the OpenAPI document describes the API and holds no results, so it stays
/// open.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn private_reads_cover_metrics_and_health_details() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| o.private_reads = true).await;
    expect_error(
        s.get("/metrics").await,
        StatusCode::UNAUTHORIZED,
        "unauthorized",
    )
    .await;
    let with_token = |path: &str| {
        s.client
            .get(format!("{}{path}", s.base))
            .header("authorization", format!("Bearer {TOKEN}"))
            .send()
    };
    let r = with_token("/metrics").await.unwrap();
    assert_eq!(r.status(), StatusCode::OK);
    assert!(r
        .text()
        .await
        .unwrap()
        .contains("tonegate_http_requests_total"));
    for path in ["/healthz", "/api/v1/healthz"] {
        let (status, open) = s.json(path).await;
        assert_eq!(status, StatusCode::OK);
        let keys: Vec<&String> = open.as_object().unwrap().keys().collect();
        assert_eq!(keys, ["status", "version"], "{open}");
        let full: serde_json::Value = with_token(path).await.unwrap().json().await.unwrap();
        assert!(
            full["runs"].is_number() && full["cpu_queue"].is_object(),
            "{full}"
        );
    }
    let (status, doc) = s.json("/api/v1/openapi.json").await;
    assert_eq!(status, StatusCode::OK);
    assert!(doc["paths"].is_object());
    expect_error(
        s.get("/api/v1/runs").await,
        StatusCode::UNAUTHORIZED,
        "unauthorized",
    )
    .await;
}

/// Defect 5: `bearer`, `BEARER` and a tab were refused.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_auth_scheme_is_case_insensitive() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| o.private_reads = true).await;
    for value in [
        format!("Bearer {TOKEN}"),
        format!("bearer {TOKEN}"),
        format!("BEARER {TOKEN}"),
        format!("Bearer\t{TOKEN}"),
        format!("bEaReR   {TOKEN} "),
    ] {
        let r = s
            .client
            .get(format!("{}/api/v1/runs", s.base))
            .header("authorization", &value)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), StatusCode::OK, "{value:?}");
    }
    for value in [
        format!("Basic {TOKEN}"),
        "Bearer".into(),
        format!("Bearer{TOKEN}"),
    ] {
        let r = s
            .client
            .get(format!("{}/api/v1/runs", s.base))
            .header("authorization", &value)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), StatusCode::UNAUTHORIZED, "{value:?}");
    }
}

/// Defect 6: an answer given before the body was read (no upload place
/// left, bad parameter, declared length over the limit) closed the
/// keep-alive connection without saying so, and the client's next request
/// hit EPIPE. (A full queue is answered once the body is in, on a
/// connection that stays open.)
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn early_answers_say_connection_close() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let hold = Arc::new(RwLock::new(()));
    let s = Arc::new(
        start(&seeded, |o| {
            o.limits.queue = 0;
            o.limits.max_body = 1 << 20;
            o.limits.max_uploads = 1;
            o.hold_workers = Some(hold.clone());
        })
        .await,
    );
    let hdr = common::hdr_bytes(dir.path(), 32, 16);
    let addr: SocketAddr = s.base.trim_start_matches("http://").parse().unwrap();
    let guard = hold_workers(&hold);
    let s2 = s.clone();
    let body = hdr.clone();
    let occupying = tokio::spawn(async move { s2.tonemap("gpu=false", body).await });
    tokio::time::sleep(Duration::from_millis(300)).await;
    // The one upload place, held by a body that never completes.
    let mut slow = TcpStream::connect(addr).unwrap();
    slow.write_all(
        format!(
            "POST /api/v1/tonemap?gpu=false HTTP/1.1\r\nHost: t\r\nContent-Length: {}\r\n\r\n#",
            hdr.len()
        )
        .as_bytes(),
    )
    .unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    let cases = [
        ("gpu=false", hdr.len(), "503", "\"busy\""),
        ("gpu=false&kee=1", hdr.len(), "400", "kee"),
        ("gpu=true", 5 << 20, "413", "too_large"),
    ];
    let answers = tokio::task::spawn_blocking(move || {
        cases
            .iter()
            .map(|&(query, len, _, _)| {
                // Keep-alive: the head, then as much body as fits in one write.
                let mut sock = TcpStream::connect(addr).unwrap();
                sock.set_read_timeout(Some(Duration::from_secs(10)))
                    .unwrap();
                let head = format!(
                    "POST /api/v1/tonemap?{query} HTTP/1.1\r\nHost: t\r\nContent-Length: {len}\r\n\r\n"
                );
                sock.write_all(head.as_bytes()).unwrap();
                let _ = sock.write_all(&vec![0u8; len.min(4096)]);
                let mut text = Vec::new();
                // The answer, then EOF: the server closes the connection.
                let _ = sock.read_to_end(&mut text);
                String::from_utf8_lossy(&text).to_lowercase()
            })
            .collect::<Vec<_>>()
    })
    .await
    .unwrap();
    for ((query, _, status, code), text) in cases.iter().zip(&answers) {
        assert!(
            text.starts_with(&format!("http/1.1 {status}")),
            "{query}: {text}"
        );
        assert!(text.contains("connection: close"), "{query}: {text}");
        assert!(text.contains(code), "{query}: {text}");
    }
    drop((guard, slow));
    assert_eq!(occupying.await.unwrap().status(), StatusCode::OK);
}

/// Defect 7: a job whose request timed out ran to its end and counted as
/// succeeded. Now it stops between stages, counts as abandoned, and the
/// worker is free for the next job.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_timed_out_job_stops_and_counts_as_abandoned() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| o.limits.timeout = Duration::from_millis(250)).await;
    // Big enough that the CPU reference with bloom takes several times the
    // timeout in a test build (about 1 s on two cores); the first stage
    // check after the timeout stops it.
    let big = common::hdr_bytes(dir.path(), 2048, 2048);
    let r = s.tonemap("gpu=false&bloom=0.5", big).await;
    expect_error(r, StatusCode::SERVICE_UNAVAILABLE, "timeout").await;
    let deadline = Instant::now() + Duration::from_secs(120);
    let metrics = loop {
        let m = s.get("/metrics").await.text().await.unwrap();
        if m.contains("tonegate_tonemap_queue_depth{queue=\"cpu\"} 0") || Instant::now() > deadline
        {
            break m;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    assert!(
        metrics.contains("tonegate_tonemap_abandoned_total{queue=\"cpu\"} 1"),
        "{metrics}"
    );
    assert!(
        metrics.contains("tonegate_tonemap_succeeded_total{queue=\"cpu\"} 0"),
        "{metrics}"
    );
    let small = common::hdr_bytes(dir.path(), 32, 16);
    assert_eq!(s.tonemap("gpu=false", small).await.status(), StatusCode::OK);
}

/// Defect 8: answers from outside the handlers were empty or plain text.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_error_is_json() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |_| {}).await;
    expect_error(
        s.get("/no/such/page").await,
        StatusCode::NOT_FOUND,
        "not_found",
    )
    .await;
    let r = s
        .client
        .delete(format!("{}/metrics", s.base))
        .send()
        .await
        .unwrap();
    expect_error(r, StatusCode::METHOD_NOT_ALLOWED, "method_not_allowed").await;
    let r = s.client.put(format!("{}/", s.base)).send().await.unwrap();
    expect_error(r, StatusCode::METHOD_NOT_ALLOWED, "method_not_allowed").await;
    let d = expect_error(
        s.get("/api/v1/runs/%FF%FE").await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    assert!(d.contains("UTF-8") || d.contains("utf-8"), "{d}");
    let long = "a".repeat(20_000);
    let d = expect_error(
        s.get(&format!("/api/v1/runs?{long}=1")).await,
        StatusCode::URI_TOO_LONG,
        "uri_too_long",
    )
    .await;
    assert!(d.len() < 200, "{d}");
    let mut req = s.client.get(format!("{}/api/v1/runs", s.base));
    for i in 0..150 {
        req = req.header(format!("x-h{i}"), "v");
    }
    expect_error(
        req.send().await.unwrap(),
        StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
        "headers_too_large",
    )
    .await;
    let r = s
        .client
        .get(format!("{}/api/v1/runs", s.base))
        .header("x-big", "v".repeat(40_000))
        .send()
        .await
        .unwrap();
    expect_error(
        r,
        StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
        "headers_too_large",
    )
    .await;
}

/// Defect 10: validation that depended on the route or the operator, and a
/// 60,000-character parameter name echoed whole.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn validation_is_the_same_everywhere_and_echoes_are_short() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |_| {}).await;
    for q in ["metric=bogus", "metric="] {
        let d = expect_error(
            s.get(&format!("/api/v1/trends?{q}")).await,
            StatusCode::BAD_REQUEST,
            "bad_parameter",
        )
        .await;
        assert!(d.contains("metric"), "{q}: {d}");
    }
    let hdr = common::hdr_bytes(dir.path(), 32, 16);
    for q in [
        "white=-1",
        "white=inf",
        "operator=reinhard02&white=-1",
        "white_fraction=0",
    ] {
        let d = expect_error(
            s.tonemap(&format!("gpu=false&{q}"), hdr.clone()).await,
            StatusCode::BAD_REQUEST,
            "bad_parameter",
        )
        .await;
        assert!(d.starts_with("white"), "{q}: {d}");
    }
    // A value is quoted short: a huge number in exponent form, a long
    // word cut to 48 characters (`key=1e300` quoted 301 digits).
    let long_word = format!("operator=agx&look={}", "p".repeat(5000));
    for (q, says) in [("key=1e300", "got 1e300"), (long_word.as_str(), "ppp…")] {
        let d = expect_error(
            s.tonemap(&format!("gpu=false&{q}"), hdr.clone()).await,
            StatusCode::BAD_REQUEST,
            "bad_parameter",
        )
        .await;
        assert!(
            d.contains(says) && d.len() < 300,
            "{}: {d}",
            &q[..20.min(q.len())]
        );
    }
    let name = "n".repeat(60_000);
    let r = s
        .client
        .post(format!("{}/api/v1/tonemap?gpu=false", s.base))
        .header("content-type", "application/x-www-form-urlencoded")
        .body(format!("{name}=1"))
        .send()
        .await
        .unwrap();
    // As a raw body this is not an image; as a query it is too long; either
    // way the answer is short.
    assert!(r.status().is_client_error());
    assert!(r.text().await.unwrap().len() < 400);
    let d = expect_error(
        s.tonemap(&format!("gpu=false&{}=1", "n".repeat(6000)), hdr)
            .await,
        StatusCode::BAD_REQUEST,
        "bad_parameter",
    )
    .await;
    assert!(d.len() < 200, "{d}");
}

/// A POST of `body` to `/api/v1/tonemap?{query}` on a fresh connection.
fn post_tonemap(addr: SocketAddr, query: &str, body: &[u8]) -> std::io::Result<String> {
    let mut s = TcpStream::connect(addr)?;
    s.set_read_timeout(Some(Duration::from_secs(120)))?;
    write!(
        s,
        "POST /api/v1/tonemap?{query} HTTP/1.1\r\nHost: t\r\nContent-Type: application/octet-stream\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    s.write_all(body)?;
    let mut answer = Vec::new();
    s.read_to_end(&mut answer)?;
    let text = String::from_utf8_lossy(&answer);
    Ok(text.lines().next().unwrap_or("").to_string())
}

/// On an NVIDIA H100 (Vulkan), `serve` died of SIGSEGV when stopped after GPU
/// requests: its worker threads were never joined, so the process exited
/// with a live Vulkan device. Now SIGTERM and SIGINT drain the queues (the
/// request in flight is answered), join the workers, release the GPU
/// context, and exit 0. On llvmpipe the crash never showed; what fails here
/// without the fix is the ordered shutdown the log records.
#[test]
fn a_signal_after_gpu_work_drains_the_queues_and_exits_zero() {
    for signal in [libc::SIGTERM, libc::SIGINT] {
        let dir = tempfile::tempdir().unwrap();
        let seeded = common::seed_empty(dir.path());
        let launch = Launch {
            args: history_args(&seeded, &[]),
            log: Some("info"),
            ..Default::default()
        };
        let mut s = serve(&launch, dir.path()).unwrap_or_else(|e| panic!("{e:?}"));
        let small = common::hdr_bytes(dir.path(), 64, 32);
        let status = post_tonemap(s.addr, "gpu=true", &small).unwrap();
        assert!(status.contains(" 200 "), "GPU tone-map: {status}");
        // A CPU job long enough to be in flight when the signal comes.
        let big = common::hdr_bytes(dir.path(), 1024, 1024);
        let addr = s.addr;
        let in_flight = std::thread::spawn(move || post_tonemap(addr, "gpu=false&bloom=0.5", &big));
        std::thread::sleep(Duration::from_millis(300));
        // SAFETY: kill(2) on our own child's pid.
        assert_eq!(unsafe { libc::kill(s.child.id() as i32, signal) }, 0);
        let answered = in_flight.join().unwrap().unwrap();
        assert!(answered.contains(" 200 "), "the job in flight: {answered}");
        let deadline = Instant::now() + Duration::from_secs(60);
        let code = loop {
            if let Some(status) = s.child.try_wait().unwrap() {
                break status.code();
            }
            assert!(Instant::now() < deadline, "serve did not stop");
            std::thread::sleep(Duration::from_millis(50));
        };
        let log = std::fs::read_to_string(&s.log).unwrap();
        assert_eq!(code, Some(0), "signal {signal}: {log}");
        assert!(log.contains("GPU context released"), "{log}");
        assert_eq!(log.matches("tone-map worker stopped").count(), 2, "{log}");
    }
}

/// A multipart upload is read by multer under the server's body limit: one
/// sent chunked (no Content-Length to refuse it by) over the limit is 413,
/// as a raw body is; two files or none are the client's mistake, 400; a
/// well-formed one is tone-mapped.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn multipart_bodies_are_read_under_the_body_limit() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |o| o.limits.max_body = 64 << 10).await;
    let addr: SocketAddr = s.base.trim_start_matches("http://").parse().unwrap();
    let hdr = common::hdr_bytes(dir.path(), 32, 16);
    let part = |name: &str, file: Option<&str>, body: &[u8]| {
        let mut p = format!("--b0undary\r\nContent-Disposition: form-data; name=\"{name}\"");
        if let Some(f) = file {
            p += &format!("; filename=\"{f}\"");
        }
        p += "\r\n\r\n";
        let mut p = p.into_bytes();
        p.extend_from_slice(body);
        p.extend_from_slice(b"\r\n");
        p
    };
    let form = |parts: &[Vec<u8>]| {
        let mut b = parts.concat();
        b.extend_from_slice(b"--b0undary--\r\n");
        b
    };
    let cases = [
        (
            "a file and a field",
            form(&[
                part("file", Some("a.hdr"), &hdr),
                part("key", None, b"0.25"),
            ]),
            "200",
            "",
        ),
        (
            "over the limit",
            form(&[part("file", Some("a.hdr"), &vec![b'x'; 80 << 10])]),
            "413",
            "too_large",
        ),
        (
            "two files",
            form(&[
                part("file", Some("a.hdr"), &hdr),
                part("file", Some("b.hdr"), &hdr),
            ]),
            "400",
            "more than one file",
        ),
        (
            "a file under another name",
            form(&[part("more", Some("b.hdr"), &hdr)]),
            "400",
            "the image goes in the part named",
        ),
        (
            "no file",
            form(&[part("key", None, b"0.25")]),
            "400",
            "no file field",
        ),
    ];
    let answers = tokio::task::spawn_blocking(move || {
        cases
            .iter()
            .map(|(what, body, status, detail)| {
                // Chunked, 16 KiB a chunk: the server learns the size only
                // by reading.
                let mut request = b"POST /api/v1/tonemap?gpu=false HTTP/1.1\r\nHost: t\r\n\
                    Content-Type: multipart/form-data; boundary=b0undary\r\n\
                    Transfer-Encoding: chunked\r\nConnection: close\r\n\r\n"
                    .to_vec();
                for chunk in body.chunks(16 << 10) {
                    request.extend_from_slice(format!("{:x}\r\n", chunk.len()).as_bytes());
                    request.extend_from_slice(chunk);
                    request.extend_from_slice(b"\r\n");
                }
                request.extend_from_slice(b"0\r\n\r\n");
                let mut sock = TcpStream::connect(addr).unwrap();
                sock.set_read_timeout(Some(Duration::from_secs(30)))
                    .unwrap();
                // The server may answer and close before it has read all.
                let _ = sock.write_all(&request);
                let mut text = Vec::new();
                let _ = sock.read_to_end(&mut text);
                (
                    *what,
                    *status,
                    *detail,
                    String::from_utf8_lossy(&text).into_owned(),
                )
            })
            .collect::<Vec<_>>()
    })
    .await
    .unwrap();
    for (what, status, detail, text) in answers {
        assert!(
            text.starts_with(&format!("HTTP/1.1 {status}")),
            "{what}: {text}"
        );
        assert!(text.contains(detail), "{what}: {text}");
    }
}
