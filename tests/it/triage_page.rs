//! The triage page in real headless Chromium, driven through the DevTools
//! protocol as a person uses it, against `tonegate serve` with its three
//! tokens: a CI-style run submits 200 frames with two key sets through the
//! API (each set 99 PNGs and an EXR; eleven of the second set's differ),
//! both fail untriaged; on the page a person is asked for the triage token,
//! marks every digest of the first set positive at once, then the
//! resubmitted second set's eleven one by one, each beside its closest
//! positive with the diff, SSIM and FLIP maps (the EXR tone-mapped with the
//! operator chosen on the page); the same submissions then pass. A frame
//! one code off passes under a fuzzy rule and fails without it; a 2 %
//! brighter one fails, its FLIP map on the page.

use crate::common;
use crate::common::cdp::{chromium, Browser};
use reqwest::multipart::{Form, Part};
use serde_json::Value;
use std::process::{Child, Command, Stdio};
use tonegate::env::BuiltinEnv;
use tonegate::image::{Image, Rgb8Image};

const SUBMIT: &str = "page-submit-token-0123456789";
const TRIAGE: &str = "page-triage-token-0123456789";

struct Serving(Child);

impl Drop for Serving {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn frame(i: u32, shift: u32) -> Rgb8Image {
    Image::from_fn(48, 32, |x, y| {
        let band = (x + shift) % 48 < 10;
        if band {
            [250, 210, (i * 2) as u8]
        } else {
            [(x * 5) as u8, (y * 7) as u8, (i * 2 + 30) as u8]
        }
    })
}

fn png(img: &Rgb8Image) -> Vec<u8> {
    tonegate::io::encode_png8(img).unwrap()
}

fn exr(gain: f32) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("sky.exr");
    let img = BuiltinEnv::Sky
        .generate(64, 32)
        .map(|c| c.map(|v| v * gain));
    tonegate::io::write_image_hdr(&p, &img).unwrap();
    std::fs::read(p).unwrap()
}

/// One key set's frames: 99 PNG tests and an EXR; `differs` moves the band
/// of every tenth PNG and brightens the EXR by 5 %.
fn key_set(differs: bool) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = (0..99u32)
        .map(|i| {
            let shift = if differs && i % 10 == 0 { 7 } else { 0 };
            (format!("scene/s{i:02}.png"), png(&frame(i, shift)))
        })
        .collect();
    files.push(("hdr/sky.exr".into(), exr(if differs { 1.05 } else { 1.0 })));
    files
}

fn submit(base: &str, files: &[(String, Vec<u8>)], keys: &[&str], rules: Option<&str>) -> Value {
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let mut form = Form::new();
        for (name, bytes) in files {
            form = form.part("file", Part::bytes(bytes.clone()).file_name(name.clone()));
        }
        for k in keys {
            form = form.text("key", k.to_string());
        }
        if let Some(r) = rules {
            form = form.text("rules", r.to_string());
        }
        let r = reqwest::Client::new()
            .post(format!("{base}/api/v1/frames/submissions"))
            .bearer_auth(SUBMIT)
            .multipart(form)
            .send()
            .await
            .unwrap();
        assert!(r.status().is_success(), "{}", r.status());
        r.json().await.unwrap()
    })
}

fn shot(b: &mut Browser, name: &str) {
    b.screenshot(&common::repo().join(format!("out/dashboard/{name}.png")));
}

/// Types into the page's who and why fields as a person would.
fn say(b: &mut Browser, why: &str) {
    b.eval(&format!(
        "(() => {{ for (const [n, v] of [['who', 'ana'], ['why', {why:?}]]) {{
            const i = document.querySelector(`input[name=${{n}}]`);
            i.value = v; i.dispatchEvent(new Event('input')); i.dispatchEvent(new Event('change'));
        }} }})()"
    ));
}

#[test]
fn frames_are_triaged_in_the_page_and_the_same_submissions_then_pass_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    for (f, t) in [("submit.token", SUBMIT), ("triage.token", TRIAGE)] {
        std::fs::write(dir.path().join(f), t).unwrap();
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args(["serve", "--bind", "127.0.0.1:0", "--db"])
        .arg(&seeded.db)
        .arg("--suite")
        .arg(&seeded.suite)
        .arg("--token-file")
        .arg(dir.path().join("token"))
        .arg("--submit-token-file")
        .arg(dir.path().join("submit.token"))
        .arg("--triage-token-file")
        .arg(dir.path().join("triage.token"))
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("tonegate serve starts");
    let base = common::served_base(&mut child);
    let _serving = Serving(child);

    let (a, b_files) = (key_set(false), key_set(true));
    let keys_a = ["device=gpu-a", "commit=c1"];
    let keys_b = ["device=gpu-b", "commit=c1"];
    let first_a = submit(&base, &a, &keys_a, None);
    let first_b = submit(&base, &b_files, &keys_b, None);
    for r in [&first_a, &first_b] {
        assert_eq!(r["passed"], false);
        assert_eq!(r["untriaged"], 100, "{}", r["untriaged"]);
    }

    let mut b = Browser::start(&chromium());
    b.open(&format!("{base}/#/frames"));
    assert_eq!(
        b.eval("document.querySelectorAll('.submission-row').length"),
        2
    );
    shot(&mut b, "frames");

    // The first key set: asked for the token, then all 100 marked at once.
    let id_a = first_a["submission"].as_i64().unwrap();
    b.open(&format!("{base}/#/frames/{id_a}"));
    assert_eq!(
        b.eval("document.querySelectorAll('.frame-card[data-status=untriaged]').length"),
        100
    );
    say(&mut b, "the first frames of the new scenes");
    b.eval("document.querySelector('button[name=all-positive]').click()");
    b.wait_for(
        "!document.getElementById('token-box').hidden && document.querySelector('#triage-msg [role=alert]')",
        "the token is asked for",
    );
    assert!(b
        .eval("document.querySelector('#triage-msg').textContent")
        .as_str()
        .unwrap()
        .contains("401"));
    b.eval(&format!(
        "document.querySelector('#token-box input').value = {TRIAGE:?}; document.querySelector('#token-box button').click()"
    ));
    b.wait_for(
        "document.getElementById('view').dataset.ready === '1' && document.querySelector('button[name=all-positive]')",
        "the page again",
    );
    say(&mut b, "the first frames of the new scenes");
    b.eval("document.querySelector('button[name=all-positive]').click()");
    b.wait_for(
        "document.querySelector('#triage-msg').dataset.done === '100'",
        "100 marked",
    );
    shot(&mut b, "frames-triaged");

    // The second key set again: eleven frames differ from the positives,
    // each shown beside the closest with its maps, and marked one by one.
    let second_b = submit(&base, &b_files, &["device=gpu-b", "commit=c2"], None);
    assert_eq!(second_b["untriaged"], 11, "{second_b}");
    let id_b = second_b["submission"].as_i64().unwrap();
    b.open(&format!("{base}/#/frames/{id_b}?operator=hable"));
    assert_eq!(
        b.eval("document.querySelectorAll('.frame-card').length"),
        11
    );
    for kind in ["frame", "positive", "diff", "ssim", "flip"] {
        b.wait_for(
            &format!("document.querySelector('.frame-card [data-kind={kind}][data-loaded=\"1\"]')"),
            &format!("the {kind} image"),
        );
    }
    // The HDR frame, tone-mapped with the operator the page chose (its
    // images load as it is scrolled to).
    b.eval("document.querySelector('.frame-card[data-test=\"hdr/sky\"]').scrollIntoView()");
    b.wait_for(
        "document.querySelector('.frame-card[data-test=\"hdr/sky\"] img[data-kind=frame][data-loaded=\"1\"]')",
        "the EXR shown",
    );
    let src = b.eval(
        "document.querySelector('.frame-card[data-test=\"hdr/sky\"] img[data-kind=positive]').dataset.src",
    );
    assert!(src.as_str().unwrap().contains("operator=hable"), "{src}");
    assert_eq!(
        b.eval("document.querySelector('select[name=operator]').value"),
        "hable"
    );
    shot(&mut b, "frames-closest");
    say(
        &mut b,
        "the band moved on purpose; the sky is brighter on gpu-b",
    );
    b.eval(
        "for (const x of document.querySelectorAll('.frame-card button[name=positive]')) x.click()",
    );
    b.wait_for(
        "document.querySelectorAll('.frame-card[data-label=positive]').length === 11",
        "eleven marked",
    );

    // The same submissions now pass.
    assert_eq!(submit(&base, &a, &keys_a, None)["passed"], true);
    assert_eq!(
        submit(&base, &b_files, &["device=gpu-b", "commit=c3"], None)["passed"],
        true
    );

    // One code off: passes under a fuzzy rule, fails without. 2 % brighter:
    // fails under it, its FLIP map on the page.
    let rules = "[[tests]]\npattern = \"scene/**\"\nchecks = [{ max_abs_diff = 1 }]\n";
    let off = frame(1, 0).map(|p| p.map(|c| c.saturating_add(1)));
    let one_off = vec![("scene/s01.png".to_string(), png(&off))];
    assert_eq!(
        submit(&base, &one_off, &keys_a, Some(rules))["passed"],
        true
    );
    assert_eq!(submit(&base, &one_off, &keys_a, None)["passed"], false);
    let bright = frame(1, 0).map(|p| p.map(|c| (f32::from(c) * 1.02).round().min(255.0) as u8));
    let bright = submit(
        &base,
        &[("scene/s01.png".to_string(), png(&bright))],
        &keys_a,
        Some(rules),
    );
    assert_eq!(bright["passed"], false);
    let detail = bright["frames"][0]["detail"].as_str().unwrap();
    assert!(detail.contains("misses"), "{detail}");
    b.open(&format!("{base}/#/frames/{}", bright["submission"]));
    b.wait_for(
        "document.querySelector('.frame-card [data-kind=flip][data-loaded=\"1\"]')",
        "the brighter frame's FLIP map",
    );
    assert!(b
        .eval("document.querySelector('.frame-card .figures').textContent")
        .as_str()
        .unwrap()
        .contains("misses"));
    shot(&mut b, "frames-brighter");
}

/// The `sh` lines of docs/frames.md's "In CI, step by step", in order:
/// (words, comment).
fn walkthrough() -> Vec<(Vec<String>, String)> {
    let text = std::fs::read_to_string(common::repo().join("docs/frames.md")).unwrap();
    let start = text
        .find("## In CI, step by step")
        .expect("docs/frames.md has its walk-through");
    let section = &text[start..];
    let section = &section[..section[3..].find("\n## ").map_or(section.len(), |e| e + 3)];
    let mut out = Vec::new();
    let mut inside = false;
    for l in section.lines() {
        if let Some(lang) = l.trim_start().strip_prefix("```") {
            inside = !inside && lang.trim() == "sh";
            continue;
        }
        if !inside || l.trim().is_empty() || l.trim_start().starts_with('#') {
            continue;
        }
        let (code, comment) = l.split_once(" #").unwrap_or((l, ""));
        out.push((
            code.split_whitespace().map(str::to_owned).collect(),
            comment.trim().to_owned(),
        ));
    }
    out
}

/// docs/frames.md's walk-through, run as a newcomer would: its commands in
/// a fresh folder beside `golden/` (the server on a free port instead of
/// 8080), and its browser step in real Chromium: the first CI run fails,
/// the page asks for the triage token and marks every digest, the second
/// run passes.
#[test]
fn the_newcomers_walkthrough_in_the_docs_runs_as_written() {
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(common::repo().join("golden"), dir.path().join("golden")).unwrap();
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let lines = walkthrough();
    assert!(lines.len() >= 4, "{lines:?}");
    let mut server: Option<Serving> = None;
    let mut base = String::new();
    let mut failed_once = false;
    for (words, comment) in lines {
        let words: Vec<String> = words
            .iter()
            .map(|w| w.replace("127.0.0.1:8080", &format!("127.0.0.1:{port}")))
            .collect();
        assert_eq!(
            words[0], "tonegate",
            "the walk-through runs tonegate only: {words:?}"
        );
        let background = words.last().map(String::as_str) == Some("&");
        let args = &words[1..words.len() - usize::from(background)];
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_tonegate"));
        cmd.args(args)
            .current_dir(dir.path())
            .env_remove("TONEGATE_DB");
        if background {
            let mut child = cmd
                .stdout(Stdio::piped())
                .stderr(Stdio::null())
                .spawn()
                .unwrap();
            base = common::served_base(&mut child);
            server = Some(Serving(child));
            continue;
        }
        let o = cmd.output().unwrap();
        let expected = if comment.contains("fails") { 1 } else { 0 };
        assert_eq!(
            o.status.code(),
            Some(expected),
            "tonegate {}: {}{}",
            args.join(" "),
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        if expected == 1 && args[..2] == ["frames", "submit"] {
            // Step 4: in the browser, as the docs say.
            assert!(
                server.is_some(),
                "the walk-through submits before it serves"
            );
            let triage = std::fs::read_to_string(dir.path().join("triage.token")).unwrap();
            let mut b = Browser::start(&chromium());
            b.open(&format!("{base}/#/frames"));
            b.eval("document.querySelector('.submission-row a').click()");
            b.wait_for(
                "document.getElementById('view').dataset.ready === '1' && document.querySelector('button[name=all-positive]')",
                "the submission's page",
            );
            say(&mut b, "the first frames of the sphere");
            b.eval("document.querySelector('button[name=all-positive]').click()");
            b.wait_for(
                "!document.getElementById('token-box').hidden",
                "the token asked for",
            );
            b.eval(&format!(
                "document.querySelector('#token-box input').value = {:?}; document.querySelector('#token-box button').click()",
                triage.trim()
            ));
            b.wait_for(
                "document.getElementById('view').dataset.ready === '1' && document.querySelector('button[name=all-positive]')",
                "the page again",
            );
            say(&mut b, "the first frames of the sphere");
            b.eval("document.querySelector('button[name=all-positive]').click()");
            b.wait_for(
                "+document.querySelector('#triage-msg').dataset.done > 0",
                "digests marked",
            );
            failed_once = true;
        }
    }
    assert!(failed_once, "the walk-through has no failing first run");
    assert!(
        dir.path().join("frames.xml").exists(),
        "the JUnit report CI reads"
    );
}
