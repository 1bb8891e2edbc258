//! `tonemap` on the CPU reference, as a whole process: an HDR output is the
//! display image with no 8-bit encode run, and a PNG output is exactly the
//! `pow`-based encode of that display image (the encoder's steps replace a
//! `pow` per sample and must not change one byte).

use crate::common;

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
        // Bloom and grade read whole frames: the staged reference.
        assert_eq!(hdr_report["path"], "staged");
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

/// A plan of statistics and `tonemap` alone goes from the input to the
/// file a pixel at a time (a band of rows at once for a PFM, an image of
/// the results for other formats, the 8-bit frame for a PNG), with none of
/// the staged path's full-frame f64 images: the files must hold exactly
/// the staged path's display image (or frame), for every operator and
/// colour path, on an input with black, subnormal, huge and
/// clamped-negative pixels and an odd size.
#[test]
fn a_pixelwise_plan_writes_exactly_what_the_staged_path_computes() {
    use tonegate::toning::{Preset, ToneSettings};
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.pfm");
    let mut img = BuiltinEnv::Night.generate(257, 129);
    img.pixels[0] = [0.0; 3];
    img.pixels[1] = [1e-40, 2e-41, 0.0];
    img.pixels[2] = [3e30, 1e30, 2e30];
    img.pixels[3] = [-1.0, 0.5, 0.25];
    img.pixels[500] = [0.0, 0.0, 1e-3];
    write_image_hdr(&input, &img).unwrap();
    let (loaded, _) = load_hdr(&input, &LoadOptions::default()).unwrap();
    let cases: Vec<(Vec<&str>, ToneSettings)> = vec![
        (vec![], ToneSettings::default()),
        (
            vec!["--preset", "reinhard02"],
            ToneSettings {
                preset: Some(Preset::Reinhard02),
                ..Default::default()
            },
        ),
        (
            vec![
                "--operator",
                "reinhard-auto-key",
                "--key",
                "auto",
                "--colour",
                "xyy",
            ],
            ToneSettings::for_operator("reinhard-auto-key", &[("key", "auto"), ("colour", "xyy")]),
        ),
        // The operator's first name is still taken.
        (
            vec!["--operator", "seed001", "--key", "auto", "--colour", "xyy"],
            ToneSettings::for_operator("reinhard-auto-key", &[("key", "auto"), ("colour", "xyy")]),
        ),
        (
            vec!["--key", "0.3", "--log-average", "0.5"],
            ToneSettings::for_operator(
                "reinhard-global",
                &[("key", "0.3"), ("log_average", "0.5")],
            ),
        ),
    ];
    for (args, settings) in cases {
        let resolved = settings.resolve().unwrap();
        let pipeline = resolved.pipeline();
        let (staged_plan, staged) = tonegate::reference::render_flat(&loaded, &pipeline).unwrap();
        let want = staged.display.to_hdr();
        for ext in ["pfm", "exr", "png"] {
            let out = dir.path().join(format!("out.{ext}"));
            let mut all = vec![
                "tonemap",
                input.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ];
            all.extend(&args);
            all.push("--json");
            let run = common::tonegate(&all);
            assert!(
                run.status.success(),
                "{args:?}: {}",
                String::from_utf8_lossy(&run.stderr)
            );
            let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
            assert_eq!(report["path"], "pixelwise", "{args:?} .{ext}");
            assert_eq!(report["adapter"], "cpu-reference", "{args:?} .{ext}");
            if ext == "png" {
                // The 8-bit frame: encode's bytes, and its plan.
                assert_eq!(plan(&report), staged_plan.names(), "{args:?}");
                let got = read_png8(&out).unwrap();
                assert!(
                    staged.frame.as_rgb8() == Some(&got),
                    "{args:?} .png: not the staged frame"
                );
                continue;
            }
            let names: Vec<&str> = staged_plan
                .names()
                .into_iter()
                .filter(|s| *s != "encode")
                .collect();
            assert_eq!(plan(&report), names, "{args:?}");
            let (got, _) = load_hdr(&out, &LoadOptions::default()).unwrap();
            assert_eq!((got.width, got.height), (want.width, want.height));
            let bits = |i: &tonegate::image::HdrImage| -> Vec<u32> {
                i.pixels.iter().flatten().map(|v| v.to_bits()).collect()
            };
            assert!(
                bits(&got) == bits(&want),
                "{args:?} .{ext}: not the staged display image"
            );
            // The report's figure, to 1e-15: serde_json's default parser
            // may land one ulp (2.2e-16 relative) off the printed value.
            let reported = report["tone"]["log_average"].as_f64().unwrap();
            let want_la = staged.tone.get("log_average").unwrap();
            assert!(
                (reported - want_la).abs() <= 1e-15 * want_la.abs(),
                "{args:?}: log-average {reported} vs {want_la}"
            );
        }
    }
}

/// `tonegate operators` lists every operator with its flags, and says which
/// can feed a PQ or HLG display; `--json` is what `GET /operators` answers.
#[test]
fn operators_lists_every_operator_and_which_feed_hdr_displays() {
    let o = common::tonegate(&["operators"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    for op in tonegate::operators::builtin() {
        let line = text
            .lines()
            .find(|l| {
                l.starts_with(&format!("{}:", op.name()))
                    || l.starts_with(&format!("{} (", op.name()))
            })
            .unwrap_or_else(|| panic!("no line for {}:\n{text}", op.name()));
        assert_eq!(
            line.contains("--display pq|hlg"),
            op.name() == "bt2390",
            "{line}"
        );
    }
    assert!(text.contains("  --knee-offset"), "{text}");
    let o = common::tonegate(&["operators", "--json"]);
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let bt = v
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["name"] == "bt2390")
        .unwrap();
    assert_eq!(bt["hdr_output"], true);
}

/// On the GPU too, a linear or HDR output stops at the display image: no
/// `encode` in the plan, and the file holds the display image (bloom,
/// tone curve and grade applied), within the GPU-against-f64 bound of the
/// CPU's file, not the input.
#[test]
fn a_gpu_hdr_output_skips_the_encode_and_keeps_the_display_image() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("sky.pfm");
    write_image_hdr(&input, &BuiltinEnv::Sky.generate(128, 64)).unwrap();
    let cpu_path = dir.path().join("cpu.pfm");
    let gpu_path = dir.path().join("gpu.pfm");
    tonemap(&input, &cpu_path, &[]);
    let report = tonemap(&input, &gpu_path, &["--gpu"]);
    assert_ne!(report["adapter"], "cpu-reference", "{report}");
    let gpu_plan = plan(&report);
    assert!(!gpu_plan.iter().any(|s| s == "encode"), "{gpu_plan:?}");
    assert!(gpu_plan.iter().any(|s| s == "grade"), "{gpu_plan:?}");
    let (cpu, _) = load_hdr(&cpu_path, &LoadOptions::default()).unwrap();
    let (gpu, _) = load_hdr(&gpu_path, &LoadOptions::default()).unwrap();
    let (src, _) = load_hdr(&input, &LoadOptions::default()).unwrap();
    let mut worst = 0.0f64;
    for (g, c) in gpu.pixels.iter().zip(&cpu.pixels) {
        for k in 0..3 {
            let (g, c) = (g[k] as f64, c[k] as f64);
            // The `tonemap` stage's bound (docs/tolerances.md); it holds
            // through the bloom and grade too (0.10 of it on lavapipe,
            // 2026-11-26).
            worst = worst.max((g - c).abs() / (1e-4 * c.abs() + 1e-6));
        }
    }
    eprintln!("GPU display image: worst {worst:.3} of the bound");
    assert!(
        worst <= 1.0,
        "GPU display image off the CPU's by {worst:.2}x"
    );
    assert!(gpu.pixels != src.pixels, "the GPU's file is its input");
}
