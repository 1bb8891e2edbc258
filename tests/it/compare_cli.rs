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

/// A CRC-32 (ISO-HDLC, PNG's), so an edited chunk is one a decoder accepts.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// `png` with a chunk inserted right after IHDR.
fn with_chunk(png: &[u8], kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
    let after_ihdr = 8 + 8 + 13 + 4;
    let mut chunk = (data.len() as u32).to_be_bytes().to_vec();
    let mut body = kind.to_vec();
    body.extend_from_slice(data);
    chunk.extend_from_slice(&body);
    chunk.extend_from_slice(&crc32(&body).to_be_bytes());
    let mut out = png[..after_ihdr].to_vec();
    out.extend_from_slice(&chunk);
    out.extend_from_slice(&png[after_ihdr..]);
    out
}

/// A 16-bit PQ frame whose cICP lies (a second cICP saying HLG, the
/// narrow-range flag, values that are no cICP) is refused with what it
/// says, in words, not read as full-range PQ.
#[test]
fn a_frame_whose_cicp_lies_is_refused_with_what_it_says() {
    let dir = tempfile::tempdir().unwrap();
    let img = tonegate::image::Rgb16Image::from_fn(16, 12, |x, y| {
        [x as u16 * 4000, y as u16 * 5000, 30000]
    });
    let good = tonegate::io::encode_frame_png(&tonegate::image::Frame::Pq16(img)).unwrap();
    let path = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p.to_string_lossy().into_owned()
    };
    let reference = path("good.png", &good);
    let o = compare(&[&reference, &reference]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The file written with PQ's cICP, and a second one put before it.
    let cases: [(&str, Vec<u8>, &str); 3] = [
        (
            "hlg.png",
            with_chunk(&good, b"cICP", &[9, 18, 0, 1]),
            "two cICP chunks",
        ),
        (
            "narrow.png",
            {
                // The writer's own cICP made narrow: its flag is the chunk's last byte.
                let at = good.windows(4).position(|w| w == b"cICP").unwrap();
                let mut b = good.clone();
                b[at + 7] = 0;
                let crc = crc32(&b[at..at + 8]);
                b[at + 8..at + 12].copy_from_slice(&crc.to_be_bytes());
                b
            },
            "narrow (video) range",
        ),
        (
            "short.png",
            with_chunk(&good, b"cICP", &[9, 16]),
            "has 2 bytes",
        ),
    ];
    for (name, bytes, said) in cases {
        let test = path(name, &bytes);
        let o = compare(&[&test, &reference]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {e}");
        assert!(e.contains(said) && e.contains(name), "{name}: {e}");
        assert!(!e.contains("Some(") && !e.contains("Cicp {"), "{name}: {e}");
    }
}
