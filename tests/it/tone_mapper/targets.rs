//! What the tone mapper writes in every target format, by each path, on
//! each adapter here, against the gate's frame: the targets' table, a mip
//! level's region, bloom and grade.

use super::*;
use tonegate::gpu::tone_mapper::TARGET_FORMATS;
use tonegate::gpu::{AdapterChoice, SourceView, TargetView};
use tonegate::{ToneMapper, ToneMapperSettings};

/// The f16 value `h` and the ends of what it may have been before it was
/// rounded: Vulkan lets a float-to-half conversion round to nearest or
/// towards zero, so within one unit in the last place, 2^-10 relative, or
/// 2^-24 absolute among the subnormals.
fn f16_span(h: half::f16) -> [f64; 3] {
    let v = f64::from(h.to_f32());
    let e = v.abs() * 2f64.powi(-10) + 2f64.powi(-24);
    [v - e, v, v + e]
}

/// How far `got` (the pixels of a `target` texture) is from the gate's
/// `frame`, in units of the bound each pixel's derivation gives; ≤ 1
/// passes.
///
/// - 8-bit targets: the same codes; any difference is infinitely far.
/// - 10-bit codes c₁₀ of an encoding the gate writes in 8 (or 16, PQ)
///   bits c: both are the same f32 signal s on this adapter rounded half
///   up, |1023·s − c₁₀| ≤ ½ and |N·s − c| ≤ ½, so |c₁₀·N/1023 − c| ≤
///   ½ + ½·N/1023, plus 10⁻³ for the f32 products' own rounding.
/// - scRGB: the f16 stored is the light v the gate encoded, rounded
///   (`f16_span`); the gate's code is within ½ of N·signal(v), and the
///   signal rises with every channel's light (the BT.2020 matrix has no
///   negative entry), so the code is within ½ of [N·signal(lo),
///   N·signal(hi)] over the span's ends, plus 10⁻³ for f32 against f64.
fn worst(
    got: &[Texel],
    target: wgpu::TextureFormat,
    frame: &Frame,
    encoding: Encoding,
    op: &Operator,
) -> f64 {
    let (top, codes): (f64, Vec<[u16; 3]>) = match frame {
        Frame::Rgb8(i) => (255.0, i.pixels.iter().map(|p| p.map(u16::from)).collect()),
        Frame::Pq16(i) => (65535.0, i.pixels.clone()),
    };
    assert_eq!(got.len(), codes.len());
    let peak = op.display_levels().map_or(1.0, |l| l.peak);
    let m = tonegate::color::bt709_to_bt2020();
    // The gate's signal, channel `k`, of linear light (display-relative for
    // SDR, scRGB for PQ).
    let signal = |light: [f64; 3], k: usize| -> f64 {
        match encoding {
            Encoding::Srgb => tonegate::reference::encode::srgb_oetf(light[k].clamp(0.0, 1.0)),
            Encoding::Gamma(g) => light[k].clamp(0.0, 1.0).powf(1.0 / g.get()),
            Encoding::Pq => {
                let nits: f64 = (0..3).map(|j| m[k][j] * light[j] * 80.0).sum();
                tonegate::color::pq_encode(nits.clamp(0.0, peak))
            }
        }
    };
    let mut worst = 0f64;
    for (g, want) in got.iter().zip(&codes) {
        for k in 0..3 {
            let c = f64::from(want[k]);
            let ratio = match (g, target) {
                (Texel::Codes(got), F::Rgb10a2Unorm) => {
                    let bound = 0.5 + 0.5 * top / 1023.0 + 1e-3;
                    (f64::from(got[k]) * top / 1023.0 - c).abs() / bound
                }
                (Texel::Codes(got), _) if got[k] == want[k] => 0.0,
                (Texel::Codes(_), _) => f64::INFINITY,
                (Texel::Half(h), _) => {
                    let spans = h.map(f16_span);
                    let lo = top * signal(spans.map(|s| s[0]), k);
                    let hi = top * signal(spans.map(|s| s[2]), k);
                    (lo - c).max(c - hi).max(0.0) / (0.5 + 1e-3)
                }
            };
            worst = worst.max(ratio);
        }
    }
    worst
}

/// Every operator at its defaults (and a gamma, and PQ for the operator
/// with display levels), into every target format by every path the
/// device allows, against the gate's frame on the same adapter.
fn every_target_on(adapter: &str) {
    let ours = GpuContext::new(&adapter.parse::<AdapterChoice>().unwrap()).unwrap();
    let (device, queue) = own_device(adapter);
    let img = night_and_ramp();
    let input = hdr_input(&device, &queue, &img);
    let input_view = view(&input);
    let gamma = Encoding::Gamma(tonegate::scene::Positive::try_from(2.4).unwrap());
    let mut cases: Vec<(Operator, Encoding)> = tonegate::operators::names()
        .into_iter()
        .map(|name| (Operator::named(name, &[]).unwrap(), Encoding::Srgb))
        .collect();
    let with_levels = cases
        .iter()
        .find(|(op, _)| op.display_levels().is_some())
        .expect("an operator with display levels")
        .0
        .clone();
    cases.push((cases[0].0.clone(), gamma));
    cases.push((with_levels, Encoding::Pq));
    let mut table = Vec::new();
    for (op, encoding) in &cases {
        let frame = tonegate_frame(&ours, &img, op, *encoding);
        let mut mapper: Option<ToneMapper> = None;
        for target in TARGET_FORMATS {
            if *encoding == Encoding::Pq
                && matches!(
                    target,
                    F::Rgba8Unorm | F::Rgba8UnormSrgb | F::Bgra8Unorm | F::Bgra8UnormSrgb
                )
            {
                continue;
            }
            let mut by_path = Vec::new();
            for path in paths(&device, target) {
                let settings = ToneMapperSettings {
                    operator: op.clone(),
                    encoding: *encoding,
                    target,
                    path,
                    adaptation: None,
                    bloom: None,
                    grade: None,
                    taa: None,
                };
                let m = match mapper.as_mut() {
                    Some(m) => {
                        m.set_settings(settings).unwrap();
                        m
                    }
                    None => mapper.insert(ToneMapper::new(&device, &queue, settings).unwrap()),
                };
                let output = texture(&device, (img.width, img.height), 1, target, usage_for(path));
                let mut encoder = device.create_command_encoder(&Default::default());
                m.record(&mut encoder, &input_view, &view(&output)).unwrap();
                queue.submit([encoder.finish()]);
                let got = read(&device, &queue, &output, 0);
                let w = worst(&got, target, &frame, *encoding, op);
                assert!(
                    w <= 1.0,
                    "{adapter} {} {encoding:?} into {target:?} by {path:?}: {w:.3}x the bound",
                    op.name()
                );
                table.push(format!(
                    "{adapter} {} {encoding:?} {target:?} {path:?} {w:.3}",
                    op.name()
                ));
                by_path.push(got);
            }
            // Both paths, the same bits.
            if let [a, b] = &by_path[..] {
                assert!(
                    a == b,
                    "{adapter} {} {target:?}: the paths differ",
                    op.name()
                );
            }
        }
    }
    // What each target, path and adapter measured (with --nocapture).
    for row in table {
        println!("{row}");
    }
}

#[test]
fn every_target_format_and_path_gets_the_gates_frame_on_lavapipe() {
    every_target_on("llvmpipe");
}

#[test]
fn every_target_format_and_path_gets_the_gates_frame_on_swiftshader() {
    every_target_on("swiftshader");
}

#[test]
fn every_target_format_and_path_gets_the_gates_frame_on_gl() {
    every_target_on("gl:llvmpipe");
}

/// A game's views: the HDR image at mip level 1 of its texture, smaller
/// than the level (dynamic resolution), into a region of mip level 1 of
/// the target, by both paths. The region holds the gate's frame; every
/// other texel of the level keeps what the application put there.
#[test]
fn a_region_of_a_mip_level_holds_the_gates_frame_and_the_rest_is_kept() {
    let ours = GpuContext::new(&AdapterChoice::default()).unwrap();
    let (device, queue) = own_device("llvmpipe");
    let img = night_and_ramp();
    let (w, h) = (img.width, img.height);
    let input = hdr_input_in(&device, &queue, &img, (2 * w + 9, 2 * h + 3), 2, 1);
    let input_view = level_view(&input, 1);
    let op = Operator::named("agx", &[]).unwrap();
    let want = tonegate_frame(&ours, &img, &op, Encoding::Srgb);
    let want = want.as_rgb8().unwrap();
    let (origin, level) = ((7, 5), (w + 20, h + 12));
    for path in [OutputPath::Compute, OutputPath::RenderPass] {
        let output = texture(
            &device,
            (2 * level.0, 2 * level.1),
            3,
            F::Rgba8Unorm,
            usage_for(path) | U::COPY_DST,
        );
        // The application's own texels: a pattern in level 1.
        let pattern: Vec<u8> = (0..level.0 * level.1 * 4)
            .map(|i| if i % 4 == 3 { 255 } else { (i % 251) as u8 })
            .collect();
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &output,
                mip_level: 1,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            &pattern,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(level.0 * 4),
                rows_per_image: None,
            },
            wgpu::Extent3d {
                width: level.0,
                height: level.1,
                depth_or_array_layers: 1,
            },
        );
        let output_view = level_view(&output, 1);
        let mut mapper = ToneMapper::new(
            &device,
            &queue,
            ToneMapperSettings {
                operator: op.clone(),
                path,
                target: wgpu::TextureFormat::Rgba8Unorm,
                ..Default::default()
            },
        )
        .unwrap();
        let mut encoder = device.create_command_encoder(&Default::default());
        mapper
            .record(
                &mut encoder,
                SourceView::from(&input_view).at_level(1).with_size(w, h),
                TargetView::from(&output_view)
                    .at_level(1)
                    .at(origin.0, origin.1),
            )
            .unwrap();
        queue.submit([encoder.finish()]);
        let got = read(&device, &queue, &output, 1);
        let (mut inside, mut kept) = (0, 0);
        for y in 0..level.1 {
            for x in 0..level.0 {
                let i = (y * level.0 + x) as usize;
                let (rx, ry) = (x.wrapping_sub(origin.0), y.wrapping_sub(origin.1));
                let Texel::Codes(c) = got[i] else {
                    unreachable!()
                };
                if rx < w && ry < h {
                    let p = want.pixels[(ry * w + rx) as usize];
                    assert_eq!(c, p.map(u16::from), "{path:?} ({x}, {y})");
                    inside += 1;
                } else {
                    let p = &pattern[i * 4..][..3];
                    assert_eq!(
                        c,
                        [p[0], p[1], p[2]].map(u16::from),
                        "{path:?} kept ({x}, {y})"
                    );
                    kept += 1;
                }
            }
        }
        assert_eq!((inside, kept), (w * h, level.0 * level.1 - w * h));
    }
}

/// Bloom and grade in the embedding: the plan `StagePlan::build` makes for
/// them, wired by tonegate's own renderer's code, so the gate's frame, bit
/// for bit, into an 8-bit storage target and a swap chain's render target,
/// on every adapter here.
#[test]
fn bloom_and_grade_in_the_embedding_give_the_gates_frame() {
    let scaled: Bloom = toml::from_str(
        "bright_pass = \"scaled\"\nthreshold = 0.6\ndownsample = 2\nradius = 5\nsigma = 2.5\nstrength = 0.7",
    )
    .unwrap();
    let threshold: Bloom = toml::from_str(
        "bright_pass = \"threshold\"\nthreshold = 0.8\ndownsample = 3\nradius = 4\nsigma = 2.0\nstrength = 0.5",
    )
    .unwrap();
    let grade: Grade =
        toml::from_str("brightness = 1.05\ncontrast = 1.2\nsaturation = 0.8").unwrap();
    let cases = [
        ("reinhard-auto-key", Some(scaled), Some(grade.clone())),
        ("agx", Some(threshold), None),
        ("hable", None, Some(grade)),
    ];
    let img = night_and_ramp();
    for adapter in ["llvmpipe", "swiftshader", "gl:llvmpipe"] {
        let ours = GpuContext::new(&adapter.parse::<AdapterChoice>().unwrap()).unwrap();
        let (device, queue) = own_device(adapter);
        let input = view(&hdr_input(&device, &queue, &img));
        for (name, bloom, grade) in &cases {
            let op = Operator::named(name, &[]).unwrap();
            let want = tonegate_frame_with(
                &ours,
                &img,
                &op,
                Encoding::Srgb,
                bloom.as_ref(),
                grade.as_ref(),
            );
            for (target, path) in [
                (F::Rgba8Unorm, OutputPath::Compute),
                (F::Bgra8UnormSrgb, OutputPath::RenderPass),
            ] {
                let mut mapper = ToneMapper::new(
                    &device,
                    &queue,
                    ToneMapperSettings {
                        operator: op.clone(),
                        target,
                        path,
                        bloom: bloom.clone(),
                        grade: grade.clone(),
                        ..Default::default()
                    },
                )
                .unwrap();
                let output = texture(&device, (img.width, img.height), 1, target, usage_for(path));
                let mut encoder = device.create_command_encoder(&Default::default());
                mapper.record(&mut encoder, &input, &view(&output)).unwrap();
                queue.submit([encoder.finish()]);
                let got = read(&device, &queue, &output, 0);
                let w = worst(&got, target, &want, Encoding::Srgb, &op);
                assert!(w == 0.0, "{adapter} {name} into {target:?}: {w}");
            }
        }
    }
}
