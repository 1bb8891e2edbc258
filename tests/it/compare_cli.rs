//! `tonegate compare` names its images as FLIP's tool does (`-r REFERENCE
//! -t TEST`) or by position, test first; HDR-FLIP takes its exposures from
//! the reference, so the two orders give different results and the report
//! says which file was which.

use crate::common;
use tonegate::env::BuiltinEnv;
use tonegate::io::write_image_hdr;

fn compare(args: &[&str]) -> std::process::Output {
    let mut all = vec!["compare"];
    all.extend_from_slice(args);
    common::tonegate(&all)
}

fn json(args: &[&str]) -> serde_json::Value {
    let mut all = args.to_vec();
    all.push("--json");
    let out = compare(&all);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("a JSON report")
}

#[test]
fn the_reference_and_the_test_are_named_by_flag_or_by_position() {
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference.pfm");
    let test = dir.path().join("test.pfm");
    let img = BuiltinEnv::Sky.generate(96, 48);
    // Four times brighter: HDR-FLIP's exposure range (from the reference's
    // maximum and median) moves by two stops with the order.
    let brighter = img.par_map(|p| p.map(|c| 4.0 * c));
    write_image_hdr(&reference, &img).unwrap();
    write_image_hdr(&test, &brighter).unwrap();
    let (r, t) = (reference.to_str().unwrap(), test.to_str().unwrap());

    let flags = json(&["-r", r, "-t", t]);
    assert_eq!(flags["reference"], r);
    assert_eq!(flags["test"], t);
    for other in [
        json(&["--test", t, "--reference", r]),
        json(&[t, r]),
        json(&["-r", r, t]),
        json(&["-t", t, r]),
    ] {
        assert_eq!(other, flags, "the same pair named another way");
    }
    let swapped = json(&["-r", t, "-t", r]);
    assert_eq!(swapped["reference"], t);
    let start = |v: &serde_json::Value| v["hdr_flip_exposures"]["start"].as_f64().unwrap();
    assert!(
        (start(&swapped) - start(&flags) + 2.0).abs() < 1e-6,
        "exposures start at {} and {} stops",
        start(&flags),
        start(&swapped)
    );

    // One image too few or too many is refused, naming what to give.
    let out = compare(&["-r", r]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("-t TEST -r REFERENCE"));
    let out = compare(&["-r", r, "-t", t, t]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("one image too many"));
}

/// `--ppd` moves every figure that says FLIP: the metrics' `flip_mean`, the
/// FLIP statistics and the definition the report states, not only the map.
#[test]
fn ppd_moves_every_flip_figure_of_a_frame_comparison() {
    let (t, r) = (
        "golden/sky-reinhard-global/001.png",
        "golden/sky-reinhard-global/000.png",
    );
    let default = json(&[t, r]);
    let near = json(&[t, r, "--ppd", "30"]);
    for v in [&default, &near] {
        assert_eq!(v["flip_mean"], v["flip"]["mean"], "{v}");
    }
    // The default distance is 67.0206 ppd (the docs round it to 67.02).
    let ppd = |v: &serde_json::Value| v["flip"]["ppd"].as_f64().unwrap();
    assert!((ppd(&default) - 67.02).abs() < 0.01, "{}", ppd(&default));
    assert_eq!(ppd(&near), 30.0);
    assert_ne!(default["flip_mean"], near["flip_mean"]);
    let definition = |v: &serde_json::Value| v["flip_definition"].as_str().unwrap().to_owned();
    assert!(definition(&default).contains("at 67.02 pixels per degree"));
    assert!(
        definition(&near).contains("at 30 pixels per degree")
            && !definition(&near).contains("67.02"),
        "{}",
        definition(&near)
    );
    // The console's metrics line follows too.
    let out = compare(&[t, r, "--ppd", "30"]);
    let text = String::from_utf8_lossy(&out.stdout);
    let first = text.lines().next().unwrap();
    let mean = near["flip_mean"].as_f64().unwrap();
    assert!(
        first.ends_with(&format!("FLIP {mean:.5}")),
        "{first} vs {mean}"
    );
}

/// HDR options given for two frame PNGs are named as ignored, and the
/// figures are the plain comparison's.
#[test]
fn hdr_options_on_frames_are_named_as_ignored() {
    let frame = "golden/grid-static/000.png";
    let plain = compare(&[frame, frame]);
    assert!(plain.status.success());
    assert!(!String::from_utf8_lossy(&plain.stderr).contains("ignored"));
    let o = compare(&[frame, frame, "--peak", "400", "--tone-mapper", "hable"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("--peak, --tone-mapper ignored"), "{e}");
    assert_eq!(o.stdout, plain.stdout);
}
