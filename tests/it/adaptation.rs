//! Eye adaptation, in `tonegate::ToneMapper` on a device opened with wgpu
//! alone (lavapipe): across a sudden light change and back, the adapted
//! luminance the GPU carries from frame to frame against the f64
//! reference's (`reference::adaptation`) fed the same frames, and the
//! frames themselves against the f64 pipeline with the adapted statistics;
//! and in the gate's scenes: the GPU's curve against the golden one, which
//! a wrong time constant misses, and the reference's frames asked out of
//! order.

use crate::tone_mapper::{hdr_input, night_and_ramp, own_device, read, texture, view, Texel};
use tonegate::image::HdrImage;
use tonegate::operators::Operator;
use tonegate::reference::adaptation::{adapt, Adapted, Metered};
use tonegate::reference::{encode, luminance_stats, tonemap};
use tonegate::scene::{Adaptation, Encoding};
use tonegate::{ToneMapper, ToneMapperError, ToneMapperSettings};

const DT: f64 = 1.0 / 60.0;

/// The light of frame `n`: dim, then 30 times brighter from frame 20 (a
/// door opened), then dim again from frame 80.
fn light(n: u32) -> f32 {
    if (20..80).contains(&n) {
        30.0
    } else {
        1.0
    }
}

fn scaled(img: &HdrImage, s: f32) -> HdrImage {
    HdrImage::from_fn(img.width, img.height, |x, y| {
        img.pixels[(x + img.width * y) as usize].map(|v| v * s)
    })
}

/// The adapted luminance per frame, GPU and f64, for `op` over 140
/// frames; every 20th frame's bytes against the f64 pipeline.
fn follow(op: Operator) -> Vec<(u32, f32, f64, f64)> {
    let (device, queue) = own_device("llvmpipe");
    let img = night_and_ramp();
    let dim = scaled(&img, 1.0);
    let bright = scaled(&img, 30.0);
    let inputs = [
        view(&hdr_input(&device, &queue, &dim)),
        view(&hdr_input(&device, &queue, &bright)),
    ];
    let output = texture(
        &device,
        (img.width, img.height),
        1,
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
    );
    let out_view = view(&output);
    let adaptation = Adaptation::new(0.25, 0.8, 0.18).unwrap();
    let mut mapper = ToneMapper::new(
        &device,
        &queue,
        ToneMapperSettings {
            operator: op.clone(),
            adaptation: Some(adaptation),
            target: wgpu::TextureFormat::Rgba8Unorm,
            ..Default::default()
        },
    )
    .unwrap();
    mapper.set_frame_seconds(DT).unwrap();
    mapper.prepare().unwrap();
    let compiled = mapper.compiled_pipelines();
    assert_eq!(
        mapper.read_adapted_luminance().unwrap(),
        None,
        "no frame yet"
    );
    let needs = op.needs();
    let lum = op.luminance();
    let measure = |i: &HdrImage| {
        luminance_stats::luminance_stats(
            &i.to_linear(),
            needs.with_log_average(),
            lum.weights,
            lum.delta,
        )
    };
    let measured = [measure(&dim), measure(&bright)];
    let mut cpu: Option<Adapted> = None;
    let mut curve = Vec::new();
    for n in 0..140u32 {
        let k = usize::from(light(n) > 1.0);
        let mut encoder = device.create_command_encoder(&Default::default());
        mapper.record(&mut encoder, &inputs[k], &out_view).unwrap();
        queue.submit([encoder.finish()]);
        let gpu = mapper.read_adapted_luminance().unwrap().unwrap();
        let next = adapt(
            Metered::log_average(&measured[k]),
            cpu.as_ref(),
            &adaptation,
            DT,
        );
        cpu = Some(next);
        curve.push((n, light(n), gpu, next.log_average.exp()));
        if n % 20 == 19 {
            // The f64 pipeline with the f64 adapted statistics: the
            // operator's resolve step, the input scaled by the
            // auto-exposure, the curve, the encoding.
            let stats = next.statistics(&measured[k]);
            let tone = op.resolve(&stats).unwrap();
            let exposure = next.exposure(&adaptation, needs);
            let input = [&dim, &bright][k].to_linear();
            let input = input.map(|p| p.map(|v| v * exposure));
            let want = encode::encode(&tonemap::tonemap(&input, &tone), Encoding::Srgb);
            let got = read(&device, &queue, &output, 0);
            // The statistics' f32 error (1e-5 relative) and the curve's
            // (1e-4) move a value by far less than a code: a code differs
            // only where its value lies on a rounding boundary, by one.
            let mut off = 0;
            for (g, w) in got.iter().zip(&want.pixels) {
                let Texel::Codes(g) = g else { unreachable!() };
                for c in 0..3 {
                    let d = (i32::from(g[c]) - i32::from(w[c])).abs();
                    assert!(d <= 1, "{} frame {n}: a code {d} off", op.name());
                    off += usize::from(d == 1);
                }
            }
            assert!(
                off * 100 <= got.len() * 3,
                "{} frame {n}: {off} codes one off",
                op.name()
            );
        }
    }
    assert_eq!(
        mapper.compiled_pipelines(),
        compiled,
        "nothing compiled after prepare"
    );
    curve
}

/// The bound on |ln L_gpu − ln L_f64| over a sequence: the measurement's
/// (the statistics' established 1e-5 relative, so 1e-5 in ln), which the
/// recursion a + (m − a)·α, a convex combination, never amplifies; plus
/// each frame's f32 rounding (ln, the step, exp: at most 4 ulp of the
/// largest |ln L|, 2^-22·6) left over from every earlier frame, damped by
/// (1 − α) a frame, so at most its 1/α_min.
fn curve_bound(adaptation: &Adaptation) -> f64 {
    let (up, down) = adaptation.steps(DT);
    1e-5 + 2f64.powi(-22) * 6.0 / up.min(down)
}

fn check_curve(name: &str, curve: &[(u32, f32, f64, f64)]) -> f64 {
    let bound = curve_bound(&Adaptation::new(0.25, 0.8, 0.18).unwrap());
    let mut worst = 0f64;
    for &(n, _, gpu, cpu) in curve {
        let e = (gpu.ln() - cpu.ln()).abs();
        assert!(
            e <= bound,
            "{name} frame {n}: gpu {gpu} f64 {cpu} ({e:.2e} > {bound:.2e})"
        );
        worst = worst.max(e / bound);
    }
    // The curve adapts: it rises after the light change, not at once, and
    // falls back more slowly than it rose.
    let at = |n: usize| curve[n].3;
    assert!(at(20) > at(19) && at(21) > at(20) && at(79) > at(21));
    assert!(at(20) < at(79) / 3.0, "no jump at the change");
    let rise = (at(30) / at(19)).ln();
    let fall = (at(79) / at(89)).ln();
    assert!(rise > fall, "light adaptation is faster than dark");
    worst
}

#[test]
fn the_adapted_luminance_follows_a_light_change_as_its_f64_reference_does() {
    let mut report = Vec::new();
    // Keys on the log average, which adaptation replaces.
    let reinhard = Operator::default();
    assert!(reinhard.needs().log_average);
    let curve = follow(reinhard);
    report.push(("reinhard-global", check_curve("reinhard", &curve), curve));
    // Keys on nothing: auto-exposure, key over the adapted luminance.
    let agx = Operator::named("agx", &[]).unwrap();
    assert!(!agx.needs().any());
    let curve = follow(agx);
    report.push(("agx", check_curve("agx", &curve), curve));
    for (name, worst, curve) in &report {
        println!("{name}: worst {worst:.3} of the bound");
        for (n, light, gpu, cpu) in curve.iter().step_by(5) {
            println!("{name} frame {n:3} light {light:4} adapted gpu {gpu:.6} f64 {cpu:.6}");
        }
    }
}

#[test]
fn a_reset_adapts_at_once_and_a_bad_frame_time_is_refused() {
    let (device, queue) = own_device("llvmpipe");
    let img = night_and_ramp();
    let dim = view(&hdr_input(&device, &queue, &img));
    let bright = view(&hdr_input(&device, &queue, &scaled(&img, 30.0)));
    let output = texture(
        &device,
        (img.width, img.height),
        1,
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::STORAGE_BINDING,
    );
    let out = view(&output);
    let mut mapper = ToneMapper::new(
        &device,
        &queue,
        ToneMapperSettings {
            // The night map and the ramp reach past the default range
            // (−6…8 EV), whose end bins would hold them: a range that holds
            // both frames, so that 30 times brighter meters ~4.9 EV up.
            adaptation: Some(Adaptation {
                min_ev: -16.0,
                max_ev: 16.0,
                ..Adaptation::default()
            }),
            target: wgpu::TextureFormat::Rgba8Unorm,
            ..Default::default()
        },
    )
    .unwrap();
    let frame = |mapper: &mut ToneMapper, input| {
        let mut encoder = device.create_command_encoder(&Default::default());
        mapper.record(&mut encoder, input, &out).unwrap();
        queue.submit([encoder.finish()]);
        mapper.read_adapted_luminance().unwrap().unwrap()
    };
    // What the bright frame measures: a fresh mapper's first frame.
    let settings = mapper.settings().clone();
    let at_bright = frame(
        &mut ToneMapper::new(&device, &queue, settings).unwrap(),
        &bright,
    );
    let at_dim = frame(&mut mapper, &dim);
    assert!(at_bright > at_dim * 10.0, "{at_dim} {at_bright}");
    let step = frame(&mut mapper, &bright);
    assert!(
        step > at_dim * 1.01 && step < at_bright * 0.5,
        "{at_dim} {step}"
    );
    mapper.reset_adaptation();
    let cut = frame(&mut mapper, &bright);
    assert_eq!(cut, at_bright);
    // A frame time of 0 holds the adapted luminance.
    mapper.set_frame_seconds(0.0).unwrap();
    let held = frame(&mut mapper, &dim);
    assert_eq!(held, cut);
    for bad in [-1.0 / 60.0, f64::NAN, f64::INFINITY] {
        let e = mapper.set_frame_seconds(bad).unwrap_err();
        assert!(matches!(e, ToneMapperError::FrameSeconds { .. }), "{e:?}");
        assert!(e.to_string().starts_with("frame time"), "{e}");
    }
}

pub(crate) fn golden_root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("golden")
}

/// The luminance each frame of `scene` was adapted to, on `renderer`.
pub(crate) fn curve_of(renderer: &tonegate::render::SceneRenderer) -> Vec<f64> {
    renderer.sequence(|_| {}).unwrap().adapted
}

#[test]
fn the_gates_adapting_scenes_follow_their_golden_curves_and_a_wrong_time_constant_does_not() {
    use tonegate::gpu::{AdapterChoice, GpuConfig, GpuContext};
    use tonegate::render::{scene_environment, SceneRenderer};
    let ctx = GpuContext::new(&AdapterChoice::default()).unwrap();
    for name in ["interior-agx-adaptation", "night-reinhard-adaptation"] {
        let scene =
            tonegate::scene::Scene::load(&golden_root().join(format!("scenes/{name}.toml")))
                .unwrap();
        let golden =
            tonegate::golden::read_adaptation_curve(&golden_root(), name, scene.frames).unwrap();
        let env = scene_environment(&scene).unwrap();
        let spp = scene.reference_spp;
        let worst = |curve: &[f64]| {
            curve
                .iter()
                .zip(&golden)
                .map(|(a, g)| (a.ln() - g.ln()).abs())
                .fold(0.0, f64::max)
        };
        // The scene's own bound (docs/adaptation.md's derivation).
        let bound = 1.5e-4;
        let gpu = SceneRenderer::gpu(&scene, &env, &ctx, GpuConfig::default(), spp).unwrap();
        let on_gpu = worst(&curve_of(&gpu));
        assert!(on_gpu <= bound, "{name}: {on_gpu:.3e}");
        // Light adaptation twice as slow: off the curve by far more.
        let mut slow = scene.clone();
        let a = slow.adaptation.as_mut().unwrap();
        a.up = tonegate::scene::Positive::try_from(a.up.get() * 2.0).unwrap();
        let gpu = SceneRenderer::gpu(&slow, &env, &ctx, GpuConfig::default(), spp).unwrap();
        let slowed = worst(&curve_of(&gpu));
        assert!(slowed > 100.0 * bound, "{name}: {slowed:.3e}");
        // The reference, asked for frames out of order, replays from frame
        // 0: each frame's curve value is the golden's exactly.
        let cpu = SceneRenderer::cpu(&scene, &env, spp);
        for n in [10, 3, 4, 20, 0] {
            let f = cpu.frame(n).unwrap();
            assert_eq!(
                f.log_average(),
                Some(golden[n as usize]),
                "{name} frame {n}"
            );
        }
        println!("{name}: GPU curve worst |Δ ln| {on_gpu:.3e}; up x2: {slowed:.3e}");
    }
}

/// `sphere` under a `[[light]]` step: the GPU's frame at light 25 is its
/// frame at light 1 times 25, one f32 product a sample (the reference
/// scales its f64 frame the same way), and the adaptation stage sits after
/// the statistics in the GPU's plan, as in the reference's.
#[test]
fn the_light_step_scales_the_gpus_sphere_frame_by_one_product() {
    use tonegate::conventions::rotation_matrix;
    use tonegate::gpu::{AdapterChoice, GpuConfig, GpuContext};
    let ctx = GpuContext::new(&AdapterChoice::default()).unwrap();
    let scene =
        tonegate::scene::Scene::load(&golden_root().join("scenes/interior-agx-adaptation.toml"))
            .unwrap();
    let env = tonegate::render::scene_environment(&scene).unwrap();
    let r = crate::common::scene_renderer(&ctx, &scene, &env, GpuConfig::default());
    assert_eq!(
        r.plan.names(),
        [
            "sphere",
            "luminance_stats",
            "adaptation",
            "tonemap",
            "encode"
        ]
    );
    let n = 7;
    assert_eq!(scene.light(n), 25.0);
    let frame_at = |light: f64| {
        r.set_light(light);
        r.set_adaptation(true);
        r.set_rotation(&rotation_matrix(scene.rotation.axis, scene.angle(n)));
        r.render(false).unwrap();
        r.read_output("sphere").unwrap().unwrap()
    };
    let unlit = frame_at(1.0);
    let lit = frame_at(scene.light(n));
    let mut checked = 0;
    for (a, b) in unlit.pixels.iter().zip(&lit.pixels) {
        for k in 0..3 {
            assert_eq!(b[k] as f32, a[k] as f32 * 25.0);
            checked += usize::from(a[k] > 0.0);
        }
    }
    assert!(checked > unlit.pixels.len(), "the frame is not black");
}

/// One pixel above f16's range (+inf in an `Rgba16Float` input: a sun, a
/// specular spike) on one frame: the adapted luminance stays what it was
/// (that frame's measurement never enters the state), and the frames after
/// it are mapped as before, not black. It used to turn the adapted value
/// into NaN for good, every later frame all 0.
#[test]
fn an_overflowing_pixel_never_blacks_out_the_frames_after_it() {
    let (device, queue) = own_device("llvmpipe");
    let img = night_and_ramp();
    let (w, h) = (img.width, img.height);
    let half_input = |spike: bool| {
        let t = texture(
            &device,
            (w, h),
            1,
            wgpu::TextureFormat::Rgba16Float,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        );
        let mut texels: Vec<u16> = img
            .pixels
            .iter()
            .flat_map(|p| [p[0], p[1], p[2], 1.0].map(|c| half::f16::from_f32(c).to_bits()))
            .collect();
        if spike {
            for c in &mut texels[4 * 77..4 * 77 + 3] {
                *c = half::f16::INFINITY.to_bits();
            }
        }
        queue.write_texture(
            t.as_image_copy(),
            bytemuck::cast_slice(&texels),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(w * 8),
                rows_per_image: None,
            },
            t.size(),
        );
        t
    };
    let (calm, sun) = (half_input(false), half_input(true));
    let (calm, sun) = (view(&calm), view(&sun));
    let output = texture(
        &device,
        (w, h),
        1,
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
    );
    let out = view(&output);
    // Log-average metering holds the state on the spike's frame; the
    // histogram skips the pixel, so its frame is metered on the others:
    // one pixel fewer moves the kept mean by at most twice the range over
    // the weight kept (the cut moves by one pixel at each end).
    let log_average = Adaptation::new(0.4, 1.6, 0.18).unwrap();
    let histogram = Adaptation::default();
    let one_pixel = 2.0 * (histogram.max_ev - histogram.min_ev) * std::f64::consts::LN_2
        / ((histogram.high - histogram.low) * f64::from(w * h));
    for (operator, adaptation, moves) in [
        ("agx", log_average, 0.0),
        ("reinhard-global", log_average, 0.0),
        ("agx", histogram, one_pixel),
        ("reinhard-global", histogram, one_pixel),
    ] {
        let mut mapper = ToneMapper::new(
            &device,
            &queue,
            ToneMapperSettings {
                operator: Operator::named(operator, &[]).unwrap(),
                adaptation: Some(adaptation),
                target: wgpu::TextureFormat::Rgba8Unorm,
                ..Default::default()
            },
        )
        .unwrap();
        let mut frame = |input: &wgpu::TextureView| {
            let mut encoder = device.create_command_encoder(&Default::default());
            mapper.record(&mut encoder, input, &out).unwrap();
            queue.submit([encoder.finish()]);
            mapper.read_adapted_luminance().unwrap().unwrap()
        };
        let mut before = 0.0;
        for _ in 0..5 {
            before = frame(&calm);
        }
        let during = frame(&sun);
        assert!(
            (during.ln() - before.ln()).abs() <= moves,
            "{operator} {:?}: the spike's frame moved the state from {before} to {during}",
            adaptation.metering
        );
        let mut after = 0.0;
        for _ in 0..3 {
            after = frame(&calm);
        }
        assert!(after.is_finite() && after > 0.0, "{operator}: {after}");
        let lit = read(&device, &queue, &output, 0)
            .iter()
            .filter(|t| matches!(t, Texel::Codes(c) if c.iter().any(|&v| v > 0)))
            .count();
        assert!(
            lit > (w * h / 2) as usize,
            "{operator}: {lit} lit pixels after the spike"
        );
    }
}
