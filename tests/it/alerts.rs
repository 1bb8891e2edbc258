//! Alerts end to end: `tonegate serve` with an alerts file scans a real
//! SQLite history that real `check` runs and `frames submit` write, and
//! delivers to a real HTTP receiver started here that refuses each event's
//! first two deliveries and accepts the third. Four events happen — the
//! gate goes red (a 2 % brighter tone mapper), a scene's FPS drops to a
//! third, and the main line gets untriaged digests twice — and each is
//! accepted exactly once, signed with HMAC-SHA256 under the webhook's
//! secret, with the commit range between the last good run (or submission)
//! and the first bad one; the delivery log in the API shows the two
//! refusals and the acceptance.
//!
//! The FPS series is recorded, not timed: runs written through the
//! history's own writer with the frame rates given here. A drop made of a
//! wait per frame depends on how fast the machine renders (on a slow
//! 2-core host a 40 ms wait was too small a change to be found).

use crate::common;
use axum::extract::State;
use axum::http::{HeaderMap, StatusCode};
use axum::routing::post;
use hmac::{Hmac, Mac};
use serde_json::Value;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tonegate::image::{Frame, Image, Rgb8Image};

const SECRET: &str = "alerts-test-secret-0123456789abcdef";

/// Every request the receiver got: its path, headers of note, body, and
/// what it answered.
#[derive(Clone, Debug)]
struct Got {
    path: String,
    event: String,
    signature: String,
    body: Vec<u8>,
    accepted: bool,
}

#[derive(Default)]
struct Receiver {
    got: Mutex<Vec<Got>>,
}

async fn receive(
    State(r): State<Arc<Receiver>>,
    uri: axum::http::Uri,
    headers: HeaderMap,
    body: axum::body::Bytes,
) -> StatusCode {
    let header = |n: &str| {
        headers
            .get(n)
            .and_then(|v| v.to_str().ok())
            .unwrap_or("")
            .to_owned()
    };
    let mut got = r.got.lock().unwrap();
    let event = header("x-tonegate-event");
    let path = uri.path().to_owned();
    // Each event's first two deliveries to a path are refused.
    let before = got
        .iter()
        .filter(|g| g.event == event && g.path == path)
        .count();
    let accepted = before >= 2;
    got.push(Got {
        path,
        event,
        signature: header("x-tonegate-signature-256"),
        body: body.to_vec(),
        accepted,
    });
    if accepted {
        StatusCode::NO_CONTENT
    } else {
        StatusCode::SERVICE_UNAVAILABLE
    }
}

fn frame(seed: u32) -> Rgb8Image {
    Image::from_fn(48, 32, |x, y| {
        if (x + seed) % 48 < 12 {
            [230, 200, 90]
        } else {
            [(x * 4) as u8, (y * 6) as u8, 40]
        }
    })
}

fn submit(db: &std::path::Path, dir: &std::path::Path, seed: u32, commit: &str) -> Value {
    std::fs::create_dir_all(dir).unwrap();
    tonegate::io::write_frame_png(&dir.join("hud.png"), &Frame::Rgb8(frame(seed))).unwrap();
    tonegate::io::write_frame_png(&dir.join("menu.png"), &Frame::Rgb8(frame(20))).unwrap();
    let o = common::tonegate(&[
        "frames",
        "submit",
        dir.to_str().unwrap(),
        "--db",
        db.to_str().unwrap(),
        "--key",
        &format!("commit={commit}"),
        "--json",
        "-",
    ]);
    serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&o.stderr)))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn each_event_is_delivered_once_signed_with_its_commit_range_through_refusals() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    std::fs::write(
        &seeded.suite,
        "scenes = [\"scenes/sky-reinhard-global.toml\"]\n",
    )
    .unwrap();

    let receiver = Arc::new(Receiver::default());
    let app = axum::Router::new()
        .route("/json", post(receive))
        .route("/slack", post(receive))
        .with_state(receiver.clone());
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let hook = format!("http://{}", listener.local_addr().unwrap());
    tokio::spawn(async move { axum::serve(listener, app).await });

    std::fs::write(dir.path().join("hook.secret"), format!("{SECRET}\n")).unwrap();
    let file = dir.path().join("alerts.toml");
    std::fs::write(
        &file,
        format!(
            "public_url = \"http://tonegate.test:8080\"\nscan_seconds = 0.2\n\
             [retry]\nfirst_seconds = 0.05\nmost_attempts = 5\n\
             [[webhook]]\nname = \"team\"\nurl = \"{hook}/json\"\nsecret_file = \"hook.secret\"\n\
             [[webhook]]\nname = \"chat\"\nurl = \"{hook}/slack\"\nformat = \"slack\"\n\
             secret_file = \"hook.secret\"\nevents = [\"gate_red\"]\n"
        ),
    )
    .unwrap();
    let alerts = tonegate::alerts::Alerts::load(&file).unwrap();
    let s = common::server::start(&seeded, |o| o.alerts = Some(alerts)).await;
    // The first scan sets where alerts start.
    tokio::time::sleep(Duration::from_millis(600)).await;

    // Six check runs, one a commit: the last three with a 2 % brighter
    // tone mapper.
    let (suite, db) = (seeded.suite.to_str().unwrap(), seeded.db.to_str().unwrap());
    for run in 1..=6 {
        let mut args = vec!["check", "--suite", suite, "--db", db];
        if run > 3 {
            args.extend(["--fault-gain", "1.02"]);
        }
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_tonegate"))
            .args(&args)
            .current_dir(common::repo())
            .env_remove("TONEGATE_DB")
            .env("TONEGATE_COMMIT", format!("c{run:02}"))
            .output()
            .unwrap();
        assert_eq!(
            o.status.code(),
            Some(if run > 3 { 1 } else { 0 }),
            "run {run}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    common::runs::record_fps_series(&seeded.db);
    // Frames on the main line: new digests (untriaged), triaged, a
    // passing submission, then a changed HUD.
    let frames = dir.path().join("frames");
    let first = submit(&seeded.db, &frames, 0, "f1");
    for f in first["frames"].as_array().unwrap() {
        let o = common::tonegate(&[
            "frames",
            "triage",
            "--db",
            db,
            "--test",
            f["test"].as_str().unwrap(),
            "--digest",
            f["digest"].as_str().unwrap(),
            "positive",
            "--who",
            "ana",
            "--why",
            "new HUD",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    assert_eq!(submit(&seeded.db, &frames, 0, "f2")["passed"], true);
    assert_eq!(submit(&seeded.db, &frames, 5, "f3")["passed"], false);

    // Until every delivery has been accepted.
    let deadline = Instant::now() + Duration::from_secs(90);
    let alerts = loop {
        let (_, alerts) = s.json("/api/v1/alerts").await;
        let done = alerts.as_array().unwrap().iter().all(|a| {
            a["deliveries"]
                .as_array()
                .unwrap()
                .iter()
                .all(|d| d["state"] == "delivered")
        });
        if done && alerts.as_array().unwrap().len() >= 4 {
            break alerts;
        }
        assert!(Instant::now() < deadline, "not all delivered: {alerts:#}");
        tokio::time::sleep(Duration::from_millis(200)).await;
    };
    // More scans find nothing new.
    tokio::time::sleep(Duration::from_millis(800)).await;
    let (_, again) = s.json("/api/v1/alerts").await;
    assert_eq!(
        again.as_array().unwrap().len(),
        alerts.as_array().unwrap().len()
    );

    let by_key: BTreeMap<String, &Value> = alerts
        .as_array()
        .unwrap()
        .iter()
        .map(|a| (a["key"].as_str().unwrap().to_owned(), a))
        .collect();
    let keys: Vec<&String> = by_key.keys().collect();
    let run = |status: &str| {
        let h = tonegate::history::History::open_read_only(&seeded.db).unwrap();
        h.runs(100)
            .unwrap()
            .into_iter()
            .filter(|r| r.status.as_str() == status)
            .map(|r| r.id)
            .min()
            .unwrap()
    };
    let first_bad = run("failed");
    let red = by_key
        .get(&format!("gate_red:{first_bad}"))
        .unwrap_or_else(|| panic!("no gate_red alert: {keys:?}"));
    assert_eq!(red["event"]["commits"]["last_good"], "c03");
    assert_eq!(red["event"]["commits"]["first_bad"], "c04");
    assert_eq!(red["event"]["runs"]["first_bad"], first_bad);
    assert_eq!(
        red["event"]["links"]["first_bad"]["dashboard"],
        format!("http://tonegate.test:8080/#/runs/{first_bad}")
    );
    let fps = by_key
        .iter()
        .find(|(k, _)| k.starts_with("change_point:fps:fps-probe:"))
        .unwrap_or_else(|| panic!("no FPS change point: {keys:?}"))
        .1;
    assert_eq!(fps["event"]["commits"]["first_bad"], "p07", "{fps:#}");
    assert_eq!(fps["event"]["commits"]["last_good"], "p06");
    let ratio = fps["event"]["ratio"].as_f64().unwrap();
    // The series' levels are 60 and 20 FPS, each ±1: the new level over
    // the old is within 1/3 ± 0.03.
    assert!((ratio - 1.0 / 3.0).abs() < 0.03, "{fps:#}");
    let untriaged: Vec<&&Value> = by_key
        .iter()
        .filter(|(k, _)| k.starts_with("untriaged:"))
        .map(|(_, v)| v)
        .collect();
    assert_eq!(untriaged.len(), 2, "{keys:?}");
    let changed = untriaged
        .iter()
        .find(|a| a["event"]["commits"]["first_bad"] == "f3")
        .expect("the changed HUD's alert");
    assert_eq!(changed["event"]["commits"]["last_good"], "f2");
    assert_eq!(changed["event"]["digests"].as_array().unwrap().len(), 1);
    assert_eq!(changed["event"]["digests"][0]["test"], "hud");
    assert_eq!(by_key.len(), 4, "{keys:?}");

    // The receiver's side: per event and webhook, two refusals and one
    // acceptance, every body signed.
    let got = receiver.got.lock().unwrap().clone();
    let mut per: BTreeMap<(String, String), Vec<&Got>> = BTreeMap::new();
    for g in &got {
        let mut mac = <Hmac<sha2::Sha256> as Mac>::new_from_slice(SECRET.as_bytes()).unwrap();
        mac.update(&g.body);
        let want = format!("sha256={}", hex::encode(mac.finalize().into_bytes()));
        assert_eq!(g.signature, want, "a bad signature on {}", g.path);
        per.entry((g.event.clone(), g.path.clone()))
            .or_default()
            .push(g);
    }
    // Four events to /json, the gate_red one to /slack too.
    assert_eq!(per.len(), 5, "{:?}", per.keys());
    // docs/alerts.md's receiver, as the page has it, run on a body and
    // header received here with the secret file as written (a newline at
    // its end): valid; and on a body one byte longer: not.
    let doc = std::fs::read_to_string(common::repo().join("docs/alerts.md")).unwrap();
    let python = doc
        .split("```python\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("a python block in docs/alerts.md");
    let first = &got[0];
    let body_file = dir.path().join("body.bin");
    for (body, expected) in [
        (first.body.clone(), "True"),
        ([&first.body[..], b" "].concat(), "False"),
    ] {
        std::fs::write(&body_file, &body).unwrap();
        let program = format!(
            "{python}\nimport sys\nprint(valid(sys.argv[1], open(sys.argv[2], 'rb').read(), sys.argv[3]))\n"
        );
        let o = std::process::Command::new("python3")
            .args(["-c", &program])
            .arg(dir.path().join("hook.secret"))
            .arg(&body_file)
            .arg(&first.signature)
            .output()
            .expect("python3");
        assert_eq!(
            String::from_utf8_lossy(&o.stdout).trim(),
            expected,
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    for ((event, path), all) in &per {
        let accepted = all.iter().filter(|g| g.accepted).count();
        assert_eq!((all.len(), accepted), (3, 1), "event {event} to {path}");
    }
    let slack = got
        .iter()
        .find(|g| g.path == "/slack" && g.accepted)
        .unwrap();
    let slack: Value = serde_json::from_slice(&slack.body).unwrap();
    let text = slack["text"].as_str().unwrap();
    assert!(
        text.contains("c03..c04") && text.contains("went red"),
        "{text}"
    );
    let red_id = red["id"].as_i64().unwrap().to_string();
    let json: Value = serde_json::from_slice(
        &got.iter()
            .find(|g| g.path == "/json" && g.accepted && g.event == red_id)
            .unwrap()
            .body,
    )
    .unwrap();
    assert_eq!(json["key"], format!("gate_red:{first_bad}"));
    assert_eq!(json["event"]["commits"]["first_bad"], "c04");
    // The API's delivery log says the same.
    for d in red["deliveries"].as_array().unwrap() {
        let statuses: Vec<i64> = d["attempts"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a["status"].as_i64().unwrap())
            .collect();
        assert_eq!(statuses, [503, 503, 204], "{d}");
    }
}

/// The same scan and delivery bookkeeping on a PostgreSQL server the test
/// starts: a red gate and new untriaged digests raise one event each however
/// often the history is scanned, a delivery is claimed once, and a refused
/// attempt waits for its back-off while an accepted one ends it.
#[test]
fn alerts_are_raised_once_and_claimed_once_on_postgresql() {
    use tonegate::alerts::{Alerts, Format, Kind, Retry, Webhook};
    use tonegate::history::{Attempted, History};
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    std::fs::write(&seeded.suite, "scenes = [\"scenes/grid-static.toml\"]\n").unwrap();
    let url = crate::common::postgres::database();
    let alerts = Alerts {
        public_url: "http://tonegate.test".into(),
        scan_every: Duration::from_secs(1),
        retry: Retry {
            first: Duration::from_secs(3600),
            most_attempts: 3,
        },
        timeout: Duration::from_secs(1),
        webhooks: vec![Webhook {
            name: "team".into(),
            url: "http://127.0.0.1:9/".into(),
            format: Format::Json,
            secret: SECRET.as_bytes().to_vec(),
            events: Kind::ALL.to_vec(),
        }],
    };
    let h = History::open(std::path::Path::new(&url)).unwrap();
    assert_eq!(tonegate::alerts::scan(&h, &alerts).unwrap(), 0);
    for (run, extra) in [("c1", None), ("c2", Some("1.02"))] {
        let mut args = vec![
            "check",
            "--suite",
            seeded.suite.to_str().unwrap(),
            "--db",
            &url,
        ];
        if let Some(g) = extra {
            args.extend(["--fault-gain", g]);
        }
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_tonegate"))
            .args(&args)
            .current_dir(common::repo())
            .env("TONEGATE_COMMIT", run)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(if extra.is_some() { 1 } else { 0 }));
    }
    let first = submit(std::path::Path::new(&url), &dir.path().join("f"), 0, "f1");
    assert_eq!(first["untriaged"], 2);
    assert_eq!(tonegate::alerts::scan(&h, &alerts).unwrap(), 2);
    assert_eq!(
        tonegate::alerts::scan(&h, &alerts).unwrap(),
        0,
        "raised twice"
    );
    let hold = Duration::from_secs(60);
    let due = h.claim_due_deliveries(hold, 10).unwrap();
    assert_eq!(due.len(), 2);
    assert!(
        h.claim_due_deliveries(hold, 10).unwrap().is_empty(),
        "claimed twice"
    );
    let red = due.iter().find(|d| d.kind == "gate_red").unwrap();
    let event: Value = serde_json::from_str(&red.payload).unwrap();
    assert_eq!(event["commits"]["last_good"], "c1");
    assert_eq!(event["commits"]["first_bad"], "c2");
    let later = (chrono::Utc::now() + chrono::Duration::hours(1))
        .to_rfc3339_opts(chrono::SecondsFormat::Millis, true);
    h.record_attempt(
        red.id,
        Attempted::Failed {
            status: Some(503),
            error: "answered 503",
            next_at: Some(later),
        },
    )
    .unwrap();
    let other = due.iter().find(|d| d.kind == "untriaged").unwrap();
    h.record_attempt(other.id, Attempted::Delivered(200))
        .unwrap();
    assert!(
        h.claim_due_deliveries(hold, 10).unwrap().is_empty(),
        "not due yet"
    );
    let listed = h.alerts(10).unwrap();
    let state = |kind: &str| {
        let a = listed.iter().find(|a| a.kind == kind).unwrap();
        (
            a.deliveries[0].state.clone(),
            a.deliveries[0].attempts.len(),
        )
    };
    assert_eq!(state("gate_red"), ("pending".into(), 1));
    assert_eq!(state("untriaged"), ("delivered".into(), 1));
    let rows = h.submissions(10).unwrap();
    assert_eq!((rows.len(), rows[0].untriaged), (1, 2));
}
