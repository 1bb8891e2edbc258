//! `tonegate::ToneMapper` inside an application that made its own device:
//! the device, queue, textures, views and command encoder are created here
//! with wgpu alone, and what it writes is tonegate's own renderer's frame
//! for the same image on the same adapter: bit for bit in every 8-bit
//! target, within the quantisation of the two encodings in the 10-bit and
//! scRGB ones, and the same bits by the compute and the render-pass path.

use tonegate::gpu::tone_mapper::TARGET_FORMATS;
use tonegate::gpu::{AdapterChoice, GpuConfig, GpuContext, GpuInput, GpuRenderer};
use tonegate::gpu::{OutputPath, SourceView, TargetView, TextureRole};
use tonegate::image::{Frame, HdrImage};
use tonegate::operators::{Operator, Value};
use tonegate::plan::{Input, StagePlan};
use tonegate::reference::Pipeline;
use tonegate::scene::{Bloom, Encoding, Grade};
use tonegate::{ToneMapper, ToneMapperError, ToneMapperSettings};
use wgpu::TextureFormat as F;
use wgpu::TextureUsages as U;

/// An application's own device on one of the adapters here, with no
/// features asked for but `BGRA8UNORM_STORAGE` where the adapter has it
/// (an application that stores into a BGRA swap chain would ask): a plain
/// `request_device`, as an application that knows nothing of tonegate
/// would open it. `adapter`: tonegate's `--adapter` for the same one.
pub(crate) fn own_device(adapter: &str) -> (wgpu::Device, wgpu::Queue) {
    let (backend, name) = match adapter {
        "llvmpipe" => (wgpu::Backends::VULKAN, "llvmpipe"),
        "swiftshader" => {
            // Where Debian's chromium puts it, outside the loader's folders.
            tonegate::gpu::adapters::add_extra_vulkan_drivers();
            (wgpu::Backends::VULKAN, "SwiftShader")
        }
        "gl:llvmpipe" => (wgpu::Backends::GL, "llvmpipe"),
        other => panic!("no adapter {other}"),
    };
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backend;
    let instance = wgpu::Instance::new(desc);
    let adapter = pollster::block_on(instance.enumerate_adapters(backend))
        .into_iter()
        .find(|a| a.get_info().name.contains(name))
        .unwrap_or_else(|| panic!("{adapter} is installed"));
    let features = adapter.features() & wgpu::Features::BGRA8UNORM_STORAGE;
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: features,
        required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
        ..Default::default()
    }))
    .expect("the adapter opens")
}

pub(crate) fn texture(
    device: &wgpu::Device,
    (w, h): (u32, u32),
    levels: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("application"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: levels,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

pub(crate) fn view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&Default::default())
}

fn level_view(t: &wgpu::Texture, level: u32) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor {
        base_mip_level: level,
        mip_level_count: Some(1),
        ..Default::default()
    })
}

/// `img` in the top-left corner of level `level` of a new `Rgba32Float`
/// texture of `levels` levels whose first level is `size`.
fn hdr_input_in(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    img: &HdrImage,
    size: (u32, u32),
    levels: u32,
    level: u32,
) -> wgpu::Texture {
    let t = texture(
        device,
        size,
        levels,
        F::Rgba32Float,
        U::TEXTURE_BINDING | U::COPY_DST,
    );
    let texels: Vec<f32> = img
        .pixels
        .iter()
        .flat_map(|p| [p[0], p[1], p[2], 1.0])
        .collect();
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture: &t,
            mip_level: level,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        bytemuck::cast_slice(&texels),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(img.width * 16),
            rows_per_image: None,
        },
        wgpu::Extent3d {
            width: img.width,
            height: img.height,
            depth_or_array_layers: 1,
        },
    );
    t
}

pub(crate) fn hdr_input(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    img: &HdrImage,
) -> wgpu::Texture {
    hdr_input_in(device, queue, img, (img.width, img.height), 1, 0)
}

/// One pixel of a target as read back: what its format holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Texel {
    /// R, G, B codes (8-bit formats in RGB order whatever the layout).
    Codes([u16; 3]),
    /// scRGB, as the half floats stored.
    Half([half::f16; 3]),
}

/// The pixels of `t`'s level `level`, as the application reads them back.
pub(crate) fn read(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    t: &wgpu::Texture,
    level: u32,
) -> Vec<Texel> {
    let (w, h) = ((t.width() >> level).max(1), (t.height() >> level).max(1));
    let bytes = t.format().block_copy_size(None).unwrap();
    let row = (w * bytes).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("application.readback"),
        size: (row * h) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: t,
            mip_level: level,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: None,
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    queue.submit([encoder.finish()]);
    buffer
        .slice(..)
        .map_async(wgpu::MapMode::Read, |r| r.unwrap());
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    let mapped = buffer.slice(..).get_mapped_range().unwrap();
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        let line = &mapped[(y * row) as usize..][..(w * bytes) as usize];
        for px in line.chunks_exact(bytes as usize) {
            out.push(match t.format() {
                F::Rgba8Unorm | F::Rgba8UnormSrgb => {
                    assert_eq!(px[3], 255, "alpha");
                    Texel::Codes([px[0], px[1], px[2]].map(u16::from))
                }
                F::Bgra8Unorm | F::Bgra8UnormSrgb => {
                    assert_eq!(px[3], 255, "alpha");
                    Texel::Codes([px[2], px[1], px[0]].map(u16::from))
                }
                F::Rgb10a2Unorm => {
                    let v = u32::from_le_bytes(px.try_into().unwrap());
                    assert_eq!(v >> 30, 3, "alpha");
                    Texel::Codes([v & 1023, (v >> 10) & 1023, (v >> 20) & 1023].map(|c| c as u16))
                }
                F::Rgba16Float => {
                    let h: Vec<half::f16> = px
                        .chunks_exact(2)
                        .map(|b| half::f16::from_le_bytes([b[0], b[1]]))
                        .collect();
                    assert_eq!(h[3], half::f16::ONE, "alpha");
                    Texel::Half([h[0], h[1], h[2]])
                }
                other => panic!("no target {other:?}"),
            });
        }
    }
    out
}

/// tonegate's own renderer on its own device for the same adapter: the
/// flat image's plan (statistics where the operator needs them, tonemap,
/// encode), its frame at the encoding's depth.
fn tonegate_frame(ctx: &GpuContext, img: &HdrImage, op: &Operator, encoding: Encoding) -> Frame {
    tonegate_frame_with(ctx, img, op, encoding, None, None)
}

/// [`tonegate_frame`] with a bloom and a grade in the plan.
fn tonegate_frame_with(
    ctx: &GpuContext,
    img: &HdrImage,
    op: &Operator,
    encoding: Encoding,
    bloom: Option<&Bloom>,
    grade: Option<&Grade>,
) -> Frame {
    let pipeline = Pipeline {
        operator: op,
        bloom,
        grade,
        encoding,
    };
    let plan = StagePlan::build(Input::Flat, op, bloom, grade);
    let r = GpuRenderer::new(
        ctx,
        plan,
        GpuInput::Flat(img),
        &pipeline,
        GpuConfig::default(),
    )
    .unwrap();
    r.render(true).unwrap().frame.unwrap()
}

pub(crate) fn night_and_ramp() -> HdrImage {
    // A size that is no multiple of a workgroup, a night map's decades and
    // a ramp over 1e-3…1e4.
    let night = tonegate::env::BuiltinEnv::Night.generate(150, 40);
    let ramp = HdrImage::ramp(150, 41, 1e-3, 1e4);
    HdrImage::from_fn(150, 81, |x, y| {
        if y < 40 {
            night.pixels[(x + 150 * y) as usize]
        } else {
            ramp.pixels[(x + 150 * (y - 40)) as usize]
        }
    })
}

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

/// The paths into a target of `format` on `device`.
fn paths(device: &wgpu::Device, format: wgpu::TextureFormat) -> Vec<OutputPath> {
    let storage = match format {
        F::Rgba8Unorm | F::Rgba16Float => true,
        F::Bgra8Unorm => device
            .features()
            .contains(wgpu::Features::BGRA8UNORM_STORAGE),
        _ => false,
    };
    if storage {
        vec![OutputPath::Compute, OutputPath::RenderPass]
    } else {
        vec![OutputPath::RenderPass]
    }
}

fn usage_for(path: OutputPath) -> wgpu::TextureUsages {
    match path {
        OutputPath::Compute => U::STORAGE_BINDING | U::COPY_SRC,
        _ => U::RENDER_ATTACHMENT | U::COPY_SRC,
    }
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

#[test]
fn views_and_settings_the_tone_mapper_cannot_use_are_refused_with_the_reason() {
    let (device, queue) = own_device("llvmpipe");
    let mut mapper = ToneMapper::new(&device, &queue, ToneMapperSettings::default()).unwrap();
    let hdr = |size, format| texture(&device, size, 1, format, U::TEXTURE_BINDING | U::COPY_DST);
    let ldr = |size, format| texture(&device, size, 1, format, U::STORAGE_BINDING | U::COPY_SRC);
    let good_in = hdr((64, 32), F::Rgba16Float);
    let good_out = ldr((64, 32), F::Rgba8Unorm);
    type Is = fn(&ToneMapperError) -> bool;
    type Case = (
        wgpu::Texture,
        u32,
        Option<(u32, u32)>,
        wgpu::Texture,
        Option<(u32, u32)>,
        Is,
        &'static str,
    );
    let cases: Vec<Case> = vec![
        (
            hdr((64, 32), F::Rgba8Unorm),
            0,
            None,
            good_out.clone(),
            None,
            |e| {
                matches!(
                    e,
                    ToneMapperError::InputFormat {
                        format: F::Rgba8Unorm
                    }
                )
            },
            "the input texture is Rgba8Unorm",
        ),
        (
            good_in.clone(),
            0,
            None,
            ldr((64, 32), F::Rgba16Float),
            None,
            |e| {
                matches!(
                    e,
                    ToneMapperError::OutputFormat {
                        format: F::Rgba16Float,
                        target: F::Rgba8Unorm
                    }
                )
            },
            "the output texture is Rgba16Float; the settings' target is Rgba8Unorm",
        ),
        (
            good_in.clone(),
            0,
            None,
            ldr((64, 31), F::Rgba8Unorm),
            None,
            |e| {
                matches!(
                    e,
                    ToneMapperError::SizeMismatch {
                        input: (64, 32),
                        output: (64, 31)
                    }
                )
            },
            "the input image is 64x32 and the output 64x31",
        ),
        (
            good_in.clone(),
            0,
            None,
            texture(&device, (64, 32), 1, F::Rgba8Unorm, U::COPY_SRC),
            None,
            // Neither storage nor an attachment: the render pass, the path
            // any format allows, is what it lacks.
            |e| matches!(e, ToneMapperError::MissingUsage { texture: TextureRole::Output, usage } if *usage == U::RENDER_ATTACHMENT),
            "the output texture lacks RENDER_ATTACHMENT usage",
        ),
        (
            texture(&device, (64, 32), 1, F::Rgba32Float, U::COPY_DST),
            0,
            None,
            good_out.clone(),
            None,
            |e| matches!(e, ToneMapperError::MissingUsage { texture: TextureRole::Input, usage } if *usage == U::TEXTURE_BINDING),
            "the input texture lacks TEXTURE_BINDING usage",
        ),
        (
            good_in.clone(),
            1,
            None,
            good_out.clone(),
            None,
            |e| {
                matches!(
                    e,
                    ToneMapperError::MipLevel {
                        texture: TextureRole::Input,
                        level: 1,
                        levels: 1
                    }
                )
            },
            "the input view's mip level 1 is past the texture's 1 levels",
        ),
        (
            good_in.clone(),
            0,
            Some((65, 32)),
            good_out.clone(),
            None,
            |e| {
                matches!(
                    e,
                    ToneMapperError::Outside {
                        texture: TextureRole::Input,
                        ..
                    }
                )
            },
            "the input region 65x32 at (0, 0) is outside its 64x32 level",
        ),
        (
            good_in.clone(),
            0,
            Some((60, 30)),
            good_out.clone(),
            Some((5, 2)),
            |e| {
                matches!(
                    e,
                    ToneMapperError::Outside {
                        texture: TextureRole::Output,
                        region: (5, 2, 60, 30),
                        level: (64, 32)
                    }
                )
            },
            "the output region 60x30 at (5, 2) is outside its 64x32 level",
        ),
        (
            good_in.clone(),
            0,
            Some((60, 30)),
            good_out.clone(),
            Some((u32::MAX, 0)),
            |e| {
                matches!(
                    e,
                    ToneMapperError::Outside {
                        texture: TextureRole::Output,
                        ..
                    }
                )
            },
            "the output region 60x30 at (4294967295, 0)",
        ),
    ];
    for (input, level, size, output, origin, is, says) in cases {
        let (iv, ov) = (view(&input), view(&output));
        let mut source = SourceView::from(&iv).at_level(level);
        source.size = size;
        let mut target = TargetView::from(&ov);
        target.origin = origin;
        let mut encoder = device.create_command_encoder(&Default::default());
        let e = mapper.record(&mut encoder, source, target).unwrap_err();
        assert!(is(&e), "{e:?}");
        assert!(e.to_string().starts_with(says), "{e} (wanted {says:?})");
    }
    // The good pair (an f16 input) still records and runs after the refusals.
    let mut encoder = device.create_command_encoder(&Default::default());
    mapper
        .record(&mut encoder, &view(&good_in), &view(&good_out))
        .unwrap();
    queue.submit([encoder.finish()]);
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();

    // Settings: refused when asked for, by `new` and by `set_settings`,
    // and the mapper keeps what it had.
    let with_levels = tonegate::operators::names()
        .into_iter()
        .map(|n| Operator::named(n, &[]).unwrap())
        .find(|op| op.display_levels().is_some())
        .unwrap();
    let settings = |operator: Operator, encoding, target, path| ToneMapperSettings {
        operator,
        encoding,
        target,
        path,
        adaptation: None,
        bloom: None,
        grade: None,
    };
    let refused: Vec<(ToneMapperSettings, Is, &str)> = vec![
        (
            settings(
                with_levels.clone(),
                Encoding::Pq,
                F::Bgra8UnormSrgb,
                OutputPath::Auto,
            ),
            |e| {
                matches!(
                    e,
                    ToneMapperError::PqIntoEightBits {
                        format: F::Bgra8UnormSrgb
                    }
                )
            },
            "encoding pq into a Bgra8UnormSrgb target",
        ),
        (
            settings(
                Operator::default(),
                Encoding::Pq,
                F::Rgb10a2Unorm,
                OutputPath::Auto,
            ),
            |e| matches!(e, ToneMapperError::PqWithoutLevels { .. }),
            "encoding pq: operator reinhard-global maps onto no display",
        ),
        (
            settings(
                Operator::default(),
                Encoding::Srgb,
                F::Rgba32Float,
                OutputPath::Auto,
            ),
            |e| {
                matches!(
                    e,
                    ToneMapperError::TargetFormat {
                        format: F::Rgba32Float
                    }
                )
            },
            "target format Rgba32Float",
        ),
        (
            settings(
                Operator::default(),
                Encoding::Srgb,
                F::Rgba8UnormSrgb,
                OutputPath::Compute,
            ),
            |e| {
                matches!(
                    e,
                    ToneMapperError::ComputeTarget {
                        format: F::Rgba8UnormSrgb
                    }
                )
            },
            "a compute pass cannot write Rgba8UnormSrgb on this device",
        ),
        (
            ToneMapperSettings {
                bloom: Some(
                    toml::from_str(
                        "bright_pass = \"scaled\"\nthreshold = 1.0\ndownsample = 2\nradius = 4\nsigma = 2.0\nstrength = 1000.0",
                    )
                    .unwrap(),
                ),
                ..Default::default()
            },
            |e| matches!(e, ToneMapperError::Display { table: "bloom", key: "strength", .. }),
            "bloom.strength: must be at most 100",
        ),
    ];
    for (s, is, says) in refused {
        let e = ToneMapper::new(&device, &queue, s.clone()).err().unwrap();
        assert!(is(&e), "{e:?}");
        assert!(e.to_string().starts_with(says), "{e} (wanted {says:?})");
        let e = mapper.set_settings(s).unwrap_err();
        assert!(is(&e), "{e:?}");
    }
    assert_eq!(mapper.settings().encoding, Encoding::Srgb);
    assert_eq!(mapper.settings().target, F::Rgba8Unorm);
}

/// An application's frame loop: `prepare` compiles every pipeline; then
/// 100 frames into a ring of three `Bgra8UnormSrgb` render attachments (a
/// swap chain's), the exposure changing every frame, compile nothing
/// more. The frames are the bytes a mapper made for that exposure gives,
/// so the uniform write took effect; switching to another operator
/// compiles once, and switching back nothing.
#[test]
fn exposure_changes_per_frame_compile_nothing_after_prepare() {
    let (device, queue) = own_device("llvmpipe");
    let img = night_and_ramp();
    let input = view(&hdr_input(&device, &queue, &img));
    let targets: Vec<wgpu::Texture> = (0..3)
        .map(|_| {
            texture(
                &device,
                (img.width, img.height),
                1,
                F::Bgra8UnormSrgb,
                U::RENDER_ATTACHMENT | U::COPY_SRC,
            )
        })
        .collect();
    let views: Vec<wgpu::TextureView> = targets.iter().map(view).collect();
    let agx = |exposure: f64| ToneMapperSettings {
        operator: Operator::named("agx", &[("exposure", Value::Number(exposure))]).unwrap(),
        target: F::Bgra8UnormSrgb,
        ..Default::default()
    };
    let exposure = |n: u32| 0.25 * 1.05f64.powi(n as i32);
    let mut mapper = ToneMapper::new(&device, &queue, agx(exposure(0))).unwrap();
    assert_eq!(mapper.compiled_pipelines(), 0, "nothing before prepare");
    mapper.prepare().unwrap();
    let prepared = mapper.compiled_pipelines();
    assert!(
        prepared >= 2,
        "tonemap and the target's at least: {prepared}"
    );
    let mut checked = 0;
    for n in 0..100u32 {
        mapper.set_settings(agx(exposure(n))).unwrap();
        let k = n as usize % 3;
        let mut encoder = device.create_command_encoder(&Default::default());
        mapper.record(&mut encoder, &input, &views[k]).unwrap();
        queue.submit([encoder.finish()]);
        if n % 33 == 0 {
            let got = read(&device, &queue, &targets[k], 0);
            let mut fresh = ToneMapper::new(&device, &queue, agx(exposure(n))).unwrap();
            let other = (k + 1) % 3;
            let mut encoder = device.create_command_encoder(&Default::default());
            fresh.record(&mut encoder, &input, &views[other]).unwrap();
            queue.submit([encoder.finish()]);
            assert!(
                got == read(&device, &queue, &targets[other], 0),
                "frame {n}"
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 4);
    assert_eq!(
        mapper.compiled_pipelines(),
        prepared,
        "a pipeline was compiled after prepare"
    );
    // Frames 0 and 99 differ: the exposure moved the image.
    let mut encoder = device.create_command_encoder(&Default::default());
    mapper.set_settings(agx(exposure(0))).unwrap();
    mapper.record(&mut encoder, &input, &views[0]).unwrap();
    queue.submit([encoder.finish()]);
    let first = read(&device, &queue, &targets[0], 0);
    mapper.set_settings(agx(exposure(99))).unwrap();
    let mut encoder = device.create_command_encoder(&Default::default());
    mapper.record(&mut encoder, &input, &views[0]).unwrap();
    queue.submit([encoder.finish()]);
    assert!(first != read(&device, &queue, &targets[0], 0));
    // Another operator is new pipelines, once; back again is none.
    let hable = ToneMapperSettings {
        operator: Operator::named("hable", &[]).unwrap(),
        target: F::Bgra8UnormSrgb,
        ..Default::default()
    };
    mapper.set_settings(hable.clone()).unwrap();
    mapper.prepare().unwrap();
    let with_hable = mapper.compiled_pipelines();
    assert!(with_hable > prepared);
    mapper.set_settings(agx(1.0)).unwrap();
    mapper.set_settings(hable).unwrap();
    mapper.prepare().unwrap();
    assert_eq!(mapper.compiled_pipelines(), with_hable);
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
