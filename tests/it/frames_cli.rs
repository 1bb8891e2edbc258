//! What `frames submit` says and how it judges, as a CI job reads it: the
//! failing frames' digests and the Markdown summary, the decode budget, the
//! `accept_new` mode, the files it skips or cannot read, and a retry
//! under its idempotency key.

use crate::common;
use crate::frames::{folder, frame, frame8, frames_cmd, submit, succeeded};
use serde_json::Value;
use tonegate::history::{History, MAIN};
use tonegate::image::{Frame, Image, Rgb8Image};
use tonegate::io::write_frame_png;

/// The console names each failing frame's whole digest (what `frames
/// triage --digest` takes) and `--summary` writes the Markdown a CI job's
/// summary shows: the verdict and a row per failing frame with its digest.
#[test]
fn the_console_and_the_summary_name_each_failing_frame_by_its_digest() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    folder(&dir);
    let summary = tmp.path().join("summary.md");
    let out = common::tonegate(&[
        "frames",
        "submit",
        dir.to_str().unwrap(),
        "--db",
        db.to_str().unwrap(),
        "--summary",
        summary.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let console = String::from_utf8_lossy(&out.stdout);
    let json = submit(&db, &dir, &[]);
    let digest = frame(&json.report, "ui/button")["digest"]
        .as_str()
        .unwrap()
        .to_owned();
    assert!(
        console.contains(&format!("FAIL ui/button (untriaged, digest {digest})")),
        "{console}"
    );
    let md = std::fs::read_to_string(&summary).unwrap();
    assert!(md.starts_with("### tonegate frames: FAILED"), "{md}");
    assert!(
        md.contains(&format!(
            "| `ui/button` | **untriaged** (fails) | `{}` |",
            &digest[..12]
        )),
        "{md}"
    );
}

/// Judging is bounded by the decode budget, read from each image's header
/// before it is decoded: a frame that needs more than all of it is refused
/// by name with the flag that raises it, and nothing is stored; under a
/// budget that holds it, the same folder is judged.
#[test]
fn a_frame_over_the_decode_budget_is_refused_before_it_is_decoded() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    // 1024×1024 8-bit: 8 MiB to decode at 8 bytes a pixel.
    let big: Rgb8Image = Image::from_fn(1024, 1024, |x, y| [(x % 256) as u8, (y % 256) as u8, 7]);
    write_frame_png(&dir.join("big.png"), &Frame::Rgb8(big)).unwrap();
    let tight = submit(&db, &dir, &["--decode-budget-mib", "4"]);
    assert_eq!(tight.code, 2, "{}", tight.stderr);
    assert!(
        tight
            .stderr
            .contains("big.png needs 8 MiB to decode and judge, more than the 4 MiB")
            && tight.stderr.contains("--decode-budget-mib"),
        "{}",
        tight.stderr
    );
    assert!(History::open(&db)
        .unwrap()
        .submissions(10)
        .unwrap()
        .is_empty());
    let roomy = submit(&db, &dir, &["--decode-budget-mib", "16"]);
    assert_eq!(roomy.code, 1, "{}", roomy.stderr);
    assert_eq!(frame(&roomy.report, "big")["status"], "untriaged");
}

/// `untriaged = "accept_new"`: a new test passes with a warning, a changed
/// one fails. A first submission of two tests passes; once one is marked,
/// a change to it fails while a test seen for the first time still passes.
#[test]
fn accept_new_lets_new_tests_in_and_stops_changed_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    let rules = tmp.path().join("rules.toml");
    std::fs::write(&rules, "untriaged = \"accept_new\"\n").unwrap();
    let rules = rules.to_str().unwrap();
    write_frame_png(&dir.join("menu.png"), &Frame::Rgb8(frame8(0))).unwrap();
    write_frame_png(&dir.join("hud.png"), &Frame::Rgb8(frame8(9))).unwrap();
    let first = submit(&db, &dir, &["--rules", rules]);
    assert_eq!(first.code, 0, "{}", first.report);
    assert_eq!(frame(&first.report, "menu")["warning"], true);
    let digest = frame(&first.report, "menu")["digest"]
        .as_str()
        .unwrap()
        .to_owned();
    let out = frames_cmd(
        &db,
        "triage",
        &[
            "--test", "menu", "--digest", &digest, "positive", "--who", "ana", "--why", "ok",
        ],
    );
    succeeded(&out);
    write_frame_png(&dir.join("menu.png"), &Frame::Rgb8(frame8(4))).unwrap();
    write_frame_png(&dir.join("radar.png"), &Frame::Rgb8(frame8(21))).unwrap();
    let second = submit(&db, &dir, &["--rules", rules]);
    assert_eq!(second.code, 1, "{}", second.report);
    let menu = frame(&second.report, "menu");
    assert_eq!(
        (menu["passed"].clone(), menu["warning"].clone()),
        (Value::Bool(false), Value::Bool(false))
    );
    assert!(
        menu["detail"]
            .as_str()
            .unwrap()
            .contains("a change, not a new test"),
        "{menu}"
    );
    assert_eq!(frame(&second.report, "radar")["passed"], true);
    assert_eq!(frame(&second.report, "radar")["warning"], true);
}

/// The folder's non-image files are named as skipped; a damaged `.png` is
/// reported by the PNG reader (it was "not an HDR image … OpenEXR, Radiance,
/// PFM"); a warning shows in the JUnit the CI reads.
#[test]
fn skipped_files_damaged_pngs_and_warnings_are_said() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("notes.txt"), "not a frame").unwrap();
    std::fs::write(dir.join("broken.png"), b"GIF89a this is no png at all").unwrap();
    let bad = submit(&db, &dir, &[]);
    assert_eq!(bad.code, 2, "{}", bad.stderr);
    assert!(
        bad.stderr.contains("skipped 1 file(s) that are not images"),
        "{}",
        bad.stderr
    );
    assert!(bad.stderr.contains("notes.txt"), "{}", bad.stderr);
    assert!(bad.stderr.contains("broken.png"), "{}", bad.stderr);
    assert!(!bad.stderr.contains("not an HDR image"), "{}", bad.stderr);
    std::fs::remove_file(dir.join("broken.png")).unwrap();
    write_frame_png(&dir.join("hud.png"), &Frame::Rgb8(frame8(2))).unwrap();
    let warn = tmp.path().join("warn.toml");
    std::fs::write(&warn, "untriaged = \"warn\"\n").unwrap();
    let junit = tmp.path().join("frames.xml");
    let warned = submit(
        &db,
        &dir,
        &[
            "--rules",
            warn.to_str().unwrap(),
            "--junit",
            junit.to_str().unwrap(),
        ],
    );
    assert_eq!(warned.code, 0, "{}", warned.stderr);
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(
        xml.contains("WARNING (passes)") && xml.contains("<system-err>"),
        "{xml}"
    );
}

/// A retry under the same idempotency key answers the first report and
/// stores nothing; the same key with a changed folder is refused.
#[test]
fn a_retried_submission_stores_nothing_twice() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    folder(&dir);
    let first = submit(&db, &dir, &["--idempotency-key", "ci-1234-frames"]);
    assert_eq!(first.code, 1);
    // The retry of the same folder answers what the first did.
    let retry = submit(&db, &dir, &["--idempotency-key", "ci-1234-frames"]);
    assert_eq!(retry.report, first.report);
    // The folder changes: the same key is refused, naming the test.
    write_frame_png(&dir.join("ui/button.png"), &Frame::Rgb8(frame8(3))).unwrap();
    let changed = submit(&db, &dir, &["--idempotency-key", "ci-1234-frames"]);
    assert_eq!(changed.code, 2, "{}", changed.stderr);
    assert!(
        changed.stderr.contains("test ui/button's frame was"),
        "{}",
        changed.stderr
    );
    let h = History::open(&db).unwrap();
    assert_eq!(h.digest_labels(MAIN, "ui/button").unwrap().len(), 1);
    // Another key is another submission.
    let other = submit(&db, &dir, &["--idempotency-key", "ci-1235-frames"]);
    assert_ne!(other.report["submission"], first.report["submission"]);
    assert_eq!(h.digest_labels(MAIN, "ui/button").unwrap().len(), 2);
}
