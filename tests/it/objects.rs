//! Artifacts in an object store: `check --artifacts s3://bucket/prefix` on
//! a PostgreSQL history keeps the images in a real S3 server (SeaweedFS,
//! `common/seaweed.rs`), each distinct image once under its SHA-256, with
//! the history holding only names, hashes, sizes and the store's address;
//! `serve` streams them back from the store; `history prune` deletes the
//! objects no kept run names, and objects nothing names at all.

use crate::common::postgres as pg;
use crate::common::seaweed::Weed;
use crate::common::{repo, seed_empty};
use sha2::{Digest, Sha256};
use std::collections::BTreeSet;
use std::process::{Command, Stdio};

const BUCKET: &str = "tonegate";
const STORE: &str = "s3://tonegate/fleet/artifacts";

fn tonegate(weed: &Weed, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args(args)
        .current_dir(repo())
        .env_remove("TONEGATE_DB")
        .envs(weed.env())
        .output()
        .unwrap()
}

#[test]
fn artifacts_go_to_an_object_store_once_and_are_served_and_pruned_from_it() {
    let weed = Weed::start(BUCKET);
    let dir = tempfile::tempdir().unwrap();
    let seeded = seed_empty(dir.path());
    let url = pg::database();
    let suite = seeded.suite.to_str().unwrap();
    // Two runs of a deterministic renderer: the same images.
    for _ in 0..2 {
        let o = tonegate(
            &weed,
            &[
                "check",
                "--cpu",
                "--suite",
                suite,
                "--db",
                &url,
                "--artifacts",
                STORE,
            ],
        );
        assert!(
            o.status.success(),
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let mut db = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    let blobs = db
        .query("SELECT sha256, size, length(data), store FROM blobs", &[])
        .unwrap();
    assert!(!blobs.is_empty());
    for b in &blobs {
        let (sha, size, held, store): (String, i64, i32, Option<String>) =
            (b.get(0), b.get(1), b.get(2), b.get(3));
        assert_eq!(store.as_deref(), Some(STORE), "{sha}");
        assert_eq!(held, 0, "{sha}: the history holds no image bytes");
        let object = weed
            .get(BUCKET, &format!("fleet/artifacts/{sha}.png"))
            .unwrap_or_else(|| panic!("{sha}.png is not in the store"));
        assert_eq!(object.len() as i64, size);
        assert_eq!(hex::encode(Sha256::digest(&object)), sha);
    }
    // Each distinct image once: as many objects as images, and both runs
    // name the same ones.
    let keys = weed.keys(BUCKET, "fleet/artifacts/");
    assert_eq!(keys.len(), blobs.len(), "{keys:?}");
    let per_run: Vec<(i64, String)> = db
        .query(
            "SELECT run_id, sha256 FROM run_artifacts ORDER BY run_id",
            &[],
        )
        .unwrap()
        .iter()
        .map(|r| (r.get(0), r.get(1)))
        .collect();
    let runs: BTreeSet<i64> = per_run.iter().map(|(r, _)| *r).collect();
    assert_eq!(runs.len(), 2);
    let names: Vec<(i64, String)> = db
        .query(
            "SELECT run_id, name FROM run_artifacts ORDER BY run_id, name",
            &[],
        )
        .unwrap()
        .iter()
        .map(|r| (r.get(0), r.get(1)))
        .collect();
    let shas = |run: i64| -> BTreeSet<&String> {
        per_run
            .iter()
            .filter(|(r, _)| *r == run)
            .map(|(_, s)| s)
            .collect()
    };
    let first = *runs.first().unwrap();
    let second = *runs.last().unwrap();
    assert_eq!(shas(first), shas(second), "{names:?}");
    assert_eq!(shas(first).len(), blobs.len(), "{names:?}");
    assert_eq!(names.len(), per_run.len());

    // The server streams each image from the store.
    let token = dir.path().join("token");
    std::fs::write(&token, "objects-token-0123456789").unwrap();
    let mut server = Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args([
            "serve",
            "--bind",
            "127.0.0.1:0",
            "--db",
            &url,
            "--suite",
            suite,
        ])
        .arg("--token-file")
        .arg(&token)
        .current_dir(repo())
        .env_remove("TONEGATE_DB")
        .envs(weed.env())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let base = crate::common::served_base(&mut server);
    let rt = tokio::runtime::Runtime::new().unwrap();
    let client = reqwest::Client::new();
    let (run, name) = names.last().unwrap().clone();
    let sha: String = db
        .query_one(
            "SELECT sha256 FROM run_artifacts WHERE run_id = $1 AND name = $2",
            &[&run, &name],
        )
        .unwrap()
        .get(0);
    let (status, length, bytes) = rt.block_on(async {
        let r = client
            .get(format!("{base}/api/v1/runs/{run}/artifacts/{name}"))
            .send()
            .await
            .unwrap();
        let length = r.headers().get("content-length").cloned();
        (r.status().as_u16(), length, r.bytes().await.unwrap())
    });
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&bytes));
    assert_eq!(hex::encode(Sha256::digest(&bytes)), sha);
    assert_eq!(
        length.unwrap().to_str().unwrap(),
        bytes.len().to_string(),
        "streamed with its length"
    );
    // An image the store lost is a clear 404 naming the store.
    let lost_key = format!("fleet/artifacts/{sha}.png");
    let kept = weed.get(BUCKET, &lost_key).unwrap();
    rt.block_on(async {
        let r = client
            .delete(format!("{}/{BUCKET}/{lost_key}", weed.base()))
            .send()
            .await
            .unwrap();
        assert!(r.status().is_success());
        let r = client
            .get(format!("{base}/api/v1/runs/{run}/artifacts/{name}"))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status().as_u16(), 404);
        let text = r.text().await.unwrap();
        assert!(text.contains(STORE) && text.contains(&sha), "{text}");
    });
    weed.put(BUCKET, &lost_key, &kept);
    // SAFETY: signals a child this test spawned.
    unsafe { libc::kill(server.id() as i32, libc::SIGTERM) };
    let _ = server.wait();

    // Prune: the runs' names go, then the objects no run names, and an
    // object nothing ever named (a write that did not finish).
    let stray = format!("fleet/artifacts/{}.png", "ab".repeat(32));
    weed.put(BUCKET, &stray, b"not an image of any run");
    std::thread::sleep(tonegate::history::STRAY_GRACE + std::time::Duration::from_secs(1));
    let o = tonegate(
        &weed,
        &["history", "prune", "--db", &url, "--keep-days", "0"],
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{out}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        out.contains(&format!(
            "{} of them from an object store), 1 object(s) nothing named",
            blobs.len()
        )),
        "{out}"
    );
    assert_eq!(weed.keys(BUCKET, "fleet/artifacts/"), Vec::<String>::new());
    let left: i64 = db
        .query_one("SELECT COUNT(*) FROM blobs", &[])
        .unwrap()
        .get(0);
    assert_eq!(left, 0);
}

/// Eight runners do 200 queued one-frame jobs twice, in one sitting: with
/// the images in the history's own table, then in SeaweedFS. Each distinct
/// image is stored once either way; the two wall times are printed (a
/// benchmark's figure, not asserted: this machine is shared and noisy).
#[test]
fn a_fleet_keeps_each_distinct_image_once_in_an_object_store() {
    let weed = Weed::start(BUCKET);
    let dir = tempfile::tempdir().unwrap();
    let (tiny, _) = crate::fleet::suites(dir.path());
    let mut times = Vec::new();
    // ABBA, so a drift of the machine's speed during the sitting falls on
    // both alike; the second S3 round finds the first's images in the store.
    let s3 = Some("s3://tonegate/fleet-200");
    for (round, store) in [None, s3, s3, None].into_iter().enumerate() {
        let url = pg::database();
        let o = tonegate(
            &weed,
            &[
                "enqueue",
                "--db",
                &url,
                "--suite",
                tiny.to_str().unwrap(),
                "--cpu",
                "--count",
                "200",
            ],
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let started = std::time::Instant::now();
        let mut runners: Vec<std::process::Child> = (0..8)
            .map(|i| {
                let mut c = Command::new(env!("CARGO_BIN_EXE_tonegate"));
                c.args(["runner", "--db", &url, "--cpu", "--name", &format!("s{i}")])
                    .args(["--poll-ms", "50", "--exit-when-idle-s", "2"])
                    .current_dir(repo())
                    .env_remove("TONEGATE_DB")
                    .envs(weed.env())
                    .stdout(Stdio::null())
                    .stderr(Stdio::null());
                if let Some(s) = store {
                    c.args(["--artifacts", s]);
                }
                c.spawn().unwrap()
            })
            .collect();
        for r in &mut runners {
            assert!(r.wait().unwrap().success());
        }
        let took = started.elapsed().as_secs_f64() - 2.0;
        let mut db = postgres::Client::connect(&url, postgres::NoTls).unwrap();
        let done: i64 = db
            .query_one("SELECT COUNT(*) FROM jobs WHERE state = 'done'", &[])
            .unwrap()
            .get(0);
        assert_eq!(done, 200);
        let (names, blobs): (i64, i64) = {
            let r = db
                .query_one(
                    "SELECT (SELECT COUNT(*) FROM run_artifacts), (SELECT COUNT(*) FROM blobs)",
                    &[],
                )
                .unwrap();
            (r.get(0), r.get(1))
        };
        assert!(
            names >= 200 && blobs >= 1 && blobs < names,
            "{names} names, {blobs} images"
        );
        if let Some(s) = store {
            let prefix = s.trim_start_matches("s3://tonegate/");
            let keys = weed.keys(BUCKET, &format!("{prefix}/"));
            assert_eq!(
                keys.len() as i64,
                blobs,
                "each distinct image once in the store"
            );
            let in_table: i64 = db
                .query_one("SELECT COUNT(*) FROM blobs WHERE store IS NULL", &[])
                .unwrap()
                .get(0);
            assert_eq!(in_table, 0);
        }
        times.push((
            round + 1,
            store.unwrap_or("the history's table"),
            took,
            names,
            blobs,
        ));
    }
    for (round, store, took, names, blobs) in &times {
        eprintln!(
            "fleet of 8, 200 one-frame jobs, round {round}, images in {store}: {took:.1} s \
             ({names} names, {blobs} distinct images)"
        );
    }
}

/// Submitted frames in the object store: a folder of 1,000 frames of 50
/// distinct images stores 50 objects and no bytes in the history; the
/// triaged digests pass the next submission, and a frame that changed is
/// compared with its positive read back from the store.
#[test]
fn submitted_frames_go_to_the_object_store_once_each() {
    use tonegate::image::{Frame, Image};
    let weed = Weed::start(BUCKET);
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    let png = |i: u32, lift: u8| {
        let p = tmp.path().join("one.png");
        let img = Image::from_fn(24, 16, |x, y| {
            [(x * 10) as u8 + lift, (y * 15) as u8, i as u8]
        });
        tonegate::io::write_frame_png(&p, &Frame::Rgb8(img)).unwrap();
        std::fs::read(&p).unwrap()
    };
    let images: Vec<Vec<u8>> = (0..50).map(|i| png(i, 0)).collect();
    for n in 0..1000 {
        std::fs::write(dir.join(format!("t{n:04}.png")), &images[n % 50]).unwrap();
    }
    let store = "s3://tonegate/frames";
    let submit = |rules: Option<&std::path::Path>| {
        let mut args = vec![
            "frames",
            "submit",
            dir.to_str().unwrap(),
            "--db",
            db.to_str().unwrap(),
            "--artifacts",
            store,
            "--json",
            "-",
        ];
        if let Some(r) = rules {
            args.extend(["--rules", r.to_str().unwrap()]);
        }
        let o = tonegate(&weed, &args);
        let report: serde_json::Value = serde_json::from_slice(&o.stdout)
            .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&o.stderr)));
        (o.status.code(), report)
    };
    let (code, first) = submit(None);
    assert_eq!(code, Some(1));
    assert_eq!(weed.keys(BUCKET, "frames/").len(), 50);
    let c = rusqlite::Connection::open(&db).unwrap();
    let (blobs, held, stored): (i64, i64, i64) = c
        .query_row(
            "SELECT COUNT(*), SUM(length(data)), SUM(store = ?1) FROM blobs",
            [store],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
        )
        .unwrap();
    assert_eq!((blobs, held, stored), (50, 0, 50));
    // Every digest positive, then the same frames pass.
    let h = tonegate::history::History::open(&db).unwrap();
    let actions: Vec<(String, String)> = first["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            (
                f["test"].as_str().unwrap().to_owned(),
                f["digest"].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    let labelled: Vec<(&str, &str, tonegate::history::Label)> = actions
        .iter()
        .map(|(t, d)| (t.as_str(), d.as_str(), tonegate::history::Label::Positive))
        .collect();
    h.triage_many(tonegate::history::MAIN, &labelled, ("ana", "first frames"))
        .unwrap();
    assert_eq!(submit(None).0, Some(0));
    // One frame a code brighter: judged against its positive, read back
    // from the store, within a one-code rule.
    std::fs::write(dir.join("t0007.png"), png(7, 1)).unwrap();
    let rules = tmp.path().join("rules.toml");
    std::fs::write(
        &rules,
        "[[tests]]\npattern = \"*\"\nchecks = [{ max_abs_diff = 1 }]\n",
    )
    .unwrap();
    let (code, third) = submit(Some(&rules));
    assert_eq!(code, Some(0), "{third}");
    let frame = third["frames"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["test"] == "t0007")
        .unwrap();
    assert_eq!(frame["status"], "matched", "{frame}");
    assert_eq!(frame["closest"]["figures"]["max_abs_diff"], 1.0);
    let (blobs, held): (i64, i64) = c
        .query_row("SELECT COUNT(*), SUM(length(data)) FROM blobs", [], |r| {
            Ok((r.get(0)?, r.get(1)?))
        })
        .unwrap();
    let digest = frame["digest"].as_str().unwrap();
    let found: i64 = c
        .query_row(
            "SELECT COUNT(*) FROM blobs WHERE sha256 = ?1",
            [digest],
            |r| r.get(0),
        )
        .unwrap();
    let distinct: i64 = c
        .query_row(
            "SELECT COUNT(DISTINCT sha256) FROM submitted_frames",
            [],
            |r| r.get(0),
        )
        .unwrap();

    assert_eq!((blobs, held, found, distinct), (51, 0, 1, 51), "{frame}");
    assert_eq!(weed.keys(BUCKET, "frames/").len(), 51);
}
