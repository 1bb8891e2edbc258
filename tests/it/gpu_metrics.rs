//! The metrics computed on the GPU against the CPU's, on real frames (the
//! goldens of consecutive frames of built-in scenes, which differ by the
//! sphere's rotation) and on synthetic pairs at odd sizes, on lavapipe,
//! SwiftShader and llvmpipe through GL. The bounds are the gate's
//! requirement for moving a metric to the GPU: the figures from integer
//! sums (MSE, RMSE, PSNR, SNR, the differences, the fraction over a code)
//! bit for bit, SSIM's mean within 1e-6 (f32 window sums against the CPU's
//! f64), FLIP's within 1e-4 of nv-flip's (a few hundred f32 operations a
//! pixel, with the adapter's exp, pow and sqrt, in another order than the
//! C++'s). The measured worst is written next to each set of tests.

use tonegate::gpu::compare::GpuCompare;
use tonegate::gpu::flip::GpuFlip;
use tonegate::gpu::{AdapterChoice, GpuContext};
use tonegate::image::{Frame, Rgb8Image};
use tonegate::metrics::flip::{flip, DEFAULT_PPD};

/// The adapter `choice` names (as `--adapter` takes it); ci/deps.sh
/// installs all three the tests name.
fn ctx(choice: &str) -> GpuContext {
    let choice: AdapterChoice = choice.parse().expect("an adapter choice");
    GpuContext::new(&choice).unwrap_or_else(|e| panic!("{choice:?}: {e}"))
}

fn golden(scene: &str, n: u32) -> Rgb8Image {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("golden");
    match tonegate::golden::read_frame(&root, scene, n).expect("the golden reads") {
        Frame::Rgb8(img) => img,
        Frame::Pq16(_) => panic!("{scene} is an 8-bit scene"),
    }
}

/// A pair of noisy images with shared structure, `width`×`height`.
fn noise_pair(width: u32, height: u32, seed: u32) -> (Rgb8Image, Rgb8Image) {
    let px = |x: u32, y: u32, c: u32, s: u32| {
        let h = (x.wrapping_mul(73_856_093)
            ^ y.wrapping_mul(19_349_663)
            ^ (c + s).wrapping_mul(83_492_791))
        .wrapping_mul(2_654_435_761)
            >> 27;
        ((x * 3 + y * 2 + c * 60 + h) % 256) as u8
    };
    let img = |s: u32| Rgb8Image {
        width,
        height,
        pixels: (0..width * height)
            .map(|i| {
                let (x, y) = (i % width, i / width);
                [px(x, y, 0, s), px(x, y, 1, s), px(x, y, 2, s)]
            })
            .collect(),
    };
    (img(seed), img(seed + 1))
}

fn compare(g: &GpuFlip, test: &Rgb8Image, reference: &Rgb8Image) -> (f64, f64, f32) {
    let cpu = flip(test.raster(), reference.raster(), DEFAULT_PPD).expect("nv-flip");
    let gpu = g
        .flip(test.raster(), reference.raster(), DEFAULT_PPD)
        .expect("FLIP on the GPU");
    assert_eq!(gpu.map.pixels.len(), cpu.map.pixels.len());
    let worst = cpu
        .map
        .pixels
        .iter()
        .zip(&gpu.map.pixels)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    (cpu.mean(), gpu.mean(), worst)
}

/// Every pair within 1e-4 of nv-flip's mean on the adapter `choice` names,
/// and identical images at exactly 0 on both.
fn flip_lock(choice: &str) {
    let ctx = ctx(choice);
    let g = GpuFlip::new(&ctx);
    let mut pairs: Vec<(String, Rgb8Image, Rgb8Image)> = Vec::new();
    for scene in [
        "sky-reinhard-global",
        "interior-agx-punchy",
        "night-auto-key-bloom",
        "grid-hable-grade",
    ] {
        pairs.push((
            format!("{scene} 1 vs 0"),
            golden(scene, 1),
            golden(scene, 0),
        ));
    }
    for (w, h, seed) in [(97, 61, 1), (5, 300, 7), (256, 3, 11)] {
        let (a, b) = noise_pair(w, h, seed);
        pairs.push((format!("noise {w}x{h}"), a, b));
    }
    let mut worst_mean = 0.0f64;
    for (name, test, reference) in &pairs {
        let (cpu, gpu, worst_pixel) = compare(&g, test, reference);
        eprintln!(
            "{name}: nv-flip {cpu:.7}, GPU {gpu:.7}, |diff| {:.2e}, worst pixel {worst_pixel:.2e}",
            (cpu - gpu).abs()
        );
        assert!(cpu > 1e-3, "{name}: the pair differs ({cpu})");
        assert!(
            (cpu - gpu).abs() <= 1e-4,
            "{name} on {}: nv-flip {cpu} against GPU {gpu}",
            ctx.adapter.name
        );
        worst_mean = worst_mean.max((cpu - gpu).abs());
    }
    eprintln!(
        "worst |mean difference| {worst_mean:.2e} on {} ({})",
        ctx.adapter.name, ctx.adapter.backend
    );
    // Identical images: no error at all, on both.
    let (a, _) = noise_pair(64, 48, 3);
    let (cpu, gpu, worst) = compare(&g, &a, &a);
    assert_eq!((cpu, gpu, worst), (0.0, 0.0, 0.0));
}

// Measured worst |mean difference| on 2026-11-27: 8.5e-7 on lavapipe
// (LLVM 15.0.6).
#[test]
fn flip_on_the_gpu_is_nv_flips_on_lavapipe() {
    flip_lock("default");
}

#[test]
fn flip_on_the_gpu_is_nv_flips_on_swiftshader() {
    flip_lock("swiftshader");
}

#[test]
fn flip_on_the_gpu_is_nv_flips_on_gl() {
    flip_lock("gl:llvmpipe");
}

/// Each pixel of the SSIM map on the GPU against the CPU's: S is a ratio of
/// window moments summed in f32 (121 weighted terms, each ≤ 255², about a
/// relative 1e-6 after the sums), where the CPU's are f64; 1e-5 is ten
/// times that. A border pixel that did not mirror its window as the CPU
/// does is off by far more (the mean, over the cropped interior only,
/// would not see it).
const SSIM_MAP_BOUND: f64 = 1e-5;

/// Every figure of each pair on the GPU against the CPU's on the adapter
/// `choice` names: the integer-based ones equal, SSIM's mean within 1e-6,
/// FLIP's within 1e-4; and the maps of a kept frame.
fn compare_lock(choice: &str) {
    let ctx = ctx(choice);
    let g = GpuCompare::new(&ctx);
    let mut pairs: Vec<(String, Rgb8Image, Rgb8Image)> = Vec::new();
    for scene in ["sky-aces2", "interior-reinhard-global-xyy", "grid-static"] {
        pairs.push((
            format!("{scene} 1 vs 0"),
            golden(scene, 1),
            golden(scene, 0),
        ));
    }
    for (w, h, seed) in [(97, 61, 1), (11, 11, 5), (300, 13, 9)] {
        let (a, b) = noise_pair(w, h, seed);
        pairs.push((format!("noise {w}x{h}"), a, b));
    }
    let (a, _) = noise_pair(40, 30, 2);
    pairs.push(("identical".into(), a.clone(), a));
    let mut worst_ssim = 0.0f64;
    let mut worst_map = 0.0f64;
    for (name, test, reference) in &pairs {
        let (cpu, _) = tonegate::metrics::compare_with_flip(test.raster(), reference.raster())
            .expect("the CPU's figures");
        let (gpu, flip) = g
            .compare(test.raster(), reference.raster())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(
            flip.map.pixels.len(),
            test.pixels.len(),
            "{name}: the map comes back whole"
        );
        for (what, a, b) in [
            ("mse", cpu.mse, gpu.mse),
            ("rmse", cpu.rmse, gpu.rmse),
            ("psnr", cpu.psnr, gpu.psnr),
            ("snr", cpu.snr, gpu.snr),
            ("mean_abs_diff", cpu.mean_abs_diff, gpu.mean_abs_diff),
            (
                "fraction_over_1lsb",
                cpu.fraction_over_1lsb,
                gpu.fraction_over_1lsb,
            ),
        ] {
            assert_eq!(a.to_bits(), b.to_bits(), "{name}: {what} {a} against {b}");
        }
        assert_eq!(cpu.max_abs_diff, gpu.max_abs_diff, "{name}");
        let ds = (cpu.ssim - gpu.ssim).abs();
        assert!(
            ds <= 1e-6,
            "{name} on {}: SSIM {} against {}",
            ctx.adapter.name,
            cpu.ssim,
            gpu.ssim
        );
        assert!(
            (cpu.flip_mean - gpu.flip_mean).abs() <= 1e-4,
            "{name}: FLIP"
        );
        worst_ssim = worst_ssim.max(ds);
        // The maps of a kept frame: SSIM's at every pixel against the CPU's
        // (borders mirrored), FLIP's the figures' own.
        let (ssim, map_flip) = g
            .maps(test.raster(), reference.raster())
            .unwrap_or_else(|e| panic!("{name}: maps: {e}"));
        let cpu_ssim = tonegate::metrics::ssim(test.raster(), reference.raster()).expect("SSIM");
        assert_eq!(ssim.mean.to_bits(), gpu.ssim.to_bits(), "{name}");
        assert_eq!(map_flip.map.pixels, flip.map.pixels, "{name}: FLIP map");
        assert_eq!(ssim.map.pixels.len(), cpu_ssim.map.pixels.len(), "{name}");
        let pixel = ssim
            .map
            .pixels
            .iter()
            .zip(&cpu_ssim.map.pixels)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f64, f64::max);
        assert!(
            pixel <= SSIM_MAP_BOUND,
            "{name} on {}: SSIM map off by {pixel:e}",
            ctx.adapter.name
        );
        worst_map = worst_map.max(pixel);
        eprintln!(
            "{name}: SSIM {:.9} against {:.9}; MSE {}; worst SSIM map pixel {pixel:.2e}",
            cpu.ssim, gpu.ssim, cpu.mse
        );
    }
    eprintln!(
        "worst |SSIM difference| {worst_ssim:.2e}, worst SSIM map pixel {worst_map:.2e} on {} ({})",
        ctx.adapter.name, ctx.adapter.backend
    );
    // Under SSIM's window: refused as the CPU refuses it.
    let (a, b) = noise_pair(10, 40, 1);
    let e = g.compare(a.raster(), b.raster()).unwrap_err();
    assert!(e.to_string().contains("11×11"), "{e}");
}

// Measured worst |SSIM difference| on 2026-11-27: 4.9e-8 on each of the
// three; worst SSIM map pixel 1.5e-6 (lavapipe, GL) and 1.4e-6
// (SwiftShader).
#[test]
fn every_figure_on_the_gpu_is_the_cpus_on_lavapipe() {
    compare_lock("default");
}

#[test]
fn every_figure_on_the_gpu_is_the_cpus_on_swiftshader() {
    compare_lock("swiftshader");
}

#[test]
fn every_figure_on_the_gpu_is_the_cpus_on_gl() {
    compare_lock("gl:llvmpipe");
}

/// Bad input gets the CPU FLIP's errors, not a device fault.
#[test]
fn flip_on_the_gpu_refuses_what_nv_flip_refuses() {
    let ctx = ctx("default");
    let g = GpuFlip::new(&ctx);
    let (a, _) = noise_pair(16, 16, 1);
    let (b, _) = noise_pair(16, 15, 1);
    let e = g.flip(a.raster(), b.raster(), DEFAULT_PPD).unwrap_err();
    assert!(
        e.to_string().contains("16×16") && e.to_string().contains("16×15"),
        "{e}"
    );
    let e = g.flip(a.raster(), a.raster(), f64::NAN).unwrap_err();
    assert!(e.to_string().contains("pixels per degree"), "{e}");
}

/// `check --metrics gpu` judges with the GPU's figures and says so; they
/// are the CPU's (FLIP's and SSIM's means within their locks, the rest the
/// same);
/// `auto` stays on the CPU on lavapipe; `--cpu --metrics gpu` is refused.
#[test]
fn check_takes_the_metrics_from_the_gpu_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let report = |metrics: &str| {
        let json = dir.path().join(format!("{metrics}.json"));
        let artifacts = dir.path().join(metrics);
        let o = crate::common::tonegate(&[
            "check",
            "--no-history",
            "--scene",
            "grid-static",
            "--scene",
            "interior-agx-punchy",
            "--metrics",
            metrics,
            "--json",
            json.to_str().unwrap(),
            "--artifacts",
            artifacts.to_str().unwrap(),
        ]);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let text = std::fs::read_to_string(&json)
            .unwrap()
            .replace("1e999", "1e308");
        serde_json::from_str::<serde_json::Value>(&text).unwrap()
    };
    let (gpu, cpu, auto) = (report("gpu"), report("cpu"), report("auto"));
    assert_eq!(gpu["metrics_on"], "gpu");
    assert_eq!(cpu["metrics_on"], "cpu");
    assert_eq!(auto["metrics_on"], "cpu", "auto on lavapipe");
    assert!(gpu["flip_definition"]
        .as_str()
        .unwrap()
        .contains("on the GPU"));
    assert!(!cpu["flip_definition"]
        .as_str()
        .unwrap()
        .contains("on the GPU"));
    let frames = |r: &serde_json::Value| -> Vec<serde_json::Value> {
        r["scenes"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|s| s["frames"].as_array().unwrap().clone())
            .collect()
    };
    let (g, c) = (frames(&gpu), frames(&cpu));
    assert!(!g.is_empty() && g.len() == c.len());
    for (g, c) in g.iter().zip(&c) {
        let (gm, cm) = (&g["metrics"], &c["metrics"]);
        let (gf, cf) = (
            gm["flip_mean"].as_f64().unwrap(),
            cm["flip_mean"].as_f64().unwrap(),
        );
        assert!(cf > 0.0 && (gf - cf).abs() <= 1e-4, "{gf} against {cf}");
        for k in ["mse", "psnr", "snr", "max_abs_diff", "fraction_over_1lsb"] {
            assert_eq!(gm[k], cm[k], "{k}");
        }
        let (gs, cs) = (gm["ssim"].as_f64().unwrap(), cm["ssim"].as_f64().unwrap());
        assert!((gs - cs).abs() <= 1e-6, "SSIM {gs} against {cs}");
    }
    // The kept frames' maps come from the device's passes under `gpu`: the
    // SSIM and FLIP PNGs are the device's maps of the kept pair, pixel for
    // pixel.
    let ctx = ctx("default");
    let device = GpuCompare::new(&ctx);
    let mut seen = 0;
    for entry in std::fs::read_dir(dir.path().join("gpu")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_owned();
        let Some(stem) = name.strip_suffix("-actual.png") else {
            continue;
        };
        let actual = tonegate::io::read_png8(&path).unwrap();
        let scene = ["grid-static", "interior-agx-punchy"]
            .into_iter()
            .find(|s| stem.starts_with(s))
            .unwrap();
        let n: u32 = stem[scene.len() + 1..scene.len() + 4].parse().unwrap();
        let (ssim, flip) = device
            .maps(actual.raster(), golden(scene, n).raster())
            .unwrap();
        let png = |kind: &str| {
            tonegate::io::read_png8(&dir.path().join("gpu").join(format!("{stem}-{kind}.png")))
                .unwrap()
        };
        for (kind, want) in [
            ("ssim", tonegate::metrics::ssim_map_image(&ssim)),
            ("flip", flip.magma_image()),
        ] {
            let got = png(kind);
            let differ = got
                .pixels
                .iter()
                .zip(&want.pixels)
                .filter(|(a, b)| a != b)
                .count();
            assert!(
                (got.width, got.height) == (want.width, want.height) && differ == 0,
                "{stem}: {differ} pixels of the {kind} map are not the device's"
            );
        }
        seen += 1;
    }
    assert!(seen >= 2, "a kept frame per scene, {seen} seen");
    let o = crate::common::tonegate(&["check", "--no-history", "--cpu", "--metrics", "gpu"]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("--metrics gpu") && e.contains("--cpu"), "{e}");
}
