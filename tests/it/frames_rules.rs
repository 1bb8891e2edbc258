//! Rules as teams write them, through the real command and decoders:
//! frames with an alpha channel, as many renderers write their
//! screenshots, judged on their colour composited over the rule's
//! background (black by default) or with the alpha dropped, never refused;
//! and a check for one adapter (the scene vocabulary's `adapter = "…"`,
//! against the submission's `adapter` key) overriding the bound for all.

use crate::frames::{frame, frame8, submit, triage};
use std::path::Path;
use tonegate::image::Frame;
use tonegate::io::write_frame_png;

/// `frame8(0)`'s colours with alpha: a 128-alpha band in rows 4..12 and
/// `band` over columns 0..16 of it (the rest opaque).
fn write_rgba(path: &Path, band: u8) {
    let rgb = frame8(0);
    let mut rgba = Vec::with_capacity(rgb.pixels.len() * 4);
    for (i, p) in rgb.pixels.iter().enumerate() {
        let (x, y) = (i as u32 % rgb.width, i as u32 / rgb.width);
        let a = match (x, y) {
            (0..16, 4..12) => band,
            (_, 4..12) => 128,
            _ => 255,
        };
        rgba.extend_from_slice(&[p[0], p[1], p[2], a]);
    }
    image::save_buffer(path, &rgba, rgb.width, rgb.height, image::ColorType::Rgba8).unwrap();
}

#[test]
fn frames_with_alpha_are_judged_over_a_background_or_without_it() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("hud.png");
    write_rgba(&path, 128);
    // Judged, not refused: untriaged (exit 1), not a bad file (exit 2).
    let first = submit(&db, &dir, &[]);
    assert_eq!(first.code, 1, "{}", first.stderr);
    assert_eq!(frame(&first.report, "hud")["status"], "untriaged");
    triage(
        &db,
        "hud",
        frame(&first.report, "hud")["digest"].as_str().unwrap(),
        "positive",
    );
    assert_eq!(submit(&db, &dir, &[]).code, 0);
    // Only the alpha of 128 pixels changes (128 → 255): over black, their
    // colour changes by up to half its code.
    write_rgba(&path, 255);
    let exact = tmp.path().join("exact.toml");
    std::fs::write(
        &exact,
        "[[tests]]\npattern = \"*\"\nchecks = [{ max_abs_diff = 0 }]\n",
    )
    .unwrap();
    let over = submit(&db, &dir, &["--rules", exact.to_str().unwrap()]);
    assert_eq!(over.code, 1, "{}", over.report);
    let f = frame(&over.report, "hud");
    assert_eq!(f["status"], "untriaged");
    let diff = f["closest"]["figures"]["max_abs_diff"].as_f64().unwrap();
    // Each band code c was c·128/255 over black, rounded, and is c now.
    let rgb = frame8(0);
    let expected = (0..16)
        .flat_map(|x| (4..12).map(move |y| (x, y)))
        .flat_map(|(x, y)| rgb.get(x, y))
        .map(|c| c - ((u32::from(c) * 128 * 2 + 255) / 510) as u8)
        .max()
        .unwrap();
    assert_eq!(diff, f64::from(expected), "over black");
    // Over white, by other amounts: the background is the rule's.
    let white = tmp.path().join("white.toml");
    std::fs::write(
        &white,
        "[[tests]]\npattern = \"*\"\nbackground = \"#ffffff\"\nchecks = [{ max_abs_diff = 0 }]\n",
    )
    .unwrap();
    let on_white = submit(&db, &dir, &["--rules", white.to_str().unwrap()]);
    let w = frame(&on_white.report, "hud")["closest"]["figures"]["max_abs_diff"]
        .as_f64()
        .unwrap();
    assert!(w > 0.0 && w != diff, "over white: {w}, over black: {diff}");
    // Alpha ignored: the colour channels are the positive's, exactly.
    let ignore = tmp.path().join("ignore.toml");
    std::fs::write(
        &ignore,
        "[[tests]]\npattern = \"*\"\nalpha = \"ignore\"\nchecks = [{ max_abs_diff = 0 }]\n",
    )
    .unwrap();
    let ignored = submit(&db, &dir, &["--rules", ignore.to_str().unwrap()]);
    assert_eq!(ignored.code, 0, "{}", ignored.report);
    assert_eq!(frame(&ignored.report, "hud")["status"], "matched");
    // A background with alpha ignored, or one that is no colour, is a
    // rules error that names its line.
    for (text, says) in [
        (
            "[[tests]]\npattern = \"*\"\nalpha = \"ignore\"\nbackground = \"#000000\"\n",
            "line 1",
        ),
        (
            "untriaged = \"fail\"\n[[tests]]\npattern = \"*\"\nbackground = \"#12\"\n",
            "#rrggbb",
        ),
    ] {
        let bad = tmp.path().join("bad.toml");
        std::fs::write(&bad, text).unwrap();
        let refused = submit(&db, &dir, &["--rules", bad.to_str().unwrap()]);
        assert_eq!(refused.code, 2, "{text}");
        assert!(refused.stderr.contains(says), "{text}: {}", refused.stderr);
    }
}

#[test]
fn a_check_for_one_adapter_overrides_the_bound_for_all() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.png");
    write_frame_png(&path, &Frame::Rgb8(frame8(0))).unwrap();
    let first = submit(&db, &dir, &[]);
    let digest = frame(&first.report, "scene")["digest"]
        .as_str()
        .unwrap()
        .to_owned();
    triage(&db, "scene", &digest, "positive");
    // Three codes off on a few pixels.
    let mut off = frame8(0);
    for x in 0..8 {
        off.pixels[x * 3][1] += 3;
    }
    write_frame_png(&path, &Frame::Rgb8(off)).unwrap();
    let rules = tmp.path().join("rules.toml");
    std::fs::write(
        &rules,
        "[[tests]]\npattern = \"*\"\nchecks = [\n  { max_abs_diff = 1 },\n  \
         { max_abs_diff = 4, adapter = \"llvmpipe\", set_by = \"llvmpipe's FMA, 2026-12-07\" },\n]\n",
    )
    .unwrap();
    let r = rules.to_str().unwrap();
    let on_llvmpipe = submit(
        &db,
        &dir,
        &["--rules", r, "--key", "adapter=llvmpipe (LLVM 15)"],
    );
    assert_eq!(on_llvmpipe.code, 0, "{}", on_llvmpipe.report);
    assert_eq!(frame(&on_llvmpipe.report, "scene")["status"], "matched");
    for keys in [&["--key", "adapter=NVIDIA H200"][..], &[]] {
        let mut args = vec!["--rules", r];
        args.extend_from_slice(keys);
        let elsewhere = submit(&db, &dir, &args);
        assert_eq!(elsewhere.code, 1, "{keys:?}: {}", elsewhere.report);
        let detail = frame(&elsewhere.report, "scene")["detail"]
            .as_str()
            .unwrap()
            .to_owned();
        assert!(detail.contains("max abs diff <= 1 (was 3"), "{detail}");
        assert!(!detail.contains("llvmpipe"), "{keys:?}: {detail}");
    }
    // A count of differing pixels: the 8 pixels are 3 codes off.
    for (pixels, code) in [(8, 0), (7, 1)] {
        std::fs::write(
            &rules,
            format!("[[tests]]\npattern = \"*\"\nchecks = [{{ max_pixels_over = {{ lsb = 2, pixels = {pixels} }} }}]\n"),
        )
        .unwrap();
        let counted = submit(&db, &dir, &["--rules", r]);
        assert_eq!(counted.code, code, "{pixels}: {}", counted.report);
        let f = frame(&counted.report, "scene");
        assert_eq!(f["closest"]["figures"]["pixels_over_2lsb"], 8.0, "{f}");
        if code == 1 {
            let detail = f["detail"].as_str().unwrap();
            assert!(detail.contains("pixels over 2 LSB <= 7 (was 8"), "{detail}");
        }
    }
    // What is about tonegate's own renders is refused, naming the line.
    std::fs::write(
        &rules,
        "[[tests]]\npattern = \"*\"\nchecks = [{ max_abs_diff = 4, spp = 4 }]\n",
    )
    .unwrap();
    let refused = submit(&db, &dir, &["--rules", r]);
    assert_eq!(refused.code, 2);
    assert!(
        refused.stderr.contains("line 1") && refused.stderr.contains("spp"),
        "{}",
        refused.stderr
    );
}

/// A mask leaves a region (a clock, say) out of every figure: a frame that
/// differs only there matches exactly, one that differs outside it does
/// not, and the same frame without the mask is off by the clock's change.
#[test]
fn a_mask_leaves_its_region_out_of_every_figure() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("status-bar.png");
    write_frame_png(&path, &Frame::Rgb8(frame8(0))).unwrap();
    let first = submit(&db, &dir, &[]);
    let digest = frame(&first.report, "status-bar")["digest"]
        .as_str()
        .unwrap()
        .to_owned();
    triage(&db, "status-bar", &digest, "positive");
    // The clock, pixels 50..60 × 2..8, shows another time.
    let clock = |x: u32, y: u32| (50..60).contains(&x) && (2..8).contains(&y);
    let mut ticked = frame8(0);
    for (i, p) in ticked.pixels.iter_mut().enumerate() {
        if clock(i as u32 % 64, i as u32 / 64) {
            *p = [255, 255, 255];
        }
    }
    write_frame_png(&path, &Frame::Rgb8(ticked.clone())).unwrap();
    let rules = tmp.path().join("rules.toml");
    let exact = "checks = [{ max_abs_diff = 0 }]\n";
    std::fs::write(&rules, format!("[[tests]]\npattern = \"*\"\n{exact}")).unwrap();
    let r = rules.to_str().unwrap();
    let unmasked = submit(&db, &dir, &["--rules", r]);
    assert_eq!(unmasked.code, 1, "{}", unmasked.report);
    let masks = "masks = [{ x = 48, y = 0, width = 16, height = 10 }]\n";
    std::fs::write(
        &rules,
        format!("[[tests]]\npattern = \"*\"\n{masks}{exact}"),
    )
    .unwrap();
    let masked = submit(&db, &dir, &["--rules", r]);
    assert_eq!(masked.code, 0, "{}", masked.report);
    let f = frame(&masked.report, "status-bar");
    assert_eq!(f["status"], "matched");
    assert_eq!(f["closest"]["figures"]["max_abs_diff"], 0.0, "{f}");
    // A change outside the mask still counts.
    ticked.pixels[30 * 64 + 5] = [0, 0, 0];
    write_frame_png(&path, &Frame::Rgb8(ticked)).unwrap();
    let outside = submit(&db, &dir, &["--rules", r]);
    assert_eq!(outside.code, 1, "{}", outside.report);
    // A mask that covers nothing is a rules error naming its line.
    let empty = "masks = [{ x = 0, y = 0, width = 0, height = 4 }]\n";
    std::fs::write(&rules, format!("\n[[tests]]\npattern = \"*\"\n{empty}")).unwrap();
    let refused = submit(&db, &dir, &["--rules", r]);
    assert_eq!(refused.code, 2);
    assert!(
        refused.stderr.contains("line 2") && refused.stderr.contains("covers nothing"),
        "{}",
        refused.stderr
    );
}

/// A test the last submission of the same trace had and this one has not
/// is listed (by default the submission still passes), fails it under
/// `vanished = "fail"`, and another device's tests are not this one's.
#[test]
fn a_test_that_vanished_is_listed_and_can_fail_the_submission() {
    let tmp = tempfile::tempdir().unwrap();
    let (db, dir) = (tmp.path().join("h.sqlite"), tmp.path().join("frames"));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, seed) in [("menu", 0), ("map", 9)] {
        write_frame_png(&dir.join(format!("{name}.png")), &Frame::Rgb8(frame8(seed))).unwrap();
    }
    let rules = tmp.path().join("rules.toml");
    std::fs::write(&rules, "untriaged = \"warn\"\n").unwrap();
    let r = rules.to_str().unwrap();
    let first = submit(
        &db,
        &dir,
        &["--rules", r, "--key", "device=a", "--key", "commit=1"],
    );
    assert_eq!(first.code, 0, "{}", first.stderr);
    assert!(first.report.get("vanished").is_none(), "{}", first.report);
    std::fs::remove_file(dir.join("map.png")).unwrap();
    let second = submit(
        &db,
        &dir,
        &["--rules", r, "--key", "device=a", "--key", "commit=2"],
    );
    assert_eq!(second.code, 0, "{}", second.stderr);
    assert_eq!(second.report["vanished"], serde_json::json!(["map"]));
    assert_eq!(second.report["vanished_since"], first.report["submission"]);
    let shown: tonegate::frames::SubmissionReport =
        serde_json::from_value(second.report.clone()).unwrap();
    let (console, summary) = (shown.console(), shown.markdown(None));
    let since = first.report["submission"].as_i64().unwrap();
    assert!(
        console.contains(&format!("VANISHED 1 test submission {since} had: map")),
        "{console}"
    );
    assert!(
        summary.contains(&format!("Vanished since submission {since}: `map`.")),
        "{summary}"
    );
    // In the JUnit, a skipped case (it does not fail this submission).
    let junit = shown.junit().unwrap();
    let case = &junit[junit.find("name=\"map\"").expect("a case for map")..];
    assert!(
        case.contains("<skipped") && case.contains(&format!("vanished: submission {since} had it")),
        "{junit}"
    );
    // Another device's first submission lost nothing.
    let other = submit(
        &db,
        &dir,
        &["--rules", r, "--key", "device=b", "--key", "commit=2"],
    );
    assert!(other.report.get("vanished").is_none(), "{}", other.report);
    // Under `vanished = "fail"` it fails; against the last submission of
    // device a (which no longer had `map`) nothing vanished.
    std::fs::write(&rules, "untriaged = \"warn\"\nvanished = \"fail\"\n").unwrap();
    let again = submit(
        &db,
        &dir,
        &["--rules", r, "--key", "device=a", "--key", "commit=3"],
    );
    assert_eq!(again.code, 0, "{}", again.report);
    std::fs::remove_file(dir.join("menu.png")).unwrap();
    write_frame_png(&dir.join("settings.png"), &Frame::Rgb8(frame8(3))).unwrap();
    let failing = submit(
        &db,
        &dir,
        &["--rules", r, "--key", "device=a", "--key", "commit=4"],
    );
    assert_eq!(failing.code, 1, "{}", failing.report);
    assert_eq!(failing.report["vanished"], serde_json::json!(["menu"]));
    assert_eq!(failing.report["passed"], false);
    let failed: tonegate::frames::SubmissionReport =
        serde_json::from_value(failing.report.clone()).unwrap();
    let junit = failed.junit().unwrap();
    let case = &junit[junit.find("name=\"menu\"").expect("a case for menu")..];
    assert!(case.contains("<failure"), "{junit}");
}
