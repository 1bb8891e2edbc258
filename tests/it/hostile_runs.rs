//! `POST /api/v1/runs` against clients that stall or never authenticate, on
//! the real binary: the token is checked before a byte of the body is read
//! (no `100 Continue` for a refused request), the body has a limit and a
//! read timeout, every refusal is JSON with `Connection: close`, and SIGTERM
//! cuts off stalled uploads instead of waiting for them. Found on 3182eae:
//! 100 unauthenticated stalled bodies held 178 MB for over 40 s, and one
//! stalled body kept the server up 25 s after SIGTERM.

use crate::common;
use crate::hostile::{history_args, serve, Launch};
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

fn rss_kib(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap()
}

/// Opens a connection and sends a `POST /runs` head declaring `declared`
/// bytes, then `sent` bytes of them; the body's rest never comes.
fn stalled(addr: SocketAddr, token: Option<&str>, declared: usize, sent: usize) -> TcpStream {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    let auth = token.map_or(String::new(), |t| format!("Authorization: Bearer {t}\r\n"));
    let head = format!(
        "POST /api/v1/runs HTTP/1.1\r\nHost: t\r\n{auth}Content-Type: application/json\r\n\
         Expect: 100-continue\r\nContent-Length: {declared}\r\n\r\n"
    );
    s.write_all(head.as_bytes()).unwrap();
    s.write_all(&vec![b' '; sent]).unwrap();
    s
}

/// Everything the server sends until it closes the connection, lower case.
fn answer(mut s: TcpStream) -> String {
    let mut text = Vec::new();
    let _ = s.read_to_end(&mut text);
    String::from_utf8_lossy(&text).to_lowercase()
}

/// The final answer of an accepted request that asked for `100 Continue`:
/// the interim answer is there, and then the final one.
fn after_continue(a: &str) -> &str {
    a.strip_prefix("http/1.1 100 continue\r\n\r\n")
        .unwrap_or_else(|| panic!("no 100 Continue before the answer: {a}"))
}

/// How many client sockets of `wanted` this process can hold open: its
/// open-file limit is raised to the hard limit first (the server child
/// inherits it, so its connection cap does not answer 503 instead of 401),
/// and 300 descriptors are left to the other tests of the binary.
fn client_sockets(wanted: u64) -> usize {
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit and setrlimit on this process with a valid struct.
    unsafe {
        if libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim) == 0 && lim.rlim_cur < lim.rlim_max {
            lim.rlim_cur = lim.rlim_max;
            libc::setrlimit(libc::RLIMIT_NOFILE, &lim);
        }
    }
    wanted.min(lim.rlim_cur.saturating_sub(300)) as usize
}

fn token(seeded: &common::Seeded) -> String {
    std::fs::read_to_string(seeded.db.parent().unwrap().join("token"))
        .unwrap()
        .trim()
        .to_owned()
}

#[test]
fn a_refused_run_request_is_answered_before_its_body_and_stalled_bodies_cost_little() {
    // Fewer than 1000 where this process may not open that many sockets
    // beside the other tests' (the count is printed).
    let clients = client_sockets(1000);
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let launch = Launch {
        args: history_args(&seeded, &[]),
        ..Default::default()
    };
    let s = serve(&launch, dir.path()).unwrap_or_else(|e| panic!("{e:?}"));
    let token = token(&seeded);
    // An authenticated body that stalls is answered when its read times out.
    let slow = stalled(s.addr, Some(&token), 100, 10);
    let slow_since = Instant::now();
    let slow = std::thread::spawn(move || (answer(slow), slow_since.elapsed()));
    std::thread::sleep(Duration::from_millis(500));
    let before = rss_kib(s.child.id());
    // 1000 unauthenticated clients, each declaring 2 MB and sending 1 KiB
    // after asking for `100 Continue`.
    let held: Vec<TcpStream> = (0..clients)
        .map(|_| stalled(s.addr, None, 2_000_000, 1024))
        .collect();
    let answers: Vec<String> = held.into_iter().map(answer).collect();
    let after = rss_kib(s.child.id());
    for a in &answers {
        assert!(a.starts_with("http/1.1 401 "), "{a}");
        assert!(!a.contains("100 continue"), "{a}");
        assert!(a.contains("connection: close"), "{a}");
        assert!(a.contains("content-type: application/json"), "{a}");
        assert!(a.contains("\"error\":\"unauthorized\""), "{a}");
    }
    let grew_mib = after.saturating_sub(before) as f64 / 1024.0;
    eprintln!(
        "POST /runs: {clients} stalled unauthenticated bodies: RSS {:.1} -> {:.1} MiB (+{grew_mib:.1} MiB)",
        before as f64 / 1024.0,
        after as f64 / 1024.0
    );
    assert!(grew_mib < 50.0, "RSS grew {grew_mib:.1} MiB");
    // Over the body limit, declared: 413 in JSON, closing, nothing read.
    let big = answer(stalled(s.addr, Some(&token), 3 << 20, 0));
    assert!(big.starts_with("http/1.1 413 "), "{big}");
    assert!(
        big.contains("connection: close") && big.contains("\"too_large\""),
        "{big}"
    );
    assert!(!big.contains("100 continue"), "{big}");
    // Over the limit, not declared (chunked): 413 in JSON once it is read.
    let mut chunked = TcpStream::connect(s.addr).unwrap();
    chunked
        .set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    let head = format!(
        "POST /api/v1/runs HTTP/1.1\r\nHost: t\r\nAuthorization: Bearer {token}\r\n\
         Transfer-Encoding: chunked\r\n\r\n"
    );
    chunked.write_all(head.as_bytes()).unwrap();
    let chunk = vec![b' '; 64 << 10];
    for _ in 0..5 {
        let _ = chunked.write_all(format!("{:x}\r\n", chunk.len()).as_bytes());
        let _ = chunked.write_all(&chunk);
        let _ = chunked.write_all(b"\r\n");
    }
    let big = answer(chunked);
    assert!(big.starts_with("http/1.1 413 "), "{big}");
    assert!(
        big.contains("\"too_large\"") && big.contains("connection: close"),
        "{big}"
    );
    let (slow, took) = slow.join().unwrap();
    let slow = after_continue(&slow);
    assert!(slow.starts_with("http/1.1 408 "), "{slow}");
    assert!(
        slow.contains("\"timeout\"") && slow.contains("connection: close"),
        "{slow}"
    );
    assert!(
        took >= Duration::from_secs(9) && took < Duration::from_secs(20),
        "{took:?}"
    );
    // The server is still well: a whole request works.
    let ok = answer({
        let mut c = TcpStream::connect(s.addr).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        c.write_all(b"GET /healthz HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n")
            .unwrap();
        c
    });
    assert!(ok.starts_with("http/1.1 200 "), "{ok}");
}

#[test]
fn sigterm_cuts_off_stalled_run_bodies_and_exits_promptly() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let launch = Launch {
        args: history_args(&seeded, &[]),
        ..Default::default()
    };
    let mut s = serve(&launch, dir.path()).unwrap_or_else(|e| panic!("{e:?}"));
    let token = token(&seeded);
    let authenticated: Vec<TcpStream> = (0..50)
        .map(|_| stalled(s.addr, Some(&token), 1000, 10))
        .collect();
    let anonymous: Vec<TcpStream> = (0..50).map(|_| stalled(s.addr, None, 1000, 10)).collect();
    std::thread::sleep(Duration::from_millis(500));
    let signalled = Instant::now();
    // SAFETY: kill(2) on our own child's pid.
    assert_eq!(unsafe { libc::kill(s.child.id() as i32, libc::SIGTERM) }, 0);
    let code = loop {
        if let Some(status) = s.child.try_wait().unwrap() {
            break status.code();
        }
        assert!(
            signalled.elapsed() < Duration::from_secs(5),
            "serve was still up 5 s after SIGTERM with stalled bodies"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    let took = signalled.elapsed();
    let log = std::fs::read_to_string(&s.log).unwrap_or_default();
    assert_eq!(code, Some(0), "{log}");
    eprintln!("serve with 100 stalled POST /runs bodies: exited 0 {took:?} after SIGTERM");
    for a in authenticated.into_iter().map(answer) {
        let a = after_continue(&a);
        assert!(a.starts_with("http/1.1 503 "), "{a}");
        assert!(
            a.contains("\"shutting_down\"") && a.contains("retry-after"),
            "{a}"
        );
    }
    for a in anonymous.into_iter().map(answer) {
        assert!(a.starts_with("http/1.1 401 "), "{a}");
    }
}

/// SIGTERM while a suite run started by `POST /runs` is going: the run is
/// marked aborted, saying why, not left `running` for the next start.
#[test]
fn sigterm_during_a_run_marks_it_aborted() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    // The whole built-in suite on the CPU: seconds, so the signal lands mid-run.
    let whole = dir.path().join("golden/suite.toml");
    let launch = Launch {
        args: vec![
            "--db",
            seeded.db.to_str().unwrap(),
            "--suite",
            whole.to_str().unwrap(),
        ],
        ..Default::default()
    };
    let mut s = serve(&launch, dir.path()).unwrap_or_else(|e| panic!("{e:?}"));
    let token = token(&seeded);
    let mut c = TcpStream::connect(s.addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    let body = r#"{"renderer": "cpu"}"#;
    c.write_all(
        format!(
            "POST /api/v1/runs HTTP/1.1\r\nHost: t\r\nAuthorization: Bearer {token}\r\n\
             Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
            body.len()
        )
        .as_bytes(),
    )
    .unwrap();
    let started = answer(c);
    assert!(started.starts_with("http/1.1 202 "), "{started}");
    let id: i64 = started
        .split("\"id\":")
        .nth(1)
        .and_then(|t| t.split([',', '}']).next())
        .and_then(|t| t.trim().parse().ok())
        .unwrap_or_else(|| panic!("{started}"));
    std::thread::sleep(Duration::from_millis(300));
    // SAFETY: kill(2) on our own child's pid.
    assert_eq!(unsafe { libc::kill(s.child.id() as i32, libc::SIGTERM) }, 0);
    let deadline = Instant::now() + Duration::from_secs(30);
    let code = loop {
        if let Some(status) = s.child.try_wait().unwrap() {
            break status.code();
        }
        assert!(Instant::now() < deadline, "serve did not stop");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(code, Some(0));
    let h = tonegate::history::History::open_read_only(&seeded.db).unwrap();
    let run = h.run(id).unwrap().unwrap();
    assert_eq!(run.status, tonegate::history::RunStatus::Aborted, "{run:?}");
    assert!(
        run.detail
            .as_deref()
            .unwrap_or("")
            .contains("the server stopped (SIGTERM or Ctrl-C) before the run finished"),
        "{run:?}"
    );
}
