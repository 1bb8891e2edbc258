//! `tonemap` on the CPU reference, as a whole process: an HDR output is the
//! display image with no 8-bit encode run, and a PNG output is exactly the
//! `pow`-based encode of that display image (the encoder's steps replace a
//! `pow` per sample and must not change one byte).

mod common;

use std::path::Path;
use tonegate::env::BuiltinEnv;
use tonegate::io::{load_hdr, read_png8, write_image_hdr, LoadOptions};
use tonegate::reference::encode::encode_channel;
use tonegate::scene::Encoding;

/// Runs `tonegate tonemap` with a plan that has every flat stage (bloom,
/// grade with contrast) and returns its JSON report.
fn tonemap(input: &Path, output: &Path, extra: &[&str]) -> serde_json::Value {
    let (input, output) = (input.to_str().unwrap(), output.to_str().unwrap());
    let mut args = vec!["tonemap", input, "-o", output];
    args.extend(["--bloom", "0.4", "--contrast", "1.2", "--json"]);
    args.extend_from_slice(extra);
    let out = common::tonegate(&args);
    assert!(
        out.status.success(),
        "tonegate failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("a JSON report")
}

fn plan(report: &serde_json::Value) -> Vec<String> {
    report["plan"]
        .as_array()
        .expect("the report has a plan")
        .iter()
        .map(|s| s.as_str().unwrap().to_string())
        .collect()
}

#[test]
fn an_hdr_output_skips_the_encode_and_a_png_is_the_exact_encode() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("night.pfm");
    write_image_hdr(&input, &BuiltinEnv::Night.generate(256, 128)).unwrap();

    for (gamma, encoding) in [
        (None, Encoding::Srgb),
        (
            Some("2.2"),
            Encoding::Gamma(2.2.try_into().expect("a positive γ")),
        ),
    ] {
        let extra: Vec<&str> = gamma.map(|g| vec!["--gamma", g]).unwrap_or_default();
        let hdr_path = dir.path().join("out.pfm");
        let hdr_report = tonemap(&input, &hdr_path, &extra);
        let hdr_plan = plan(&hdr_report);
        assert!(
            !hdr_plan.iter().any(|s| s == "encode"),
            "an HDR output ran {hdr_plan:?}"
        );
        for stage in ["tonemap", "bloom_composite", "grade"] {
            assert!(hdr_plan.iter().any(|s| s == stage), "{hdr_plan:?}");
        }

        let png_path = dir.path().join("out.png");
        let png_plan = plan(&tonemap(&input, &png_path, &extra));
        assert_eq!(png_plan.last().map(String::as_str), Some("encode"));
        assert_eq!(&png_plan[..png_plan.len() - 1], &hdr_plan[..]);

        // The PNG is the display image encoded with the pow-based formula.
        // The PFM holds that image rounded to f32 (relative error at most
        // 2^-24, plus 2^-150 for subnormals), so the code the process
        // computed from the f64 value lies between the codes of the f32
        // value's rounding interval ends, which the encode's monotonicity
        // guarantees; almost always those are one code.
        let (display, _) = load_hdr(&hdr_path, &LoadOptions::default()).unwrap();
        let frame = read_png8(&png_path).unwrap();
        assert_eq!((frame.width, frame.height), (display.width, display.height));
        for (p, q) in display.pixels.iter().zip(&frame.pixels) {
            for c in 0..3 {
                let v = f64::from(p[c]);
                let slack = v.abs() * 2f64.powi(-24) + 2f64.powi(-150);
                let lo = encode_channel(v - slack, encoding);
                let hi = encode_channel(v + slack, encoding);
                assert!(
                    (lo..=hi).contains(&q[c]),
                    "{encoding:?}: {v:e} encoded as {} not in {lo}..={hi}",
                    q[c]
                );
            }
        }
    }
}
