//! The history database: migrations, WAL, and nightly regressions found
//! against the previous runs on the same adapter and configuration.

use std::collections::BTreeMap;
use tonegate::check::{SceneResult, TestKind};
use tonegate::gate::{find_regressions, scene_record};
use tonegate::history::{History, RunAdapter, RunKind, RunMeta, RunStatus, SCHEMA_VERSION};
use tonegate::perf::TimingSummary;
use tonegate::suite::Performance;

fn scene(name: &str, sphere_ms: f64, fps: f64) -> SceneResult {
    SceneResult {
        scene: name.into(),
        test: TestKind::Moving,
        renderer: "test".into(),
        adapter: "llvmpipe".into(),
        spp: 16,
        plan: vec!["sphere", "encode"],
        frames: Vec::new(),
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
        fps: Some(fps),
    }
}

fn adapter(name: &str, config: &str) -> RunAdapter {
    RunAdapter {
        name: name.into(),
        backend: "Vulkan".into(),
        driver: "llvmpipe".into(),
        driver_info: "Mesa".into(),
        config: config.into(),
    }
}

/// Records a finished run with one scene; returns its id.
fn record(h: &mut History, a: &RunAdapter, r: &SceneResult) -> i64 {
    let id = h.start_run(RunKind::Check, &RunMeta::default()).unwrap();
    h.set_adapter(id, a).unwrap();
    h.record_scene(id, &scene_record(r).unwrap()).unwrap();
    h.finish_run(id, RunStatus::Passed, None, None).unwrap();
    id
}

#[test]
fn migrations_are_versioned_idempotent_and_a_newer_schema_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("sub/h.sqlite");
    let h = History::open(&db).unwrap();
    assert_eq!(h.schema_version().unwrap(), SCHEMA_VERSION);
    drop(h);
    // Opening again applies nothing twice.
    let h = History::open(&db).unwrap();
    assert_eq!(h.schema_version().unwrap(), SCHEMA_VERSION);
    drop(h);
    // WAL mode persists in the file.
    let conn = rusqlite::Connection::open(&db).unwrap();
    let mode: String = conn
        .query_row("PRAGMA journal_mode", [], |r| r.get(0))
        .unwrap();
    assert_eq!(mode, "wal");
    conn.pragma_update(None, "user_version", SCHEMA_VERSION + 5)
        .unwrap();
    drop(conn);
    let err = History::open(&db)
        .err()
        .expect("a newer schema must be refused");
    assert!(err.to_string().contains("schema version"), "{err}");
    // Nothing was lost by the refusal.
    let conn = rusqlite::Connection::open(&db).unwrap();
    let tables: i64 = conn
        .query_row(
            "SELECT COUNT(*) FROM sqlite_master WHERE name = 'runs'",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(tables, 1);
}

#[test]
fn a_slowdown_is_flagged_against_the_same_adapter_and_config_only() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = History::open(&dir.path().join("h.sqlite")).unwrap();
    let llvm = adapter("llvmpipe", "{\"spp\":16}");
    // Five nightly runs with ~2 % noise.
    for ms in [10.0, 10.2, 9.9, 10.1, 9.8] {
        record(&mut h, &llvm, &scene("sky", ms, 100.0 / ms));
    }
    // Another adapter's and another config's slow runs must not be the baseline.
    record(
        &mut h,
        &adapter("other gpu", "{\"spp\":16}"),
        &scene("sky", 1.0, 900.0),
    );
    record(
        &mut h,
        &adapter("llvmpipe", "{\"spp\":1}"),
        &scene("sky", 1.0, 900.0),
    );
    let p = Performance::default();
    // A run within the noise: nothing flagged.
    let ok = scene("sky", 10.3, 9.7);
    let id = record(&mut h, &llvm, &ok);
    let found = find_regressions(&h, id, "llvmpipe", "{\"spp\":16}", &[ok], &p).unwrap();
    assert!(found.is_empty(), "{found:?}");
    // A 30 % slower sphere and the FPS it costs: both flagged, encode not.
    let slow = scene("sky", 13.0, 7.7);
    let id = record(&mut h, &llvm, &slow);
    let found = find_regressions(&h, id, "llvmpipe", "{\"spp\":16}", &[slow], &p).unwrap();
    let metrics: Vec<&str> = found.iter().map(|g| g.metric.as_str()).collect();
    assert_eq!(metrics, ["fps", "sphere"], "{found:?}");
    let sphere = &found[1];
    assert_eq!(sphere.runs, 6);
    assert!((sphere.median - 10.05).abs() < 1e-9, "{sphere:?}");
    assert!(sphere.bound > 10.3 && sphere.bound < 13.0, "{sphere:?}");
    h.record_regressions(id, &found).unwrap();
    let trend = h
        .trend(
            "sphere",
            &tonegate::history::TrendFilter {
                scene: Some("sky"),
                adapter: Some("llvmpipe"),
                limit: 50,
                ..Default::default()
            },
        )
        .unwrap();
    assert_eq!(trend.len(), 8);
    assert!(trend.last().unwrap().regression);
    assert!(!trend[0].regression);
    // The API's and the command line's filter is a substring in any case,
    // as the run list's is (it needed the exact name); the exact one stays
    // for regression baselines.
    let by = |exact: Option<&str>, contains: Option<&str>| {
        h.trend(
            "sphere",
            &tonegate::history::TrendFilter {
                scene: Some("sky"),
                adapter: exact,
                adapter_contains: contains,
                limit: 50,
                ..Default::default()
            },
        )
        .unwrap()
        .len()
    };
    assert_eq!(by(None, Some("LLVM")), 8);
    assert_eq!(
        by(None, Some("llvm_")),
        0,
        "a LIKE wildcard matches only itself"
    );
    assert_eq!(by(Some("llvm"), None), 0);
}

#[test]
fn with_too_few_previous_runs_nothing_is_flagged() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = History::open(&dir.path().join("h.sqlite")).unwrap();
    let a = adapter("llvmpipe", "{}");
    record(&mut h, &a, &scene("sky", 10.0, 10.0));
    let slow = scene("sky", 50.0, 2.0);
    let id = record(&mut h, &a, &slow);
    let found =
        find_regressions(&h, id, "llvmpipe", "{}", &[slow], &Performance::default()).unwrap();
    assert!(found.is_empty());
}

#[test]
fn a_version_1_file_is_migrated_without_losing_its_runs() {
    use tonegate::check::FrameResult;
    use tonegate::metrics::Metrics;
    let frame = |mean_abs_diff: f64| FrameResult {
        frame: 0,
        metrics: Metrics {
            mse: 1.0,
            rmse: 1.0,
            psnr: 48.1,
            snr: 40.0,
            ssim: 0.99,
            max_abs_diff: 2,
            mean_abs_diff,
            fraction_over_1lsb: 0.01,
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
    };
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("h.sqlite");
    let a = adapter("llvmpipe", "{}");
    // The file schema version 1 made, with one run in it written as that
    // version wrote it (no mean_abs_diff or flip_mean columns, no fleet, no
    // artifact store).
    let conn = rusqlite::Connection::open(&db).unwrap();
    conn.execute_batch(tonegate::history::migrations()[0])
        .unwrap();
    conn.execute_batch(
        "PRAGMA user_version = 1;
         INSERT INTO runs (id, kind, status, started_at, tonegate_version, host, pid, adapter, config)
           VALUES (1, 'check', 'passed', '2026-11-20T00:00:00.000Z', '0.1.0', 'h', 1, 'llvmpipe', '{}');
         INSERT INTO scene_results (run_id, scene, test, passed, frames, result)
           VALUES (1, 'sky', 'moving', 1, 1, '{}');
         INSERT INTO frame_metrics (run_id, scene, frame, mse, rmse, psnr, snr, ssim, max_abs_diff, fraction_over_1lsb)
           VALUES (1, 'sky', 0, 1.0, 1.0, 48.1, 40.0, 0.99, 2, 0.01);",
    )
    .unwrap();
    drop(conn);
    let old_id = 1;
    let mut h = History::open(&db).unwrap();
    assert_eq!(h.schema_version().unwrap(), SCHEMA_VERSION);
    let mut new = scene("sky", 10.0, 10.0);
    new.frames.push(frame(0.25));
    let new_id = record(&mut h, &a, &new);
    let trend = |metric| {
        h.trend(
            metric,
            &tonegate::history::TrendFilter {
                limit: 10,
                ..Default::default()
            },
        )
        .unwrap()
    };
    // The old run keeps its figures; the new column has the new run only.
    let psnr = trend("psnr");
    assert_eq!(
        psnr.iter().map(|p| p.run_id).collect::<Vec<_>>(),
        [old_id, new_id]
    );
    let mean = trend("mean_abs_diff");
    assert_eq!(mean.len(), 1, "{mean:?}");
    assert_eq!((mean[0].run_id, mean[0].value), (new_id, 0.25));
    let flip = trend("flip_mean");
    assert_eq!(flip.len(), 1, "{flip:?}");
    assert_eq!((flip[0].run_id, flip[0].value), (new_id, 0.002));
}

/// Change points: a 6 % level shift in a stage's time, under the
/// regression window's 10 % floor run by run, is marked at the run where it
/// began, per adapter: another adapter's faster runs interleaved with it are
/// another series, with no shift of its own, and are marked nowhere.
#[test]
fn a_level_shift_is_marked_at_its_run_and_per_adapter() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = History::open(&dir.path().join("h.sqlite")).unwrap();
    let llvm = adapter("llvmpipe", "{}");
    let other = adapter("other gpu", "{}");
    let wobble = [0.0, 0.15, -0.1, 0.2, -0.2, 0.05, -0.15, 0.1];
    let mut first_shifted = 0;
    for i in 0..40 {
        let ms = if i < 20 { 10.0 } else { 10.6 } + wobble[i % wobble.len()];
        let id = record(&mut h, &llvm, &scene("sky", ms, 100.0 / ms));
        if i == 20 {
            first_shifted = id;
        }
        record(
            &mut h,
            &other,
            &scene("sky", 2.0 + wobble[(i + 3) % 8] * 0.1, 500.0),
        );
    }
    let filter = tonegate::history::TrendFilter {
        scene: Some("sky"),
        limit: 200,
        ..Default::default()
    };
    let trend = h.trend("sphere", &filter).unwrap();
    let marked: Vec<(i64, Option<String>)> = trend
        .iter()
        .filter(|p| p.change.is_some())
        .map(|p| (p.run_id, p.adapter.clone()))
        .collect();
    assert_eq!(marked.len(), 1, "{marked:?}");
    let (run, on) = &marked[0];
    assert_eq!(on.as_deref(), Some("llvmpipe"));
    // Within one run of where the shift began (runs alternate adapters).
    assert!((run - first_shifted).abs() <= 2, "{run} vs {first_shifted}");
    let ratio = trend.iter().find_map(|p| p.change).unwrap();
    assert!(ratio > 1.04 && ratio < 1.08, "{ratio}");
}

/// Series are split by renderer configuration too. An f16 config
/// joining halfway at a steadily higher time is its own flat series, not a
/// level shift of the f32 one; a real shift within one config is still found.
#[test]
fn a_new_configuration_is_its_own_series_not_a_level_shift() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = History::open(&dir.path().join("h.sqlite")).unwrap();
    let f32 = adapter("llvmpipe", "{\"hdr_format\":\"rgba32float\"}");
    let f16 = adapter("llvmpipe", "{\"hdr_format\":\"rgba16float\"}");
    let wobble = [0.0, 0.15, -0.1, 0.2, -0.2, 0.05, -0.15, 0.1];
    for i in 0..40 {
        let ms = 10.0 + wobble[i % 8];
        record(&mut h, &f32, &scene("sky", ms, 100.0 / ms));
        if i >= 20 {
            record(
                &mut h,
                &f16,
                &scene("sky", 12.0 + wobble[(i + 3) % 8], 80.0),
            );
        }
    }
    let filter = tonegate::history::TrendFilter {
        scene: Some("sky"),
        limit: 200,
        ..Default::default()
    };
    let trend = h.trend("sphere", &filter).unwrap();
    assert_eq!(trend.len(), 60);
    let marked: Vec<i64> = trend
        .iter()
        .filter(|p| p.change.is_some())
        .map(|p| p.run_id)
        .collect();
    assert!(marked.is_empty(), "a new config is not a shift: {marked:?}");
    // A real 6 % shift in the f32 series is still found.
    for i in 0..20 {
        let ms = 10.6 + wobble[i % 8];
        record(&mut h, &f32, &scene("sky", ms, 100.0 / ms));
    }
    let trend = h.trend("sphere", &filter).unwrap();
    let marked: Vec<i64> = trend
        .iter()
        .filter(|p| p.change.is_some())
        .map(|p| p.run_id)
        .collect();
    assert_eq!(marked.len(), 1, "{marked:?}");
}

/// An injected fault (`check --fault-gain`) is recorded in the run's config
/// but stands for a defect: its runs continue the series, so the shift they
/// cause is found (the dashboard test's twelve runs rely on it).
#[test]
fn an_injected_fault_is_a_level_shift_of_the_same_series() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = History::open(&dir.path().join("h.sqlite")).unwrap();
    let clean = adapter("llvmpipe", "{\"hdr_format\":\"rgba32float\"}");
    let faulty = adapter(
        "llvmpipe",
        "{\"hdr_format\":\"rgba32float\",\"fault_gain\":1.02}",
    );
    let wobble = [0.0, 0.15, -0.1, 0.2, -0.2, 0.05, -0.15, 0.1];
    for i in 0..30 {
        let (a, base) = if i < 15 {
            (&clean, 10.0)
        } else {
            (&faulty, 10.8)
        };
        let ms = base + wobble[i % 8];
        record(&mut h, a, &scene("sky", ms, 100.0 / ms));
    }
    let filter = tonegate::history::TrendFilter {
        scene: Some("sky"),
        limit: 200,
        ..Default::default()
    };
    let trend = h.trend("sphere", &filter).unwrap();
    let marked: Vec<i64> = trend
        .iter()
        .filter(|p| p.change.is_some())
        .map(|p| p.run_id)
        .collect();
    assert_eq!(marked.len(), 1, "{marked:?}");
    assert!((marked[0] - 16).abs() <= 2, "{marked:?}");
}

/// The commands that only read a history name the missing SQLite file and
/// exit 2, creating nothing: `history`, `fleet` and `frames log` alike
/// (the last two answered "unable to open database file").
#[test]
fn reading_commands_name_a_history_that_is_not_there() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("new.sqlite");
    let db = db.to_str().unwrap();
    for args in [
        &["history", "--db", db][..],
        &["fleet", "--db", db],
        &["frames", "log", "--db", db],
    ] {
        let o = crate::common::tonegate(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(&format!("no history at {db}")),
            "{args:?}: {err}"
        );
        assert!(!dir.path().join("new.sqlite").exists(), "{args:?} made one");
    }
}

/// `serve` on a SQLite history whose folder cannot be made stops with exit
/// 2 naming the history and the folder (it named the token file it would
/// have put beside it).
#[test]
fn serve_names_a_history_whose_folder_cannot_be_made() {
    let o = crate::common::tonegate(&[
        "serve",
        "--bind",
        "127.0.0.1:0",
        "--db",
        "/proc/no-such-folder/h.sqlite",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(
            "--db /proc/no-such-folder/h.sqlite: cannot create its folder /proc/no-such-folder"
        ),
        "{err}"
    );
}

/// A token file holding a short token is refused when `serve` starts,
/// naming the file and the minimum (a 1-byte token was accepted).
#[test]
fn serve_refuses_a_short_token() {
    let dir = tempfile::tempdir().unwrap();
    let token = dir.path().join("short.token");
    std::fs::write(&token, "x\n").unwrap();
    let db = dir.path().join("h.sqlite");
    let o = crate::common::tonegate(&[
        "serve",
        "--bind",
        "127.0.0.1:0",
        "--db",
        db.to_str().unwrap(),
        "--token-file",
        token.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("short.token: the token is 1 characters; a token is at least 16"),
        "{err}"
    );
}
