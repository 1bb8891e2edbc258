//! What `tonegate frames` keeps: a thousand frames of fifty distinct
//! images store fifty images, and `history prune` drops old submissions
//! and the untriaged digests only they had while positive digests keep
//! their images.

use crate::common;
use crate::frames::{frame, frame8, submit, triage};
use tonegate::history::History;
use tonegate::image::{Frame, Image};
use tonegate::io::write_frame_png;

/// A thousand frames of fifty distinct images are fifty stored images.
#[test]
fn a_thousand_frames_of_fifty_images_store_fifty() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    let images: Vec<Vec<u8>> = (0..50)
        .map(|i| {
            let path = tmp.path().join(format!("src{i}.png"));
            let img = Image::from_fn(16, 16, |x, y| [(x * 16) as u8, (y * 16) as u8, i as u8]);
            write_frame_png(&path, &Frame::Rgb8(img)).unwrap();
            std::fs::read(&path).unwrap()
        })
        .collect();
    for n in 0..1000 {
        std::fs::write(dir.join(format!("t{n:04}.png")), &images[n % 50]).unwrap();
    }
    let run = submit(&db, &dir, &[]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert_eq!(run.report["frames"].as_array().unwrap().len(), 1000);
    let stats = History::open(&db).unwrap().artifact_stats().unwrap();
    assert_eq!(stats.blobs, 50);
}

/// `history prune --keep-days` drops frames submissions older than the
/// keep, and the untriaged digests (and their images) only they had; a
/// positive digest keeps its label and its image, and the next submission
/// is judged by it.
#[test]
fn old_submissions_are_pruned_and_labelled_digests_kept() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    write_frame_png(&dir.join("kept.png"), &Frame::Rgb8(frame8(0))).unwrap();
    write_frame_png(&dir.join("loose.png"), &Frame::Rgb8(frame8(9))).unwrap();
    let first = submit(&db, &dir, &[]);
    let kept = frame(&first.report, "kept")["digest"]
        .as_str()
        .unwrap()
        .to_owned();
    let loose = frame(&first.report, "loose")["digest"]
        .as_str()
        .unwrap()
        .to_owned();
    triage(&db, "kept", &kept, "positive");
    // The submission and its images, as if made in 2020.
    let c = rusqlite::Connection::open(&db).unwrap();
    let old = "2020-01-01T00:00:00.000Z";
    c.execute("UPDATE frame_submissions SET submitted_at = ?1", [old])
        .unwrap();
    c.execute("UPDATE blobs SET stored_at = ?1", [old]).unwrap();
    let o = common::tonegate(&[
        "history",
        "prune",
        "--keep-days",
        "1",
        "--db",
        db.to_str().unwrap(),
    ]);
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{said}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        said.contains("1 frames submission(s) (1 untriaged digest(s) only they had)"),
        "{said}"
    );
    let count =
        |sql: &str, digest: &str| -> i64 { c.query_row(sql, [digest], |r| r.get(0)).unwrap() };
    assert_eq!(
        count("SELECT COUNT(*) FROM frame_submissions WHERE ?1 <> ''", "x"),
        0
    );
    assert_eq!(
        count("SELECT COUNT(*) FROM blobs WHERE sha256 = ?1", &kept),
        1
    );
    assert_eq!(
        count("SELECT COUNT(*) FROM blobs WHERE sha256 = ?1", &loose),
        0
    );
    assert_eq!(
        count(
            "SELECT COUNT(*) FROM digest_labels WHERE sha256 = ?1",
            &loose
        ),
        0
    );
    // The next submission: the positive still holds, the loose frame is new again.
    let next = submit(&db, &dir, &[]);
    assert_eq!(frame(&next.report, "kept")["status"], "positive");
    assert_eq!(frame(&next.report, "loose")["status"], "untriaged");
}

/// The last good commit an alert names is the same trace's (every key but
/// `commit`): a red submission of `device=a` gets `device=a`'s last passing
/// commit, not that of `device=b`, submitted in between.
#[test]
fn the_last_good_submission_is_the_same_devices() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    write_frame_png(&dir.join("scene.png"), &Frame::Rgb8(frame8(0))).unwrap();
    let warn = tmp.path().join("warn.toml");
    std::fs::write(&warn, "untriaged = \"warn\"\n").unwrap();
    let w = warn.to_str().unwrap();
    for (device, commit) in [("a", "a1"), ("b", "b1"), ("a", "a2")] {
        let d = format!("device={device}");
        let c = format!("commit={commit}");
        let run = submit(&db, &dir, &["--rules", w, "--key", &d, "--key", &c]);
        assert_eq!(run.code, 0, "{}", run.stderr);
    }
    let h = History::open(&db).unwrap();
    let subs = h.main_submissions_since(0, 10).unwrap();
    let (last, keys) = subs.iter().max_by_key(|(id, _)| *id).unwrap();
    let (_, good) = h
        .last_passing_main_submission(*last, keys)
        .unwrap()
        .unwrap();
    let good: serde_json::Value = serde_json::from_str(&good).unwrap();
    assert_eq!(good["commit"], "a1", "{good}");
    assert_eq!(good["device"], "a");
    // A trace with no passing submission before it has none.
    let other = serde_json::json!({"device": "c", "commit": "c1"}).to_string();
    assert_eq!(h.last_passing_main_submission(*last, &other).unwrap(), None);
}
