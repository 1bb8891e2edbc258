//! The GPU pipeline against the CPU reference, stage by stage and frame by
//! frame, on lavapipe (installed by ci/test.sh). Every comparison is between
//! two different renders: the GPU's output and the f64 reference fed the same
//! input.

use crate::common;

use tonegate::conventions::{equirect_uv, rotation_matrix, sphere_direction};
use tonegate::golden::read_frame;
use tonegate::gpu::{
    AdapterChoice, Execution, GpuConfig, GpuContext, GpuInput, GpuRenderer, HdrFormat,
    ReductionMethod,
};
use tonegate::image::Frame;
use tonegate::image::LinearImage;
use tonegate::metrics::{compare_frames, frame_fraction_over};
use tonegate::plan::{Stage, StagePlan};
use tonegate::reference::{self, luminance_stats, scene_camera, tonemap, Pipeline};
use tonegate::render::scene_environment;
use tonegate::scene::Scene;
use tonegate::suite::load_suite;

fn context() -> GpuContext {
    GpuContext::new(&AdapterChoice::default())
        .unwrap_or_else(|e| panic!("{e}\n(ci/test.sh installs mesa-vulkan-drivers; run it once)"))
}

/// The suite's scenes whose frames stand alone: a TAA scene's frame depends
/// on the frames before it, and tests/taa.rs compares those sequences (and
/// each TAA stage) on both renderers.
fn suite() -> Vec<Scene> {
    let all =
        load_suite(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("golden/suite.toml"))
            .unwrap();
    // A TAA or an adapting scene's frame depends on the frames before it:
    // tests/it/taa.rs and tests/it/adaptation.rs render those in order.
    all.into_iter()
        .filter(|s| s.taa_active().is_none() && s.adaptation.is_none())
        .collect()
}

/// The share of PQ pixels whose codes may differ by 1 between the GPU's
/// f32 encode and the f64 one of the same display image. The GPU's ST 2084
/// (shaders/shared/pq.wgsl) carries a few f32 roundings into the signal,
/// a few hundredths of a 16-bit code, so samples that close to a rounding
/// boundary land on its other side: 1.75 % of `sky-bt2390-pq`'s pixels on
/// llvmpipe (2026-11-26; 21.9 % with the textbook formula, whose q^m2
/// multiplies q's rounding by 78.8). 5 % leaves room for another adapter's
/// pow and exp, which WGSL lets be a few ULP less exact.
const PQ_ENCODE_DIFFER: f64 = 0.05;

/// Samples that differ between two frames of one depth and size.
fn differing_samples(a: &Frame, b: &Frame) -> usize {
    fn count<P: AsRef<[T]>, T: PartialEq>(a: &[P], b: &[P]) -> usize {
        a.iter()
            .zip(b)
            .map(|(p, q)| {
                p.as_ref()
                    .iter()
                    .zip(q.as_ref())
                    .filter(|(x, y)| x != y)
                    .count()
            })
            .sum()
    }
    match (a, b) {
        (Frame::Rgb8(a), Frame::Rgb8(b)) => count(&a.pixels, &b.pixels),
        (Frame::Pq16(a), Frame::Pq16(b)) => count(&a.pixels, &b.pixels),
        _ => panic!("frames of two depths: {} and {}", a.kind(), b.kind()),
    }
}

/// A renderer of `img` as a flat image (no sphere stage) with `pipeline`'s
/// plan, at default settings.
fn flat_renderer<'a>(
    ctx: &'a GpuContext,
    img: &tonegate::image::HdrImage,
    pipeline: &Pipeline,
) -> GpuRenderer<'a> {
    let plan = StagePlan::build(
        tonegate::plan::Input::Flat,
        pipeline.operator,
        pipeline.bloom,
        pipeline.grade,
    );
    GpuRenderer::new(
        ctx,
        plan,
        GpuInput::Flat(img),
        pipeline,
        GpuConfig::default(),
    )
    .unwrap()
}

/// Fraction of channel values with |a − b| > rel·|b| + abs, and the worst ratio.
fn fraction_outside(a: &LinearImage, b: &LinearImage, rel: f64, abs: f64) -> (f64, f64) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let mut outside = 0usize;
    let mut worst = 0.0f64;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            let bound = rel * q[c].abs() + abs;
            let ratio = (p[c] - q[c]).abs() / bound;
            worst = worst.max(ratio);
            if ratio > 1.0 {
                outside += 1;
            }
        }
    }
    (outside as f64 / (3 * a.pixel_count()) as f64, worst)
}

/// max − min of each channel over the four texels bilinear reads at (u, v).
fn footprint_range(env: &tonegate::image::HdrImage, u: f64, v: f64) -> [f64; 3] {
    let (w, h) = (env.width as i64, env.height as i64);
    let x0 = (u * w as f64 - 0.5).floor() as i64;
    let y0 = (v * h as f64 - 0.5).floor() as i64;
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
        let x = (x0 + dx).rem_euclid(w) as u32;
        let y = (y0 + dy).clamp(0, h - 1) as u32;
        let p = env.get(x, y);
        for k in 0..3 {
            lo[k] = lo[k].min(p[k] as f64);
            hi[k] = hi[k].max(p[k] as f64);
        }
    }
    [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]]
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

/// Final frames against a 1-spp CPU render of the same scene, every frame of
/// every suite scene. Tolerance: PSNR ≥ 50 dB and ≥ 99.9 % of pixels within
/// 1 LSB. Origin: the GPU works in f32 with its own atan2/acos (2 ULP) where
/// the reference uses f64; at an HDR edge of 10⁴:1 a 1e-5-texel footprint shift
/// moves a value by a few percent (measured: up to 4 % in interior scenes),
/// and a value that lands on an 8-bit rounding boundary flips by 1 LSB. 50 dB
/// is an MSE of 0.65 LSB², i.e. such flips on well under 1 % of values.
#[test]
fn final_frames_match_the_cpu_render_of_the_same_scene() {
    let ctx = context();
    for scene in suite() {
        let env = scene_environment(&scene).unwrap();
        let r = common::scene_renderer(&ctx, &scene, &env, GpuConfig::default());
        let mut worst_psnr = f64::INFINITY;
        let mut golden_psnr = Vec::new();
        for n in 0..scene.frames {
            r.set_rotation(&rotation_matrix(scene.rotation.axis, scene.angle(n)));
            let gpu = r.render(true).unwrap();
            let frame = gpu.frame.unwrap();
            let cpu = reference::render_frame(&scene, &env, n, 1).unwrap();
            let m = compare_frames(&frame, &cpu.frame).map(|(m, _)| m).unwrap();
            let over = frame_fraction_over(&frame, &cpu.frame, 1).unwrap();
            assert!(
                m.psnr >= 50.0 && over <= 0.001,
                "{} frame {n}: PSNR {:.2} dB, {:.4} % of pixels off by more than 1 LSB (max {})",
                scene.name,
                m.psnr,
                over * 100.0,
                m.max_abs_diff
            );
            worst_psnr = worst_psnr.min(m.psnr);
            let golden = read_frame(
                std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/golden")),
                &scene.name,
                n,
            )
            .unwrap();
            golden_psnr.push(
                compare_frames(&frame, &golden)
                    .map(|(m, _)| m)
                    .unwrap()
                    .psnr,
            );
        }
        // Against the 16-spp goldens: the plain path's aliasing, reported.
        let mean = golden_psnr.iter().sum::<f64>() / golden_psnr.len() as f64;
        println!(
            "{:<36} vs CPU 1 spp: worst PSNR {:>7.2} dB | vs 16-spp golden: worst {:.2} dB, mean {:.2} dB",
            scene.name,
            worst_psnr,
            golden_psnr.iter().cloned().fold(f64::INFINITY, f64::min),
            mean
        );
    }
}

/// Each stage's GPU output against the reference stage fed the GPU's own input.
#[test]
fn each_stage_matches_its_reference_on_the_same_input() {
    let ctx = context();
    for scene in suite() {
        let env = scene_environment(&scene).unwrap();
        // The adapter's own reduction, and the workgroup trees (what a GPU
        // runs: shared memory, and subgroups where it has them, as llvmpipe
        // does) for plans that reduce the frame (statistics or the grade's
        // mean).
        let reduces = ["luminance_stats", "grade_stats"]
            .iter()
            .any(|s| StagePlan::for_scene(&scene, 1).contains(s));
        let reductions = match reduces {
            true => vec![
                ReductionMethod::Auto,
                ReductionMethod::Tree,
                ReductionMethod::SubgroupTree,
            ],
            false => vec![ReductionMethod::Auto],
        };
        for reduction in reductions {
            let config = GpuConfig {
                reduction,
                ..Default::default()
            };
            let r = common::scene_renderer(&ctx, &scene, &env, config);
            let n = 3.min(scene.frames - 1);
            r.set_rotation(&rotation_matrix(scene.rotation.axis, scene.angle(n)));
            let gpu = r.render(true).unwrap();
            let name = &format!("{} ({reduction:?})", scene.name);
            let pipeline = Pipeline::of_scene(&scene);
            let plan = StagePlan::for_scene(&scene, 1);
            // sphere: against the CPU's own sphere render. Tolerance: 1e-4 relative
            // (f32 arithmetic) plus a footprint shift of 1e-4 texel times the
            // range of the four texels it interpolates. Origin: texel coordinates
            // near 1024 carry an f32 ulp of 6e-5 texel and the shader's atan2/acos
            // ~2 ULP; bilinear changes by at most (range × shift), which at a
            // 10⁴:1 window edge is far more than 1e-4 of the value.
            let hdr = r.read_output("sphere").unwrap().unwrap();
            let cpu_hdr = reference::render_frame(&scene, &env, n, 1).unwrap().hdr;
            let rotation = rotation_matrix(scene.rotation.axis, scene.angle(n));
            let camera = scene_camera(&scene);
            let mut worst = 0.0f64;
            for (i, (g, c)) in hdr.pixels.iter().zip(&cpu_hdr.pixels).enumerate() {
                let (x, y) = (
                    (i % hdr.width as usize) as f64,
                    (i / hdr.width as usize) as f64,
                );
                let d = sphere_direction(&rotation, camera.ray(x + 0.5, y + 0.5));
                let (u, v) = equirect_uv(d);
                let range = footprint_range(&env, u, v);
                for k in 0..3 {
                    let bound = 1e-4 * c[k].abs() + 1e-4 * range[k] + 1e-7;
                    worst = worst.max((g[k] - c[k]).abs() / bound);
                }
            }
            assert!(
                worst <= 1.0,
                "{name} sphere: an error {worst:.2}x its bound"
            );
            // luminance_stats: f32 compensated sums vs the f64 reference, 1e-5 relative.
            let lum = pipeline.operator.luminance();
            let (weights, delta) = (lum.weights, lum.delta);
            let mut cpu_stats = Default::default();
            if let Some(Stage::LuminanceStats(needs)) =
                plan.stages().iter().find(|s| s.name() == "luminance_stats")
            {
                cpu_stats = luminance_stats::luminance_stats(&hdr, *needs, weights, delta);
                let s = &gpu.stats;
                if let Some(v) = cpu_stats.log_average {
                    assert!(
                        rel(s.log_average as f64, v) <= 1e-5,
                        "{name} log_average {} vs {v}",
                        s.log_average
                    );
                }
                if let Some(v) = cpu_stats.weighted_log_average {
                    assert!(
                        rel(s.weighted_log_average as f64, v) <= 1e-5,
                        "{name} weighted {} vs {v}",
                        s.weighted_log_average
                    );
                }
                if let Some(v) = cpu_stats.min {
                    assert!(rel(s.min as f64, v) <= 1e-6, "{name} min {} vs {v}", s.min);
                }
                if let Some(v) = cpu_stats.max {
                    assert!(rel(s.max as f64, v) <= 1e-6, "{name} max {} vs {v}", s.max);
                }
            }
            // tonemap: the curve in f32 against f64 with the same statistics.
            // Every value the operator resolves, GPU (f32) against f64: the
            // statistics' 1e-5 doubled.
            let params = pipeline.operator.resolve(&cpu_stats).unwrap();
            let gpu_params = pipeline.operator.gpu_resolved(gpu.stats.tone);
            for (n, want) in &params.params.values {
                let got = gpu_params.get(n).unwrap_or(f64::NAN);
                assert!(rel(got, *want) <= 2e-5, "{name} {n} {got} vs {want}");
            }
            let cpu_toned = tonemap::tonemap(&hdr, &params);
            let toned = r.read_output("tonemap").unwrap().unwrap();
            let (out, worst) = fraction_outside(&toned, &cpu_toned, 1e-4, 1e-6);
            assert!(
                out == 0.0,
                "{name} tonemap: {:.4} % of values off (worst {worst:.1}x)",
                out * 100.0
            );
            // The rest of the chain, stage by stage, each fed the GPU's input.
            let mut display = toned.clone();
            if let (Some(b), Some(blurred)) = (pipeline.bloom, r.read_output("bloom_blur").unwrap())
            {
                let src = if b.bright_pass == tonegate::scene::BrightPass::Scaled {
                    &hdr
                } else {
                    &toned
                };
                let lmax = cpu_stats.max.unwrap_or(0.0);
                let bright = reference::bloom_bright::bloom_bright(
                    src,
                    b.bright_pass,
                    b.threshold.get(),
                    lmax,
                    weights,
                );
                let low =
                    reference::bloom_downsample::bloom_downsample(&bright, b.downsample.get());
                let cpu_blur =
                    reference::bloom_blur::bloom_blur(&low, b.radius.get(), b.sigma.get());
                let (out, worst) = fraction_outside(&blurred, &cpu_blur, 1e-4, 1e-6);
                assert!(
                    out == 0.0,
                    "{name} bloom chain: {:.4} % off (worst {worst:.1}x)",
                    out * 100.0
                );
                let composite = r.read_output("bloom_composite").unwrap().unwrap();
                let cpu_composite =
                    reference::bloom_composite::bloom_composite(&toned, &blurred, b.strength.get());
                let (out, worst) = fraction_outside(&composite, &cpu_composite, 1e-5, 1e-6);
                assert!(
                    out == 0.0,
                    "{name} bloom_composite: {:.4} % off (worst {worst:.1}x)",
                    out * 100.0
                );
                display = composite;
            }
            if let (Some(g), Some(graded)) = (pipeline.grade, r.read_output("grade").unwrap()) {
                let mean = reference::grade_stats::grade_stats(&display);
                let cpu_graded = reference::grade::grade(&display, g, mean);
                // Contrast subtracts the grey: values near it cancel, hence the
                // absolute term (1e-5 of the display range).
                let (out, worst) = fraction_outside(&graded, &cpu_graded, 1e-4, 1e-5);
                assert!(
                    out == 0.0,
                    "{name} grade: {:.4} % off (worst {worst:.1}x)",
                    out * 100.0
                );
                display = graded;
            }
            let gpu_display = r.read_output("display").unwrap().unwrap();
            assert_eq!(
                gpu_display, display,
                "{name}: display is the last stage's output"
            );
            // encode: same rounding rule; only values within f32 rounding of a
            // quantisation boundary may differ, by 1 LSB (one 16-bit code
            // for PQ, whose share of such values is PQ_ENCODE_DIFFER).
            let cpu_frame = reference::encode::encode_frame(
                &gpu_display,
                pipeline.encoding,
                pipeline.operator.display_levels(),
            )
            .unwrap();
            let frame = gpu.frame.unwrap();
            let m = compare_frames(&frame, &cpu_frame).map(|(m, _)| m).unwrap();
            let over = frame_fraction_over(&frame, &cpu_frame, 0).unwrap();
            let allowed = match frame {
                Frame::Rgb8(_) => 1e-4,
                Frame::Pq16(_) => PQ_ENCODE_DIFFER,
            };
            println!(
                "{name} encode: max {} code(s), {:.4} % of pixels differ",
                m.max_abs_diff,
                over * 100.0
            );
            assert!(
                m.max_abs_diff <= 1 && over <= allowed,
                "{name} encode: max {} , {:.5} % differ",
                m.max_abs_diff,
                over * 100.0
            );
        }
    }
}

#[test]
fn every_reduction_agrees_with_f64_on_odd_and_prime_sizes() {
    let ctx = context();
    let op = tonegate::operators::Operator::named("reinhard-auto-key", &[]).unwrap();
    let pipeline = Pipeline {
        operator: &op,
        bloom: None,
        grade: None,
        encoding: tonegate::scene::Encoding::Srgb,
    };
    for (w, h) in [
        (1, 1),
        (1, 7),
        (7, 1),
        (13, 17),
        (97, 31),
        (331, 127),
        (33, 33),
        (1021, 509),
        (1920, 1080),
        (4096, 2048),
    ] {
        let img = tonegate::env::BuiltinEnv::Night.generate(w, h);
        let plan = StagePlan::build(tonegate::plan::Input::Flat, &op, None, None);
        let Some(Stage::LuminanceStats(needs)) = plan.stages().first().cloned() else {
            panic!("seed001 needs statistics");
        };
        let lum = op.luminance();
        let cpu = luminance_stats::luminance_stats(&img.to_linear(), needs, lum.weights, lum.delta);
        for reduction in [
            ReductionMethod::BlockPartials,
            ReductionMethod::PingPong,
            ReductionMethod::Tree,
            ReductionMethod::SubgroupTree,
            ReductionMethod::Auto,
        ] {
            let config = GpuConfig {
                reduction,
                ..Default::default()
            };
            let r = GpuRenderer::new(&ctx, plan.clone(), GpuInput::Flat(&img), &pipeline, config)
                .unwrap();
            // llvmpipe has subgroup operations: the subgroup tree really ran.
            assert!(ctx.subgroups, "{}", ctx.adapter.name);
            assert_eq!(r.config.reduction, reduction.resolve(ctx.traits()));
            let s = r.render(false).unwrap().stats;
            let what = format!("{w}x{h} {reduction:?}");
            assert!(
                rel(
                    s.weighted_log_average as f64,
                    cpu.weighted_log_average.unwrap()
                ) <= 1e-5,
                "{what}: weighted {} vs {:?}",
                s.weighted_log_average,
                cpu.weighted_log_average
            );
            assert!(rel(s.min as f64, cpu.min.unwrap()) <= 1e-6, "{what}: min");
            assert!(rel(s.max as f64, cpu.max.unwrap()) <= 1e-6, "{what}: max");
            assert!(
                rel(s.weight_sum as f64, cpu.weight_sum.unwrap()) <= 1e-5,
                "{what}: Σw {} vs {:?}",
                s.weight_sum,
                cpu.weight_sum
            );
        }
    }
}

#[test]
fn only_the_plans_stages_are_built_and_timed() {
    let ctx = context();
    for scene in suite() {
        let env = scene_environment(&scene).unwrap();
        let r = common::scene_renderer(&ctx, &scene, &env, GpuConfig::default());
        let plan = StagePlan::for_scene(&scene, 1);
        assert_eq!(r.stage_names(), plan.names(), "{}", scene.name);
        let frame = r.render(false).unwrap();
        let timed: Vec<&str> = frame.timings.iter().map(|t| t.stage.as_str()).collect();
        assert_eq!(timed, plan.names(), "{}", scene.name);
        assert!(
            frame.timings.iter().all(|t| t.ms > 0.0 && t.ms < 10_000.0),
            "{:?}",
            frame.timings
        );
    }
    // The fixed-parameter scene has no statistics stage at all.
    let scene = suite()
        .into_iter()
        .find(|s| s.name == "interior-reinhard02-fixed-bloom004")
        .unwrap();
    assert!(!StagePlan::for_scene(&scene, 1).contains("luminance_stats"));
}

#[test]
fn a_wrong_gpu_render_fails_the_comparison() {
    // The comparison must be able to fail: a GPU render with a key 2 % off.
    let ctx = context();
    let mut scene = suite()
        .into_iter()
        .find(|s| s.name == "sky-reinhard-global")
        .unwrap();
    let env = scene_environment(&scene).unwrap();
    let cpu = reference::render_frame(&scene, &env, 3, 1).unwrap();
    let key = scene.operator.values().number("key").unwrap();
    scene.operator = tonegate::operators::Operator::with(
        scene.operator.definition_arc(),
        &[("key", tonegate::operators::Value::Number(key * 1.02))],
    )
    .unwrap();
    let r = common::scene_renderer(&ctx, &scene, &env, GpuConfig::default());
    r.set_rotation(&rotation_matrix(scene.rotation.axis, scene.angle(3)));
    let frame = r.render(true).unwrap().frame.unwrap();
    let over = frame_fraction_over(&frame, &cpu.frame, 1).unwrap();
    assert!(over > 0.001, "a 2 % key error went unnoticed ({over})");
}

#[test]
fn half_float_intermediates_render_within_a_few_lsb_where_in_range() {
    // rgba16float carries 11 bits: a 2^-11 relative error before the curve.
    // On a scene whose values stay below 65504 the frame stays within 2 LSB
    // on 99 % of pixels.
    let ctx = context();
    let scene = suite()
        .into_iter()
        .find(|s| s.name == "night-reinhard-global")
        .unwrap();
    let env = scene_environment(&scene).unwrap();
    let config = GpuConfig {
        hdr_format: HdrFormat::Rgba16Float,
        ..Default::default()
    };
    let r = common::scene_renderer(&ctx, &scene, &env, config);
    // The night map stays below 65504: f16 really is used, not promoted.
    assert_eq!(r.config.hdr_format, HdrFormat::Rgba16Float, "{:?}", r.notes);
    r.set_rotation(&rotation_matrix(scene.rotation.axis, scene.angle(2)));
    let frame = r.render(true).unwrap().frame.unwrap();
    let cpu = reference::render_frame(&scene, &env, 2, 1).unwrap();
    let over = frame_fraction_over(&frame, &cpu.frame, 2).unwrap();
    assert!(
        over <= 0.01,
        "{:.3} % of pixels off by more than 2 LSB",
        over * 100.0
    );
}

#[test]
fn oversized_frames_are_refused_not_crashed() {
    let ctx = context();
    let limit = ctx.limits.max_texture_dimension_2d;
    let img = tonegate::image::HdrImage::filled(limit + 1, 1, [1.0; 3]);
    let op = tonegate::operators::Operator::default();
    let pipeline = Pipeline {
        operator: &op,
        bloom: None,
        grade: None,
        encoding: tonegate::scene::Encoding::Srgb,
    };
    let plan = StagePlan::build(tonegate::plan::Input::Flat, &op, None, None);
    let err = GpuRenderer::new(
        &ctx,
        plan,
        GpuInput::Flat(&img),
        &pipeline,
        GpuConfig::default(),
    )
    .err()
    .expect("refused");
    assert!(err.to_string().contains("texture limit"), "{err}");
}

#[test]
fn a_plan_its_pipeline_cannot_fill_is_an_error_on_both_renderers() {
    // A plan with bloom stages run with a pipeline that has no bloom: the
    // plan is valid, the pairing is a caller's bug, and neither renderer panics.
    let ctx = context();
    let img = tonegate::image::HdrImage::filled(16, 12, [2.0, 1.0, 0.5]);
    let op = tonegate::operators::Operator::default();
    let bloom: tonegate::scene::Bloom =
        toml::from_str("threshold = 0.5\nradius = 2\nsigma = 1.0\nstrength = 0.5").unwrap();
    let plan = StagePlan::build(tonegate::plan::Input::Flat, &op, Some(&bloom), None);
    let without_bloom = Pipeline {
        operator: &op,
        bloom: None,
        grade: None,
        encoding: tonegate::scene::Encoding::Srgb,
    };
    let cpu = reference::run_plan(&plan, img.to_linear(), &without_bloom)
        .expect_err("the reference refuses");
    assert!(cpu.to_string().contains("bloom_bright"), "{cpu}");
    for execution in [Execution::Staged, Execution::Fused] {
        let config = GpuConfig {
            execution,
            ..GpuConfig::default()
        };
        let gpu = GpuRenderer::new(
            &ctx,
            plan.clone(),
            GpuInput::Flat(&img),
            &without_bloom,
            config,
        )
        .err()
        .expect("the GPU refuses");
        assert!(
            matches!(gpu, tonegate::gpu::GpuError::Plan(_)),
            "{execution:?}: {gpu}"
        );
    }
}

#[test]
fn hardware_filtering_is_an_option_with_its_error_measured() {
    // The sampler's weights are the driver's, not the reference's bilinear:
    // fixed-function units quantise the fraction (8 bits on many GPUs), which
    // shows at 10⁴:1 edges, so the general bound is PSNR ≥ 40 dB against the
    // CPU 1-spp render. llvmpipe filters Rgba32Float with f32 weights in
    // nearly the same arithmetic as shared/conventions.wgsl: measured here
    // (2026-11-21) within 1 LSB of the manual path, and held to that there.
    let ctx = context();
    if !ctx.float32_filterable {
        panic!("{} cannot filter Rgba32Float textures", ctx.adapter.name);
    }
    let config = GpuConfig {
        env_filter: tonegate::gpu::EnvFilter::Hardware,
        ..Default::default()
    };
    for scene in suite() {
        let env = scene_environment(&scene).unwrap();
        let r = common::scene_renderer(&ctx, &scene, &env, config);
        let n = 3.min(scene.frames - 1);
        r.set_rotation(&rotation_matrix(scene.rotation.axis, scene.angle(n)));
        let frame = r.render(true).unwrap().frame.unwrap();
        let cpu = reference::render_frame(&scene, &env, n, 1).unwrap();
        let m = compare_frames(&frame, &cpu.frame).map(|(m, _)| m).unwrap();
        println!(
            "{:<36} hardware filter vs CPU 1 spp: PSNR {:.2} dB, max {}",
            scene.name, m.psnr, m.max_abs_diff
        );
        assert!(m.psnr >= 40.0, "{}: {:.2} dB", scene.name, m.psnr);
        if ctx.adapter.name.contains("llvmpipe") {
            let manual = common::scene_renderer(&ctx, &scene, &env, GpuConfig::default());
            manual.set_rotation(&rotation_matrix(scene.rotation.axis, scene.angle(n)));
            let manual = manual.render(true).unwrap().frame.unwrap();
            let d = compare_frames(&frame, &manual).map(|(m, _)| m).unwrap();
            let differ = frame_fraction_over(&frame, &manual, 0).unwrap();
            println!(
                "    vs the manual filter: max {} LSB, {:.4} % of pixels differ",
                d.max_abs_diff,
                differ * 100.0
            );
            assert!(
                d.max_abs_diff <= 1,
                "{}: llvmpipe's sampler is {} LSB from the manual filter",
                scene.name,
                d.max_abs_diff
            );
        }
    }
}

/// `bloom_blur` writes several pixels per invocation: frames whose
/// low-resolution size is no multiple of that run, and radii from 1 to
/// larger than the frame (every tap clamped), still match the reference
/// blur of the same input. Tolerance as in the stage-by-stage test: 1e-4
/// relative (f32 sums of up to 129 taps against f64) plus 1e-6 absolute.
#[test]
fn bloom_blur_matches_at_odd_sizes_and_every_radius() {
    let ctx = context();
    let scene = suite()
        .into_iter()
        .find(|s| s.name == "interior-reinhard02-fixed-bloom004")
        .unwrap();
    // A deterministic pseudo-random frame with values from 0 to 20.
    let mut state = 0x2545_f491u32;
    let mut next = || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32 * 20.0
    };
    for (width, height, radius) in [
        (45u32, 29u32, 1u32),
        (45, 29, 6),
        (38, 21, 13),
        (33, 17, 64),
    ] {
        let img = tonegate::image::HdrImage {
            width,
            height,
            pixels: (0..width * height)
                .map(|_| [next(), next(), next()])
                .collect(),
        };
        let bloom: tonegate::scene::Bloom = toml::from_str(&format!(
            "bright_pass = \"threshold\"\nthreshold = 0.3\ndownsample = 2\nradius = {radius}\nsigma = 4.0\nstrength = 0.5"
        ))
        .unwrap();
        let pipeline = Pipeline {
            bloom: Some(&bloom),
            grade: None,
            ..Pipeline::of_scene(&scene)
        };
        let r = flat_renderer(&ctx, &img, &pipeline);
        r.render(false).unwrap();
        let toned = r.read_output("tonemap").unwrap().unwrap();
        let blurred = r.read_output("bloom_blur").unwrap().unwrap();
        let weights = pipeline.operator.luminance().weights;
        let bright = reference::bloom_bright::bloom_bright(
            &toned,
            bloom.bright_pass,
            bloom.threshold.get(),
            0.0,
            weights,
        );
        let low = reference::bloom_downsample::bloom_downsample(&bright, 2);
        assert_eq!((blurred.width, blurred.height), (low.width, low.height));
        let cpu = reference::bloom_blur::bloom_blur(&low, radius, 4.0);
        let (out, worst) = fraction_outside(&blurred, &cpu, 1e-4, 1e-6);
        assert!(
            out == 0.0,
            "{width}x{height} radius {radius}: {:.4} % off (worst {worst:.1}x)",
            out * 100.0
        );
        // The frame has content at the edges the runs end on.
        assert!(cpu.pixels.iter().any(|p| p[0] > 0.01), "nothing bright");
    }
}

/// `--execution fused` against the staged path on every frame of every suite
/// scene: two different kernel sets over the same per-pixel functions. With
/// f32 intermediates a stage's output survives the texture round trip
/// exactly, so the only room for a difference is a compiler contracting or
/// reordering the arithmetic differently in the larger kernel. On llvmpipe
/// (measured: not one value differs) the frames must be identical; on other
/// adapters within 1 LSB. Against the CPU the fused frames keep the staged
/// bounds (PSNR ≥ 50 dB, ≥ 99.9 % within 1 LSB). Plans with a grade must
/// fall back to staged and say so; their gradeless variants are fused, which
/// covers the threshold bright pass on the tone-mapped frame.
#[test]
fn fused_execution_renders_the_staged_frames() {
    let ctx = context();
    let fused_config = GpuConfig {
        execution: Execution::Fused,
        ..Default::default()
    };
    let exact = ctx.adapter.name.contains("llvmpipe");
    let mut scenes = suite();
    let gradeless: Vec<Scene> = scenes
        .iter()
        .filter(|s| s.grade.is_some())
        .map(|s| Scene {
            name: format!("{}-gradeless", s.name),
            grade: None,
            ..s.clone()
        })
        .collect();
    scenes.extend(gradeless);
    let mut fused_scenes = 0;
    let mut from_toned = false;
    for scene in scenes {
        let env = scene_environment(&scene).unwrap();
        let staged = common::scene_renderer(&ctx, &scene, &env, GpuConfig::default());
        let fused = common::scene_renderer(&ctx, &scene, &env, fused_config);
        let has_grade = scene.grade.is_some();
        if has_grade {
            assert_eq!(fused.config.execution, Execution::Staged, "{}", scene.name);
            assert!(
                fused.notes.iter().any(|n| n.contains("staged")),
                "{}: {:?}",
                scene.name,
                fused.notes
            );
            continue;
        }
        fused_scenes += 1;
        // Fewer kernels, and the merged stages are named in the timing.
        let names = fused.stage_names();
        from_toned |= names.contains(&"tonemap+bloom_bright+bloom_downsample");
        assert!(names.len() < staged.stage_names().len(), "{names:?}");
        assert!(
            names.iter().any(|n| n.ends_with("+encode")),
            "{}: {names:?}",
            scene.name
        );
        let mut differing = 0usize;
        for n in 0..scene.frames {
            let rotation = rotation_matrix(scene.rotation.axis, scene.angle(n));
            staged.set_rotation(&rotation);
            fused.set_rotation(&rotation);
            let a = staged.render(true).unwrap().frame.unwrap();
            let out = fused.render(true).unwrap();
            let timed: Vec<&str> = out.timings.iter().map(|t| t.stage.as_str()).collect();
            assert_eq!(timed, names);
            let b = out.frame.unwrap();
            let m = compare_frames(&b, &a).map(|(m, _)| m).unwrap();
            assert!(
                m.max_abs_diff <= if exact { 0 } else { 1 },
                "{} frame {n}: fused differs from staged by {} LSB",
                scene.name,
                m.max_abs_diff
            );
            differing += differing_samples(&a, &b);
            let cpu = reference::render_frame(&scene, &env, n, 1).unwrap();
            let m = compare_frames(&b, &cpu.frame).map(|(m, _)| m).unwrap();
            let over = frame_fraction_over(&b, &cpu.frame, 1).unwrap();
            assert!(
                m.psnr >= 50.0 && over <= 0.001,
                "{} frame {n} fused vs CPU: PSNR {:.2} dB, {:.4} % over 1 LSB",
                scene.name,
                m.psnr,
                over * 100.0
            );
        }
        println!(
            "{:<36} fused {:?}: {differing} values differ from staged",
            scene.name, names
        );
    }
    assert!(fused_scenes >= 8, "only {fused_scenes} scenes fused");
    assert!(
        from_toned,
        "no scene fused a bright pass on the toned frame"
    );
}

/// The subnormal policy (`color::SMALLEST_NORMAL`): a pixel whose luminance
/// is under f32's smallest normal is toned to exactly 0 by both renderers,
/// in both colour paths, so the GPU never divides by a value an adapter may
/// flush. llvmpipe keeps subnormals, so this branch is taken here only
/// because the policy says so: without it the GPU would write c·curve/Y
/// (about 1e-7 here) and this test fails.
#[test]
fn subnormal_luminance_is_toned_to_zero_on_both_renderers() {
    use tonegate::color::{luminance_with, SMALLEST_NORMAL};
    use tonegate::image::HdrImage;
    use tonegate::toning::ToneSettings;

    let ctx = context();
    // Subnormal, tiny normal and ordinary pixels, and one bright one.
    let img = HdrImage::from_fn(64, 32, |x, y| {
        let i = x + 64 * y;
        let v = match i % 4 {
            0 | 1 => 1.0e-40 * (1 + i % 100) as f32,
            2 => 1.0e-37 * (1 + i) as f32,
            _ => 0.01 * (1 + i % 97) as f32,
        };
        if i == 2047 {
            [40.0, 30.0, 20.0]
        } else {
            [v, v * 0.5, v * 0.25]
        }
    });
    for (operator, colour) in [("reinhard-auto-key", "ratio"), ("reinhard-global", "xyy")] {
        let mut settings = ToneSettings {
            operator: operator.into(),
            bloom: 0.3,
            contrast: 1.1,
            ..Default::default()
        };
        settings.params.set("colour", colour);
        let resolved = settings.resolve().unwrap();
        let pipeline = resolved.pipeline();
        let r = flat_renderer(&ctx, &img, &pipeline);
        let gpu = r.render(true).unwrap();
        let toned = r.read_output("tonemap").unwrap().unwrap();
        let (_, cpu) = reference::render_flat(&img, &pipeline).unwrap();
        let weights = pipeline.operator.luminance().weights;
        let mut zeroed = 0;
        for (i, p) in img.pixels.iter().enumerate() {
            let c = [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])];
            let g = toned.pixels[i];
            assert!(
                g.iter().all(|v| v.is_finite()),
                "{operator:?}: pixel {i} {g:?}"
            );
            if luminance_with(c, weights) < SMALLEST_NORMAL {
                assert_eq!(g, [0.0; 3], "{operator:?} GPU: pixel {i} of {p:?}");
                assert_eq!(cpu.toned.pixels[i], [0.0; 3], "{operator:?} CPU: pixel {i}");
                zeroed += 1;
            }
        }
        assert!(zeroed > 500, "{operator:?}: only {zeroed} subnormal pixels");
        let frame = gpu.frame.unwrap();
        let (frame, cpu_frame) = (frame.as_rgb8().unwrap(), cpu.frame.as_rgb8().unwrap());
        let worst = frame
            .as_bytes()
            .iter()
            .zip(cpu_frame.as_bytes())
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap();
        assert!(worst <= 1, "{operator:?}: GPU vs CPU {worst} LSB");
    }
}

/// Frames in flight (frame n copied out while n+1 renders) give exactly the
/// frames, statistics and order of rendering one frame at a time, for a
/// plain scene and a TAA scene (whose history runs through the frames).
#[test]
fn frames_in_flight_match_one_at_a_time_in_order() {
    use tonegate::gpu::FRAMES_IN_FLIGHT;
    use tonegate::render::SceneRenderer;
    let ctx = context();
    let all =
        load_suite(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("golden/suite.toml"))
            .unwrap();
    let plain = all
        .iter()
        .find(|s| s.taa_active().is_none() && s.bloom.is_some())
        .expect("a scene with bloom");
    let taa = all
        .iter()
        .find(|s| s.taa_active().is_some())
        .expect("a TAA scene");
    for scene in [plain, taa] {
        let env = scene_environment(scene).unwrap();
        // The gate's path: the whole sequence with frames in flight.
        let piped = SceneRenderer::gpu(scene, &env, &ctx, GpuConfig::default(), 1).unwrap();
        let mut told = Vec::new();
        let rendered = piped.sequence(|n| told.push(n)).unwrap();
        // One frame at a time, each waited for, on a renderer of its own.
        let serial = SceneRenderer::gpu(scene, &env, &ctx, GpuConfig::default(), 1).unwrap();
        assert_eq!(
            told,
            (0..scene.frames).collect::<Vec<_>>(),
            "{}",
            scene.name
        );
        assert_eq!(rendered.frames.len(), scene.frames as usize);
        let mut changes = 0;
        for n in 0..scene.frames {
            let one = serial.frame(n).unwrap().image;
            assert!(
                rendered.frames[n as usize] == one,
                "{} frame {n}: in flight differs from one at a time",
                scene.name
            );
            if n > 0 && rendered.frames[n as usize] != rendered.frames[n as usize - 1] {
                changes += 1;
            }
        }
        // The frames differ from each other, so a reordering would show.
        assert!(changes > 0, "{}: every frame alike", scene.name);
        assert!(rendered.fps.unwrap() > 0.0);
    }

    // The renderer's own API: statistics and stage times per frame, the
    // frames in order, and no more than FRAMES_IN_FLIGHT outstanding.
    let scene = plain;
    let env = scene_environment(scene).unwrap();
    let r = common::scene_renderer(&ctx, scene, &env, GpuConfig::default());
    let angle = |n: u32| rotation_matrix(scene.rotation.axis, scene.angle(n));
    let mut one_at_a_time = Vec::new();
    for n in 0..6 {
        r.set_rotation(&angle(n));
        one_at_a_time.push(r.render(true).unwrap());
    }
    let mut seen = Vec::new();
    r.frames::<tonegate::gpu::GpuError>(
        0..6,
        |n| r.set_rotation(&angle(n)),
        |n| n % 2 == 0,
        |n, f| {
            let want = &one_at_a_time[n as usize];
            assert_eq!(f.stats, want.stats, "frame {n} statistics");
            assert_eq!(f.frame.is_some(), n % 2 == 0, "frame {n} read back");
            if let Some(img) = &f.frame {
                assert!(Some(img) == want.frame.as_ref(), "frame {n} image");
            }
            assert_eq!(f.timings.len(), want.timings.len(), "frame {n} timings");
            seen.push(n);
            Ok(())
        },
    )
    .unwrap();
    assert_eq!(seen, (0..6).collect::<Vec<_>>());
    let tickets: Vec<_> = (0..FRAMES_IN_FLIGHT)
        .map(|_| r.submit(false).unwrap())
        .collect();
    let refused = r.submit(false).map(|_| ()).unwrap_err().to_string();
    assert!(refused.contains("not collected"), "{refused}");
    for t in tickets {
        r.collect(t).unwrap();
    }
    r.render(false).expect("slots free again after collecting");
}

/// A frame whose collection fails (here: an error the device raised while
/// it was in flight) still frees its staging slot and unmaps its buffers:
/// the frames after it, through every slot, render exactly what they would
/// have. Without that, the failed slot's mapped buffers make each later
/// copy into them an error, and the slot is refused as still taken.
#[test]
fn a_failed_collect_frees_its_slot_for_the_frames_after_it() {
    use tonegate::gpu::FRAMES_IN_FLIGHT;
    let ctx = context();
    let all =
        load_suite(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("golden/suite.toml"))
            .unwrap();
    let scene = &all[0];
    let env = scene_environment(scene).unwrap();
    let r = common::scene_renderer(&ctx, scene, &env, GpuConfig::default());
    r.set_rotation(&rotation_matrix(scene.rotation.axis, scene.angle(1)));
    let want = r.render(true).unwrap();
    let ticket = r.submit(true).unwrap();
    // A real validation error on the same device while the frame is in
    // flight: a buffer that asks to be mapped both ways.
    let _bad = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("test.invalid"),
        size: 16,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::MAP_WRITE,
        mapped_at_creation: false,
    });
    let failed = r.collect(ticket).map(|_| ()).unwrap_err().to_string();
    assert!(failed.to_lowercase().contains("usage"), "{failed}");
    for k in 0..=FRAMES_IN_FLIGHT {
        let f = r
            .render(true)
            .unwrap_or_else(|e| panic!("frame {k} after the failed one: {e}"));
        assert_eq!(f.stats, want.stats, "frame {k} after the failed one");
        assert!(f.frame == want.frame, "frame {k} after the failed one");
    }
    ctx.wait().expect("no error left on the device");
}

/// The server's renderers kept between images: an image of a size class
/// and settings seen before is reloaded into the kept renderer, in the
/// top-left corner of its larger textures, and renders exactly what a fresh
/// renderer of its own size does, whatever an earlier, larger image left
/// outside it, with every reduction and both executions; an input that
/// would change the configuration in effect (f16 promoted) or another class
/// gets its own.
#[test]
fn kept_renderers_render_what_fresh_ones_do() {
    use tonegate::gpu::{size_class, RendererPool};
    use tonegate::toning::{tone_map, tone_map_until, OutputKind, ToneSettings};
    let ctx = context();
    // reinhard-auto-key's automatic key reads the minimum, the maximum and the
    // weighted log-average; the bloom and the grade's mean read the frame.
    let mut settings = ToneSettings {
        operator: "reinhard-auto-key".into(),
        bloom: 0.04,
        contrast: 1.2,
        ..Default::default()
    };
    settings.params.set("key", "auto");
    let resolved = settings.resolve().unwrap();
    let pipeline = resolved.pipeline();
    let (w, h) = (129, 67);
    let limit = ctx.limits.max_texture_dimension_2d;
    assert_eq!(size_class(w, h, limit), (192, 128));
    let night = tonegate::env::BuiltinEnv::Night.generate(w, h);
    let sky = tonegate::env::BuiltinEnv::Sky.generate(w, h);
    // Beyond f16's range: f16 intermediates are promoted to f32 for it.
    let mut hot = sky.clone();
    hot.pixels[7] = [1e6, 1e6, 1e6];
    // Same class, larger, with its brightest and darkest pixels outside the
    // smaller images: a frame that read past its extent would take its
    // minimum, maximum, log-average or bloom from them.
    let mut big = tonegate::env::BuiltinEnv::Sky.generate(190, 125);
    assert_eq!(size_class(190, 125, limit), (192, 128));
    for y in 0..125 {
        for x in 0..190 {
            if x >= w as usize || y >= h as usize {
                big.pixels[y * 190 + x] = if (x + y) % 2 == 0 {
                    [3e4, 3e4, 3e4]
                } else {
                    [1e-3, 0.0, 1e-3]
                };
            }
        }
    }
    let odd = tonegate::env::BuiltinEnv::Night.generate(131, 97);
    assert_eq!(size_class(131, 97, limit), (192, 128));
    let small = tonegate::env::BuiltinEnv::Night.generate(31, 17);
    let reductions = [
        ReductionMethod::BlockPartials,
        ReductionMethod::PingPong,
        ReductionMethod::Tree,
        ReductionMethod::SubgroupTree,
    ];
    let mut configs: Vec<GpuConfig> = reductions
        .iter()
        .map(|&reduction| GpuConfig {
            reduction,
            ..Default::default()
        })
        .collect();
    configs.push(GpuConfig {
        hdr_format: HdrFormat::Rgba16Float,
        ..Default::default()
    });
    configs.push(GpuConfig {
        execution: Execution::Fused,
        ..Default::default()
    });
    for config in configs {
        let mut kept = RendererPool::new(&ctx);
        let order = [&night, &big, &sky, &night, &odd, &hot, &sky, &small, &sky];
        // The display image read back (a float output) covers the image: the
        // default configuration asks for it too, on the same kept renderers.
        let wants = match config == GpuConfig::default() {
            true => vec![OutputKind::Linear, OutputKind::Encoded],
            false => vec![OutputKind::Encoded],
        };
        for ((i, img), &want) in order
            .iter()
            .enumerate()
            .flat_map(|io| wants.iter().map(move |w| (io, w)))
        {
            let fresh = tone_map(img, &pipeline, Some((&ctx, config)), want).unwrap();
            let reused = tone_map_until(img, &pipeline, Some((&mut kept, config)), want, &|| false)
                .unwrap()
                .unwrap();
            let what = format!("image {i} ({config:?}, {want:?})");
            if want == OutputKind::Linear {
                let (a, b) = (
                    reused.image.linear().unwrap(),
                    fresh.image.linear().unwrap(),
                );
                assert_eq!((a.width, a.height), (img.width, img.height), "{what}");
                assert!(a.pixels == b.pixels, "{what}: display differs");
            }
            let (reused_frame, fresh_frame) = (reused.image.encoded(), fresh.image.encoded());
            assert_eq!(
                reused_frame.is_some(),
                want == OutputKind::Encoded,
                "{what}"
            );
            match config.reduction {
                // Blocks and 2×2 levels start at the corner whatever the
                // textures' size: the same partials, merged in the same
                // order with empty ones between, which change nothing.
                ReductionMethod::BlockPartials | ReductionMethod::PingPong => {
                    assert!(reused_frame == fresh_frame, "{what}: frame differs");
                    assert_eq!(
                        format!("{:?}", reused.report.stats),
                        format!("{:?}", fresh.report.stats),
                        "{what}"
                    );
                }
                // The trees merge the tiles' partials in pairs set by the
                // tile grid, which the class widens: the same sums in
                // another order. Tolerance: compensated f32 merges of at
                // most 24 576 pixels differ by a few ε (1.2e-7) relative,
                // and a frame by at most one code where a value sits on a
                // rounding boundary.
                _ => {
                    let (a, b) = (&reused.report.stats, &fresh.report.stats);
                    for (name, x, y) in [
                        ("log_average", a.log_average, b.log_average),
                        ("weighted", a.weighted_log_average, b.weighted_log_average),
                        ("min", a.min, b.min),
                        ("max", a.max, b.max),
                        ("weight_sum", a.weight_sum, b.weight_sum),
                    ] {
                        let (x, y) = (x.unwrap(), y.unwrap());
                        assert!((x - y).abs() <= 1e-6 * y.abs(), "{what}: {name} {x} {y}");
                    }
                    let (fa, fb) = (reused_frame.unwrap(), fresh_frame.unwrap());
                    assert_eq!((fa.width, fa.height), (fb.width, fb.height), "{what}");
                    let worst = fa
                        .pixels
                        .iter()
                        .zip(&fb.pixels)
                        .flat_map(|(p, q)| (0..3).map(move |c| p[c].abs_diff(q[c])))
                        .max();
                    assert!(worst <= Some(1), "{what}: {worst:?} codes apart");
                }
            }
        }
        // Every image but `small` shares one renderer of class 192×128.
        assert_eq!(kept.len(), 2, "{config:?}");
        assert_eq!(kept.pixels(), 192 * 128 + 64 * 64, "{config:?}");
    }

    // The budget, in pixels of the kept renderers' textures: the least
    // recently used renderer goes when a new one has no room beside it, one
    // over the budget alone renders its image and is not kept, and an image
    // within the budget whose class is not gets a renderer of its own size.
    let budget = 192 * 128 + 64 * 64;
    let mut kept = RendererPool::with_limits(&ctx, 3, budget);
    let medium = tonegate::env::BuiltinEnv::Night.generate(100, 50);
    let large = tonegate::env::BuiltinEnv::Sky.generate(200, 150);
    let snug = tonegate::env::BuiltinEnv::Sky.generate(170, 168);
    assert!(170 * 168 <= budget && size_class(170, 168, limit) == (192, 192));
    let expect = [
        (&night, vec![(192, 128)]),
        (&small, vec![(192, 128), (64, 64)]),
        // night must go: 192·128 + 64·64 + 128·64 is over the budget.
        (&medium, vec![(64, 64), (128, 64)]),
        (&large, vec![]),
        (&small, vec![(64, 64)]),
        (&snug, vec![(170, 168)]),
    ];
    for (i, (img, classes)) in expect.iter().enumerate() {
        let encoded = OutputKind::Encoded;
        let fresh = tone_map(img, &pipeline, Some((&ctx, GpuConfig::default())), encoded).unwrap();
        let reused = tone_map_until(
            img,
            &pipeline,
            Some((&mut kept, GpuConfig::default())),
            encoded,
            &|| false,
        )
        .unwrap()
        .unwrap();
        assert!(
            reused.image.encoded().is_some() && reused.image.encoded() == fresh.image.encoded(),
            "budget image {i}: frame differs"
        );
        assert_eq!(kept.len(), classes.len(), "budget image {i}");
        assert_eq!(
            kept.pixels(),
            classes
                .iter()
                .map(|&(w, h)| w as u64 * h as u64)
                .sum::<u64>(),
            "budget image {i}"
        );
        assert!(kept.pixels() <= budget);
    }
    // An image wider than the adapter allows is refused without dropping
    // the renderers kept.
    let limit = ctx.limits.max_texture_dimension_2d;
    let wide = tonegate::env::BuiltinEnv::Night.generate(limit + 1, 1);
    let refused = tone_map_until(
        &wide,
        &pipeline,
        Some((&mut kept, GpuConfig::default())),
        OutputKind::Encoded,
        &|| false,
    )
    .map(|_| ())
    .unwrap_err()
    .to_string();
    assert!(refused.contains("texture limit"), "{refused}");
    assert_eq!(kept.len(), 1, "the kept renderer survives a refused image");

    // A frame within the texture limit whose largest buffer (8 bytes a
    // pixel) is over the adapter's buffer limits is refused before anything
    // is created; one row fewer is taken. (llvmpipe: 16384-pixel textures,
    // 128 MiB storage bindings, so the refusal is exercised here.)
    let buffers = ctx
        .limits
        .max_storage_buffer_binding_size
        .min(ctx.limits.max_buffer_size);
    let rows = (buffers / 8 / limit as u64 + 1) as u32;
    if ctx.adapter.name.contains("llvmpipe") {
        assert!(rows <= limit, "{buffers} bytes, {limit} pixels a side");
    }
    if rows <= limit {
        let refused = ctx.check_frame(limit, rows).unwrap_err().to_string();
        assert!(refused.contains("buffer limit"), "{refused}");
        ctx.check_frame(limit, rows - 1).unwrap();
    } else {
        ctx.check_frame(limit, limit).unwrap();
    }
}

/// `tonegate render` writes the frames it renders with frames in flight:
/// every PNG, in order, is the frame one-at-a-time rendering gives, and
/// frames.json lists them in order with their statistics.
#[test]
fn the_render_command_writes_every_frame_in_order() {
    use tonegate::render::SceneRenderer;
    let dir = tempfile::tempdir().unwrap();
    let scene_path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("golden/scenes/night-auto-key-bloom.toml");
    let o = common::tonegate(&[
        "render",
        scene_path.to_str().unwrap(),
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let scene = Scene::load(&scene_path).unwrap();
    let env = scene_environment(&scene).unwrap();
    let ctx = context();
    let serial = SceneRenderer::gpu(&scene, &env, &ctx, GpuConfig::default(), 1).unwrap();
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("frames.json")).unwrap())
            .unwrap();
    let listed = report["frames"].as_array().unwrap();
    assert_eq!(listed.len(), scene.frames as usize);
    for n in 0..scene.frames {
        assert_eq!(listed[n as usize]["frame"], n);
        assert!(listed[n as usize]["stats"]["weighted_log_average"].is_number());
        let file = dir.path().join(tonegate::golden::frame_file(n));
        let written = tonegate::io::read_frame_png(&file).unwrap();
        assert!(
            written == serial.frame(n).unwrap().image,
            "frame {n}: the written PNG is not the frame"
        );
    }
}
