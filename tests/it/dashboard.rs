//! The dashboard in real headless Chromium (Debian's `chromium`, installed by
//! ci/deps.sh) against `tonegate serve` on a seeded history: each page is
//! loaded, its rendered DOM checked for the runs, the charts and the image
//! comparison (images decoded by the browser), and screenshotted into
//! out/dashboard/ as CI artifacts.

use crate::common;
use crate::common::cdp::chromium;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

struct Serving {
    child: Child,
    base: String,
}

impl Drop for Serving {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn serve(seeded: &common::Seeded, dir: &Path) -> Serving {
    let mut child = Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args(["serve", "--bind", "127.0.0.1:0", "--db"])
        .arg(&seeded.db)
        .arg("--suite")
        .arg(&seeded.suite)
        .arg("--token-file")
        .arg(dir.join("token"))
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("tonegate serve starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    // "tonegate serving http://127.0.0.1:PORT/  (...)"
    let base = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("no address in {line:?}"))
        .trim_end_matches('/')
        .to_owned();
    Serving { child, base }
}

/// Loads `url`, lets its fetches finish (virtual time), returns the DOM and
/// saves a screenshot as out/dashboard/<name>.png.
fn browse(url: &str, name: &str) -> String {
    let profile = tempfile::tempdir().unwrap();
    let common_args = |c: &mut Command| {
        c.args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .args([
            "--run-all-compositor-stages-before-draw",
            "--virtual-time-budget=8000",
        ])
        .arg("--window-size=1400,1600")
        .stderr(Stdio::null());
    };
    let mut c = Command::new(chromium());
    common_args(&mut c);
    let out = c
        .arg("--dump-dom")
        .arg(url)
        .output()
        .expect("chromium runs");
    assert!(out.status.success(), "chromium failed on {url}");
    let dom = String::from_utf8_lossy(&out.stdout).into_owned();
    let shots = common::repo().join("out/dashboard");
    std::fs::create_dir_all(&shots).unwrap();
    let shot = shots.join(format!("{name}.png"));
    let mut c = Command::new(chromium());
    common_args(&mut c);
    let status = c
        .arg(format!("--screenshot={}", shot.display()))
        .arg(url)
        .status()
        .expect("chromium runs");
    assert!(status.success() && shot.exists(), "no screenshot of {url}");
    assert!(
        dom.contains("id=\"view\" aria-live=\"polite\" data-ready=\"1\""),
        "{url} never finished rendering:\n{dom}"
    );
    assert!(
        !dom.contains("role=\"alert\""),
        "{url} shows an error:\n{dom}"
    );
    dom
}

fn count(dom: &str, needle: &str) -> usize {
    dom.matches(needle).count()
}

#[test]
fn the_dashboard_shows_runs_charts_and_image_comparisons_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed(dir.path());
    let s = serve(&seeded, dir.path());

    let dom = browse(&format!("{}/#/runs", s.base), "runs");
    assert_eq!(count(&dom, "class=\"run-row\""), 3, "{dom}");
    assert_eq!(count(&dom, "data-status=\"failed\""), 1);
    assert!(dom.contains("class=\"badge passed\""));
    assert!(dom.contains(&format!("href=\"#/runs/{}\"", seeded.failed)));
    let dom = browse(&format!("{}/#/runs?status=failed", s.base), "runs-failed");
    assert_eq!(count(&dom, "class=\"run-row\""), 1, "the status filter");

    // The failing run: scenes, checks, per-frame table, the comparer with
    // golden / actual / diff / SSIM / FLIP images the browser decoded, and a slider.
    let dom = browse(
        &format!(
            "{}/#/runs/{}?scene=sky-reinhard-global",
            s.base, seeded.failed
        ),
        "run-failed",
    );
    assert!(dom.contains("Scene sky-reinhard-global"), "{dom}");
    assert!(dom.contains("class=\"badge failed\""));
    assert!(count(&dom, "data-frame=") >= 8, "eight frames in the table");
    assert!(dom.contains("class=\"comparer\""), "{dom}");
    for kind in ["golden", "actual", "diff", "ssim", "flip"] {
        let marker = format!("data-kind=\"{kind}\" data-loaded=\"1\"");
        assert!(dom.contains(&marker), "{kind} image not loaded:\n{dom}");
    }
    assert!(dom.contains("type=\"range\""), "the slider");
    assert!(dom.contains("min_psnr 50"), "the checks table");
    // A passing run can be looked at too (each scene's worst frame is kept).
    let dom = browse(
        &format!("{}/#/runs/{}", s.base, seeded.passed),
        "run-passed",
    );
    assert!(
        dom.contains("data-kind=\"actual\" data-loaded=\"1\""),
        "{dom}"
    );

    // Trends: FPS, PSNR, SSIM and stage time charts with points.
    let dom = browse(
        &format!("{}/#/trends?scene=sky-reinhard-global", s.base),
        "trends",
    );
    assert!(count(&dom, "<svg class=\"chart\"") >= 5, "{dom}");
    assert!(dom.contains("Worst-frame FLIP mean"), "the FLIP trend");
    assert!(count(&dom, "class=\"series\"") >= 4, "{dom}");
    assert!(count(&dom, "<circle") >= 8, "{dom}");
    assert!(dom.contains("data-series=\"sphere\""), "a stage series");
    // A part of the page that is left out leaves nothing behind (it once
    // printed "null" under the explanation).
    assert!(!dom.contains(">null<"), "{dom}");

    // The error-against-time scatter with its front.
    let dom = browse(&format!("{}/#/tradeoff", s.base), "tradeoff");
    assert!(dom.contains("<svg class=\"chart scatter\""), "{dom}");
    assert!(count(&dom, "class=\"point pareto\"") >= 2, "{dom}");
    assert!(dom.contains("class=\"front\""));

    // The tone-map page's controls: the operator's parameters come from
    // its definition (reinhard-global's by default, agx's when asked).
    let dom = browse(&format!("{}/#/tonemap", s.base), "tonemap");
    for name in [
        "file",
        "operator",
        "key",
        "white_fraction",
        "colour",
        "bloom",
        "gamma",
    ] {
        assert!(
            dom.contains(&format!("name=\"{name}\"")),
            "{name} control:\n{dom}"
        );
    }
    for op in tonegate::operators::builtin() {
        assert!(
            dom.contains(&format!("<option value=\"{}\"", op.name())),
            "{}",
            op.name()
        );
    }
    let dom = browse(&format!("{}/#/tonemap?operator=agx", s.base), "tonemap-agx");
    assert!(
        dom.contains("name=\"look\"") && dom.contains("name=\"exposure\""),
        "{dom}"
    );
    assert!(!dom.contains("name=\"white_fraction\""), "{dom}");
    // PQ and HLG are offered only where the operator can feed them.
    let display = |dom: &str| {
        dom.split("name=\"display\"")
            .nth(1)
            .and_then(|d| d.split("</select>").next())
            .map(str::to_owned)
            .unwrap_or_else(|| panic!("no display control:\n{dom}"))
    };
    assert!(
        display(&dom).contains("<option value=\"pq\" disabled"),
        "{dom}"
    );
}

/// bt2390 to a PQ display on the tone-map page: the 16-bit PNG is decoded by
/// the browser, and its display and light levels are shown.
#[test]
fn the_tone_map_page_writes_pq_for_bt2390_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = serve(&seeded, dir.path());
    let dom = browse(
        &format!("{}/#/tonemap?sample=sky&operator=bt2390&display=pq", s.base),
        "tonemap-pq",
    );
    assert!(dom.contains("data-loaded=\"1\""), "{dom}");
    assert!(dom.contains("<dt>Display</dt><dd>pq, 0"), "{dom}");
    assert!(dom.contains("<dt>MaxCLL / MaxFALL</dt>"), "{dom}");
    assert!(!dom.contains("<option value=\"pq\" disabled"), "{dom}");
}

/// The contact sheet: a built-in sample through every operator the server
/// knows, side by side, each decoded by the browser with the server's time.
#[test]
fn the_contact_sheet_shows_every_operator_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = serve(&seeded, dir.path());
    let dom = browse(
        &format!("{}/#/tonemap?sample=night&sheet=1", s.base),
        "contact-sheet",
    );
    assert!(
        dom.contains("class=\"contact-sheet\" data-done=\"1\""),
        "{dom}"
    );
    for op in tonegate::operators::builtin() {
        let cell = dom
            .split(&format!("data-operator=\"{}\"", op.name()))
            .nth(1)
            .unwrap_or_else(|| panic!("no cell for {}:\n{dom}", op.name()));
        let cell = cell.split("</figure>").next().unwrap();
        assert!(cell.contains("data-loaded=\"1\""), "{}: {cell}", op.name());
        assert!(cell.contains(" ms"), "{}: {cell}", op.name());
        assert!(cell.contains("data-ms=\""), "{}: {cell}", op.name());
    }
}

/// A run of the TAA scenes shows the no-AA / clip / edge-aware / default
/// TAA comparison: one table per test with every variant's best / worst /
/// mean, the ghosting test's PSNR gain over no AA frame by frame as a chart
/// (a line per TAA scene), and each variant's last frame and SSIM map beside
/// the golden, decoded by the browser.
#[test]
fn the_dashboard_compares_the_taa_variants_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    std::fs::write(
        &seeded.suite,
        "scenes = [\"scenes/taa-static-noaa.toml\", \"scenes/taa-static-clip.toml\", \"scenes/taa-static-edge.toml\", \"scenes/taa-ghost-noaa.toml\", \"scenes/taa-ghost-clip.toml\", \"scenes/taa-ghost-edge.toml\", \"scenes/taa-ghost.toml\"]\n",
    )
    .unwrap();
    let (suite, db) = (seeded.suite.to_str().unwrap(), seeded.db.to_str().unwrap());
    let o = common::tonegate(&["check", "--suite", suite, "--db", db]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let s = serve(&seeded, dir.path());
    let dom = browse(&format!("{}/#/runs/1", s.base), "run-taa");
    assert_eq!(
        count(&dom, "class=\"taa-compare\""),
        2,
        "static and ghosting:\n{dom}"
    );
    assert_eq!(count(&dom, "class=\"taa-row\""), 7, "{dom}");
    // Both tests for each variant; the ghosting test twice for `clip` (the
    // thesis's and the default TAA).
    for (variant, images) in [("off", 4), ("clip", 6), ("edge_aware", 4)] {
        assert_eq!(
            count(
                &dom,
                &format!("data-variant=\"{variant}\" data-loaded=\"1\"")
            ),
            images,
            "{variant}: actual and SSIM map of both tests decoded:\n{dom}"
        );
    }
    // The gain chart: only the ghosting test (a static test judges one
    // frame), a line per TAA scene, the default TAA's settings in its row.
    assert_eq!(count(&dom, "taa-gain"), 1, "{dom}");
    for scene in ["taa-ghost-clip", "taa-ghost-edge", "taa-ghost"] {
        assert!(
            dom.contains(&format!("data-series=\"{scene}\"")),
            "{scene} line:\n{dom}"
        );
    }
    assert!(
        dom.contains("PSNR gain over no AA (taa-ghost-noaa)"),
        "{dom}"
    );
    assert!(
        dom.contains("catmull_rom history, motion feedback, tonemapped blend"),
        "{dom}"
    );
    assert_eq!(
        count(
            &dom,
            "data-kind=\"golden\" data-variant=\"golden\" data-loaded=\"1\""
        ),
        2
    );
    assert!(dom.contains("PSNR dB best @f"), "{dom}");
}

/// Change points: twelve check runs whose last six have a tone
/// mapper 2 % too bright shift the SSIM series' level; the trends page draws
/// a dashed rule at the first of them and lists the shift. (Eight runs, four
/// and four, cannot reach p <= 0.01: only 70 orderings exist.)
#[test]
fn the_trend_charts_mark_a_level_shift_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    std::fs::write(
        &seeded.suite,
        "scenes = [\"scenes/sky-reinhard-global.toml\"]\n",
    )
    .unwrap();
    let (suite, db) = (seeded.suite.to_str().unwrap(), seeded.db.to_str().unwrap());
    for run in 1..=12 {
        let mut args = vec!["check", "--suite", suite, "--db", db];
        if run > 6 {
            args.extend(["--fault-gain", "1.02"]);
        }
        let o = common::tonegate(&args);
        // The fault fails the gate (exit 1); anything else (2: the check
        // could not run) would leave the series without its runs.
        assert_eq!(
            o.status.code(),
            Some(if run > 6 { 1 } else { 0 }),
            "run {run}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let s = serve(&seeded, dir.path());
    let dom = browse(
        &format!("{}/#/trends?scene=sky-reinhard-global", s.base),
        "trends-shift",
    );
    assert!(
        dom.contains("class=\"change\""),
        "no level-shift rule:\n{dom}"
    );
    assert!(dom.contains("SSIM ×") && dom.contains("at run 7"), "{dom}");
    assert!(!dom.contains(">null<"), "{dom}");
}

/// The fleet page lists the runners (a stopped one and a live,
/// idle one) and the queue (two jobs done, one waiting for a label no
/// runner has), from a history the real `runner` wrote.
#[test]
fn the_fleet_page_shows_runners_and_the_queue_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let (suite, db) = (seeded.suite.to_str().unwrap(), seeded.db.to_str().unwrap());
    let enqueue = |extra: &[&str]| {
        let mut args = vec![
            "enqueue",
            "--db",
            db,
            "--suite",
            suite,
            "--scene",
            "grid-static",
            "--cpu",
        ];
        args.extend(extra);
        let o = common::tonegate(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    enqueue(&["--count", "2"]);
    enqueue(&["--want-label", "nvidia"]);
    let runner = |name: &str, extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_tonegate"))
            .args([
                "runner", "--db", db, "--cpu", "--name", name, "--labels", "small",
            ])
            .args(["--poll-ms", "100", "--heartbeat-ms", "500"])
            .args(extra)
            .current_dir(common::repo())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    let done = runner("first", &["--max-jobs", "2"]).wait().unwrap();
    assert!(done.success());
    let mut live = runner("second", &["--exit-when-idle-s", "120"]);
    let s = serve(&seeded, dir.path());
    let dom = browse(&format!("{}/#/fleet?all=1", s.base), "fleet");
    let _ = live.kill();
    let _ = live.wait();
    assert_eq!(count(&dom, "class=\"runner-row\""), 2, "{dom}");
    assert_eq!(
        count(&dom, "class=\"runner-row\" data-state=\"stopped\""),
        1,
        "{dom}"
    );
    assert_eq!(
        count(&dom, "class=\"runner-row\" data-state=\"idle\""),
        1,
        "{dom}"
    );
    assert_eq!(
        count(&dom, "class=\"job-row\" data-state=\"done\""),
        2,
        "{dom}"
    );
    assert_eq!(
        count(&dom, "class=\"job-row\" data-state=\"queued\""),
        1,
        "{dom}"
    );
    assert!(
        dom.contains("label nvidia") && dom.contains("2 done") && dom.contains("1 queued"),
        "{dom}"
    );
}

/// A plain HTTP/1.1 GET with `Connection: close`; the body.
fn http_get(base: &str, path: &str) -> String {
    use std::io::{Read, Write};
    let host = base.trim_start_matches("http://");
    let mut s = std::net::TcpStream::connect(host).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap();
    assert!(head.starts_with("HTTP/1.1 200"), "{path}: {head}");
    body.to_owned()
}

/// Three adapters' newest runs in one history: lavapipe and GL-on-llvmpipe
/// pass, SwiftShader runs with a 2 % too-bright tone mapper and fails. The
/// matrix (API and page) has a column per adapter with its measured
/// subnormal behaviour, marks the scenes that split, and links each cell to
/// its run's comparer.
#[test]
fn the_adapter_matrix_marks_a_scene_that_splits_between_adapters_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let (suite, db) = (seeded.suite.to_str().unwrap(), seeded.db.to_str().unwrap());
    for (args, code) in [
        (vec![], 0),
        (vec!["--backend", "gl"], 0),
        (vec!["--adapter", "swiftshader", "--fault-gain", "1.02"], 1),
    ] {
        let mut all = vec!["check", "--suite", suite, "--db", db];
        all.extend(args.iter().copied());
        let o = common::tonegate(&all);
        assert_eq!(
            o.status.code(),
            Some(code),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let s = serve(&seeded, dir.path());
    let body = http_get(&s.base, "/api/v1/matrix");
    let m: serde_json::Value = serde_json::from_str(&body.replace("1e999", "1e308"))
        .unwrap_or_else(|e| panic!("{e}: {body}"));
    let adapters = m["adapters"].as_array().unwrap();
    assert_eq!(adapters.len(), 3, "{m}");
    let column = |name: &str, backend: &str| {
        adapters
            .iter()
            .position(|a| a["adapter"].as_str().unwrap().contains(name) && a["backend"] == backend)
            .unwrap_or_else(|| panic!("no {name} on {backend}: {m}"))
    };
    let (vk, gl, ss) = (
        column("llvmpipe", "Vulkan"),
        column("llvmpipe", "Gl"),
        column("SwiftShader", "Vulkan"),
    );
    assert_eq!(adapters[ss]["flushes_subnormals"], true);
    assert_eq!(adapters[vk]["flushes_subnormals"], false);
    let cells = m["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 6, "two scenes on three adapters");
    for c in cells {
        let col = c["column"].as_u64().unwrap() as usize;
        assert_eq!(c["passed"], col != ss, "{c}");
        assert!(c["worst_psnr"].as_f64().unwrap() > 0.0 && c["fps"].as_f64().unwrap() > 0.0);
        if col == gl {
            assert!(c["worst_flip"].as_f64().unwrap() < 1e-3, "{c}");
        }
    }
    let split: Vec<&str> = m["split"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap())
        .collect();
    assert_eq!(split, ["grid-static", "sky-reinhard-global"], "{m}");

    // The page: a column per adapter, a failing cell per scene on
    // SwiftShader, each linking to its run.
    // `browse` refuses a page with an alert; the split banner is one, so
    // the DOM is read here without that check.
    let matrix_dom = |hash: &str| {
        let url = format!("{}/#/{hash}", s.base);
        let profile = tempfile::tempdir().unwrap();
        let out = Command::new(chromium())
            .args(["--headless", "--no-sandbox", "--disable-gpu"])
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .args(["--virtual-time-budget=8000", "--dump-dom"])
            .arg(&url)
            .stderr(Stdio::null())
            .output()
            .expect("chromium runs");
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let dom = matrix_dom("matrix");
    assert!(dom.contains("data-ready=\"1\""), "{dom}");
    assert_eq!(count(&dom, "<th data-adapter="), 3, "{dom}");
    assert_eq!(count(&dom, "data-passed=\"0\""), 2, "{dom}");
    assert_eq!(count(&dom, "data-passed=\"1\""), 4, "{dom}");
    assert_eq!(count(&dom, "class=\"split\""), 2, "{dom}");
    assert!(
        dom.contains("flushes subnormals") && dom.contains("keeps subnormals"),
        "{dom}"
    );
    let ss_run = adapters[ss]["run_id"].as_i64().unwrap();
    assert!(
        dom.contains(&format!(
            "href=\"#/runs/{ss_run}?scene=sky-reinhard-global\""
        )),
        "a cell links to its run's comparer: {dom}"
    );
    assert!(
        dom.contains("Split: grid-static, sky-reinhard-global"),
        "{dom}"
    );
    // A long name is cut in its column, whole in its title; with fewer
    // columns than adapters, the page says how many it leaves out.
    assert!(
        dom.contains(&format!(
            "class=\"name\" title=\"{}\"",
            adapters[ss]["adapter"].as_str().unwrap()
        )),
        "{dom}"
    );
    assert_eq!(m["adapters_total"], 3, "{m}");
    assert!(!dom.contains("data-more="), "{dom}");
    let cut = matrix_dom("matrix?limit=2");
    assert_eq!(count(&cut, "<th data-adapter="), 2, "{cut}");
    assert!(
        cut.contains("data-more=\"1\"")
            && cut.contains("Showing the 2 most recently run of 3 adapters"),
        "{cut}"
    );
}
