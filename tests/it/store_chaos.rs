//! A fleet through its artifact store's restarts: four `tonegate runner`
//! processes on a PostgreSQL history keep their images in a real S3 server
//! (SeaweedFS), and do 200 queued one-frame jobs, each a scene of its own
//! (so every job has images the store has never seen), while the test kills
//! the store (SIGKILL) twice, for 3 s and the 10-20 s SeaweedFS takes to
//! answer again after its start. Every job is
//! done once with one passed run, no runner exits, no image is left pending
//! and every image the history names is in the store, once, with its hash.
//! The time each restart took is printed.

use crate::common::postgres as pg;
use crate::common::seaweed::Weed;
use crate::common::{copy_dir, repo};
use crate::fleet::wait_for;
use sha2::{Digest, Sha256};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use tonegate::history::{History, JobSpec};

const BUCKET: &str = "tonegate";
const STORE: &str = "s3://tonegate/chaos";
const JOBS: usize = 200;
const RUNNERS: usize = 4;

/// A copy of golden/ with `JOBS` one-frame 48x32 scenes, each with its own
/// key (so its own images), blessed; the suite file.
fn many_scenes(dir: &Path) -> std::path::PathBuf {
    let golden = dir.join("golden");
    copy_dir(&repo().join("golden"), &golden);
    let mut list = Vec::new();
    for i in 0..JOBS {
        let name = format!("t{i:03}");
        let description = format!("the store chaos test's job {i}: one small frame of its own");
        std::fs::write(
            golden.join(format!("scenes/{name}.toml")),
            crate::fleet::tiny_scene(&name, &description, 0.10 + 0.002 * i as f64),
        )
        .unwrap();
        list.push(format!("\"scenes/{name}.toml\""));
    }
    let suite = golden.join("many.toml");
    std::fs::write(&suite, format!("scenes = [{}]\n", list.join(", "))).unwrap();
    let o = crate::common::tonegate(&["golden", "bless", "--suite", suite.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    suite
}

fn runner(url: &str, weed: &Weed, name: &str, log: &Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args(["runner", "--db", url, "--cpu", "--name", name])
        .args(["--artifacts", STORE])
        .args([
            "--poll-ms",
            "50",
            "--heartbeat-ms",
            "200",
            "--lost-after-s",
            "3",
        ])
        .current_dir(repo())
        .env_remove("TONEGATE_DB")
        .env_remove("TONEGATE_DB_RETRY_S")
        .envs(weed.env())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .unwrap()
}

#[test]
fn a_fleet_rides_out_two_kills_of_its_artifact_store() {
    let mut weed = Weed::start(BUCKET);
    let dir = tempfile::tempdir().unwrap();
    let suite = many_scenes(dir.path());
    let url = pg::database();
    let h = History::open(Path::new(&url)).unwrap();
    for i in 0..JOBS {
        h.enqueue(&JobSpec {
            suite: suite.to_string_lossy().into_owned(),
            scenes: vec![format!("t{i:03}")],
            cpu: true,
            adapter: None,
            label: None,
        })
        .unwrap();
    }
    let logs = dir.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    let log =
        |i: usize| std::fs::read_to_string(logs.join(format!("r{i}.log"))).unwrap_or_default();
    let mut runners: Vec<Child> = (0..RUNNERS)
        .map(|i| {
            runner(
                &url,
                &weed,
                &format!("r{i}"),
                &logs.join(format!("r{i}.log")),
            )
        })
        .collect();
    let mut db = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    let done = |db: &mut postgres::Client| -> i64 {
        db.query_one("SELECT COUNT(*) FROM jobs WHERE state = 'done'", &[])
            .unwrap()
            .get(0)
    };

    // Two kills of 3 s (and the restart), while jobs are being done:
    // each once the fleet has done a few more jobs, the first of them
    // through the store that came back.
    let mut restarts = Vec::new();
    let mut until = 5;
    for round in 0..2 {
        wait_for("a few jobs done", Duration::from_secs(120), || {
            done(&mut db) >= until
        });
        let before = done(&mut db);
        assert!(
            (before as usize) < JOBS,
            "outage {round}: every job was done before the store went down; the test saw no outage"
        );
        let down = Instant::now();
        weed.kill();
        std::thread::sleep(Duration::from_secs(3));
        let took = weed.start_again(BUCKET);
        restarts.push((down.elapsed(), took, before));
        until = before + 5;
    }
    wait_for("every job to be done", Duration::from_secs(300), || {
        done(&mut db) as usize >= JOBS
    });
    for (i, r) in runners.iter_mut().enumerate() {
        assert!(
            r.try_wait().unwrap().is_none(),
            "runner r{i} exited: {}",
            log(i)
        );
    }
    for r in &runners {
        // SAFETY: signals a child this test spawned.
        assert_eq!(unsafe { libc::kill(r.id() as i32, libc::SIGTERM) }, 0);
    }
    for (i, r) in runners.iter_mut().enumerate() {
        let status = r.wait().unwrap();
        assert!(status.success(), "runner r{i}: {status}: {}", log(i));
    }

    // Each job once, with one passed run.
    for r in db
        .query("SELECT id, state, attempts FROM jobs", &[])
        .unwrap()
    {
        let (id, state, attempts): (i64, String, i64) = (r.get(0), r.get(1), r.get(2));
        assert_eq!((state.as_str(), attempts), ("done", 1), "job {id}");
    }
    let runs: Vec<(Option<i64>, String)> = db
        .query("SELECT job_id, status FROM runs ORDER BY job_id", &[])
        .unwrap()
        .iter()
        .map(|r| (r.get(0), r.get(1)))
        .collect();
    assert_eq!(runs.len(), JOBS);
    assert!(
        runs.iter().all(|(j, s)| j.is_some() && s == "passed"),
        "{runs:?}"
    );

    // Nothing pending, and every image the history names is in the store
    // with its hash, once.
    let blobs = db
        .query("SELECT sha256, size, store, pending FROM blobs", &[])
        .unwrap();
    let names: i64 = db
        .query_one("SELECT COUNT(*) FROM run_artifacts", &[])
        .unwrap()
        .get(0);
    assert!(names as usize >= JOBS, "{names} names");
    for b in &blobs {
        let (sha, size, store, pending): (String, i64, Option<String>, Option<String>) =
            (b.get(0), b.get(1), b.get(2), b.get(3));
        assert_eq!(pending, None, "{sha} is pending");
        assert_eq!(store.as_deref(), Some(STORE), "{sha}");
        let object = weed
            .get(BUCKET, &format!("chaos/{sha}.png"))
            .unwrap_or_else(|| panic!("{sha}.png was lost"));
        assert_eq!(
            (object.len() as i64, hex::encode(Sha256::digest(&object))),
            (size, sha)
        );
    }
    assert_eq!(
        weed.keys(BUCKET, "chaos/").len(),
        blobs.len(),
        "an image stored twice"
    );
    // The runners saw the store go and come back.
    let held: Vec<usize> = (0..RUNNERS)
        .map(|i| log(i).matches("takes images again: held on").count())
        .collect();
    assert!(held.iter().sum::<usize>() >= 2, "{held:?}: {}", log(0));
    for (round, (outage, restart, before)) in restarts.iter().enumerate() {
        eprintln!(
            "store chaos, outage {}: {before} of {JOBS} jobs done when killed; down {:.1} s, \
             of which the restart took {:.1} s",
            round + 1,
            outage.as_secs_f64(),
            restart.as_secs_f64()
        );
    }
    eprintln!(
        "store chaos: {JOBS} jobs done once each by {RUNNERS} runners, 0 runner exits, \
         {} images in the store, {names} names, 0 pending; runners that held on: {held:?}",
        blobs.len()
    );
}
