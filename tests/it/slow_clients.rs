//! Clients that send a tone-map body slowly hold no queue place: 4, then
//! 100 connections sending their body at a byte every half second, half of
//! them to each queue, while a well-behaved client tone-maps one image
//! after another (c = 1). Every one of its answers is 200, at about its
//! quiet rate; the uploads' gauges see the slow bodies being received.
//! And one address's 260 slow uploads take only its share of the places:
//! a client at another address is still served.

use crate::common;
use crate::common::server::start;
use reqwest::StatusCode;
use std::time::{Duration, Instant};
use tokio::io::AsyncWriteExt;

/// A connection from loopback address `from` (127.0.0.0/8 is all this
/// machine's) that declared a 100 kB body and sends a byte of it every
/// 500 ms until it is aborted or its connection is closed.
fn slow_upload(base: &str, gpu: bool, from: std::net::Ipv4Addr) -> tokio::task::JoinHandle<()> {
    let addr: std::net::SocketAddr = base.trim_start_matches("http://").parse().unwrap();
    tokio::spawn(async move {
        let socket = tokio::net::TcpSocket::new_v4().unwrap();
        socket
            .bind(std::net::SocketAddr::new(from.into(), 0))
            .unwrap();
        let mut s = socket.connect(addr).await.unwrap();
        let head = format!(
            "POST /api/v1/tonemap?gpu={gpu} HTTP/1.1\r\nHost: x\r\n\
             Content-Type: application/octet-stream\r\nContent-Length: 100000\r\n\r\n"
        );
        s.write_all(head.as_bytes()).await.unwrap();
        loop {
            if s.write_all(b"#").await.is_err() {
                return;
            }
            tokio::time::sleep(Duration::from_millis(500)).await;
        }
    })
}

/// The median time of `n` tone-maps one after another; every answer must be 200.
async fn p50(s: &common::server::Running, hdr: &[u8], n: usize, when: &str) -> Duration {
    let mut times = Vec::with_capacity(n);
    for i in 0..n {
        let t = Instant::now();
        let r = s.tonemap("gpu=false", hdr.to_vec()).await;
        let status = r.status();
        let body = r.text().await.unwrap_or_default();
        assert_eq!(status, StatusCode::OK, "{when}, request {i}: {body}");
        times.push(t.elapsed());
    }
    times.sort();
    times[n / 2]
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn slow_uploads_hold_no_queue_place() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    // Two places per queue, as `serve` has by default.
    let s = start(&seeded, |o| o.limits.queue = 1).await;
    let hdr = common::hdr_bytes(dir.path(), 32, 16);
    let quiet = p50(&s, &hdr, 30, "quiet").await;
    let mut figures = vec![("quiet", quiet)];
    let mut slow = Vec::new();
    for (n, when) in [(4, "with 4 slow uploads"), (100, "with 100 slow uploads")] {
        while slow.len() < n {
            // From four addresses, each within its share of the places.
            let from = std::net::Ipv4Addr::new(127, 0, 0, 2 + (slow.len() % 4) as u8);
            slow.push(slow_upload(&s.base, slow.len() % 2 == 0, from));
        }
        // Until the server is receiving every one of them.
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let m = s.get("/metrics").await.text().await.unwrap();
            if m.contains(&format!("tonegate_tonemap_uploads {n}\n")) {
                break;
            }
            assert!(Instant::now() < deadline, "{n} slow uploads not seen: {m}");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let busy = p50(&s, &hdr, 30, when).await;
        // Blocked, a request would wait for a place until its timeout (60 s)
        // or get 503; three times the quiet median (plus 20 ms for a noisy,
        // shared machine) is far from both and far above the noise.
        assert!(
            busy <= quiet * 3 + Duration::from_millis(20),
            "{when}: p50 {busy:?} against {quiet:?} quiet"
        );
        figures.push((when, busy));
    }
    for t in &slow {
        t.abort();
    }
    eprintln!(
        "slow uploads: p50 of a 32x16 CPU tone-map at c=1: {}",
        figures
            .iter()
            .map(|(w, d)| format!("{w} {:.2} ms", d.as_secs_f64() * 1e3))
            .collect::<Vec<_>>()
            .join(", ")
    );
}

/// Reads from `s` until an HTTP status line arrives; its code.
async fn status_of(s: &mut tokio::net::TcpStream) -> u16 {
    use tokio::io::AsyncReadExt;
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    while !got.windows(2).any(|w| w == b"\r\n") {
        let n = tokio::time::timeout(Duration::from_secs(10), s.read(&mut buf))
            .await
            .expect("an answer before the body is complete")
            .unwrap();
        assert!(n > 0, "closed without an answer");
        got.extend_from_slice(&buf[..n]);
    }
    let line = String::from_utf8_lossy(&got);
    line.split(' ').nth(1).unwrap().parse().unwrap()
}

/// An image over the pixel limit is refused from its header while its body
/// is still coming (chunked, so no length says anything), raw and as a
/// multipart file; the body is never completed.
#[tokio::test]
async fn an_image_too_large_is_refused_from_its_header_before_its_body_is_in() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |_| {}).await;
    let addr = s.base.trim_start_matches("http://").to_owned();
    // 6000 x 5000 = 30 Mpx, over the default 8 Mi; 360 MB of pixels follow.
    let header = b"PF\n6000 5000\n-1.0\n";
    let boundary = "XyZ";
    let opening = format!(
        "--{boundary}\r\nContent-Disposition: form-data; name=\"file\"; filename=\"big.pfm\"\r\n\
         Content-Type: application/octet-stream\r\n\r\n"
    );
    for (gpu, multipart) in [(true, false), (false, false), (true, true)] {
        let mut c = tokio::net::TcpStream::connect(&addr).await.unwrap();
        let content_type = if multipart {
            format!("multipart/form-data; boundary={boundary}")
        } else {
            "application/octet-stream".into()
        };
        let head = format!(
            "POST /api/v1/tonemap?gpu={gpu} HTTP/1.1\r\nHost: x\r\nContent-Type: {content_type}\r\n\
             Transfer-Encoding: chunked\r\n\r\n"
        );
        c.write_all(head.as_bytes()).await.unwrap();
        let mut first = Vec::new();
        if multipart {
            first.extend_from_slice(opening.as_bytes());
        }
        first.extend_from_slice(header);
        first.extend_from_slice(&[0u8; 4096]);
        c.write_all(format!("{:x}\r\n", first.len()).as_bytes())
            .await
            .unwrap();
        c.write_all(&first).await.unwrap();
        c.write_all(b"\r\n").await.unwrap();
        let code = status_of(&mut c).await;
        assert_eq!(code, 413, "gpu={gpu} multipart={multipart}");
    }
}

/// One address opens 260 slow uploads: it holds its share of the places
/// (32) and the rest are refused at once, while a tone-map from another
/// address is answered 200, and so is one from the same address under a
/// token (a token's holder is a client of its own). When the places were not shared out, those
/// uploads took all 256 and everyone got 503 for as long as they lasted.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_address_slow_uploads_leave_places_for_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |_| {}).await;
    let hdr = common::hdr_bytes(dir.path(), 32, 16);
    let flood = std::net::Ipv4Addr::new(127, 0, 0, 9);
    let slow: Vec<_> = (0..260)
        .map(|i| slow_upload(&s.base, i % 2 == 0, flood))
        .collect();
    // Until the server holds the flood's share and the flood has settled:
    // its other uploads refused, the count still for a second. (Under a
    // loaded test run one of the 260 connects can fail, seen 2026-12-07:
    // 227 refused and 32 held, so the count is not required to reach 228.)
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut settled = (0, Instant::now());
    loop {
        let m = s.get("/metrics").await.text().await.unwrap();
        let refused = m
            .lines()
            .find_map(|l| l.strip_prefix("tonegate_tonemap_uploads_refused_total "))
            .and_then(|v| v.trim().parse::<u64>().ok())
            .unwrap_or(0);
        if refused != settled.0 {
            settled = (refused, Instant::now());
        }
        let still = settled.1.elapsed() >= Duration::from_secs(1);
        if m.contains("tonegate_tonemap_uploads 32\n") && refused >= 200 && still {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the flood's share not reached: {m}"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let r = s.tonemap("gpu=false", hdr.clone()).await;
    let status = r.status();
    let body = r.text().await.unwrap_or_default();
    assert_eq!(status, StatusCode::OK, "another address: {body}");
    // From the flood's own address: anonymous, it is refused (the address
    // holds its share); with the server's token, it is a client of its own.
    let same_address = reqwest::Client::builder()
        .local_address(std::net::IpAddr::from(flood))
        .build()
        .unwrap();
    let from_flood = |token: bool| {
        let mut r = same_address
            .post(format!("{}/api/v1/tonemap?gpu=false", s.base))
            .body(hdr.clone());
        if token {
            r = r.bearer_auth(common::server::TOKEN);
        }
        r.send()
    };
    let anonymous = from_flood(false).await.unwrap();
    assert_eq!(anonymous.status(), StatusCode::SERVICE_UNAVAILABLE);
    let with_token = from_flood(true).await.unwrap();
    assert_eq!(
        with_token.status(),
        StatusCode::OK,
        "{}",
        with_token.text().await.unwrap_or_default()
    );
    for t in &slow {
        t.abort();
    }
}
