//! The CI gate end to end, through the binary: exit codes, JUnit, JSON,
//! artifacts, the history and what a kill -9 leaves behind.

use crate::common;

use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};
use tonegate::history::{History, RunStatus};
use tonegate::image::{Frame, Rgb16Image};

use common::{repo, tonegate};

/// The number of scenes in the built-in suite (golden/suite.toml).
fn suite_size() -> usize {
    tonegate::suite::load_suite(&repo().join("golden/suite.toml"))
        .unwrap()
        .len()
}

fn text(o: &Output) -> String {
    format!(
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

/// Reads a report; +-inf is written as the literal 1e999 (what Python and
/// JavaScript read back as infinity), which serde_json's `Value` cannot hold.
fn read_json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap();
    serde_json::from_str(&text.replace("1e999", "1e308")).unwrap()
}

fn run_status(db: &Path, id: i64) -> String {
    History::open_read_only(db)
        .unwrap()
        .status(id)
        .unwrap()
        .expect("run recorded")
        .as_str()
        .to_owned()
}

#[test]
fn check_passes_on_main_writes_junit_json_and_records_the_run() {
    // The whole gate on the default adapter: the run the adapter tests hold
    // to the validation layer too (one run of the suite for both).
    let gate = common::lavapipe_gate();
    let o = &gate.output;
    let (db, junit, json) = (&gate.db, &gate.junit, &gate.json);
    assert_eq!(o.status.code(), Some(0), "{}", text(o));
    let xml = std::fs::read_to_string(junit).unwrap();
    // One test suite a scene, and the stress suite (the built-in suite sets `stress = true`).
    assert_eq!(
        xml.matches("<testsuite ").count(),
        suite_size() + 1,
        "{xml}"
    );
    assert!(xml.contains("<testsuite name=\"stress\""), "{xml}");
    assert!(!xml.contains("<failure"), "{xml}");
    assert!(
        xml.contains("PSNR &gt;= 50 dB") || xml.contains("PSNR >= 50 dB"),
        "{xml}"
    );
    let report = read_json(json);
    assert_eq!(report["passed"], true);
    // Which adapter and why, in the report, the JUnit and the console.
    let chosen = report["adapter"]["chosen"].as_str().unwrap();
    assert!(
        chosen.starts_with("default: the software rasterizer"),
        "{chosen}"
    );
    assert!(xml.contains("name=\"adapter_chosen\""), "{xml}");
    assert!(text(o).contains("adapter chosen: default"), "{}", text(o));
    assert_eq!(report["stress"]["passed"], true);
    assert!(report["stress"]["cases"].as_array().unwrap().len() >= 32);
    let scenes = report["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), suite_size());
    for sc in scenes {
        // Every scene judged something, at its default spp (the goldens' own;
        // 1 for the TAA scenes), and has per-frame metrics.
        assert!(
            sc["checks"]
                .as_array()
                .unwrap()
                .iter()
                .any(|c| c["passed"] == true),
            "{sc}"
        );
        let taa = sc["scene"].as_str().unwrap().starts_with("taa-");
        assert_eq!(sc["spp"], if taa { 1 } else { 16 }, "{}", sc["scene"]);
        if taa {
            let plan: Vec<&str> = sc["plan"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_str().unwrap())
                .collect();
            let name = sc["scene"].as_str().unwrap();
            assert_eq!(
                plan.contains(&"taa"),
                !name.ends_with("noaa"),
                "{name}: {plan:?}"
            );
            assert_eq!(
                plan.contains(&"taa_sobel"),
                name.contains("edge"),
                "{name}: {plan:?}"
            );
        }
        assert!(!sc["frames"].as_array().unwrap().is_empty());
        assert!(sc["summaries"]["psnr"]["worst_frame"].is_u64());
    }
    let static_scene = scenes.iter().find(|s| s["scene"] == "grid-static").unwrap();
    assert_eq!(static_scene["test"], "static");
    assert_eq!(static_scene["judged_frames"], serde_json::json!([5]));
    let id = report["run_id"].as_i64().unwrap();
    assert_eq!(run_status(db, id), "passed");
    let h = History::open_read_only(db).unwrap();
    let runs = h.runs(10).unwrap();
    assert_eq!(runs[0].scenes as usize, suite_size());
    assert_eq!(
        runs[0].adapter.as_deref(),
        report["adapter"]["name"].as_str()
    );
    assert!(runs[0].suite_hash.is_some());
}

#[test]
fn a_tone_mapper_two_percent_too_bright_fails_with_artifacts_and_junit_failures() {
    let dir = tempfile::tempdir().unwrap();
    let (db, junit, art) = (
        dir.path().join("h.sqlite"),
        dir.path().join("junit.xml"),
        dir.path().join("artifacts"),
    );
    let o = tonegate(&[
        "check",
        "--db",
        s(&db),
        "--junit",
        s(&junit),
        "--artifacts",
        s(&art),
        "--fault-gain",
        "1.02",
        // The two scenes it looks at, an 8-bit and a PQ one (the whole suite
        // with its stress rows made this test a minute of the test command).
        "--scene",
        "sky-reinhard-global",
        "--scene",
        "sky-bt2390-pq",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let out = text(&o);
    assert!(out.contains("FAIL PSNR >= 50 dB"), "{out}");
    // The perceptual bound catches it too (a GPU frame 2 % too bright scores
    // 0.019 to 0.043 on llvmpipe, over the 0.001 bound).
    assert!(out.contains("FAIL FLIP mean <= 0.001"), "{out}");
    // Five images per failing frame, named <scene>-<frame>-<adapter>-<kind>.png.
    let names: Vec<String> = std::fs::read_dir(&art)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    let actual: Vec<&String> = names
        .iter()
        .filter(|n| n.starts_with("sky-reinhard-global-000-"))
        .collect();
    assert_eq!(actual.len(), 5, "{names:?}");
    for kind in ["actual", "golden", "diff", "ssim", "flip"] {
        let name = names
            .iter()
            .find(|n| {
                n.starts_with("sky-reinhard-global-000-") && n.ends_with(&format!("-{kind}.png"))
            })
            .unwrap_or_else(|| panic!("no {kind} artifact in {names:?}"));
        let img = tonegate::io::read_png8(&art.join(name)).unwrap();
        assert_eq!((img.width, img.height), (320, 180));
    }
    // The actual frame really is brighter than the golden.
    let read = |kind: &str| {
        let name = names
            .iter()
            .find(|n| {
                n.starts_with("sky-reinhard-global-000-") && n.ends_with(&format!("-{kind}.png"))
            })
            .unwrap();
        tonegate::io::read_png8(&art.join(name)).unwrap()
    };
    let sum = |img: &tonegate::image::Rgb8Image| -> u64 {
        img.raster().samples.iter().map(|&v| v as u64).sum()
    };
    assert!(sum(&read("actual")) > sum(&read("golden")));
    // The scene of 16-bit PQ frames fails too (its PSNR bound is the only
    // 80 dB one), and its frames' artifacts are PQ frames, the actual one
    // brighter.
    assert!(out.contains("FAIL PSNR >= 80 dB"), "{out}");
    let pq = |kind: &str| {
        let name = names
            .iter()
            .find(|n| n.starts_with("sky-bt2390-pq-000-") && n.ends_with(&format!("-{kind}.png")))
            .unwrap_or_else(|| panic!("no sky-bt2390-pq {kind} artifact in {names:?}"));
        tonegate::io::read_frame_png(&art.join(name)).unwrap()
    };
    let (Frame::Pq16(actual), Frame::Pq16(golden)) = (pq("actual"), pq("golden")) else {
        panic!("the PQ scene's artifacts are not 16-bit PQ frames");
    };
    let sum16 = |img: &Rgb16Image| -> u64 { img.pixels.iter().flatten().map(|&v| v as u64).sum() };
    assert!(sum16(&actual) > sum16(&golden));
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(xml.contains("<failure"), "{xml}");
    assert!(xml.contains("worst PSNR"), "{xml}");
    let actual_path = art
        .join(
            names
                .iter()
                .find(|n| n.starts_with("sky-reinhard-global-000-") && n.ends_with("-actual.png"))
                .unwrap(),
        )
        .display()
        .to_string();
    assert!(xml.contains(&actual_path), "{actual_path} not in {xml}");
    let h = History::open_read_only(&db).unwrap();
    assert_eq!(h.runs(1).unwrap()[0].status.as_str(), "failed");
}

#[test]
fn a_run_that_cannot_happen_exits_2_and_is_recorded_as_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("h.sqlite");
    let junit = dir.path().join("junit.xml");
    // An unknown key in the suite file.
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "scenes = []\ncolour = 1\n").unwrap();
    let o = tonegate(&[
        "check",
        "--db",
        s(&db),
        "--suite",
        s(&bad),
        "--junit",
        s(&junit),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("colour"), "{}", text(&o));
    assert!(std::fs::read_to_string(&junit).unwrap().contains("<error"));
    // A missing golden.
    let copy = dir.path().join("golden");
    common::copy_dir(&repo().join("golden"), &copy);
    std::fs::remove_file(copy.join("night-reinhard-global/003.png")).unwrap();
    let o = tonegate(&[
        "check",
        "--db",
        s(&db),
        "--suite",
        s(&copy.join("suite.toml")),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("night-reinhard-global: golden frame 003.png is missing"),
        "{}",
        text(&o)
    );
    // No such adapter.
    let o = tonegate(&["check", "--db", s(&db), "--adapter", "no-such-gpu-anywhere"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let h = History::open_read_only(&db).unwrap();
    let runs = h.runs(10).unwrap();
    assert_eq!(runs.len(), 3);
    assert!(
        runs.iter()
            .all(|r| r.status.as_str() == "error" && r.detail.is_some()),
        "{runs:?}"
    );
}

#[test]
fn a_scene_with_no_checks_fails() {
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("golden");
    common::copy_dir(&repo().join("golden"), &copy);
    let path = copy.join("scenes/grid-static.toml");
    let scene = std::fs::read_to_string(&path).unwrap();
    let head = &scene[..scene.find("[[checks]]").unwrap()];
    std::fs::write(&path, head).unwrap();
    std::fs::write(
        copy.join("suite.toml"),
        "scenes = [\"scenes/grid-static.toml\"]\n",
    )
    .unwrap();
    let o = tonegate(&[
        "check",
        "--no-history",
        "--suite",
        s(&copy.join("suite.toml")),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("a scene with no checks fails"),
        "{}",
        text(&o)
    );
}

/// A recorded run of one scene, grid-static, on the CPU reference at `spp`:
/// what a test needs of a finished run, without rendering the suite.
fn record_grid_static(db: &Path, spp: &str) -> Output {
    tonegate(&[
        "check",
        "--db",
        s(db),
        "--cpu",
        "--spp",
        spp,
        "--scene",
        "grid-static",
    ])
}

#[test]
fn kill_9_during_a_check_leaves_a_consistent_database_with_the_run_aborted() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("h.sqlite");
    // A finished run first (one scene is a finished run): the kill must
    // not touch it.
    let o = record_grid_static(&db, "16");
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let mut child = Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args(["check", "--db", s(&db)])
        .current_dir(repo())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Wait until the run has committed at least one scene, then kill it mid-run.
    let start = Instant::now();
    let id = loop {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the run never started"
        );
        if let Ok(h) = History::open_read_only(&db) {
            let runs = h.runs(1).unwrap_or_default();
            if let Some(r) = runs.first().filter(|r| r.id == 2 && r.scenes >= 1) {
                assert_eq!(r.status.as_str(), "running");
                break r.id;
            }
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap(); // reap it, so /proc no longer shows the pid
                           // Readers see the run as it was left.
    assert_eq!(run_status(&db, id), "running");
    // The next writer's start marks it aborted; the file is sound and the
    // committed rows of both runs are intact.
    let h = History::open(&db).unwrap();
    assert_eq!(
        h.status(id).unwrap().map(RunStatus::as_str),
        Some("aborted")
    );
    assert_eq!(h.status(1).unwrap().map(RunStatus::as_str), Some("passed"));
    assert_eq!(h.integrity().unwrap(), "ok");
    let runs = h.runs(10).unwrap();
    assert_eq!(runs[1].scenes, 1);
    assert!(runs[0].scenes >= 1 && (runs[0].scenes as usize) <= suite_size());
    assert!(runs[0].detail.as_deref().unwrap().contains("crash or kill"));
    drop(h);
    let o = tonegate(&["history", "--db", s(&db)]);
    assert_eq!(o.status.code(), Some(0));
    assert!(text(&o).contains("aborted"), "{}", text(&o));
}

#[test]
fn history_prints_a_metric_trend_and_refuses_unknown_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("h.sqlite");
    // Two runs of the scene the trend is asked for: the history holds what
    // a run recorded, whatever else the suite has.
    for _ in 0..2 {
        let o = record_grid_static(&db, "1");
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    }
    let o = tonegate(&[
        "history",
        "--db",
        s(&db),
        "--scene",
        "grid-static",
        "--metric",
        "psnr",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let points: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let points = points.as_array().unwrap();
    assert_eq!(points.len(), 2);
    // The CPU reference at 1 spp is deterministic: the same worst PSNR both times.
    assert_eq!(points[0]["value"], points[1]["value"]);
    assert!((points[0]["value"].as_f64().unwrap() - 22.24).abs() < 0.01);
    let o = tonegate(&["history", "--db", s(&db), "--metric", "bogus metric"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("unknown metric"), "{}", text(&o));
    // A name that could be a stage but is not one is refused too, in the
    // API's words (it printed "no values" and exited 0).
    let o = tonegate(&["history", "--db", s(&db), "--metric", "bogus"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("unknown metric \"bogus\"; use psnr"),
        "{}",
        text(&o)
    );
    let o = tonegate(&["history", "--db", s(&dir.path().join("none.sqlite"))]);
    assert_eq!(o.status.code(), Some(2));
}

/// A deliberately broken TAA fails the TAA scenes' checks. Both
/// faults keep every other stage right: the clipping box left out (the
/// history's stale colours stay) and the history reprojected as if the
/// sphere stood still. The same scenes pass without a fault, on the same
/// adapter, in the same test. The thesis's scenes fail their PSNR and SSIM
/// bounds; the default TAA's scenes fail their gain over no AA (without
/// the box, a history reprojected exactly stays good enough for the
/// per-frame bounds, not for the gain).
#[test]
fn a_broken_taa_fails_the_ghosting_checks() {
    let ghost = [
        "--scene",
        "taa-ghost-clip",
        "--scene",
        "taa-ghost-edge",
        "--scene",
        "taa-ghost",
        "--scene",
        "taa-ghost-grid",
        "--scene",
        "taa-fast",
    ];
    let mut args = vec!["check", "--no-history"];
    args.extend(ghost);
    let o = tonegate(&args);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    for fault in ["no-clip", "wrong-rotation"] {
        let mut args = vec!["check", "--no-history", "--taa-fault", fault];
        args.extend(ghost);
        let o = tonegate(&args);
        let out = text(&o);
        assert_eq!(o.status.code(), Some(1), "{fault}: {out}");
        for scene in [
            "taa-ghost-clip ",
            "taa-ghost-edge ",
            "taa-ghost ",
            "taa-ghost-grid ",
            "taa-fast ",
        ] {
            let line = out
                .lines()
                .find(|l| l.starts_with(scene))
                .unwrap_or_else(|| panic!("{fault}: no {scene} row in {out}"));
            assert!(line.ends_with("FAIL"), "{fault}: {line}");
        }
        // The no-AA baselines came along and pass.
        for scene in ["taa-ghost-noaa ", "taa-ghost-grid-noaa ", "taa-fast-noaa "] {
            let line = out.lines().find(|l| l.starts_with(scene)).unwrap();
            assert!(line.ends_with("ok"), "{fault}: {line}");
        }
        assert!(out.contains("FAIL PSNR >= 19.5 dB"), "{fault}: {out}");
        assert!(out.contains("FAIL SSIM >= 0.925"), "{fault}: {out}");
        assert!(
            out.contains("FAIL mean PSNR gain over taa-ghost-noaa >= 2.47 dB"),
            "{fault}: {out}"
        );
        assert!(
            out.contains("FAIL mean PSNR gain over taa-ghost-grid-noaa >= 2.74 dB"),
            "{fault}: {out}"
        );
    }
    // A scene the suite lacks is named in the error.
    let o = tonegate(&["check", "--no-history", "--scene", "no-such-scene"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains(
            "--scene: no scene \"no-such-scene\" in the suite; it has: sky-reinhard-global"
        ),
        "{}",
        text(&o)
    );
}

/// A recorded run's images are in the history (content-addressed)
/// and in the folder beside it; `history prune` drops both for old runs and
/// keeps the run's metrics.
#[test]
fn history_prune_drops_old_runs_images_and_keeps_their_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let db = s(&seeded.db);
    let o = tonegate(&[
        "check",
        "--db",
        db,
        "--suite",
        s(&seeded.suite),
        "--fault-gain",
        "1.02",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let folder = dir.path().join("artifacts/run-1");
    let files = std::fs::read_dir(&folder).unwrap().count();
    let h = History::open_read_only(&seeded.db).unwrap();
    let stats = h.artifact_stats().unwrap();
    assert_eq!(stats.names as usize, files, "{stats:?}");
    assert!(stats.blobs > 0 && stats.bytes > 0);
    drop(h);
    // Days reaching back before 1970: nothing is that old (it panicked
    // with an overflow in the date arithmetic).
    let o = tonegate(&["history", "prune", "--db", db, "--keep-days", "100000000"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(
        text(&o).contains("pruned the artifacts of 0 run(s)"),
        "{}",
        text(&o)
    );
    // Within the kept days: nothing goes.
    let o = tonegate(&["history", "prune", "--db", db, "--keep-days", "30"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("of 0 run(s)"), "{}", text(&o));
    assert!(folder.is_dir());
    // Everything older than now goes; the run and its metrics stay.
    let o = tonegate(&["history", "prune", "--db", db, "--keep-days", "0"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("of 1 run(s)") && text(&o).contains("1 folder(s)"),
        "{}",
        text(&o)
    );
    assert!(!folder.exists());
    let h = History::open_read_only(&seeded.db).unwrap();
    assert_eq!(h.artifact_stats().unwrap().blobs, 0);
    assert_eq!(h.status(1).unwrap(), Some(RunStatus::Failed));
    assert_eq!(h.run(1).unwrap().unwrap().scenes, 2);
    // A --db before the subcommand is refused, not silently ignored.
    let o = tonegate(&["history", "--db", db, "prune", "--keep-days", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

/// Expectations per device. A scene marked `expected_fail` on
/// llvmpipe does not fail the gate when it fails there (JUnit: skipped with
/// the reason), is reported when it passes (remove it), stops applying when
/// expired; `flaky` tolerates a failure; another adapter's expectation does
/// not apply; a bad one is refused naming the key.
#[test]
fn expectations_per_adapter_excuse_a_known_failure_and_report_the_rest() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let scene_file = dir.path().join("golden/scenes/grid-static.toml");
    let original = std::fs::read_to_string(&scene_file).unwrap();
    let with = |lines: &str| {
        std::fs::write(
            &scene_file,
            format!("{original}\n[[expectations]]\n{lines}\n"),
        )
        .unwrap()
    };
    let run = |fault: bool, today: Option<&str>| {
        let junit = dir.path().join("junit.xml");
        let mut c = Command::new(env!("CARGO_BIN_EXE_tonegate"));
        c.args(["check", "--no-history", "--scene", "grid-static", "--suite"])
            .arg(&seeded.suite)
            .arg("--junit")
            .arg(&junit)
            .current_dir(repo())
            .env_remove("TONEGATE_DB");
        if fault {
            c.args(["--fault-gain", "1.02"]);
        }
        if let Some(d) = today {
            c.env("TONEGATE_TODAY", d);
        }
        let o = c.output().unwrap();
        let xml = std::fs::read_to_string(&junit).unwrap_or_default();
        (o.status.code(), text(&o), xml)
    };
    with(
        "adapter = \"LLVMPIPE\"\nstatus = \"expected_fail\"\nreason = \"a known 2 % brightness fault\"\n\
         bug = \"https://example.invalid/bug/1\"\nexpires = \"2030-01-01\"",
    );
    // It fails there, as expected: the gate passes and says why.
    let (code, out, xml) = run(true, None);
    assert_eq!(code, Some(0), "{out}");
    assert!(out.contains("EXPECTED FAILURE on this adapter: a known 2 % brightness fault, https://example.invalid/bug/1"), "{out}");
    assert!(out.contains("XFAIL PSNR >= 50 dB"), "{out}");
    // The summary does not call an excused failure a plain one.
    assert!(
        out.contains("PASSED: 0 of 1 scenes passed, 1 failed as expected"),
        "{out}"
    );
    assert!(
        xml.contains("<skipped message=\"expected_fail on llvmpipe"),
        "{xml}"
    );
    assert!(!xml.contains("<failure"), "{xml}");
    // It passes: reported so the line gets removed.
    let (code, out, xml) = run(false, None);
    assert_eq!(code, Some(0), "{out}");
    assert!(out.contains("UNEXPECTED PASS"), "{out}");
    assert!(xml.contains("UNEXPECTED PASS"), "{xml}");
    // The last day still applies; the day after, it does not and says so.
    assert_eq!(run(true, Some("2030-01-01")).0, Some(0));
    let (code, out, xml) = run(true, Some("2030-01-02"));
    assert_eq!(code, Some(1), "{out}");
    assert!(
        out.contains(
            "EXPIRED expectation, no longer applied: expected_fail on LLVMPIPE expired 2030-01-01"
        ),
        "{out}"
    );
    assert!(xml.contains("<failure"), "{xml}");
    // Flaky: a failure is tolerated, a pass is normal.
    with("adapter = \"llvmpipe\"\nstatus = \"flaky\"\nreason = \"races\"");
    let (code, out, _) = run(true, None);
    assert_eq!(code, Some(0), "{out}");
    assert!(
        out.contains("FLAKY on this adapter, failure tolerated: races"),
        "{out}"
    );
    // Another adapter's expectation does not excuse llvmpipe.
    with("adapter = \"NVIDIA\"\nstatus = \"expected_fail\"\nreason = \"subnormals\"");
    let (code, out, _) = run(true, None);
    assert_eq!(code, Some(1), "{out}");
    assert!(!out.contains("EXPECTED FAILURE"), "{out}");
    // A bad one is refused, naming the key.
    with("adapter = \"llvmpipe\"\nstatus = \"expected_fail\"\nreason = \"x\"\nexpires = \"soon\"");
    let (code, out, _) = run(false, None);
    assert_eq!(code, Some(2), "{out}");
    assert!(
        out.contains("key `expectations` (expectation 1): expires"),
        "{out}"
    );
    with("adapter = \"llvmpipe\"\nstatus = \"broken\"\nreason = \"x\"");
    assert_eq!(run(false, None).0, Some(2));
}

/// The options that trade accuracy (docs/tolerances.md) are judged by their own
/// measured bounds: f16 plus the hardware filter passes, with the f16 FLIP
/// bound applied in place of the generic one, and a tone mapper 2 % too
/// bright still fails under those bounds.
#[test]
fn options_that_trade_accuracy_pass_at_their_own_bounds_and_a_fault_still_fails() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("report.json");
    let run = |fault: bool| {
        let mut args = vec![
            "check",
            "--no-history",
            "--hdr-format",
            "rgba16float",
            "--env-filter",
            "hardware",
            "--scene",
            "grid-reinhard02-grade",
            "--scene",
            "interior-reinhard-global-xyy",
            "--json",
            s(&json),
        ];
        if fault {
            args.extend(["--fault-gain", "1.02"]);
        }
        let o = tonegate(&args);
        (o.status.code(), text(&o), read_json(&json))
    };
    let flip_checks = |report: &serde_json::Value, scene: &str| -> Vec<serde_json::Value> {
        report["scenes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["scene"] == scene)
            .unwrap()["checks"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|c| c["spec"].get("max_flip_mean").is_some())
            .cloned()
            .collect()
    };
    let (code, out, report) = run(false);
    assert_eq!(code, Some(0), "{out}");
    let flips = flip_checks(&report, "grid-reinhard02-grade");
    let generic = flips
        .iter()
        .find(|c| c["spec"]["options"].is_null())
        .unwrap();
    let f16 = flips
        .iter()
        .find(|c| c["spec"]["options"] == serde_json::json!(["rgba16float"]))
        .unwrap();
    assert!(generic["passed"].is_null(), "{generic}");
    assert!(
        generic["detail"].as_str().unwrap().contains("overridden"),
        "{generic}"
    );
    assert_eq!(f16["passed"], true, "{f16}");
    let (code, out, report) = run(true);
    assert_eq!(code, Some(1), "{out}");
    for scene in ["grid-reinhard02-grade", "interior-reinhard-global-xyy"] {
        let flips = flip_checks(&report, scene);
        let f16 = flips
            .iter()
            .find(|c| c["spec"]["options"] == serde_json::json!(["rgba16float"]))
            .unwrap();
        assert_eq!(f16["passed"], false, "{scene}: {f16}");
    }
}

/// A FIFO named as a scene, a suite, an image, the goldens' manifest, a
/// frames rules file, a token file or an alerts file is refused at once
/// with exit 2 and the path, where opening it blocked until a writer came
/// (`plan`, `check --suite`, `frames submit --rules` and `serve --alerts`
/// waited until killed).
#[test]
fn a_fifo_in_place_of_a_file_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("ff");
    // And one a PNG by its name, as compare picks the kind by extension.
    let fifo_png = dir.path().join("ff.png");
    let made = Command::new("mkfifo")
        .arg(&fifo)
        .arg(&fifo_png)
        .status()
        .unwrap();
    assert!(made.success());
    // A copy of the goldens whose manifest is a FIFO.
    let golden = dir.path().join("golden");
    common::copy_dir(&repo().join("golden"), &golden);
    let manifest = golden.join("manifest.toml");
    std::fs::remove_file(&manifest).unwrap();
    assert!(Command::new("mkfifo")
        .arg(&manifest)
        .status()
        .unwrap()
        .success());
    let out = dir.path().join("out.png");
    let suite = golden.join("suite.toml");
    // A folder of frames, and a history, for the commands that read a
    // rules or token file beside them.
    let frames = dir.path().join("frames");
    std::fs::create_dir(&frames).unwrap();
    std::fs::copy(
        repo().join("golden/grid-static/000.png"),
        frames.join("grid.png"),
    )
    .unwrap();
    let db = dir.path().join("h.sqlite");
    let runs: [&[&str]; 9] = [
        &["plan", s(&fifo)],
        &["check", "--no-history", "--cpu", "--suite", s(&fifo)],
        &["tonemap", s(&fifo), "-o", s(&out)],
        &["compare", s(&fifo_png), "golden/grid-static/000.png"],
        &["golden", "verify", "--suite", s(&suite), "grid-static"],
        &[
            "frames",
            "submit",
            s(&frames),
            "--db",
            s(&db),
            "--rules",
            s(&fifo),
        ],
        &[
            "frames",
            "submit",
            s(&frames),
            "--server",
            "http://127.0.0.1:9",
            "--token-file",
            s(&fifo),
        ],
        &[
            "serve",
            "--bind",
            "127.0.0.1:0",
            "--db",
            s(&db),
            "--alerts",
            s(&fifo),
        ],
        &[
            "serve",
            "--bind",
            "127.0.0.1:0",
            "--db",
            s(&db),
            "--token-file",
            s(&fifo),
        ],
    ];
    for args in runs {
        let mut child = Command::new(env!("CARGO_BIN_EXE_tonegate"))
            .args(args)
            .current_dir(repo())
            .env_remove("TONEGATE_DB")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let start = Instant::now();
        while child.try_wait().unwrap().is_none() {
            if start.elapsed() > Duration::from_secs(20) {
                child.kill().unwrap();
                panic!("{args:?} still waits on the FIFO after 20 s");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let o = child.wait_with_output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
        assert!(text(&o).contains("regular file"), "{args:?}: {}", text(&o));
    }
}

/// A stdout whose reader has gone: the write end of a pipe whose read end is
/// already closed, so the first write fails, every time.
fn closed_stdout() -> std::process::Stdio {
    use std::os::fd::FromRawFd;
    let mut fds = [0i32; 2];
    // SAFETY: pipe(2) fills two new descriptors, which are owned here.
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0);
    // SAFETY: fds[0] is a descriptor this test owns and never uses again.
    unsafe { libc::close(fds[0]) };
    // SAFETY: fds[1] is open and owned by nothing else.
    std::process::Stdio::from(unsafe { std::os::fd::OwnedFd::from_raw_fd(fds[1]) })
}

#[test]
fn a_closed_stdout_ends_the_output_quietly_and_the_run_is_stored_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("h.sqlite");
    let run = |args: &[&str]| {
        common::bare_tonegate()
            .args(args)
            .stdout(closed_stdout())
            .output()
            .expect("tonegate runs")
    };
    for args in [
        &["operators"][..],
        &["operators", "--json"],
        &[
            "compare",
            "golden/grid-static/000.png",
            "golden/grid-static/000.png",
        ],
    ] {
        let o = run(args);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {e}");
        assert!(
            !e.contains("panicked") && !e.contains("Broken pipe"),
            "{args:?}: {e}"
        );
    }
    // The gate's run is stored as passed and the exit code is the gate's.
    let o = run(&[
        "check",
        "--db",
        s(&db),
        "--cpu",
        "--spp",
        "1",
        "--scene",
        "grid-static",
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    let h = History::open_read_only(&db).unwrap();
    assert_eq!(h.status(1).unwrap(), Some(RunStatus::Passed));
    drop(h);
    let o = run(&["history", "--db", s(&db)]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// `plan` shows what `check` renders: the scene's reference spp unless
/// `--spp` says otherwise.
#[test]
fn plan_shows_the_spp_check_renders_with() {
    let o = tonegate(&["plan", "golden/scenes/grid-static.toml", "--json"]);
    assert!(o.status.success(), "{}", text(&o));
    let scene = std::fs::read_to_string(repo().join("golden/scenes/grid-static.toml")).unwrap();
    let spp: u32 = scene
        .lines()
        .find_map(|l| {
            l.trim()
                .strip_prefix("reference_spp")?
                .trim()
                .strip_prefix('=')?
                .trim()
                .parse()
                .ok()
        })
        .unwrap_or(16);
    assert!(spp > 1);
    let plan = String::from_utf8_lossy(&o.stdout);
    assert!(
        plan.contains(&format!("\"spp\": {spp}")) || plan.contains(&format!("\"spp\":{spp}")),
        "{plan}"
    );
    let o = tonegate(&[
        "plan",
        "golden/scenes/grid-static.toml",
        "--json",
        "--spp",
        "1",
    ]);
    let plan = String::from_utf8_lossy(&o.stdout);
    assert!(
        plan.contains("\"spp\": 1") || plan.contains("\"spp\":1"),
        "{plan}"
    );
}

/// `check --json` says where its wall time went: every phase is there, the
/// parts fit inside their phases and the phases inside the whole, and the
/// console prints the same line.
#[test]
fn the_report_says_where_the_time_went() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("report.json");
    let o = tonegate(&[
        "check",
        "--no-history",
        "--scene",
        "grid-static",
        "--json",
        s(&json),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let report = read_json(&json);
    let p = &report["phases"];
    let v = |k: &str| {
        p[k].as_f64()
            .unwrap_or_else(|| panic!("phases.{k} missing: {p}"))
    };
    for k in [
        "device_s",
        "pipelines_s",
        "render_s",
        "goldens_s",
        "metrics_s",
        "history_s",
    ] {
        assert!(v(k) >= 0.0, "{k}: {p}");
    }
    assert!(
        v("device_s") > 0.0 && v("render_s") > 0.0 && v("metrics_s") > 0.0,
        "{p}"
    );
    // Parts measured inside a phase are within it (1 ms of clock slack);
    // a scene's frames are judged in parallel, so the metrics' parts are
    // within the phase's time on every core.
    let slack = 1e-3;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
    assert!(
        v("ssim_s") + v("flip_s") + v("errors_s") + v("fraction_over_s")
            <= v("metrics_s") * cores + slack,
        "{p}"
    );
    assert!(v("ssim_s") > 0.0 && v("flip_s") > 0.0, "{p}");
    assert!(
        v("readback_wait_s") + v("readback_copy_s") <= v("render_s") + slack,
        "{p}"
    );
    assert!(v("readback_copy_s") > 0.0, "{p}");
    let phases: f64 = [
        "device_s",
        "pipelines_s",
        "render_s",
        "goldens_s",
        "metrics_s",
        "artifacts_s",
        "history_s",
        "stress_s",
    ]
    .iter()
    .map(|k| v(k))
    .sum();
    assert!(phases <= v("total_s") + slack, "{phases} > total: {p}");
    assert!(text(&o).contains("time: "), "{}", text(&o));
}

/// `check` run outside the repository, with the default suite: exit 2,
/// the missing suite named with what to do, and no history made there
/// (it said "cannot read scene file" and recorded an errored run in a new
/// `.tonegate/history.sqlite`).
#[test]
fn check_away_from_the_repository_says_where_the_suite_is_expected_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .arg("check")
        .current_dir(dir.path())
        .env_remove("TONEGATE_DB")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("no suite at golden/suite.toml"), "{t}");
    assert!(t.contains("--suite"), "{t}");
    assert!(!dir.path().join(".tonegate").exists(), "a history was made");
}
