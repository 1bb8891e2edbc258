//! A fleet through its database's restarts: eight `tonegate runner`
//! processes and a `tonegate serve` process on a PostgreSQL cluster of the
//! test's own (`common/postgres.rs`), 200 runs submitted through
//! `POST /api/v1/runs` over 20 s while the test stops PostgreSQL twice for
//! about 5 s (`pg_ctl stop -m fast`, and again with `-m immediate`, whose
//! start recovers from the WAL) and starts it again. Every accepted run is
//! queued once and done once, with one finished run; no runner exits; a
//! request that could not be served while the database was down was answered
//! 503 with `Retry-After` and was sent again. The time each part took to
//! recover is printed.

use crate::common::postgres as pg;
use crate::common::repo;
use crate::fleet::{suites, wait_for};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime};

const TOKEN: &str = "chaos-token-0123456789abcdef";
const JOBS: usize = 200;

fn runner(url: &str, name: &str, log: &Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args(["runner", "--db", url, "--cpu", "--name", name])
        .args(["--labels", "small"])
        .args(["--poll-ms", "50", "--heartbeat-ms", "200"])
        .args(["--lost-after-s", "3"])
        .current_dir(repo())
        .env_remove("TONEGATE_DB")
        .env_remove("TONEGATE_DB_RETRY_S")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .unwrap()
}

/// `tonegate serve` on the database; its base address.
fn serve(url: &str, suite: &Path, dir: &Path) -> (Child, String) {
    let token = dir.join("token");
    std::fs::write(&token, TOKEN).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args(["serve", "--bind", "127.0.0.1:0", "--db", url])
        .arg("--suite")
        .arg(suite)
        .arg("--token-file")
        .arg(&token)
        .current_dir(repo())
        .env_remove("TONEGATE_DB")
        .env_remove("TONEGATE_DB_RETRY_S")
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(dir.join("serve.log")).unwrap())
        .spawn()
        .unwrap();
    let base = crate::common::served_base(&mut child);
    (child, base)
}

/// What the submitting client saw.
#[derive(Default)]
struct Submitted {
    jobs: Vec<i64>,
    /// 503 answers, each followed by the same request again.
    unavailable: usize,
}

/// Submits `JOBS` runs, one every 100 ms; a 503 is sent again after its
/// `Retry-After`. Any other answer than 202 or 503 fails the test.
fn submit(base: String, out: Arc<Mutex<Submitted>>) {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let client = reqwest::Client::new();
    rt.block_on(async {
        for i in 0..JOBS {
            let due = Instant::now() + Duration::from_millis(100);
            loop {
                // Sent again after a 503 under the same key: a run the
                // database committed before the answer was lost is not
                // queued a second time.
                let r = client
                    .post(format!("{base}/api/v1/runs"))
                    .bearer_auth(TOKEN)
                    .header("Idempotency-Key", format!("chaos-{i}"))
                    .body(r#"{"renderer": "cpu"}"#)
                    .send()
                    .await
                    .unwrap_or_else(|e| panic!("submission {i}: the server did not answer: {e}"));
                let status = r.status().as_u16();
                let retry: Option<u64> = r
                    .headers()
                    .get("retry-after")
                    .and_then(|v| v.to_str().ok()?.parse().ok());
                let body = r.text().await.unwrap();
                match status {
                    202 => {
                        let v: serde_json::Value = serde_json::from_str(&body).unwrap();
                        out.lock().unwrap().jobs.push(v["job"].as_i64().unwrap());
                        break;
                    }
                    503 => {
                        assert!(
                            body.contains("\"history_unavailable\""),
                            "submission {i}: {body}"
                        );
                        let wait = retry.unwrap_or_else(|| panic!("503 without Retry-After"));
                        out.lock().unwrap().unavailable += 1;
                        tokio::time::sleep(Duration::from_secs(wait)).await;
                    }
                    _ => panic!("submission {i}: {status} {body}"),
                }
            }
            tokio::time::sleep_until(due.into()).await;
        }
    });
}

fn rfc3339(t: SystemTime) -> chrono::DateTime<chrono::Utc> {
    t.into()
}

fn chaos(mode: &str) {
    let dir = tempfile::tempdir().unwrap();
    let (tiny, _) = suites(dir.path());
    let cluster = pg::private(&format!("chaos-{mode}"));
    let url = cluster.database();
    let (mut server, base) = serve(&url, &tiny, dir.path());
    let logs = dir.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    let mut runners: Vec<Child> = (0..8)
        .map(|i| runner(&url, &format!("c{i}"), &logs.join(format!("c{i}.log"))))
        .collect();
    let log = |name: &str| std::fs::read_to_string(logs.join(name)).unwrap_or_default();
    let submitted = Arc::new(Mutex::new(Submitted::default()));
    let submitter = {
        let (base, out) = (base.clone(), submitted.clone());
        std::thread::spawn(move || submit(base, out))
    };
    let rt = tokio::runtime::Runtime::new().unwrap();
    let client = reqwest::Client::new();
    let read = |path: &str| {
        rt.block_on(async {
            let r = client
                .get(format!("{base}{path}"))
                .timeout(Duration::from_secs(20))
                .send()
                .await
                .unwrap();
            let retry = r.headers().get("retry-after").cloned();
            (r.status().as_u16(), retry, r.text().await.unwrap())
        })
    };

    // Two outages of about 5 s, 5 s apart, while runs are being submitted.
    let mut recoveries = Vec::new();
    std::thread::sleep(Duration::from_secs(3));
    for round in 0..2 {
        let down = Instant::now();
        cluster.stop(mode).unwrap();
        // Reads while the database is down: 503 with Retry-After, as JSON.
        let (status, retry, body) = read("/api/v1/queue?limit=1");
        assert_eq!(status, 503, "outage {round}: {body}");
        assert!(retry.is_some(), "outage {round}: no Retry-After");
        assert!(body.contains("\"history_unavailable\""), "{body}");
        let (status, _, body) = read("/healthz");
        assert_eq!(status, 503, "outage {round}: {body}");
        std::thread::sleep(Duration::from_secs(5).saturating_sub(down.elapsed()));
        cluster.start_again().unwrap();
        let up = Instant::now();
        let up_wall = SystemTime::now();
        // The server: the first read answered after the start.
        let mut server_back = None;
        while server_back.is_none() {
            assert!(
                up.elapsed() < Duration::from_secs(30),
                "the server did not recover"
            );
            if read("/api/v1/queue?limit=1").0 == 200 {
                server_back = Some(up.elapsed());
            } else {
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        recoveries.push((down.elapsed() - up.elapsed(), up_wall, server_back.unwrap()));
        std::thread::sleep(Duration::from_secs(5));
    }
    submitter.join().expect("the submitter");
    let submitted = std::mem::take(&mut *submitted.lock().unwrap());
    assert_eq!(submitted.jobs.len(), JOBS);

    // Every accepted run is done.
    let mut db = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    wait_for("every job to be done", Duration::from_secs(300), || {
        let n: i64 = db
            .query_one("SELECT COUNT(*) FROM jobs WHERE state = 'done'", &[])
            .unwrap()
            .get(0);
        n as usize >= JOBS
    });
    // No runner exited, through both outages; each stops on SIGTERM.
    for (i, r) in runners.iter_mut().enumerate() {
        assert!(
            r.try_wait().unwrap().is_none(),
            "runner c{i} exited: {}",
            log(&format!("c{i}.log"))
        );
    }
    for r in &runners {
        // SAFETY: signals a child this test spawned.
        assert_eq!(unsafe { libc::kill(r.id() as i32, libc::SIGTERM) }, 0);
    }
    for (i, r) in runners.iter_mut().enumerate() {
        let status = r.wait().unwrap();
        assert!(
            status.success(),
            "runner c{i}: {status}: {}",
            log(&format!("c{i}.log"))
        );
    }
    // SAFETY: as above.
    assert_eq!(unsafe { libc::kill(server.id() as i32, libc::SIGTERM) }, 0);
    assert!(server.wait().unwrap().success());

    // Exactly the accepted runs were queued, once each.
    let mut accepted = submitted.jobs.clone();
    accepted.sort_unstable();
    accepted.dedup();
    assert_eq!(accepted.len(), JOBS, "a job id was answered twice");
    let rows = db
        .query(
            "SELECT id, state, attempts, claimed_at FROM jobs ORDER BY id",
            &[],
        )
        .unwrap();
    let ids: Vec<i64> = rows.iter().map(|r| r.get(0)).collect();
    assert_eq!(ids, accepted, "the queue holds exactly the accepted runs");
    for r in &rows {
        let (id, state, attempts): (i64, String, i64) = (r.get(0), r.get(1), r.get(2));
        assert_eq!((state.as_str(), attempts), ("done", 1), "job {id}");
    }
    // One finished run per job, and no other run.
    let mut per_job: BTreeMap<i64, Vec<String>> = BTreeMap::new();
    for r in db.query("SELECT job_id, status FROM runs", &[]).unwrap() {
        let job: Option<i64> = r.get(0);
        per_job
            .entry(job.expect("every run is a job's"))
            .or_default()
            .push(r.get(1));
    }
    assert_eq!(per_job.len(), JOBS);
    for (job, runs) in &per_job {
        assert_eq!(runs, &["passed"], "job {job}");
    }
    // Each runner lost its connections and made new ones.
    let waited: Vec<usize> = (0..8)
        .map(|i| {
            log(&format!("c{i}.log"))
                .matches("answers again: reconnected")
                .count()
        })
        .collect();
    assert!(
        waited.iter().all(|&n| n >= 1),
        "a runner did not see the outages ({waited:?}): {}",
        log("c0.log")
    );

    // The figures for the closing note: after each start, the server's
    // first answered read and the fleet's first claim.
    let claims: Vec<chrono::DateTime<chrono::Utc>> = rows
        .iter()
        .map(|r| {
            let at: String = r.get(3);
            chrono::DateTime::parse_from_rfc3339(&at).unwrap().into()
        })
        .collect();
    for (round, (outage, up_wall, server_back)) in recoveries.iter().enumerate() {
        let up = rfc3339(*up_wall);
        let first_claim = claims
            .iter()
            .filter(|c| **c >= up)
            .min()
            .map(|c| (*c - up).num_milliseconds());
        eprintln!(
            "chaos ({mode}), outage {}: down {:.1} s; server answered {:.0} ms after the start, \
             first claim {} ms after it",
            round + 1,
            outage.as_secs_f64(),
            server_back.as_secs_f64() * 1000.0,
            first_claim.map_or("(none)".into(), |m| m.to_string())
        );
    }
    eprintln!(
        "chaos ({mode}): {JOBS} jobs done once each by 8 runners, 0 runner exits, \
         {} submissions answered 503 and sent again, reconnections seen per runner {waited:?}",
        submitted.unavailable
    );
}

#[test]
fn a_fleet_rides_out_two_fast_restarts_of_its_database() {
    chaos("fast");
}

#[test]
fn a_fleet_rides_out_two_immediate_restarts_of_its_database() {
    chaos("immediate");
}
