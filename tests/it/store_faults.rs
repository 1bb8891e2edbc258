//! The artifact store as a fault domain: a `check` whose store is down
//! keeps its results (the images wait in the history, pending, served from
//! there) and `history pending --upload` sends them on once the store is
//! back; reads of a store that is down answer 503 with `Retry-After` and no
//! address; without credentials the cloud's metadata service is never
//! asked, unless `TONEGATE_S3_INSTANCE_METADATA=1` says so.

use crate::common::repo;
use crate::common::seaweed::Weed;
use sha2::{Digest, Sha256};
use std::net::TcpListener;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

const BUCKET: &str = "tonegate";
const STORE: &str = "s3://tonegate/faults";

/// The `AWS_*` variables of a store at `endpoint`, anonymous.
fn store_env(endpoint: &str) -> Vec<(&'static str, String)> {
    vec![
        ("AWS_ENDPOINT", endpoint.to_owned()),
        ("AWS_ALLOW_HTTP", "true".into()),
        ("AWS_SKIP_SIGNATURE", "true".into()),
        ("AWS_REGION", "us-east-1".into()),
    ]
}

/// A tonegate command with no `AWS_*` variable but `env`.
fn command(env: &[(&'static str, String)]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_tonegate"));
    c.current_dir(repo()).env_remove("TONEGATE_DB");
    for (k, _) in std::env::vars() {
        if k.starts_with("AWS_") || k == "TONEGATE_S3_INSTANCE_METADATA" {
            c.env_remove(k);
        }
    }
    c.envs(env.iter().map(|(k, v)| (*k, v.as_str())));
    c
}

fn run(env: &[(&'static str, String)], args: &[&str]) -> std::process::Output {
    command(env).args(args).output().unwrap()
}

/// A check report from stdout (an infinite PSNR is written 1e999, which
/// serde_json does not read as a number).
fn report_of(o: &std::process::Output) -> serde_json::Value {
    let text = String::from_utf8_lossy(&o.stdout).replace("1e999", "null");
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {}", said(o)))
}

fn said(o: &std::process::Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A loopback port nothing listens on.
fn dead_endpoint() -> String {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = l.local_addr().unwrap().port();
    drop(l);
    format!("http://127.0.0.1:{port}")
}

/// `serve` on the history; the child and its base address.
fn serve(db: &str, env: &[(&'static str, String)]) -> (Child, String) {
    let mut child = command(env)
        .args(["serve", "--bind", "127.0.0.1:0", "--db", db])
        .env("TONEGATE_DB_RETRY_S", "2")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let base = crate::common::served_base(&mut child);
    (child, base)
}

fn stop(mut child: Child) {
    // SAFETY: signals a child this test spawned.
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let _ = child.wait();
}

/// GET `url`: status, Retry-After, body, and how long the answer took.
fn get(url: &str) -> (u16, Option<String>, Vec<u8>, Duration) {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let started = Instant::now();
        let r = reqwest::Client::new()
            .get(url)
            .timeout(Duration::from_secs(60))
            .send()
            .await
            .unwrap();
        let retry = r
            .headers()
            .get("retry-after")
            .map(|v| v.to_str().unwrap().to_owned());
        let status = r.status().as_u16();
        let body = r.bytes().await.unwrap().to_vec();
        (status, retry, body, started.elapsed())
    })
}

/// The history's pending images, as `history pending --json` lists them.
fn pending(db: &str) -> Vec<serde_json::Value> {
    let o = run(&[], &["history", "pending", "--db", db, "--json"]);
    assert!(o.status.success(), "{}", said(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// Counts the connections made to a loopback listener (each closed at once).
fn listener() -> (String, Arc<AtomicUsize>) {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = format!("http://{}", l.local_addr().unwrap());
    let seen = Arc::new(AtomicUsize::new(0));
    let counted = seen.clone();
    std::thread::spawn(move || {
        for c in l.incoming() {
            counted.fetch_add(1, Ordering::SeqCst);
            drop(c);
        }
    });
    (addr, seen)
}

#[test]
fn a_store_outage_keeps_the_runs_results_and_the_images_wait_in_the_history() {
    let mut weed = Weed::start(BUCKET);
    let dir = tempfile::tempdir().unwrap();
    let (suite, _) = crate::fleet::suites(dir.path());
    let suite = suite.to_str().unwrap();
    let db_path = dir.path().join("h.sqlite");
    let db = db_path.to_str().unwrap();
    let down = store_env(&dead_endpoint());

    // The store is down for the whole run: the run passes and is stored as
    // passed with its metrics; its images wait in the history.
    // `check` on the CPU with the store at `env`, its report to stdout and a
    // retry budget of 1 s.
    let check_with = |env: &[(&'static str, String)], store: &str, more: &[&str]| {
        let mut args = vec![
            "check",
            "--cpu",
            "--suite",
            suite,
            "--db",
            db,
            "--artifacts",
            store,
            "--json",
            "-",
            "--db-retry-s",
            "1",
        ];
        args.extend_from_slice(more);
        run(env, &args)
    };
    let o = check_with(&down, STORE, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", said(&o));
    let report = report_of(&o);
    let run_id = report["run_id"].as_i64().unwrap();
    let listed: Vec<String> = report["artifacts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a.as_str().unwrap().to_owned())
        .collect();
    let waiting = report["artifacts_pending"].as_array().unwrap();
    assert!(!listed.is_empty());
    assert_eq!(waiting.len(), listed.len(), "{waiting:?}");
    let reason = waiting[0]["reason"].as_str().unwrap();
    assert!(reason.contains("did not answer"), "{reason}");
    assert!(!reason.contains("127.0.0.1"), "{reason}");
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("pending"),
        "{}",
        said(&o)
    );
    let h = tonegate::history::History::open_read_only(&db_path).unwrap();
    assert_eq!(format!("{:?}", h.runs(10).unwrap()[0].status), "Passed");
    assert!(h.report(run_id).unwrap().is_some());
    drop(h);
    let images = pending(db);
    assert!(!images.is_empty());
    assert!(images
        .iter()
        .all(|p| p["store"] == STORE && p["runs"][0] == run_id));

    // Served from the history meanwhile.
    let (server, base) = serve(db, &store_env(&weed.base()));
    let name = &listed[0];
    let url = format!("{base}/api/v1/runs/{run_id}/artifacts/{name}");
    let (status, _, bytes, _) = get(&url);
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&bytes));
    let sha = hex::encode(Sha256::digest(&bytes));

    // The store is back: the images go to it and leave the history's table.
    let o = run(
        &store_env(&weed.base()),
        &["history", "pending", "--db", db, "--upload"],
    );
    assert_eq!(o.status.code(), Some(0), "{}", said(&o));
    assert!(pending(db).is_empty());
    let object = weed
        .get(BUCKET, &format!("faults/{sha}.png"))
        .expect("the image is in the store");
    assert_eq!(object, bytes);
    let (status, _, again, _) = get(&url);
    assert_eq!((status, again), (200, bytes.clone()));

    // The store goes down: a read answers 503 with Retry-After, naming no
    // address, within the server's budget.
    weed.kill();
    let (status, retry, body, took) = get(&url);
    let text = String::from_utf8_lossy(&body);
    assert_eq!(status, 503, "{text}");
    assert!(retry.is_some(), "{text}");
    assert!(text.contains("artifact_store_unavailable"), "{text}");
    assert!(
        !text.contains("127.0.0.1") && !text.contains("http"),
        "{text}"
    );
    assert!(took < Duration::from_secs(30), "{took:?}");
    stop(server);

    // Without credentials the metadata service is not asked: the server
    // answers 503 and the (stand-in) metadata endpoint sees no connection.
    let (metadata, seen) = listener();
    let no_keys = vec![
        ("AWS_ENDPOINT", weed.base()),
        ("AWS_ALLOW_HTTP", "true".to_owned()),
        ("AWS_METADATA_ENDPOINT", metadata.clone()),
    ];
    let (server, base) = serve(db, &no_keys);
    let (status, _, body, _) = get(&format!("{base}/api/v1/runs/{run_id}/artifacts/{name}"));
    assert_eq!(status, 503, "{}", String::from_utf8_lossy(&body));
    stop(server);
    assert_eq!(
        seen.load(Ordering::SeqCst),
        0,
        "the metadata service was asked"
    );
    // `check` refuses such a store before it renders anything.
    let o = run(
        &no_keys,
        &[
            "check",
            "--cpu",
            "--suite",
            suite,
            "--no-history",
            "--artifacts",
            STORE,
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", said(&o));
    assert!(said(&o).contains("no credentials"), "{}", said(&o));
    // Asked for, it is: the test can see a probe.
    let mut asked = no_keys.clone();
    asked.push(("TONEGATE_S3_INSTANCE_METADATA", "1".into()));
    let (server, base) = serve(db, &asked);
    let (status, _, _, _) = get(&format!("{base}/api/v1/runs/{run_id}/artifacts/{name}"));
    stop(server);
    assert_eq!(status, 503);
    assert!(
        seen.load(Ordering::SeqCst) > 0,
        "asked for, the probe happens"
    );

    // Dropped: a second outage's images go, the run's results stay.
    let o = check_with(&down, "s3://tonegate/elsewhere", &["--spp", "3"]);
    // Other frames (3 spp), so other images; judged or not at that spp.
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", said(&o));
    let second = report_of(&o);
    assert!(!second["artifacts_pending"].as_array().unwrap().is_empty());
    assert_eq!(
        pending(db).len(),
        second["artifacts_pending"].as_array().unwrap().len()
    );
    let o = run(&[], &["history", "pending", "--db", db, "--drop"]);
    assert_eq!(o.status.code(), Some(0), "{}", said(&o));
    assert!(pending(db).is_empty());
    let h = tonegate::history::History::open_read_only(&db_path).unwrap();
    let second_id = second["run_id"].as_i64().unwrap();
    // Its names of the dropped images are gone; those of images the store
    // already held (the golden, the same as the first run's) stay.
    let (named, dropped) = (
        second["artifacts"].as_array().unwrap().len(),
        second["artifacts_pending"].as_array().unwrap().len(),
    );
    assert!(dropped < named, "{named} {dropped}");
    assert_eq!(h.artifact_names(second_id).unwrap().len(), named - dropped);
    assert_ne!(format!("{:?}", h.runs(10).unwrap()[0].status), "Error");
    // The first run's images, in the store, are untouched.
    assert_eq!(h.artifact_names(run_id).unwrap().len(), listed.len());
}

/// A frames submission whose store is down is held up once, not once per
/// image: after the first image the store did not take, the rest are kept
/// pending at once. Ten new images cost about what one does in attempts
/// on the store (each of which counts a connection here), the report lists
/// the ten pending digests, and `history pending` names the submission
/// that holds each.
#[test]
fn a_store_outage_holds_a_frames_submission_up_once() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("h.sqlite");
    let db = db.to_str().unwrap();
    let (endpoint, seen) = listener();
    let env = store_env(&endpoint);
    let submit = |frames: &std::path::Path| {
        let o = command(&env)
            .args([
                "frames",
                "submit",
                frames.to_str().unwrap(),
                "--db",
                db,
                "--artifacts",
                STORE,
                "--json",
                "-",
            ])
            .env("TONEGATE_DB_RETRY_S", "1")
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(1), "{}", said(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    // Images of their own in each folder (`seed`): no digest is shared.
    let folder = |name: &str, n: u32, seed: u32| {
        let d = dir.path().join(name);
        std::fs::create_dir_all(&d).unwrap();
        for i in 0..n {
            let img: tonegate::image::Rgb8Image = tonegate::image::Image::from_fn(16, 8, |x, y| {
                [(x * 9 + i) as u8, y as u8, (i * 20 + seed) as u8]
            });
            tonegate::io::write_frame_png(
                &d.join(format!("{name}{i}.png")),
                &tonegate::image::Frame::Rgb8(img),
            )
            .unwrap();
        }
        d
    };
    let one = submit(&folder("one", 1, 7));
    let for_one = seen.load(Ordering::SeqCst);
    assert!(for_one >= 1, "the store was tried");
    let ten = submit(&folder("ten", 10, 0));
    let for_ten = seen.load(Ordering::SeqCst) - for_one;
    assert_eq!(one["pending_images"].as_array().unwrap().len(), 1, "{one}");
    assert_eq!(ten["pending_images"].as_array().unwrap().len(), 10, "{ten}");
    // Retries back off with jitter, so the counts are close, not equal;
    // one hold-up per image would be ten times as many.
    assert!(
        for_ten <= 3 * for_one + 3,
        "ten images: {for_ten} attempts on the store, one image: {for_one}"
    );
    let id = ten["submission"].as_i64().unwrap();
    let listed = pending(db);
    let of_ten: Vec<&serde_json::Value> = listed
        .iter()
        .filter(|p| p["submissions"] == serde_json::json!([id]))
        .collect();
    assert_eq!(of_ten.len(), 10, "{listed:#?}");
}
