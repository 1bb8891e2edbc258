//! The API's target (docs/api.md): `GET /api/v1/runs` and `/api/v1/trends`
//! under 50 ms at 10,000 stored runs, on SQLite and on PostgreSQL (a real
//! server started here, as the tests start it); the slowest median measured
//! on the 2-vCPU developer machine, 2026-11-24, was 30.1 ms (PostgreSQL).
//! Seeds each history through the public API (10,000 check runs on two
//! adapters, 4 scenes of 4 frames and 3 timed stages each, a level shift and
//! regressions), serves it in-process and times each request from outside,
//! as a client sees it: median and p95 of 30 after 3 warm-ups.
//!
//! `cargo bench --bench history` (`-- --runs N` for another size); under
//! `cargo test --benches` it runs at 200 runs as a smoke test (the test
//! command, ci/test.sh, builds no bench).

#[path = "../tests/it/common/postgres.rs"]
mod pg;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;
use tonegate::check::{FrameResult, SceneResult, TestKind};
use tonegate::gate::scene_record;
use tonegate::history::{History, Regression, RunAdapter, RunKind, RunMeta, RunStatus};
use tonegate::metrics::Metrics;
use tonegate::perf::TimingSummary;
use tonegate::server::{Limits, ServeOptions, Server};

const SCENES: [&str; 4] = [
    "grid-static",
    "sky-reinhard-global",
    "night-reinhard-global",
    "interior-reinhard-global-xyy",
];

fn scene(name: &str, i: usize, shift: f64) -> SceneResult {
    let frames = (0..4)
        .map(|f| FrameResult {
            frame: f,
            metrics: Metrics {
                mse: 0.01,
                rmse: 0.1,
                psnr: 60.0 + ((i * 7 + f as usize) % 13) as f64 * 0.1,
                snr: 50.0,
                ssim: 0.999,
                max_abs_diff: 1,
                mean_abs_diff: 0.01,
                fraction_over_1lsb: 0.0,
                flip_mean: 1e-5,
                bits: 8,
                ssim_definition: String::new(),
            },
            fraction_over: BTreeMap::new(),
            pixels_over: BTreeMap::new(),
            flip_percentiles: BTreeMap::new(),
            adaptation: None,
            failed_checks: Vec::new(),
            artifacts: Vec::new(),
        })
        .collect();
    let ms = (2.0 + ((i * 13) % 7) as f64 * 0.02) * shift;
    SceneResult {
        scene: name.into(),
        test: TestKind::Moving,
        renderer: "bench".into(),
        adapter: "llvmpipe".into(),
        spp: 16,
        plan: vec!["sphere", "tonemap", "encode"],
        frames,
        judged_frames: Vec::new(),
        summaries: BTreeMap::new(),
        checks: Vec::new(),
        problems: Vec::new(),
        taa: None,
        expectation: None,
        expired_expectations: Vec::new(),
        timings: ["sphere", "tonemap", "encode"]
            .iter()
            .map(|s| TimingSummary {
                name: (*s).into(),
                median_ms: ms,
                p95_ms: ms * 1.1,
            })
            .collect(),
        fps: Some(1000.0 / (3.0 * ms)),
    }
}

fn seed(db: &Path, runs: usize) -> f64 {
    let start = Instant::now();
    let mut h = History::open(db).unwrap();
    for i in 0..runs {
        let name = if i % 2 == 0 {
            "llvmpipe (LLVM 15.0.6, 256 bits)"
        } else {
            "NVIDIA H100 80GB HBM3"
        };
        let id = h.start_run(RunKind::Check, &RunMeta::default()).unwrap();
        h.set_adapter(
            id,
            &RunAdapter {
                name: name.into(),
                backend: "Vulkan".into(),
                driver: "d".into(),
                driver_info: "i".into(),
                config: "{}".into(),
            },
        )
        .unwrap();
        // A 3 % level shift 150 runs before the end: in view of the
        // default trend (200 runs) and the dashboard's (500).
        let shift = if i + 150 > runs { 1.03 } else { 1.0 };
        for s in SCENES {
            h.record_scene(id, &scene_record(&scene(s, i, shift)).unwrap())
                .unwrap();
        }
        if i % 50 == 0 {
            let g = Regression {
                scene: SCENES[0].into(),
                metric: "sphere".into(),
                value: 3.0,
                median: 2.0,
                mad: 0.01,
                bound: 2.2,
                runs: 10,
                ratio: 1.5,
            };
            h.record_regressions(id, &[g]).unwrap();
        }
        let status = if i % 17 == 0 {
            RunStatus::Failed
        } else {
            RunStatus::Passed
        };
        h.finish_run(id, status, None, Some("{}")).unwrap();
    }
    start.elapsed().as_secs_f64()
}

/// (first, median, p95) in ms and the answer's size: the first request
/// pays for what the server then remembers (change points).
async fn time(base: &str, client: &reqwest::Client, path: &str) -> (f64, f64, f64, usize) {
    let mut ms = Vec::new();
    let mut first = 0.0;
    let mut bytes = 0;
    for i in 0..33 {
        let t = Instant::now();
        let r = client.get(format!("{base}{path}")).send().await.unwrap();
        assert_eq!(r.status(), 200, "{path}");
        bytes = r.bytes().await.unwrap().len();
        let took = t.elapsed().as_secs_f64() * 1e3;
        if i == 0 {
            first = took;
        }
        if i >= 3 {
            ms.push(took);
        }
    }
    ms.sort_by(f64::total_cmp);
    (first, ms[ms.len() / 2], ms[ms.len() * 95 / 100], bytes)
}

fn measure(label: &str, db: PathBuf, runs: usize) {
    let seeding = seed(&db, runs);
    println!("{label}: seeded {runs} runs in {seeding:.1} s");
    if std::env::var_os("TONEGATE_BENCH_EXPLAIN").is_some() && label == "postgres" {
        let mut c = postgres::Client::connect(&db.to_string_lossy(), postgres::NoTls).unwrap();
        let sql = "EXPLAIN ANALYZE SELECT r.id, r.kind,
                    (SELECT COUNT(*) FROM scene_results s WHERE s.run_id = r.id),
                    (SELECT COUNT(*) FROM scene_results s WHERE s.run_id = r.id AND s.passed = 0),
                    (SELECT COUNT(*) FROM regressions g WHERE g.run_id = r.id)
             FROM runs r WHERE (CAST($1 AS TEXT) IS NULL OR r.status = $1)
               AND (CAST($2 AS TEXT) IS NULL OR r.kind = $2)
               AND (CAST($3 AS TEXT) IS NULL OR LOWER(r.adapter) LIKE $3 ESCAPE '\\')
             ORDER BY r.id DESC LIMIT $4";
        for row in c
            .query(
                sql,
                &[&None::<String>, &None::<String>, &None::<String>, &100i64],
            )
            .unwrap()
        {
            let line: String = row.get(0);
            println!("  {line}");
        }
    }
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let server = Server::bind(ServeOptions {
            bind: "127.0.0.1:0".parse().unwrap(),
            db,
            token: "bench-token-0123456789".into(),
            private_reads: false,
            suite: "golden/suite.toml".into(),
            adapter: Default::default(),
            gpu_config: Default::default(),
            limits: Limits::default(),
            conn: Default::default(),
            hold_workers: None,
            scoped: Default::default(),
            alerts: None,
        })
        .await
        .unwrap();
        let base = format!("http://{}", server.local_addr().unwrap());
        let (_stop, rx) = tokio::sync::oneshot::channel::<()>();
        tokio::spawn(server.run(async move {
            let _ = rx.await;
        }));
        let client = reqwest::Client::new();
        for path in [
            "/api/v1/runs",
            "/api/v1/runs?status=failed&limit=50",
            "/api/v1/runs?adapter=nvidia",
            "/api/v1/trends?metric=psnr",
            "/api/v1/trends?metric=sphere&scene=grid-static",
            "/api/v1/trends?metric=sphere&limit=500",
            "/api/v1/queue",
        ] {
            let (first, median, p95, bytes) = time(&base, &client, path).await;
            println!(
                "{label}: GET {path:<48} first {first:6.1} ms  median {median:6.1} ms  p95 {p95:6.1} ms  ({bytes} bytes)"
            );
        }
    });
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let runs = args
        .iter()
        .position(|a| a == "--runs")
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000);
    // `cargo bench` passes --bench; `cargo test --benches` runs this
    // binary without it: then a smoke run at 200 runs.
    let runs = if args.iter().any(|a| a == "--bench") {
        runs
    } else {
        200
    };
    let dir = tempfile::tempdir().unwrap();
    measure("sqlite", dir.path().join("h.sqlite"), runs);
    measure("postgres", PathBuf::from(pg::database()), runs);
}
