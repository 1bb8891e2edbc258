//! The history on a real PostgreSQL server (started by these tests,
//! `common/postgres.rs`) gives the same answers as on SQLite, keeps the same
//! guarantees (versioned migrations, a newer schema refused, a killed run
//! marked aborted, finished runs untouched, read-only readers), and `check`,
//! `history` and `serve` work on it.

use crate::common;
use crate::common::postgres as pg;
use crate::common::server;

use common::{repo, seed_empty, tonegate};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};
use tonegate::check::{FrameResult, SceneResult, TestKind};
use tonegate::gate::{find_regressions, scene_record};
use tonegate::history::{
    History, RunAdapter, RunKind, RunMeta, RunStatus, StoredArtifact, TradeoffRecord, TrendFilter,
    SCHEMA_VERSION,
};
use tonegate::metrics::Metrics;
use tonegate::perf::TimingSummary;
use tonegate::suite::Performance;

fn frame(i: u32, psnr: f64, ssim: f64) -> FrameResult {
    FrameResult {
        frame: i,
        metrics: Metrics {
            mse: 65025.0 / 10f64.powf(psnr / 10.0),
            rmse: (65025.0 / 10f64.powf(psnr / 10.0)).sqrt(),
            psnr,
            snr: psnr - 6.0,
            ssim,
            max_abs_diff: (i % 7) as u16,
            mean_abs_diff: 0.1 * f64::from(i),
            fraction_over_1lsb: 0.001 * f64::from(i),
            flip_mean: 0.002,
            bits: 8,
            ssim_definition: String::new(),
        },
        fraction_over: BTreeMap::new(),
        pixels_over: BTreeMap::new(),
        flip_percentiles: BTreeMap::new(),
        adaptation: None,
        failed_checks: Vec::new(),
        artifacts: Vec::new(),
    }
}

fn scene(name: &str, sphere_ms: f64, psnr: f64) -> SceneResult {
    SceneResult {
        scene: name.into(),
        test: TestKind::Moving,
        renderer: "test".into(),
        adapter: "llvmpipe".into(),
        spp: 16,
        plan: vec!["sphere", "encode"],
        // An identical frame (+inf PSNR) and a NaN SSIM are stored too.
        frames: vec![
            frame(0, psnr, 0.99),
            frame(1, psnr + 1.5, f64::NAN),
            frame(2, f64::INFINITY, 1.0),
        ],
        judged_frames: Vec::new(),
        summaries: BTreeMap::new(),
        checks: Vec::new(),
        problems: Vec::new(),
        taa: None,
        expectation: None,
        expired_expectations: Vec::new(),
        timings: vec![
            TimingSummary {
                name: "sphere".into(),
                median_ms: sphere_ms,
                p95_ms: sphere_ms * 1.1,
            },
            TimingSummary {
                name: "encode".into(),
                median_ms: 0.4,
                p95_ms: 0.5,
            },
        ],
        fps: Some(1000.0 / (sphere_ms + 0.4)),
    }
}

fn adapter(name: &str, config: &str) -> RunAdapter {
    RunAdapter {
        name: name.into(),
        backend: "Vulkan".into(),
        driver: "driver".into(),
        driver_info: "info".into(),
        config: config.into(),
    }
}

/// The same history written through the public API: 24 check runs on two
/// adapters and two configurations with a 6 % level shift in one series,
/// a flagged regression, a failed run, an error run, a running run and a
/// tradeoff run.
fn fill(h: &mut History) {
    let llvm = adapter("llvmpipe", "{\"spp\":16}");
    let gpu = adapter("NVIDIA H100", "{\"spp\":16}");
    let wobble = [0.0, 0.15, -0.1, 0.2, -0.2, 0.05, -0.15, 0.1];
    for i in 0..24 {
        let (a, base) = if i % 2 == 0 {
            (&llvm, 10.0)
        } else {
            (&gpu, 2.0)
        };
        let shift = if a.name == "llvmpipe" && i >= 12 {
            1.06
        } else {
            1.0
        };
        let ms = (base + wobble[i % 8] * 0.1 * base) * shift;
        let id = h
            .start_run(
                RunKind::Check,
                &RunMeta {
                    suite: Some("golden/suite.toml".into()),
                    suite_hash: None,
                    git_commit: Some(format!("c{i}")),
                },
            )
            .unwrap();
        h.set_suite_hash(id, "abc").unwrap();
        h.set_adapter(id, a).unwrap();
        let results = [
            scene("sky", ms, 48.0 + i as f64 * 0.1),
            scene("grid", ms * 2.0, 40.0),
        ];
        for r in &results {
            h.record_scene(id, &scene_record(r).unwrap()).unwrap();
        }
        let found =
            find_regressions(h, id, &a.name, &a.config, &results, &Performance::default()).unwrap();
        h.record_regressions(id, &found).unwrap();
        let status = if i == 7 {
            RunStatus::Failed
        } else {
            RunStatus::Passed
        };
        h.finish_run(id, status, None, Some(&format!("{{\"run\":{i}}}")))
            .unwrap();
    }
    // A much slower run: flagged against its adapter's history.
    let id = h.start_run(RunKind::Check, &RunMeta::default()).unwrap();
    h.set_adapter(id, &llvm).unwrap();
    let slow = [scene("sky", 20.0, 48.0)];
    h.record_scene(id, &scene_record(&slow[0]).unwrap())
        .unwrap();
    let found = find_regressions(
        h,
        id,
        "llvmpipe",
        &llvm.config,
        &slow,
        &Performance::default(),
    )
    .unwrap();
    assert!(!found.is_empty(), "the slow run must be flagged");
    h.record_regressions(id, &found).unwrap();
    h.finish_run(id, RunStatus::Passed, None, None).unwrap();
    let id = h.start_run(RunKind::Check, &RunMeta::default()).unwrap();
    h.finish_run(id, RunStatus::Error, Some("no adapter"), None)
        .unwrap();
    let id = h.start_run(RunKind::Tradeoff, &RunMeta::default()).unwrap();
    let points: Vec<TradeoffRecord> = ["b", "a", "c"]
        .iter()
        .enumerate()
        .map(|(i, l)| TradeoffRecord {
            scene: "sky".into(),
            label: (*l).into(),
            config: format!("{{\"k\":{i}}}"),
            ms: 1.0 + i as f64,
            psnr: if i == 1 { f64::NAN } else { 40.0 + i as f64 },
            ssim: 0.9,
            log_average_rel_error: 1e-6,
            pareto: i != 2,
        })
        .collect();
    h.record_tradeoff(id, &points).unwrap();
    h.finish_run(id, RunStatus::Passed, None, None).unwrap();
    // Left running by this (live) process: not aborted by the next open.
    h.start_run(RunKind::Check, &RunMeta::default()).unwrap();
}

/// Everything the history answers, as JSON, times of day removed (the two
/// histories were written a few milliseconds apart).
fn answers(h: &History) -> serde_json::Value {
    let mut out = serde_json::Map::new();
    let mut put = |k: String, v: serde_json::Value| {
        out.insert(k, v);
    };
    put(
        "runs".into(),
        serde_json::to_value(h.runs(1000).unwrap()).unwrap(),
    );
    put(
        "runs_3".into(),
        serde_json::to_value(h.runs(3).unwrap()).unwrap(),
    );
    put(
        "run_7".into(),
        serde_json::to_value(h.run(7).unwrap()).unwrap(),
    );
    put(
        "run_999".into(),
        serde_json::to_value(h.run(999).unwrap()).unwrap(),
    );
    put(
        "report_2".into(),
        serde_json::to_value(h.report(2).unwrap()).unwrap(),
    );
    put(
        "counts".into(),
        serde_json::to_value(h.status_counts().unwrap()).unwrap(),
    );
    put(
        "scenes".into(),
        serde_json::to_value(h.scenes().unwrap()).unwrap(),
    );
    put(
        "stages".into(),
        serde_json::to_value(h.stages(3, "grid").unwrap()).unwrap(),
    );
    put(
        "tradeoff".into(),
        serde_json::to_value(h.tradeoff_points(27).unwrap()).unwrap(),
    );
    let filters = [
        (
            "all",
            TrendFilter {
                limit: 500,
                ..Default::default()
            },
        ),
        (
            "limit",
            TrendFilter {
                limit: 5,
                ..Default::default()
            },
        ),
        (
            "sky",
            TrendFilter {
                scene: Some("sky"),
                limit: 500,
                ..Default::default()
            },
        ),
        (
            "llvm",
            TrendFilter {
                adapter: Some("llvmpipe"),
                limit: 500,
                ..Default::default()
            },
        ),
        (
            "before",
            TrendFilter {
                before: Some(10),
                limit: 500,
                ..Default::default()
            },
        ),
        (
            "config",
            TrendFilter {
                config: Some("{\"spp\":16}"),
                finished_only: true,
                limit: 500,
                ..Default::default()
            },
        ),
        (
            "other_config",
            TrendFilter {
                config: Some("{}"),
                limit: 500,
                ..Default::default()
            },
        ),
    ];
    for metric in [
        "psnr",
        "ssim",
        "snr",
        "max_abs_diff",
        "mean_abs_diff",
        "fps",
        "sphere",
        "encode",
    ] {
        for (name, f) in &filters {
            put(
                format!("trend {metric} {name}"),
                serde_json::to_value(h.trend(metric, f).unwrap()).unwrap(),
            );
        }
    }
    let mut v = serde_json::Value::Object(out);
    strip_times(&mut v);
    v
}

fn strip_times(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.remove("started_at");
            m.remove("ended_at");
            m.values_mut().for_each(strip_times);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(strip_times),
        _ => {}
    }
}

#[test]
fn the_same_runs_give_the_same_answers_on_sqlite_and_postgres() {
    let dir = tempfile::tempdir().unwrap();
    let mut lite = History::open(&dir.path().join("h.sqlite")).unwrap();
    let url = pg::database();
    let mut shared = History::open(Path::new(&url)).unwrap();
    assert!(shared.is_shared() && !lite.is_shared());
    fill(&mut lite);
    fill(&mut shared);
    let (a, b) = (answers(&lite), answers(&shared));
    // Not two empty answers: the runs, the shift and the regression are there.
    assert_eq!(a["runs"].as_array().unwrap().len(), 28);
    let sky = a["trend sphere llvm"].as_array().unwrap();
    assert!(
        sky.iter().any(|p| p.get("change").is_some()),
        "the 6 % shift must be marked"
    );
    assert!(sky.iter().any(|p| p["regression"] == true));
    assert_eq!(a["trend psnr before"].as_array().unwrap().len(), 18);
    assert_eq!(a["stages"], serde_json::json!(["sphere", "encode"]));
    assert_eq!(
        a["tradeoff"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["label"].clone())
            .collect::<Vec<_>>(),
        ["b", "a", "c"]
    );
    for (k, va) in a.as_object().unwrap() {
        assert_eq!(va, &b[k], "{k} differs between SQLite and PostgreSQL");
    }
    // Reading back through a read-only connection gives the same again.
    drop(shared);
    let reader = History::open_read_only(Path::new(&url)).unwrap();
    assert_eq!(answers(&reader), b);
}

#[test]
fn migrations_are_serialised_versioned_and_a_newer_schema_is_refused() {
    let url = pg::database();
    // Six runners opening a fresh database at once: one migrates, none fails.
    let handles: Vec<_> = (0..6)
        .map(|_| {
            let url = url.clone();
            std::thread::spawn(move || {
                let h = History::open(Path::new(&url)).unwrap();
                h.schema_version().unwrap()
            })
        })
        .collect();
    for t in handles {
        assert_eq!(t.join().unwrap(), SCHEMA_VERSION);
    }
    let h = History::open(Path::new(&url)).unwrap();
    let id = h.start_run(RunKind::Check, &RunMeta::default()).unwrap();
    h.finish_run(id, RunStatus::Passed, None, None).unwrap();
    drop(h);
    // A reader cannot write.
    let reader = History::open_read_only(Path::new(&url)).unwrap();
    let err = reader
        .start_run(RunKind::Check, &RunMeta::default())
        .expect_err("a read-only history must refuse a write");
    assert!(err.to_string().contains("read-only"), "{err}");
    drop(reader);
    // A newer tonegate's schema is refused by writers and readers alike.
    let mut c = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    c.batch_execute("UPDATE tonegate_schema SET version = version + 5")
        .unwrap();
    for open in [History::open, History::open_read_only] {
        let err = open(Path::new(&url))
            .err()
            .expect("a newer schema must be refused");
        assert!(err.to_string().contains("schema version"), "{err}");
    }
    // Nothing was lost by the refusal.
    let n: i64 = c
        .query_one("SELECT COUNT(*) FROM runs", &[])
        .unwrap()
        .get(0);
    assert_eq!(n, 1);
}

#[test]
fn an_unreachable_database_is_a_clear_error_without_the_password() {
    // Port 1 on loopback: nothing listens there.
    let url = "postgres://ci:hunter2@127.0.0.1:1/tonegate";
    let err = History::open(Path::new(url))
        .err()
        .expect("no server there");
    let text = err.to_string();
    assert!(
        text.contains("127.0.0.1:1") && !text.contains("hunter2"),
        "{text}"
    );
    // A retry budget of 1 s, not the default 10: the error is the same.
    let o = tonegate(&["history", "--db", url, "--db-retry-s", "1"]);
    assert_eq!(o.status.code(), Some(2), "{o:?}");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("127.0.0.1:1") && !stderr.contains("hunter2"),
        "{stderr}"
    );
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `check`, `history` and `serve` on a PostgreSQL history, and what a kill -9
/// of a check leaves there.
#[test]
fn check_history_and_serve_work_on_postgres() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = seed_empty(dir.path());
    let url = pg::database();
    let suite = s(&seeded.suite);
    let o = tonegate(&["check", "--suite", suite, "--db", &url]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{out}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        out.contains(&format!("recorded as run 1 in {url}")),
        "{out}"
    );
    let o = tonegate(&[
        "check",
        "--suite",
        suite,
        "--db",
        &url,
        "--fault-gain",
        "1.02",
    ]);
    assert_eq!(o.status.code(), Some(1));
    // A check killed mid-run: its run is aborted by the next writer, the
    // finished runs are untouched.
    let mut child = Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args([
            "check", "--suite", suite, "--db", &url, "--cpu", "--spp", "16",
        ])
        .current_dir(repo())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the run never started"
        );
        let h = History::open_read_only(Path::new(&url)).unwrap();
        if h.run(3).unwrap().is_some_and(|r| r.scenes >= 1) {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let h = History::open(Path::new(&url)).unwrap();
    assert_eq!(h.status(3).unwrap(), Some(RunStatus::Aborted));
    assert_eq!(h.status(1).unwrap(), Some(RunStatus::Passed));
    assert_eq!(h.status(2).unwrap(), Some(RunStatus::Failed));
    assert_eq!(h.run(1).unwrap().unwrap().scenes, 2);
    drop(h);
    let o = tonegate(&["history", "--db", &url]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}");
    for word in ["passed", "failed", "aborted"] {
        assert!(out.contains(word), "{word}: {out}");
    }
    let o = tonegate(&["history", "--db", &url, "--metric", "psnr"]);
    assert_eq!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stdout).contains("grid-static"));

    // The server reads the same history.
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let seeded = common::Seeded {
            db: PathBuf::from(&url),
            ..seeded
        };
        let srv = server::start(&seeded, |_| {}).await;
        let (status, runs) = srv.json("/api/v1/runs").await;
        assert_eq!(status, 200);
        let statuses: Vec<&str> = runs
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["status"].as_str().unwrap())
            .collect();
        assert_eq!(statuses, ["aborted", "failed", "passed"]);
        let (status, trend) = srv
            .json("/api/v1/trends?metric=psnr&scene=grid-static")
            .await;
        assert_eq!(status, 200, "{trend}");
        assert!(trend.to_string().contains("\"run_id\":2"), "{trend}");
        let (status, one) = srv.json("/api/v1/runs/2").await;
        assert_eq!(status, 200);
        assert_eq!(one["run"]["status"], "failed");
        assert_eq!(one["report"]["passed"], false);
        // The failing run's images come from the shared history: no folder
        // holds them (a PostgreSQL history has none).
        assert!(one["report"]["artifacts_dir"].is_null(), "{one}");
        let names: Vec<String> = one["report"]["artifacts"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_str().unwrap().to_owned())
            .collect();
        assert!(names.iter().any(|n| n.ends_with("-diff.png")), "{names:?}");
        for name in &names {
            let r = srv.get(&format!("/api/v1/runs/2/artifacts/{name}")).await;
            assert_eq!(r.status(), 200, "{name}");
            let bytes = r.bytes().await.unwrap();
            tonegate::io::decode_png8(&bytes, name).expect("a PNG");
        }
    });
    // Identical images (the goldens, and run 1's worst frames that run 3
    // re-rendered) are stored once.
    let h = History::open_read_only(Path::new(&url)).unwrap();
    let stats = h.artifact_stats().unwrap();
    assert!(stats.names > 0 && stats.blobs < stats.names, "{stats:?}");
}

/// The fleet's queue on both engines: a job's selector is matched against
/// the runner's adapter (a case-insensitive substring) and labels, as plain
/// text, the oldest matching job goes first, a lost runner's job is queued
/// again once and aborted the second time, and a lost runner cannot finish
/// its job.
#[test]
fn claims_follow_selectors_and_a_job_lost_twice_is_aborted() {
    use tonegate::history::{JobSpec, RunnerInfo};
    let dir = tempfile::tempdir().unwrap();
    let url = pg::database();
    for db in [dir.path().join("h.sqlite"), PathBuf::from(&url)] {
        let h = History::open(&db).unwrap();
        let job = |adapter: Option<&str>, label: Option<&str>| {
            h.enqueue(&JobSpec {
                suite: "golden/suite.toml".into(),
                adapter: adapter.map(Into::into),
                label: label.map(Into::into),
                ..Default::default()
            })
            .unwrap()
        };
        let nvidia_only = job(Some("nvidia"), None);
        let gpu_label = job(None, Some("gpu"));
        let any = job(None, None);
        let runner = |adapter: &str, labels: &[&str]| {
            let info = RunnerInfo {
                name: adapter.into(),
                adapter: adapter.into(),
                driver: "d".into(),
                labels: labels.iter().map(|l| (*l).to_owned()).collect(),
            };
            (h.register_runner(&info).unwrap(), info)
        };
        let (lvp, lvp_info) = runner("llvmpipe (LLVM 15.0.6, 256 bits)", &["cpu", "gpux"]);
        let claim = |(id, info): &(i64, RunnerInfo)| {
            h.claim(*id, &info.adapter, &info.labels)
                .unwrap()
                .map(|j| j.id)
        };
        // Not the NVIDIA job, not the `gpu` one (`gpux` is another label).
        assert_eq!(claim(&(lvp, lvp_info.clone())), Some(any), "{db:?}");
        assert_eq!(claim(&(lvp, lvp_info.clone())), None);
        let h100 = runner("NVIDIA H100 80GB HBM3", &["gpu"]);
        assert_eq!(claim(&h100), Some(nvidia_only));
        assert!(h.finish_job(h100.0, nvidia_only, "run 2 passed").unwrap());
        assert_eq!(claim(&h100), Some(gpu_label));
        // The H100 runner goes silent holding its job: queued again, once.
        std::thread::sleep(Duration::from_millis(20));
        h.heartbeat(lvp).unwrap();
        let expired = h.expire_runners(Duration::from_millis(10)).unwrap();
        assert_eq!(expired.runners, [h100.0]);
        assert_eq!(expired.requeued, [gpu_label]);
        assert!(!h.heartbeat(h100.0).unwrap(), "a lost runner is told so");
        assert!(!h.finish_job(h100.0, gpu_label, "late").unwrap());
        let again = runner("NVIDIA H100 80GB HBM3", &["gpu"]);
        assert_eq!(claim(&again), Some(gpu_label));
        std::thread::sleep(Duration::from_millis(20));
        h.heartbeat(lvp).unwrap();
        let expired = h.expire_runners(Duration::from_millis(10)).unwrap();
        assert_eq!(expired.aborted, [gpu_label]);
        let jobs = h.jobs(None, 10).unwrap();
        let state = |id| jobs.iter().find(|j| j.id == id).unwrap().state.clone();
        assert_eq!(state(gpu_label), "aborted");
        assert_eq!(state(nvidia_only), "done");
        assert!(h.finish_job(lvp, any, "run 1 passed").unwrap());
        assert_eq!(h.jobs(Some("done"), 10).unwrap().len(), 2);
        // A bad label is refused with what is wrong.
        let err = h
            .enqueue(&JobSpec {
                suite: "s".into(),
                label: Some("a,b".into()),
                ..Default::default()
            })
            .unwrap_err();
        assert!(
            err.to_string().contains("label: use letters, digits")
                && err.to_string().contains("\"a,b\""),
            "{err}"
        );
        // A runner's name is bounded (it had no limit) and plain.
        for name in ["n".repeat(129), String::new(), "a\u{0}b".into()] {
            let err = h
                .register_runner(&RunnerInfo {
                    name,
                    adapter: "a".into(),
                    driver: "d".into(),
                    labels: Vec::new(),
                })
                .unwrap_err();
            assert!(
                err.to_string().contains("runner name: 1 to 128 characters"),
                "{err}"
            );
        }
        // A selector is plain text: LIKE's wildcards in it match only
        // themselves (`prob_` is not `probe`, `%` is not every adapter).
        let wildcard_label = job(None, Some("prob_"));
        let wildcard_adapter = job(Some("%"), None);
        let probe = runner("cpu-reference", &["probe"]);
        assert_eq!(claim(&probe), None, "{db:?}");
        let exact = runner("cpu-reference", &["prob_"]);
        assert_eq!(claim(&exact), Some(wildcard_label), "{db:?}");
        let percent = runner("odd 100% adapter", &[]);
        assert_eq!(claim(&percent), Some(wildcard_adapter), "{db:?}");
    }
}

/// The artifact store on both engines: an image is stored once by its
/// SHA-256, a run reads back its own names, and pruning drops old runs'
/// names and only the images no kept run names.
#[test]
fn artifacts_are_stored_once_and_pruning_keeps_what_kept_runs_name() {
    let dir = tempfile::tempdir().unwrap();
    let url = pg::database();
    let lite = dir.path().join("h.sqlite");
    for db in [lite.clone(), PathBuf::from(&url)] {
        let h = History::open(&db).unwrap();
        let (a, b, c) = (vec![1u8, 2, 3], vec![4u8; 1000], vec![0u8, 255]);
        let old = h.start_run(RunKind::Check, &RunMeta::default()).unwrap();
        let new = h.start_run(RunKind::Check, &RunMeta::default()).unwrap();
        let files = |v: &[(&str, &Vec<u8>)]| -> Vec<(String, Vec<u8>)> {
            v.iter()
                .map(|(n, b)| ((*n).to_owned(), (*b).clone()))
                .collect()
        };
        assert_eq!(
            h.store_artifacts(old, &files(&[("a.png", &a), ("b.png", &b)]))
                .unwrap()
                .new,
            2
        );
        assert_eq!(
            h.store_artifacts(new, &files(&[("a.png", &a), ("c.png", &c)]))
                .unwrap()
                .new,
            1
        );
        for id in [old, new] {
            h.finish_run(id, RunStatus::Passed, None, None).unwrap();
        }
        let stats = h.artifact_stats().unwrap();
        assert_eq!((stats.names, stats.blobs, stats.bytes), (4, 3, 1005));
        assert_eq!(
            h.artifact(new, "a.png").unwrap(),
            Some(StoredArtifact::Bytes(a.clone()))
        );
        assert_eq!(h.artifact(new, "b.png").unwrap(), None);
        assert_eq!(h.artifact_names(old).unwrap(), ["a.png", "b.png"]);
        // Nothing is old yet.
        let p = h.prune_artifacts(Duration::from_secs(86_400)).unwrap();
        assert_eq!((p.runs.len(), p.names, p.blobs), (0, 0, 0));
        // Make the first run, and the images, a year old.
        let age = [
            format!("UPDATE runs SET started_at = '2025-01-01T00:00:00.000Z' WHERE id = {old}"),
            "UPDATE blobs SET stored_at = '2025-01-01T00:00:00.000Z'".to_owned(),
        ];
        if db == lite {
            let c = rusqlite::Connection::open(&lite).unwrap();
            for sql in &age {
                c.execute(sql, []).unwrap();
            }
        } else {
            let mut c = postgres::Client::connect(&url, postgres::NoTls).unwrap();
            for sql in &age {
                c.execute(sql.as_str(), &[]).unwrap();
            }
        }
        // A span reaching back before 1970 keeps everything, on both
        // engines (it overflowed the date arithmetic and panicked).
        let p = h
            .prune_artifacts(Duration::from_secs(100_000_000 * 86_400))
            .unwrap();
        assert_eq!((p.runs.len(), p.names, p.blobs), (0, 0, 0), "{db:?}");
        let p = h.prune_artifacts(Duration::from_secs(86_400)).unwrap();
        assert_eq!(p.runs, [old]);
        assert_eq!((p.names, p.blobs, p.bytes), (2, 1, 1000), "{db:?}");
        assert_eq!(h.artifact(old, "a.png").unwrap(), None);
        assert_eq!(
            h.artifact(new, "a.png").unwrap(),
            Some(StoredArtifact::Bytes(a.clone()))
        );
        assert_eq!(
            h.artifact(new, "c.png").unwrap(),
            Some(StoredArtifact::Bytes(c.clone()))
        );
        // The run itself, its metrics and report, stay.
        assert_eq!(h.status(old).unwrap(), Some(RunStatus::Passed));
    }
}
