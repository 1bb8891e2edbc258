//! `tonegate frames`: a renderer's own frames through the gate, from the
//! command line, on a real SQLite history and real files through the real
//! decoders: the first submission is untriaged and fails, the digests are
//! triaged, the second passes; a frame one code off passes under a fuzzy
//! rule and fails without it; a brighter one fails with its FLIP; a negative
//! digest fails; a retried submission stores nothing twice; bad folders are
//! refused by name with nothing stored.

use crate::common;
use crate::common::postgres as pg;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Output;
use tonegate::env::BuiltinEnv;
use tonegate::history::{History, Label, MAIN};
use tonegate::image::{Frame, Image, Rgb16Image, Rgb8Image};
use tonegate::io::{write_frame_png, write_image_hdr};

/// A 64×40 8-bit frame: a gradient with a bright square whose place `seed`
/// moves.
pub(crate) fn frame8(seed: u32) -> Rgb8Image {
    Image::from_fn(64, 40, |x, y| {
        let inside = (x + seed) % 64 >= 20 && (x + seed) % 64 < 36 && (12..28).contains(&y);
        if inside {
            [240, 220, 200]
        } else {
            [(x * 3) as u8, (y * 5) as u8, ((x + y) * 2) as u8]
        }
    })
}

/// A PQ frame (16-bit codes) of the same shape.
fn frame_pq() -> Rgb16Image {
    Image::from_fn(48, 32, |x, y| [(x * 900) as u16, (y * 1500) as u16, 30000])
}

/// The folder a CI step would submit: two 8-bit tests in a subfolder, a PQ
/// frame and an EXR.
pub(crate) fn folder(dir: &Path) {
    std::fs::create_dir_all(dir.join("ui")).unwrap();
    write_frame_png(&dir.join("ui/button.png"), &Frame::Rgb8(frame8(0))).unwrap();
    write_frame_png(&dir.join("ui/menu.png"), &Frame::Rgb8(frame8(9))).unwrap();
    write_frame_png(&dir.join("hdr-panel.png"), &Frame::Pq16(frame_pq())).unwrap();
    write_image_hdr(&dir.join("sky.exr"), &BuiltinEnv::Sky.generate(64, 32)).unwrap();
}

pub(crate) struct Run {
    pub code: i32,
    pub report: Value,
    pub stderr: String,
}

pub(crate) fn submit(db: &Path, dir: &Path, more: &[&str]) -> Run {
    let mut args = vec![
        "frames",
        "submit",
        dir.to_str().unwrap(),
        "--db",
        db.to_str().unwrap(),
        "--json",
        "-",
    ];
    args.extend_from_slice(more);
    let out = common::tonegate(&args);
    Run {
        code: out.status.code().unwrap_or(-1),
        report: serde_json::from_slice(&out.stdout).unwrap_or(Value::Null),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

pub(crate) fn frame<'a>(report: &'a Value, test: &str) -> &'a Value {
    report["frames"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["test"] == test)
        .unwrap_or_else(|| panic!("no frame {test} in {report}"))
}

/// `tonegate frames SUB --db DB ARGS...`.
pub(crate) fn frames_cmd(db: &Path, sub: &str, args: &[&str]) -> Output {
    let mut all = vec!["frames", sub, "--db", db.to_str().unwrap()];
    all.extend_from_slice(args);
    common::tonegate(&all)
}

pub(crate) fn succeeded(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn triage_run(db: &Path, test: &str, digest: &str, label: &str, more: &[&str]) -> Output {
    let mut args = vec!["--test", test, "--digest", digest, label];
    args.extend_from_slice(&["--who", "ada", "--why", "looked right"]);
    args.extend_from_slice(more);
    frames_cmd(db, "triage", &args)
}

fn triage_on(db: &Path, test: &str, digest: &str, label: &str, more: &[&str]) {
    succeeded(&triage_run(db, test, digest, label, more));
}

pub(crate) fn triage(db: &Path, test: &str, digest: &str, label: &str) {
    triage_on(db, test, digest, label, &[]);
}

/// On a SQLite history and on a PostgreSQL server the test starts.
#[test]
fn untriaged_frames_fail_until_triaged_and_then_pass() {
    let tmp = tempfile::tempdir().unwrap();
    let postgres = pg::database();
    for db in [tmp.path().join("h.sqlite"), PathBuf::from(postgres)] {
        first_run_triage_second_run(&db, tmp.path());
    }
}

fn first_run_triage_second_run(db: &Path, tmp: &Path) {
    let dir = tmp.join("frames");
    folder(&dir);
    let keys = ["--key", "device=llvmpipe", "--key", "branch=main"];
    let first = submit(db, &dir, &keys);
    assert_eq!(first.code, 1, "{}", first.stderr);
    assert_eq!(first.report["untriaged"], 4);
    assert_eq!(first.report["keys"]["device"], "llvmpipe");
    let tests = ["ui/button", "ui/menu", "hdr-panel", "sky"];
    for t in tests {
        let f = frame(&first.report, t);
        assert_eq!(f["status"], "untriaged", "{f}");
        assert!(
            f["detail"].as_str().unwrap().contains("no positive yet"),
            "{f}"
        );
        triage(db, t, f["digest"].as_str().unwrap(), "positive");
    }
    let second = submit(db, &dir, &keys);
    assert_eq!(second.code, 0, "{}", second.report);
    for t in tests {
        assert_eq!(frame(&second.report, t)["status"], "positive");
    }
    // The log says who did what, in order; JUnit has a case a frame.
    let log = frames_cmd(db, "log", &["--json", "-"]);
    let log: Value = serde_json::from_slice(&log.stdout).unwrap();
    let logged: Vec<&str> = log
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["test"].as_str().unwrap())
        .collect();
    assert_eq!(logged, tests);
    assert_eq!(log[0]["who"], "ada");
    let junit = tmp.join("frames.xml");
    let j = submit(db, &dir, &["--junit", junit.to_str().unwrap()]);
    assert_eq!(j.code, 0);
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert_eq!(xml.matches("<testcase").count(), 4, "{xml}");
    // Each image is stored once however often it was submitted.
    let h = History::open(db).unwrap();
    for t in tests {
        let labels = h.digest_labels(MAIN, t).unwrap();
        assert_eq!(labels.len(), 1, "{t}");
        assert_eq!(labels[0].1, Label::Positive);
        assert!(h.blob(&labels[0].0).unwrap().is_some());
    }
}

#[test]
fn a_fuzzy_rule_passes_one_code_off_and_not_a_brighter_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.png");
    write_frame_png(&path, &Frame::Rgb8(frame8(0))).unwrap();
    let first = submit(&db, &dir, &[]);
    triage(
        &db,
        "scene",
        frame(&first.report, "scene")["digest"].as_str().unwrap(),
        "positive",
    );
    // One code off on a few pixels: a new digest.
    let mut off = frame8(0);
    for x in 0..8 {
        off.pixels[x * 3][1] += 1;
    }
    write_frame_png(&path, &Frame::Rgb8(off)).unwrap();
    let strict = submit(&db, &dir, &[]);
    assert_eq!(strict.code, 1);
    let f = frame(&strict.report, "scene");
    assert_eq!(f["status"], "untriaged");
    assert_eq!(f["closest"]["figures"]["max_abs_diff"], 1.0, "{f}");
    let rules = tmp.path().join("rules.toml");
    std::fs::write(
        &rules,
        "[[tests]]\npattern = \"*\"\nchecks = [{ max_abs_diff = 1 }, { max_flip_mean = 0.01 }]\n",
    )
    .unwrap();
    let fuzzy = submit(&db, &dir, &["--rules", rules.to_str().unwrap()]);
    assert_eq!(fuzzy.code, 0, "{}", fuzzy.report);
    assert_eq!(frame(&fuzzy.report, "scene")["status"], "matched");
    // 2 % brighter: past both bounds, with its FLIP in the report.
    let brighter = frame8(0);
    let brighter = Image::from_fn(64, 40, |x, y| {
        brighter
            .get(x, y)
            .map(|c| (f64::from(c) * 1.02).round().min(255.0) as u8)
    });
    write_frame_png(&path, &Frame::Rgb8(brighter)).unwrap();
    let bright = submit(&db, &dir, &["--rules", rules.to_str().unwrap()]);
    assert_eq!(bright.code, 1);
    let f = frame(&bright.report, "scene");
    assert_eq!(f["status"], "untriaged");
    assert!(
        f["closest"]["figures"]["flip_mean"].as_f64().unwrap() > 0.0,
        "{f}"
    );
    assert!(f["detail"].as_str().unwrap().contains("misses"), "{f}");
    // The same judgement with the GPU's metrics (on the default adapter,
    // llvmpipe here): the error figures exact, SSIM within 1e-6 and FLIP
    // within 1e-4 of the CPU's, the bounds `check --metrics gpu` locks
    // them to (docs/checks.md#metrics-on-the-gpu).
    let on_gpu = submit(
        &db,
        &dir,
        &["--rules", rules.to_str().unwrap(), "--metrics", "gpu"],
    );
    assert_eq!(on_gpu.code, 1, "{}", on_gpu.stderr);
    assert!(
        on_gpu.stderr.contains("compared with the GPU's metrics on"),
        "{}",
        on_gpu.stderr
    );
    let g = frame(&on_gpu.report, "scene");
    assert_eq!(g["detail"], f["detail"]);
    for (name, cpu) in f["closest"]["figures"].as_object().unwrap() {
        let (cpu, gpu) = (
            cpu.as_f64().unwrap(),
            g["closest"]["figures"][name].as_f64().unwrap(),
        );
        let tolerance = match name.as_str() {
            "ssim" => 1e-6,
            "flip_mean" => 1e-4,
            _ => 1e-9 * cpu.abs().max(1.0),
        };
        assert!(
            (cpu - gpu).abs() <= tolerance,
            "{name}: CPU {cpu}, GPU {gpu}"
        );
    }
    // Marked negative, it fails as such; warned untriaged digests pass.
    let digest = f["digest"].as_str().unwrap().to_owned();
    triage(&db, "scene", &digest, "negative");
    let negative = submit(&db, &dir, &[]);
    assert_eq!(negative.code, 1);
    assert_eq!(frame(&negative.report, "scene")["status"], "negative");
    write_frame_png(&path, &Frame::Rgb8(frame8(5))).unwrap();
    let warn = tmp.path().join("warn.toml");
    std::fs::write(&warn, "untriaged = \"warn\"\n").unwrap();
    let warned = submit(&db, &dir, &["--rules", warn.to_str().unwrap()]);
    assert_eq!(warned.code, 0, "{}", warned.report);
    assert_eq!(frame(&warned.report, "scene")["warning"], true);
}

#[test]
fn bad_folders_are_refused_by_name_and_store_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let db = tmp.path().join("h.sqlite");
    let case = |name: &str, build: &dyn Fn(&Path), says: &str| {
        let dir = tmp.path().join(name);
        std::fs::create_dir_all(&dir).unwrap();
        build(&dir);
        let run = submit(&db, &dir, &[]);
        assert_eq!(run.code, 2, "{name}: {}", run.stderr);
        assert!(run.stderr.contains(says), "{name}: {}", run.stderr);
    };
    let good =
        |dir: &Path| write_frame_png(&dir.join("fine.png"), &Frame::Rgb8(frame8(0))).unwrap();
    case(
        "truncated",
        &|dir| {
            good(dir);
            let bytes = std::fs::read(dir.join("fine.png")).unwrap();
            std::fs::write(dir.join("cut.png"), &bytes[..bytes.len() / 2]).unwrap();
        },
        "cut.png",
    );
    case(
        "duplicate",
        &|dir| {
            good(dir);
            write_image_hdr(&dir.join("fine.exr"), &BuiltinEnv::Sky.generate(16, 8)).unwrap();
        },
        "are both frames of test \"fine\"",
    );
    case(
        "cicp",
        &|dir| {
            // 16-bit codes whose PNG says nothing of PQ.
            tonegate::io::write_png16(&dir.join("plain16.png"), &frame_pq()).unwrap();
        },
        "plain16.png",
    );
    case(
        "many",
        &|dir| {
            let bytes = {
                good(dir);
                std::fs::read(dir.join("fine.png")).unwrap()
            };
            for i in 0..tonegate::frames::MAX_FRAMES {
                std::fs::write(dir.join(format!("t{i:05}.png")), &bytes).unwrap();
            }
        },
        "a submission takes at most 4096",
    );
    case(
        "lying",
        &|dir| {
            good(dir);
            let mut bytes = std::fs::read(dir.join("fine.png")).unwrap();
            // IHDR's width and height (bytes 16..24): 1e5 × 1e5.
            bytes[16..20].copy_from_slice(&100_000u32.to_be_bytes());
            bytes[20..24].copy_from_slice(&100_000u32.to_be_bytes());
            std::fs::write(dir.join("huge.png"), &bytes).unwrap();
        },
        "huge.png",
    );
    case("empty", &|_| {}, "no images");
    // Nothing of any of them was stored.
    let h = History::open(&db).unwrap();
    assert!(h.digest_labels(MAIN, "fine").unwrap().is_empty());
    assert!(h.triage_log(None).unwrap().is_empty());
    // Triage of a digest the test never had is refused.
    let out = triage_run(&db, "fine", "00", "positive", &[]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("has no digest 00"));
}

/// A branch's submission uses the main line's positives and its own; what
/// is triaged on the branch stays there until the branch is promoted, and
/// the next main-line run sees it then.
#[test]
fn a_branch_falls_back_to_main_and_its_promotion_reaches_main() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    folder(&dir);
    let first = submit(&db, &dir, &[]);
    for f in first.report["frames"].as_array().unwrap() {
        triage(
            &db,
            f["test"].as_str().unwrap(),
            f["digest"].as_str().unwrap(),
            "positive",
        );
    }
    // The branch changes one frame.
    write_frame_png(&dir.join("ui/button.png"), &Frame::Rgb8(frame8(7))).unwrap();
    let on_branch = ["--key", "branch=feature-x"];
    let branch = submit(&db, &dir, &on_branch);
    assert_eq!(branch.code, 1);
    assert_eq!(branch.report["branch"], "feature-x");
    assert_eq!(
        frame(&branch.report, "ui/menu")["status"],
        "positive",
        "main's positive"
    );
    let changed = frame(&branch.report, "ui/button");
    assert_eq!(changed["status"], "untriaged");
    let digest = changed["digest"].as_str().unwrap().to_owned();
    triage_on(
        &db,
        "ui/button",
        &digest,
        "positive",
        &["--branch", "feature-x"],
    );
    assert_eq!(submit(&db, &dir, &on_branch).code, 0);
    // The main line has not seen it ("main" is the main line by name too).
    let main = submit(&db, &dir, &["--key", "branch=main"]);
    assert_eq!(main.code, 1);
    assert_eq!(frame(&main.report, "ui/button")["status"], "untriaged");
    let out = frames_cmd(
        &db,
        "promote",
        &["--branch", "feature-x", "--who", "ada", "--why", "merged"],
    );
    succeeded(&out);
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("1 label of"));
    let after = submit(&db, &dir, &[]);
    assert_eq!(after.code, 0, "{}", after.report);
    let log = History::open(&db)
        .unwrap()
        .triage_log(Some("ui/button"))
        .unwrap();
    let last = log.last().unwrap();
    assert_eq!(
        (last.branch.as_str(), last.why.as_str()),
        ("", "promoted from feature-x: merged")
    );
    // Promoting again says nothing the main line has not (the log keeps
    // its length); a branch nobody triaged on is refused by name.
    let again = frames_cmd(
        &db,
        "promote",
        &["--branch", "feature-x", "--who", "ada", "--why", "again"],
    );
    succeeded(&again);
    assert!(String::from_utf8_lossy(&again.stdout).starts_with("0 labels of"));
    let h = History::open(&db).unwrap();
    assert_eq!(h.triage_log(Some("ui/button")).unwrap().len(), log.len());
    let none = frames_cmd(
        &db,
        "promote",
        &["--branch", "feature-y", "--who", "ada", "--why", "typo"],
    );
    assert_eq!(none.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&none.stderr).contains("no branch \"feature-y\""),
        "{}",
        String::from_utf8_lossy(&none.stderr)
    );
}

/// An ignore rule passes a failing frame of the tests and keys it covers,
/// and no others, until it expires; then the frame fails again.
#[test]
fn an_ignore_rule_expires_and_the_frame_fails_again() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(dir.join("ui")).unwrap();
    write_frame_png(&dir.join("ui/flaky.png"), &Frame::Rgb8(frame8(0))).unwrap();
    assert_eq!(submit(&db, &dir, &[]).code, 1);
    let seconds = 6.0;
    let hours = format!("{}", seconds / 3600.0);
    let out = frames_cmd(
        &db,
        "ignore",
        &[
            "--test",
            "ui/*",
            "--key",
            "device=gpu-a",
            "--hours",
            &hours,
            "--who",
            "ada",
            "--reason",
            "driver bug 42",
        ],
    );
    succeeded(&out);
    let started = std::time::Instant::now();
    let covered = submit(&db, &dir, &["--key", "device=gpu-a"]);
    let other = submit(&db, &dir, &["--key", "device=gpu-b"]);
    assert!(
        started.elapsed().as_secs_f64() < seconds,
        "the machine was too slow to see the rule live"
    );
    assert_eq!(covered.code, 0, "{}", covered.report);
    let f = frame(&covered.report, "ui/flaky");
    assert_eq!(f["status"], "ignored");
    assert!(
        f["detail"].as_str().unwrap().contains("driver bug 42"),
        "{f}"
    );
    assert_eq!(other.code, 1, "another device is not covered");
    std::thread::sleep(std::time::Duration::from_secs_f64(
        seconds + 0.2 - started.elapsed().as_secs_f64().min(seconds),
    ));
    let expired = submit(&db, &dir, &["--key", "device=gpu-a"]);
    assert_eq!(expired.code, 1);
    assert_eq!(frame(&expired.report, "ui/flaky")["status"], "untriaged");
    // Out-of-range durations are refused.
    for bad in ["0", "-1", "9000", "nan"] {
        let args = ["--test", "x", "--hours", bad, "--who", "a", "--reason", "r"];
        let out = frames_cmd(&db, "ignore", &args);
        assert_eq!(out.status.code(), Some(2), "--hours {bad}");
    }
}
