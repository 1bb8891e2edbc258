//! HDR output: the light, PQ and HLG signals and 16-bit code values locked to
//! colour-science (tests/display/vectors.json, regenerated in CI by
//! tests/display/make_vectors.sh from pinned versions when the lock's inputs
//! change, ci/locks.sh), and the 16-bit PNG
//! read back through the real decoders: the same code values and the cICP,
//! mDCV and cLLI chunks written. Through `tonemap` and `POST /tonemap` too.

use serde_json::Value as Json;
use tonegate::color::bt709_to_bt2020;
use tonegate::operators::DisplayLevels;
use tonegate::toning::display::code16;
use tonegate::toning::{Display, HdrOutput, OutputKind, ToneSettings, TonedImage};

fn vectors() -> Json {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/display/vectors.json");
    serde_json::from_str(&std::fs::read_to_string(path).expect("tests/display/vectors.json"))
        .unwrap()
}

fn triples(v: &Json) -> Vec<[f64; 3]> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|t| [0, 1, 2].map(|k| t[k].as_f64().unwrap()))
        .collect()
}

/// Both sides are f64 from the same inputs (ours through libm, colour's
/// through numpy): they differ by the order of operations, a few ulps. The
/// light is compared at 1e-12 relative (+1e-12 cd/m² near 0), the signal at
/// 1e-12 absolute, both thousands of ulps wide; a peak 0.1 % off moves the
/// signal by more than 1e-5.
const LIGHT_REL: f64 = 1e-12;
const SIGNAL_ABS: f64 = 1e-12;

/// The worst error over one case (as a fraction of the bound), asserting
/// each bound and that every 16-bit code value is colour-science's, except
/// where its signal·65535 lies within 1e-6 of a rounding boundary (counted).
fn lock(case: &Json, inputs: &[[f64; 3]], peak_scale: f64) -> (f64, usize) {
    let display = match case["transfer"].as_str().unwrap() {
        "PQ" => Display::Pq,
        _ => Display::Hlg,
    };
    let out = HdrOutput {
        display,
        levels: DisplayLevels {
            black: case["black_nits"].as_f64().unwrap(),
            peak: case["peak_nits"].as_f64().unwrap() * peak_scale,
        },
    };
    let name = case["name"].as_str().unwrap();
    let m = bt709_to_bt2020();
    let (light, signal) = (triples(&case["light"]), triples(&case["signal"]));
    let codes = triples(&case["codes"]);
    let mut worst = 0.0f64;
    let mut ties = 0;
    for (i, v) in inputs.iter().enumerate() {
        let nits = out.nits(&m, *v);
        let s = out.signal(nits);
        for k in 0..3 {
            let e = (nits[k] - light[i][k]).abs() / (LIGHT_REL * light[i][k].abs() + 1e-12);
            assert!(e <= 1.0, "{name} {v:?}: light {nits:?} vs {:?}", light[i]);
            let e2 = (s[k] - signal[i][k]).abs() / SIGNAL_ABS;
            assert!(e2 <= 1.0, "{name} {v:?}: signal {s:?} vs {:?}", signal[i]);
            worst = worst.max(e).max(e2);
            let scaled = signal[i][k].clamp(0.0, 1.0) * 65535.0;
            if (scaled - scaled.floor() - 0.5).abs() < 1e-6 {
                ties += 1;
                continue;
            }
            assert_eq!(code16(s[k]) as f64, codes[i][k], "{name} {v:?} channel {k}");
        }
    }
    (worst, ties)
}

#[test]
fn pq_and_hlg_output_match_colour_science() {
    let v = vectors();
    assert_eq!(v["colour_science"], "0.4.7");
    let inputs = triples(&v["inputs"]);
    assert!(inputs.len() > 100);
    let cases = v["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 6);
    for case in cases {
        let (worst, ties) = lock(case, &inputs, 1.0);
        assert!(
            ties <= 2,
            "{}: {ties} values on a rounding boundary",
            case["name"]
        );
        eprintln!(
            "{}: worst {worst:.3} of the bound, {ties} ties",
            case["name"]
        );
    }
}

/// A display peak 0.1 % off fails the lock, for PQ and for HLG.
#[test]
fn a_changed_display_fails_the_lock() {
    let v = vectors();
    let inputs = triples(&v["inputs"]);
    for i in [0, 3] {
        let case = &v["cases"][i];
        let r =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| lock(case, &inputs, 1.001)));
        assert!(r.is_err(), "{}: a 0.1 % peak change passed", case["name"]);
    }
}

fn sky() -> tonegate::image::HdrImage {
    tonegate::env::BuiltinEnv::Sky.generate(96, 48)
}

/// The file written, decoded by `image`'s PNG decoder and its chunks by
/// `png`'s, holds the code values and chunks the tone-map made.
#[test]
fn the_16_bit_png_reads_back_with_its_code_values_and_chunks() {
    let dir = tempfile::tempdir().unwrap();
    let img = sky();
    for (display, peak) in [(Display::Pq, "1000"), (Display::Hlg, "1000")] {
        let settings = ToneSettings {
            display,
            ..ToneSettings::for_operator(
                "bt2390",
                &[("source_peak", "4000"), ("target_peak", peak)],
            )
        };
        let resolved = settings.resolve().unwrap();
        let want = resolved.output_kind(OutputKind::Encoded).unwrap();
        let toned = tonegate::toning::tone_map(&img, &resolved.pipeline(), None, want).unwrap();
        let TonedImage::Hdr(codes, info) = &toned.image else {
            panic!("{display:?}: no 16-bit image");
        };
        let hdr = toned.report.hdr.expect("an HDR report");
        let path = dir.path().join(format!("{}.png", display.as_str()));
        toned.image.write(&path).unwrap();

        let back = tonegate::io::read_png16(&path).unwrap();
        assert_eq!((back.width, back.height), (96, 48));
        assert_eq!(back.pixels, codes.pixels, "{display:?}: code values");
        // Not a flat image: the sky spans many code values.
        let distinct: std::collections::BTreeSet<u16> = back.pixels.iter().map(|p| p[1]).collect();
        assert!(distinct.len() > 100, "{}", distinct.len());

        let bytes = std::fs::read(&path).unwrap();
        let found = tonegate::io::read_hdr_png_info(&bytes, "out").unwrap();
        let (cicp, mastering, light) = (found.cicp, found.mastering, found.light_level);
        assert_eq!(cicp, Some(info.cicp));
        match display {
            Display::Pq => {
                assert_eq!(cicp.unwrap().transfer, 16);
                let m = mastering.expect("mDCV");
                assert!((m.max_nits - 1000.0).abs() < 1e-4 && m.min_nits == 0.0);
                assert!((m.primaries[0][0] - 0.64).abs() < 2e-5, "{m:?}");
                assert!((m.white[1] - 0.329).abs() < 2e-5, "{m:?}");
                let l = light.expect("cLLI");
                assert!((l.max_cll - hdr.max_cll).abs() <= 1e-4, "{l:?} {hdr:?}");
                assert!((l.max_fall - hdr.max_fall).abs() <= 1e-4, "{l:?} {hdr:?}");
                // The sun clips at the source peak and the EETF takes it to
                // the target's.
                assert!((hdr.max_cll - 1000.0).abs() < 1e-6, "{hdr:?}");
                assert!(hdr.max_fall > 10.0 && hdr.max_fall < hdr.max_cll);
            }
            _ => {
                assert_eq!(cicp.unwrap().transfer, 18);
                assert_eq!((mastering, light), (None, None));
            }
        }
        assert_eq!(cicp.unwrap().primaries, 9);
    }
}

#[test]
fn a_display_the_operator_cannot_feed_is_refused_with_the_reason() {
    let refuse = |display, op: &str, params: &[(&str, &str)], want: &str| {
        let s = ToneSettings {
            display,
            ..ToneSettings::for_operator(op, params)
        };
        let e = s.resolve().unwrap_err().to_string();
        assert!(e.contains(want), "{e} (wanted {want:?})");
    };
    refuse(
        Display::Hlg,
        "agx",
        &[],
        "operator agx's output is relative to an SDR display's white",
    );
    refuse(Display::Pq, "reinhard-global", &[], "bt2390");
    refuse(
        Display::Hlg,
        "bt2390",
        &[("target_black", "0.1")],
        "HLG output is for a display black of 0",
    );
    let s = ToneSettings {
        display: Display::Pq,
        gamma: Some(2.2),
        ..ToneSettings::for_operator("bt2390", &[])
    };
    assert!(s
        .resolve()
        .unwrap_err()
        .to_string()
        .contains("gamma: applies to SDR output only"));
    // PQ into an HDR file format is refused too: only a PNG holds it.
    let s = ToneSettings {
        display: Display::Pq,
        ..ToneSettings::for_operator("bt2390", &[])
    };
    let e = s
        .resolve()
        .unwrap()
        .output_kind(OutputKind::Linear)
        .unwrap_err();
    assert!(e.to_string().contains("name the output .png"), "{e}");
    // SDR output of bt2390 stays what it was.
    let s = ToneSettings::for_operator("bt2390", &[]);
    assert_eq!(
        s.resolve()
            .unwrap()
            .output_kind(OutputKind::Encoded)
            .unwrap(),
        OutputKind::Encoded
    );
}

/// `POST /tonemap?display=pq` answers the 16-bit PNG with its chunks (the
/// same bytes as the library's, on the CPU), and an HLG output of an SDR
/// operator is a 400 with the reason.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_api_writes_pq_and_refuses_what_has_no_meaning() {
    use crate::common;
    use reqwest::StatusCode;
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = common::server::start(&seeded, |_| {}).await;
    let hdr = common::hdr_bytes(dir.path(), 96, 64);

    // GET /operators says which operators can feed PQ or HLG.
    let (status, ops) = s.json("/api/v1/operators").await;
    assert_eq!(status, StatusCode::OK);
    let ops = ops.as_array().unwrap();
    assert_eq!(ops.len(), tonegate::operators::all().len());
    for o in ops {
        let name = o["name"].as_str().unwrap();
        assert_eq!(o["hdr_output"], name == "bt2390", "{name}");
        assert!(
            o["params"].as_array().is_some_and(|p| !p.is_empty()),
            "{name}"
        );
    }

    let r = s
        .tonemap(
            "gpu=false&operator=bt2390&display=pq&target_peak=1000",
            hdr.clone(),
        )
        .await;
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(r.headers()["content-type"], "image/png");
    assert_eq!(r.headers()["x-tonegate-display"], "pq");
    let max_cll: f64 = r.headers()["x-tonegate-max-cll"]
        .to_str()
        .unwrap()
        .parse()
        .unwrap();
    assert!(max_cll > 0.0 && max_cll <= 1000.0, "{max_cll}");
    let png = r.bytes().await.unwrap();
    let found = tonegate::io::read_hdr_png_info(&png, "answer").unwrap();
    let (cicp, mastering) = (found.cicp, found.mastering);
    assert_eq!(cicp, Some(tonegate::io::Cicp::BT2100_PQ));
    assert!((mastering.unwrap().max_nits - 1000.0).abs() < 1e-4);
    let settings = ToneSettings {
        display: Display::Pq,
        ..ToneSettings::for_operator("bt2390", &[("target_peak", "1000")])
    };
    let (img, _) = tonegate::io::decode_hdr(&hdr, "x", &Default::default()).unwrap();
    let resolved = settings.resolve().unwrap();
    let want = resolved.output_kind(OutputKind::Encoded).unwrap();
    let toned = tonegate::toning::tone_map(&img, &resolved.pipeline(), None, want).unwrap();
    let TonedImage::Hdr(codes, info) = &toned.image else {
        panic!("no 16-bit image");
    };
    assert_eq!(
        png.to_vec(),
        tonegate::io::encode_hdr_png(codes, info).unwrap(),
        "the API's CPU path is the library's"
    );

    let r = s
        .tonemap("gpu=false&operator=agx&display=hlg", hdr.clone())
        .await;
    assert_eq!(r.status(), StatusCode::BAD_REQUEST);
    let body = r.text().await.unwrap();
    assert!(body.contains("relative to an SDR display"), "{body}");
    let r = s
        .tonemap("gpu=false&operator=bt2390&display=hdr10", hdr)
        .await;
    assert_eq!(r.status(), StatusCode::BAD_REQUEST);
    let body = r.text().await.unwrap();
    assert!(body.contains("display"), "{body}");
}

/// A scene's PQ frames (docs/display.md#pq-frames) are encoded by the same
/// arithmetic as the PQ output file: on the lock's colours and displays,
/// `PqEncoder` gives colour-science's code values.
#[test]
fn pq_frames_encode_to_the_locked_pq_codes() {
    use tonegate::reference::encode::PqEncoder;
    let v = vectors();
    let inputs = triples(&v["inputs"]);
    let mut checked = 0;
    for case in v["cases"].as_array().unwrap() {
        if case["transfer"] != "PQ" {
            continue;
        }
        let pq = PqEncoder::new(DisplayLevels {
            black: case["black_nits"].as_f64().unwrap(),
            peak: case["peak_nits"].as_f64().unwrap(),
        });
        let (signal, codes) = (triples(&case["signal"]), triples(&case["codes"]));
        for (i, c) in inputs.iter().enumerate() {
            let got = pq.pixel(*c);
            for k in 0..3 {
                // A value on a rounding boundary may round either way.
                let scaled = signal[i][k].clamp(0.0, 1.0) * 65535.0;
                if (scaled - scaled.floor() - 0.5).abs() < 1e-6 {
                    continue;
                }
                assert_eq!(
                    f64::from(got[k]),
                    codes[i][k],
                    "{} {c:?} channel {k}",
                    case["name"]
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 1000, "{checked}");
}

/// A PQ frame's PNG holds its codes and says BT.2100 PQ; a 16-bit PNG that
/// does not say so is not taken for a PQ frame.
#[test]
fn a_pq_frame_png_reads_back_and_a_16_bit_png_of_no_pq_is_refused() {
    use tonegate::image::{Frame, Rgb16Image};
    let dir = tempfile::tempdir().unwrap();
    let img = Rgb16Image::from_fn(37, 5, |x, y| {
        [x as u16 * 1700, y as u16 * 13_000 + 7, 65535 - x as u16]
    });
    let path = dir.path().join("000.png");
    tonegate::io::write_frame_png(&path, &Frame::Pq16(img.clone())).unwrap();
    assert_eq!(
        tonegate::io::read_frame_png(&path).unwrap(),
        Frame::Pq16(img.clone())
    );
    let bytes = std::fs::read(&path).unwrap();
    let chunks = tonegate::io::read_hdr_png_info(&bytes, "000.png").unwrap();
    assert_eq!(chunks.cicp, Some(tonegate::io::Cicp::BT2100_PQ));
    // The same codes as a plain 16-bit PNG: refused, saying why.
    let plain = dir.path().join("plain.png");
    tonegate::io::write_png16(&plain, &img).unwrap();
    let e = tonegate::io::read_frame_png(&plain)
        .unwrap_err()
        .to_string();
    assert!(e.contains("plain.png") && e.contains("PQ"), "{e}");
    // An 8-bit frame reads back as one.
    let eight = tonegate::image::Rgb8Image::filled(3, 2, [1, 2, 3]);
    tonegate::io::write_frame_png(&plain, &Frame::Rgb8(eight.clone())).unwrap();
    assert_eq!(
        tonegate::io::read_frame_png(&plain).unwrap(),
        Frame::Rgb8(eight)
    );
}
