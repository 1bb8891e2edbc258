//! A fleet: eight `tonegate runner` processes and the server on one
//! real PostgreSQL (started by `common/postgres.rs`), 200 queued runs of a
//! one-frame suite plus one long run that a runner is killed (-9) in the
//! middle of. Every job is done exactly once, none is lost, none is run by
//! two runners, the killed runner's run is aborted and its job finished by
//! another; the throughput and the queue latency are printed.

use crate::common;
use crate::common::postgres as pg;
use crate::common::server;

use common::{copy_dir, repo, tonegate};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use tonegate::history::{History, JobSpec, RunStatus};

/// A one-frame 48x32 scene of the grid under `seed000` with this key,
/// held to its own golden (the CPU reference renders it identically).
pub(crate) fn tiny_scene(name: &str, description: &str, key: f64) -> String {
    format!(
        r#"name = "{name}"
description = "{description}"
size = [48, 32]
fov_y = 60.0
frames = 1

[environment]
builtin = "grid"
size = [64, 32]

[rotation]
degrees_per_frame = 0.0

[operator]
kind = "seed000"
key = {key}
white_fraction = 0.9

[[checks]]
min_psnr = 50.0
set_by = "the CPU reference against its own golden: identical"
"#
    )
}

/// A copy of golden/ with a one-frame 48x32 scene and its golden blessed,
/// and the two-scene suite as the long job.
pub(crate) fn suites(dir: &Path) -> (PathBuf, PathBuf) {
    let golden = dir.join("golden");
    copy_dir(&repo().join("golden"), &golden);
    std::fs::write(
        golden.join("scenes/tiny.toml"),
        tiny_scene("tiny", "the fleet test's job: one small frame", 0.18),
    )
    .unwrap();
    let tiny = golden.join("tiny.toml");
    std::fs::write(&tiny, "scenes = [\"scenes/tiny.toml\"]\n").unwrap();
    let o = tonegate(&["golden", "bless", "--suite", tiny.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The message names the folder the goldens went to, not "golden/".
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains(&format!("into {}", golden.display())),
        "{said}"
    );
    let long = golden.join("long.toml");
    std::fs::write(
        &long,
        "scenes = [\"scenes/grid-static.toml\", \"scenes/sky-reinhard-global.toml\", \"scenes/night-reinhard-global.toml\"]\n",
    )
    .unwrap();
    (tiny, long)
}

fn runner(url: &str, name: &str, labels: &str, log: &Path) -> Child {
    let log = std::fs::File::create(log).unwrap();
    Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args(["runner", "--db", url, "--cpu", "--name", name])
        .args(["--labels", labels])
        .args([
            "--poll-ms",
            "50",
            "--heartbeat-ms",
            "200",
            "--lost-after-s",
            "3",
        ])
        .args(["--exit-when-idle-s", "4"])
        .current_dir(repo())
        .env_remove("TONEGATE_DB")
        .stdout(Stdio::null())
        .stderr(log)
        .spawn()
        .unwrap()
}

pub(crate) fn wait_for(what: &str, limit: Duration, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < limit, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// `tonegate enqueue` of `suite` with `more` exits 2 saying `says`.
fn enqueue_refused(url: &str, suite: &Path, more: &[&str], says: &str) {
    let mut args = vec!["enqueue", "--db", url, "--suite", suite.to_str().unwrap()];
    args.extend_from_slice(more);
    let o = tonegate(&args);
    assert_eq!(o.status.code(), Some(2), "{args:?}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(says), "{args:?}: {err}");
}

fn millis_between(a: &str, b: &str) -> f64 {
    let a = chrono::DateTime::parse_from_rfc3339(a).unwrap();
    let b = chrono::DateTime::parse_from_rfc3339(b).unwrap();
    (b - a).num_milliseconds() as f64
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn eight_runners_do_every_queued_run_exactly_once_and_a_killed_runners_run_is_finished_by_another()
{
    let dir = tempfile::tempdir().unwrap();
    let (tiny, long) = suites(dir.path());
    let url = pg::database();
    let db = PathBuf::from(&url);
    let h = History::open(&db).unwrap();
    // Job 1, the long one, only for runners labelled `long`.
    let long_job = h
        .enqueue(&JobSpec {
            suite: long.display().to_string(),
            label: Some("long".into()),
            ..Default::default()
        })
        .unwrap();
    assert_eq!(long_job, 1);
    let logs = dir.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    // The victim starts alone, so it is the one to claim the long job.
    let mut victim = runner(&url, "victim", "long", &logs.join("victim.log"));
    let mut run_of_victim = 0;
    wait_for(
        "the victim to start the long run",
        Duration::from_secs(60),
        || {
            let job = &h.jobs(None, 1).unwrap()[0];
            match job.run_id {
                Some(run) if h.run(run).unwrap().is_some_and(|r| r.scenes >= 1) => {
                    run_of_victim = run;
                    true
                }
                _ => false,
            }
        },
    );
    // 190 jobs from the command line, 10 through the server's POST /runs.
    let o = tonegate(&[
        "enqueue",
        "--db",
        &url,
        "--suite",
        tiny.to_str().unwrap(),
        "--cpu",
        "--count",
        "190",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rt = tokio::runtime::Runtime::new().unwrap();
    let seeded = common::Seeded {
        db: db.clone(),
        suite: tiny.clone(),
        passed: 0,
        failed: 0,
        tradeoff: 0,
    };
    let srv = rt.block_on(server::start(&seeded, |_| {}));
    for _ in 0..10 {
        let r = rt
            .block_on(
                srv.client
                    .post(format!("{}/api/v1/runs", srv.base))
                    .bearer_auth(server::TOKEN)
                    .body(r#"{"renderer": "cpu"}"#)
                    .send(),
            )
            .unwrap();
        assert_eq!(r.status(), 202);
    }
    // A selector is checked: an unknown key, a bad label, an empty adapter
    // and control characters are 400s (a NUL reached PostgreSQL, which
    // refused the statement: a 500), in the words `enqueue` uses.
    for (body, says) in [
        (r#"{"renderer": "cpu", "gpu": 1}"#, "unknown field"),
        (r#"{"label": "a,b"}"#, "label: use letters"),
        (r#"{"spp": 4}"#, "spp"),
        (
            r#"{"adapter": ""}"#,
            "adapter: a name substring of 1 to 200 characters, no control characters",
        ),
        (
            r#"{"adapter": "a\u0000b"}"#,
            "adapter: a name substring of 1 to 200 characters, no control characters, got",
        ),
        (
            r#"{"scenes": ["sky\u0007"]}"#,
            "scenes: names of 1 to 200 characters, no control characters",
        ),
        (r#"{"scenes": ["no-such-scene"]}"#, "scenes: no scene "),
    ] {
        let r = rt
            .block_on(
                srv.client
                    .post(format!("{}/api/v1/runs", srv.base))
                    .bearer_auth(server::TOKEN)
                    .body(body)
                    .send(),
            )
            .unwrap();
        assert_eq!(r.status(), 400, "{body}");
        let text = rt.block_on(r.text()).unwrap();
        assert!(text.contains(says), "{body}: {text}");
    }
    enqueue_refused(
        &url,
        &tiny,
        &["--want-adapter", ""],
        "adapter: a name substring of 1 to 200 characters, no control characters",
    );
    // Scenes are checked against the suite when queued, in the API's words;
    // a file that is not a suite is refused before anything is queued.
    enqueue_refused(
        &url,
        &tiny,
        &["--scene", "no-such-scene"],
        "scenes: no scene \"no-such-scene\" in the suite; it has: ",
    );
    let not_a_suite = dir.path().join("passwd");
    std::fs::write(&not_a_suite, "root:x:0:0:root:/root:/bin/bash\n").unwrap();
    enqueue_refused(&url, &not_a_suite, &[], "--suite: ");
    let started = Instant::now();
    let mut others: Vec<Child> = (1..8)
        .map(|i| {
            let labels = if i == 1 { "long,spare" } else { "small" };
            runner(
                &url,
                &format!("r{i}"),
                labels,
                &logs.join(format!("r{i}.log")),
            )
        })
        .collect();
    // The victim dies in the middle of its run.
    assert_eq!(h.status(run_of_victim).unwrap(), Some(RunStatus::Running));
    victim.kill().unwrap();
    victim.wait().unwrap();
    for c in &mut others {
        let status = loop {
            if let Some(s) = c.try_wait().unwrap() {
                break s;
            }
            assert!(
                started.elapsed() < Duration::from_secs(300),
                "the runners did not finish in 5 minutes; logs in {}",
                logs.display()
            );
            std::thread::sleep(Duration::from_millis(50));
        };
        assert!(status.success(), "a runner failed: {status}");
    }
    let elapsed = started.elapsed().as_secs_f64();
    let log = |name: &str| std::fs::read_to_string(logs.join(name)).unwrap_or_default();

    // Every job done, exactly once.
    let jobs = h.jobs(None, 1000).unwrap();
    assert_eq!(jobs.len(), 201);
    let not_done: Vec<_> = jobs.iter().filter(|j| j.state != "done").collect();
    assert!(not_done.is_empty(), "{not_done:?}\n{}", log("r1.log"));
    let long = jobs.iter().find(|j| j.id == long_job).unwrap();
    assert_eq!(long.attempts, 2, "{long:?}");
    assert!(jobs
        .iter()
        .filter(|j| j.id != long_job)
        .all(|j| j.attempts == 1));
    // The runs: one finished run per job, the long job's first one aborted.
    let runs = h.runs(1000).unwrap();
    assert_eq!(runs.len(), 202, "one run per claim");
    let mut finished_per_job: BTreeMap<i64, usize> = BTreeMap::new();
    let pg = postgres::Client::connect(&url, postgres::NoTls);
    let mut pg = pg.unwrap();
    for row in pg
        .query(
            "SELECT job_id, status FROM runs WHERE status IN ('passed', 'failed')",
            &[],
        )
        .unwrap()
    {
        let job: Option<i64> = row.get(0);
        *finished_per_job
            .entry(job.expect("every run is a job's"))
            .or_default() += 1;
        let status: String = row.get(1);
        assert_eq!(status, "passed");
    }
    assert_eq!(finished_per_job.len(), 201, "every job has a finished run");
    assert!(
        finished_per_job.values().all(|&n| n == 1),
        "no job finished twice"
    );
    assert_eq!(
        h.status(run_of_victim).unwrap(),
        Some(RunStatus::Aborted),
        "the killed runner's run"
    );
    // Marked by whichever saw it first: a writer opening the history on the
    // same host (the victim's process is gone) or the heartbeat expiry.
    let aborted = runs.iter().find(|r| r.id == run_of_victim).unwrap();
    let why = aborted.detail.as_deref().unwrap_or("");
    assert!(
        why.contains("crash or kill") || why.contains("runner victim"),
        "{aborted:?}"
    );
    // The job's own record says which runner was lost.
    assert!(
        long.detail.as_deref().unwrap_or("").starts_with("run ")
            && log("r1.log").contains(&format!("job {long_job} (attempt 2)")),
        "{long:?}\n{}",
        log("r1.log")
    );
    // Each job's run is its finished one.
    for j in &jobs {
        let run = j.run_id.expect("a done job has its run");
        assert_ne!(run, run_of_victim);
    }
    // The runners: the victim lost, the rest stopped; the work was shared.
    let runners = h.runners(true).unwrap();
    assert_eq!(runners.len(), 8);
    for r in &runners {
        let want = if r.name == "victim" {
            "lost"
        } else {
            "stopped"
        };
        assert_eq!(r.state, want, "{r:?}");
    }
    let mut per_runner: BTreeMap<i64, usize> = BTreeMap::new();
    for j in &jobs {
        *per_runner.entry(j.runner_id.unwrap()).or_default() += 1;
    }
    assert!(per_runner.len() >= 4, "the jobs went to {per_runner:?}");
    // The server shows the fleet.
    let (status, queue) = rt.block_on(srv.json("/api/v1/queue?state=done&limit=5"));
    assert_eq!(status, 200);
    assert_eq!(queue["counts"]["done"], 201);
    assert_eq!(queue["jobs"].as_array().unwrap().len(), 5);
    let (status, all) = rt.block_on(srv.json("/api/v1/runners?all=true"));
    assert_eq!(status, 200);
    assert_eq!(all.as_array().unwrap().len(), 8);
    let (status, live) = rt.block_on(srv.json("/api/v1/runners"));
    assert_eq!(status, 200);
    assert_eq!(live.as_array().unwrap().len(), 0);
    let metrics = rt.block_on(async { srv.get("/metrics").await.text().await.unwrap() });
    for line in [
        "tonegate_jobs{state=\"done\"} 201",
        "tonegate_runners{state=\"stopped\"} 7",
        "tonegate_runners{state=\"lost\"} 1",
    ] {
        assert!(metrics.contains(line), "{line} not in\n{metrics}");
    }

    // The figures for the closing note.
    let latency: Vec<f64> = jobs
        .iter()
        .filter(|j| j.id != long_job)
        .map(|j| millis_between(&j.queued_at, j.claimed_at.as_deref().unwrap()))
        .collect();
    let small_done = jobs.iter().filter(|j| j.id != long_job).count();
    eprintln!(
        "fleet: {small_done} one-frame jobs + 1 long job by 7 runners (+1 killed) in {elapsed:.1} s \
         (from the runners' start to the last exit, 4 s of idle wait included): \
         {:.0} jobs/min; queue latency (queued to claimed) median {:.0} ms, max {:.0} ms \
         (jobs were queued before the runners started); jobs per runner {:?}",
        small_done as f64 / (elapsed - 4.0) * 60.0,
        median(latency.clone()),
        latency.iter().cloned().fold(0.0, f64::max),
        per_runner.values().collect::<Vec<_>>()
    );
}

/// The same queue on the embedded SQLite history: two runners on one
/// machine share it, each job done once.
#[test]
fn runners_share_a_sqlite_history_too() {
    let dir = tempfile::tempdir().unwrap();
    let (tiny, _) = suites(dir.path());
    let db = dir.path().join("h.sqlite");
    let url = db.to_str().unwrap();
    let o = tonegate(&[
        "enqueue",
        "--db",
        url,
        "--suite",
        tiny.to_str().unwrap(),
        "--cpu",
        "--count",
        "12",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let logs = dir.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    let mut rs: Vec<Child> = (0..2)
        .map(|i| {
            runner(
                url,
                &format!("s{i}"),
                "small",
                &logs.join(format!("s{i}.log")),
            )
        })
        .collect();
    for r in &mut rs {
        assert!(r.wait().unwrap().success());
    }
    let h = History::open_read_only(&db).unwrap();
    let jobs = h.jobs(None, 100).unwrap();
    assert_eq!(jobs.len(), 12);
    assert!(
        jobs.iter().all(|j| j.state == "done" && j.attempts == 1),
        "{jobs:?}"
    );
    let runs = h.runs(100).unwrap();
    assert_eq!(runs.len(), 12);
    assert!(
        runs.iter().all(|r| r.status == RunStatus::Passed),
        "{runs:?}"
    );
    let o = tonegate(&["fleet", "--db", url, "--all"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && out.contains("jobs: 12 done"), "{out}");
    assert_eq!(out.matches(" stopped ").count(), 2, "{out}");
}

/// SIGTERM asks a runner to stop: it finishes the job in hand (recorded as
/// the job's, not requeued), marks itself stopped and exits 0.
#[test]
fn sigterm_lets_a_runner_finish_its_job_and_stop() {
    let dir = tempfile::tempdir().unwrap();
    // Three scenes on the CPU: seconds, so the signal lands mid-run (the
    // whole built-in suite made this test 45 s of the test command).
    let (_, whole) = suites(dir.path());
    let db = dir.path().join("h.sqlite");
    let url = db.to_str().unwrap();
    let o = tonegate(&[
        "enqueue",
        "--db",
        url,
        "--suite",
        whole.to_str().unwrap(),
        "--cpu",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let log = dir.path().join("r.log");
    let mut child = Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args([
            "runner",
            "--db",
            url,
            "--cpu",
            "--name",
            "term",
            "--poll-ms",
            "50",
        ])
        .current_dir(repo())
        .env_remove("TONEGATE_DB")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    wait_for("the job's run to start", Duration::from_secs(60), || {
        History::open_read_only(&db)
            .ok()
            .and_then(|h| h.jobs(None, 1).ok())
            .is_some_and(|j| j.first().is_some_and(|j| j.run_id.is_some()))
    });
    let h = History::open_read_only(&db).unwrap();
    let job = &h.jobs(None, 1).unwrap()[0];
    assert_eq!(job.state, "claimed");
    assert_eq!(
        h.status(job.run_id.unwrap()).unwrap(),
        Some(RunStatus::Running)
    );
    drop(h);
    // SAFETY: signals a child this test spawned.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGTERM) }, 0);
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "the runner did not stop"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    let log = std::fs::read_to_string(&log).unwrap();
    assert!(status.success(), "{status}: {log}");
    let h = History::open_read_only(&db).unwrap();
    let job = &h.jobs(None, 1).unwrap()[0];
    assert_eq!(
        (job.state.as_str(), job.attempts),
        ("done", 1),
        "{job:?}\n{log}"
    );
    assert_eq!(
        h.status(job.run_id.unwrap()).unwrap(),
        Some(RunStatus::Passed)
    );
    assert_eq!(h.runners(true).unwrap()[0].state, "stopped");
    assert!(log.contains("asked to stop"), "{log}");
}

/// The queue is bounded: past `--max-queued-jobs` waiting jobs a submission
/// is answered 503 `queue_full` (the CLI exits 2 in the same words), a
/// listing shows at most 20 scene names a job and stops at 1 MiB, and one
/// job is read by its id (it used to read the whole table and filter it).
#[test]
fn the_queue_and_its_listing_are_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let (tiny, _) = suites(dir.path());
    let url = pg::database();
    let db = PathBuf::from(&url);
    let h = History::open(&db).unwrap();
    // 100 jobs stored with 1000 scene names of 200 four-byte characters
    // each (0.8 MB a job), as a client could queue them before names were
    // checked against the suite.
    let long: Vec<String> = (0..1000).map(|_| "\u{1D11E}".repeat(200)).collect();
    for _ in 0..100 {
        h.enqueue(&JobSpec {
            suite: tiny.display().to_string(),
            scenes: long.clone(),
            ..Default::default()
        })
        .unwrap();
    }
    let rt = tokio::runtime::Runtime::new().unwrap();
    let seeded = common::Seeded {
        db: db.clone(),
        suite: tiny.clone(),
        passed: 0,
        failed: 0,
        tradeoff: 0,
    };
    let srv = rt.block_on(server::start(&seeded, |o| o.limits.max_queued_jobs = 103));
    let text = rt.block_on(async {
        srv.get("/api/v1/queue?limit=100")
            .await
            .text()
            .await
            .unwrap()
    });
    assert!(text.len() <= (1 << 20) + 4096, "{} bytes", text.len());
    let listing: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(listing["truncated"], true);
    let jobs = listing["jobs"].as_array().unwrap();
    assert!(!jobs.is_empty() && jobs.len() < 100, "{}", jobs.len());
    for j in jobs {
        assert_eq!(j["scenes"].as_array().unwrap().len(), 20);
        assert_eq!(j["scenes_total"], 1000);
    }
    let (status, one) = rt.block_on(srv.json("/api/v1/queue?job=7"));
    assert_eq!(status, 200);
    assert_eq!(one["jobs"].as_array().unwrap().len(), 1);
    assert_eq!(one["jobs"][0]["id"], 7);
    assert_eq!(one["truncated"], false);
    // Three more fit under the limit of 103; the next is refused.
    let post = || {
        rt.block_on(async {
            let r = srv
                .client
                .post(format!("{}/api/v1/runs", srv.base))
                .bearer_auth(server::TOKEN)
                .body(r#"{"renderer": "cpu"}"#)
                .send()
                .await
                .unwrap();
            let retry = r.headers().get("retry-after").is_some();
            (r.status().as_u16(), retry, r.text().await.unwrap())
        })
    };
    for _ in 0..3 {
        let (status, _, body) = post();
        assert_eq!(status, 202, "{body}");
    }
    let (status, retry, body) = post();
    assert_eq!(status, 503, "{body}");
    assert!(retry, "no Retry-After");
    assert!(
        body.contains("\"queue_full\"") && body.contains("103 jobs are waiting (at most 103)"),
        "{body}"
    );
    enqueue_refused(
        &url,
        &tiny,
        &["--max-queued", "103"],
        "the queue is full: 103 jobs are waiting (at most 103)",
    );
    assert_eq!(h.jobs(Some("queued"), 1000).unwrap().len(), 103);
}

/// A run queued under an idempotency key is queued once: the same key
/// answers the same job (even once the queue is full), another key queues
/// another job, and a job without a key is queued each time.
#[test]
fn a_run_queued_under_an_idempotency_key_is_queued_once() {
    let url = pg::database();
    let h = History::open(Path::new(&url)).unwrap();
    let spec = JobSpec {
        suite: "golden/suite.toml".into(),
        ..Default::default()
    };
    let first = h.enqueue_keyed(&spec, 2, Some("ci-41")).unwrap();
    assert_eq!(h.enqueue_keyed(&spec, 2, Some("ci-41")).unwrap(), first);
    let other = h.enqueue_keyed(&spec, 2, Some("ci-42")).unwrap();
    assert_ne!(other, first);
    // The queue is full now: a retry of an accepted run still gets its id.
    assert_eq!(h.enqueue_keyed(&spec, 2, Some("ci-42")).unwrap(), other);
    assert!(h.enqueue_keyed(&spec, 2, Some("ci-43")).is_err());
    assert_eq!(h.jobs(None, 100).unwrap().len(), 2);
    h.enqueue_keyed(&spec, 10, None).unwrap();
    h.enqueue_keyed(&spec, 10, None).unwrap();
    assert_eq!(h.jobs(None, 100).unwrap().len(), 4);
}
