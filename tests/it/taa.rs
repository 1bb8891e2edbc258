//! TAA (docs/taa.md) on the GPU against the f64 reference: each TAA stage fed
//! the same inputs, the whole recurrence frame after frame, and the
//! sequencing (`SceneRenderer` replays from the last reset).

use crate::common;

use std::path::Path;
use tonegate::conventions::{reprojection, rotation_matrix, taa_jitter};
use tonegate::gpu::{AdapterChoice, GpuConfig, GpuContext};
use tonegate::image::LinearImage;
use tonegate::plan::StagePlan;
use tonegate::reference::taa::{taa, Reprojection, TaaFrame, TaaHistory};
use tonegate::reference::taa_sobel::taa_sobel;
use tonegate::reference::{scene_camera, sphere};
use tonegate::render::{scene_environment, SceneRenderer};
use tonegate::scene::Scene;

fn context() -> GpuContext {
    GpuContext::new(&AdapterChoice::default())
        .unwrap_or_else(|e| panic!("{e}\n(ci/test.sh installs mesa-vulkan-drivers; run it once)"))
}

fn scene(variant: &str, sharpen: f64, omega: f64) -> Scene {
    scene_with(variant, sharpen, omega, "")
}

/// `keys`: more lines of the `[taa]` table ("" for every default).
pub(crate) fn scene_with(variant: &str, sharpen: f64, omega: f64, keys: &str) -> Scene {
    let text = format!(
        r#"
name = "taa-test"
size = [96, 54]
frames = 8
[environment]
builtin = "interior"
size = [256, 128]
[rotation]
degrees_per_frame = {omega}
[taa]
variant = "{variant}"
sharpen = {sharpen}
{keys}
reset_frames = [5]
[[checks]]
min_psnr = 0.0
"#
    );
    Scene::parse(&text, Path::new("taa-test.toml")).unwrap()
}

/// The largest |a − b| / (rel·|b| + abs) over every channel.
fn worst(a: &LinearImage, b: &LinearImage, rel: f64, abs: f64) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs() / (rel * q[c].abs() + abs)))
        .fold(0.0, f64::max)
}

/// Each frame, the GPU's `taa_sobel`, `taa`, history and frame counts
/// against the f64 stage fed the GPU's own inputs (its jittered `sphere`
/// output and its previous history), for every clipping box with and
/// without the sharpen, either history filter, either feedback rule and
/// either blend.
///
/// Tolerance: 2e-4 relative plus 2e-4 of the frame's largest value. Origin:
/// the GPU reprojects in f32, so its history read lands up to ~1e-5 px from
/// the f64 point (a 96-px film, f32's 6e-8 relative spacing through a 3×3
/// matrix, a divide and a scale); bilinear turns that into ~1e-5 of the
/// local contrast, and the interior map's window edges are ~1e3:1 within a
/// pixel (Catmull-Rom's weights reach 1.15 in sum of magnitudes, a little
/// more). The sharpen then scales a difference by up to 1 + 4s. Measured
/// worst on llvmpipe, as a fraction of the bound: 0.09 (edge-aware, s = 1).
#[test]
fn each_taa_stage_matches_its_reference_on_the_gpus_inputs() {
    let ctx = context();
    // The thesis's TAA, as its scenes run it.
    let thesis = "history_filter = \"bilinear\"\nfeedback = \"luminance\"\nblend = \"linear\"";
    let cases = [
        ("clip", 0.0, thesis),
        ("clip", 0.25, thesis),
        ("edge_aware", 0.0, thesis),
        ("edge_aware", 1.0, thesis),
        (
            "clip",
            0.0,
            "history_filter = \"catmull_rom\"\nfeedback = \"luminance\"",
        ),
        ("edge_aware", 0.25, "history_filter = \"catmull_rom\""),
        // The defaults: Catmull-Rom, motion feedback, tone-mapped blend.
        ("clip", 0.0, ""),
        ("variance", 0.0, ""),
        ("variance", 0.25, "variance_gamma = 1.5\nblend = \"linear\""),
    ];
    for (variant, sharpen, keys) in cases {
        let worst = stage_by_stage(&ctx, GpuConfig::default(), variant, sharpen, keys, 2e-4);
        eprintln!("{variant} s={sharpen} {keys:?}: worst {worst:.3} of the bound");
    }
}

/// The history read through the texture unit's filter (`--env-filter
/// hardware`: 9 bilinear taps for Catmull-Rom, one for bilinear), stage by
/// stage against the same f64 reference as the loads.
///
/// Tolerance: 2e-3 relative plus 2e-3 of the frame's largest value, ten
/// times the loads' bound. Origin: the filter's sub-texel weights are
/// quantised (8 bits on NVIDIA, as few as 4 under Vulkan's minimum), which
/// moves each tap's weight by up to 2⁻⁹ (8 bits) of the difference between
/// its texels; over Catmull-Rom's taps (sum of |w| ≤ 1.2) and the interior
/// map's 1e3:1 window edges that is ~2e-3 of the frame's largest value at an
/// 8-bit adapter. A tap at the wrong place (half a texel off) is off by
/// a large fraction of the local contrast and fails it. Measured worst on
/// llvmpipe, as a fraction of the bound, in the test's output.
#[test]
fn the_hardware_filtered_history_matches_the_reference_within_its_quantisation() {
    let ctx = context();
    if !ctx.float32_filterable {
        panic!("{}: no float32-filterable textures", ctx.adapter.name);
    }
    let config = GpuConfig {
        env_filter: tonegate::gpu::EnvFilter::Hardware,
        ..Default::default()
    };
    let mut worst: f64 = 0.0;
    for (variant, sharpen, keys) in [
        ("clip", 0.0, ""),
        ("variance", 0.0, ""),
        ("edge_aware", 0.25, ""),
        (
            "clip",
            0.0,
            "history_filter = \"bilinear\"\nfeedback = \"luminance\"",
        ),
    ] {
        let w = stage_by_stage(&ctx, config, variant, sharpen, keys, 2e-3);
        eprintln!("hardware {variant} s={sharpen} {keys:?}: worst {w:.3} of the bound");
        worst = worst.max(w);
    }
    // The texture unit's arithmetic is not the loads': some bit differs.
    let second_frame = |config: GpuConfig| {
        let sc = scene("clip", 0.0, 0.5);
        let env = scene_environment(&sc).unwrap();
        let r = common::scene_renderer(&ctx, &sc, &env, config);
        for n in 0..2 {
            let rot = rotation_matrix(sc.rotation.axis, sc.angle(n));
            let prev = rotation_matrix(sc.rotation.axis, sc.angle(n.saturating_sub(1)));
            r.set_frame(&rot, taa_jitter(n));
            r.set_taa_history((n > 0).then_some(&reprojection(&prev, &rot)));
            r.render(false).unwrap();
        }
        r.read_output("taa").unwrap().unwrap()
    };
    assert_ne!(
        second_frame(config).pixels,
        second_frame(GpuConfig::default()).pixels,
        "the hardware filter's entries were not used"
    );
    eprintln!("hardware filter: worst {worst:.3} of the bound");
}

/// One scene's frames through the GPU's TAA and through the f64 stage fed
/// the GPU's own inputs; panics past `bound` (relative, and of the frame's
/// largest value), returns the worst error as a fraction of it.
fn stage_by_stage(
    ctx: &GpuContext,
    config: GpuConfig,
    variant: &str,
    sharpen: f64,
    keys: &str,
    bound: f64,
) -> f64 {
    let sc = scene_with(variant, sharpen, 0.5, keys);
    let env = scene_environment(&sc).unwrap();
    let r = common::scene_renderer(ctx, &sc, &env, config);
    let camera = scene_camera(&sc);
    let params = StagePlan::for_scene(&sc, 1).taa().unwrap();
    let taa_cfg = sc.taa.as_ref().unwrap();
    let mut history: Option<TaaHistory> = None;
    let mut worst_seen: f64 = 0.0;
    for n in 0..sc.frames {
        let rot = rotation_matrix(sc.rotation.axis, sc.angle(n));
        let prev = rotation_matrix(sc.rotation.axis, sc.angle(n.saturating_sub(1)));
        let m = reprojection(&prev, &rot);
        let reset = taa_cfg.resets_at(n);
        r.set_frame(&rot, taa_jitter(n));
        r.set_taa_history((!reset).then_some(&m));
        r.render(false).unwrap();
        let current = r.read_output("sphere").unwrap().unwrap();
        // The jittered sphere itself against the f64 one at the same offset.
        let cpu_sphere = sphere::sphere_jittered(&env, &camera, &rot, taa_jitter(n));
        let scale = cpu_sphere
            .pixels
            .iter()
            .flatten()
            .fold(0.0f64, |a, &b| a.max(b));
        let sphere_err = worst(&current, &cpu_sphere, 1e-3, 1e-3 * scale);
        assert!(
            sphere_err <= 1.0,
            "{variant} frame {n}: sphere {sphere_err}"
        );
        let amount = (variant == "edge_aware").then(|| taa_sobel(&current));
        if let Some(a) = &amount {
            let gpu = r.read_output("taa_sobel").unwrap().unwrap();
            let cpu = LinearImage::from_fn(a.width, a.height, |x, y| [a.get(x, y); 3]);
            let e = worst(&gpu, &cpu, 0.0, 1e-4);
            assert!(e <= 1.0, "{variant} frame {n}: taa_sobel off by {e} x 1e-4");
        }
        let frame = TaaFrame {
            history: if reset { None } else { history.as_ref() },
            reprojection: Reprojection::Rotation { camera, matrix: m },
        };
        let cpu = taa(&current, amount.as_ref(), &frame, &params);
        let gpu_out = r.read_output("taa").unwrap().unwrap();
        let gpu_hist = r.read_output("taa_history").unwrap().unwrap();
        let gpu_frames = r.read_output("taa_confidence").unwrap().unwrap();
        // Frame counts are small integers: exact on both.
        let cpu_frames = &cpu.history.confidence;
        for (k, (g, c)) in gpu_frames.pixels.iter().zip(&cpu_frames.pixels).enumerate() {
            assert_eq!(
                g[0], *c,
                "{variant} {keys:?} frame {n}: frame count of pixel {k}"
            );
        }
        let e = worst(&gpu_hist, &cpu.history.colour, bound, bound * scale).max(worst(
            &gpu_out,
            &cpu.output,
            bound,
            bound * scale,
        ));
        worst_seen = worst_seen.max(e);
        assert!(
            e <= 1.0,
            "{variant} s={sharpen} {keys:?} frame {n}: taa off by {e} of the bound"
        );
        // The next frame's history is the GPU's own (stage by stage).
        history = Some(TaaHistory {
            colour: gpu_hist,
            confidence: cpu.history.confidence,
        });
    }
    worst_seen
}

/// The whole sequence on both renderers through `SceneRenderer` (the CPU's
/// recurrence from its own frames, the GPU's from its own): the 8-bit frames
/// agree within the accuracy bound of every other GPU-vs-CPU frame test
/// (PSNR ≥ 50 dB, tests/gpu.rs says why), frames rendered out of order
/// included (the renderer replays from the last reset).
#[test]
fn taa_sequences_agree_on_both_renderers_in_any_order() {
    let ctx = context();
    for variant in ["clip", "edge_aware"] {
        let sc = scene(variant, 0.25, 0.5);
        let env = scene_environment(&sc).unwrap();
        let cpu = SceneRenderer::cpu(&sc, &env, 1);
        let gpu = SceneRenderer::gpu(&sc, &env, &ctx, GpuConfig::default(), 1).unwrap();
        let in_order: Vec<_> = (0..sc.frames)
            .map(|n| cpu.frame(n).unwrap().image)
            .collect();
        for n in [3u32, 7, 1, 2, 6, 0, 4] {
            let g = gpu.frame(n).unwrap().image;
            let m = tonegate::metrics::compare_frames(&g, &in_order[n as usize])
                .map(|(m, _)| m)
                .unwrap();
            assert!(m.psnr >= 50.0, "{variant} frame {n}: {:.2} dB", m.psnr);
            // Out of order on the CPU too: the same frame as in order.
            assert_eq!(
                cpu.frame(n).unwrap().image,
                in_order[n as usize],
                "cpu frame {n}"
            );
        }
        // The history matters: frame 4 (no reset) differs from a fresh
        // render of the same jittered frame, frame 5 (a reset) does not.
        let plain = |n: u32| {
            let rot = rotation_matrix(sc.rotation.axis, sc.angle(n));
            sphere::sphere_jittered(&env, &scene_camera(&sc), &rot, taa_jitter(n))
        };
        let (o4, _) = tonegate::reference::render_taa_frame(&sc, &env, 4, None).unwrap();
        let passed = tonegate::reference::taa::sharpen(&plain(4), 0.25);
        assert!(
            o4.hdr.pixels == passed.pixels,
            "a reset passes the frame through (sharpened)"
        );
        assert_ne!(in_order[4], o4.frame, "frame 4 carries history");
        let (o5, _) = tonegate::reference::render_taa_frame(&sc, &env, 5, None).unwrap();
        assert_eq!(in_order[5], o5.frame, "frame 5 is a reset");
    }
}
