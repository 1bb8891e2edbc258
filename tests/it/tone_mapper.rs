//! `tonegate::ToneMapper` inside an application that made its own device:
//! the device, queue, textures and command encoder are created here with
//! wgpu alone, and the bytes it writes are tonegate's own renderer's for the
//! same image on the same adapter (lavapipe), bit for bit.

use tonegate::gpu::tone_mapper::OUTPUT_FORMAT;
use tonegate::gpu::TextureRole;
use tonegate::gpu::{AdapterChoice, GpuConfig, GpuContext, GpuInput, GpuRenderer};
use tonegate::image::HdrImage;
use tonegate::operators::{Operator, Value};
use tonegate::plan::{Input, StagePlan};
use tonegate::reference::Pipeline;
use tonegate::scene::Encoding;
use tonegate::{ToneMapper, ToneMapperError, ToneMapperSettings};

/// An application's own device on lavapipe, with no features asked for: a
/// plain `request_device`, as an application that knows nothing of
/// tonegate would open it.
fn own_device() -> (wgpu::Device, wgpu::Queue) {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    let instance = wgpu::Instance::new(desc);
    let adapter = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN))
        .into_iter()
        .find(|a| a.get_info().name.contains("llvmpipe"))
        .expect("lavapipe (mesa-vulkan-drivers) is installed");
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default()))
        .expect("lavapipe opens")
}

fn texture(
    device: &wgpu::Device,
    (w, h): (u32, u32),
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
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

fn hdr_input(device: &wgpu::Device, queue: &wgpu::Queue, img: &HdrImage) -> wgpu::Texture {
    let t = texture(
        device,
        (img.width, img.height),
        wgpu::TextureFormat::Rgba32Float,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
    let texels: Vec<f32> = img
        .pixels
        .iter()
        .flat_map(|p| [p[0], p[1], p[2], 1.0])
        .collect();
    queue.write_texture(
        t.as_image_copy(),
        bytemuck::cast_slice(&texels),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(img.width * 16),
            rows_per_image: None,
        },
        t.size(),
    );
    t
}

/// The output texture's RGB bytes, read back by the application.
fn read_rgb(device: &wgpu::Device, queue: &wgpu::Queue, t: &wgpu::Texture) -> Vec<u8> {
    let (w, h) = (t.width(), t.height());
    let row = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("application.readback"),
        size: (row * h) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        t.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: None,
            },
        },
        t.size(),
    );
    queue.submit([encoder.finish()]);
    buffer
        .slice(..)
        .map_async(wgpu::MapMode::Read, |r| r.unwrap());
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    let mapped = buffer.slice(..).get_mapped_range().unwrap();
    let mut rgb = Vec::with_capacity((w * h * 3) as usize);
    for y in 0..h {
        let line = &mapped[(y * row) as usize..][..(w * 4) as usize];
        for px in line.chunks_exact(4) {
            assert_eq!(px[3], 255, "alpha");
            rgb.extend_from_slice(&px[..3]);
        }
    }
    rgb
}

/// tonegate's own renderer on its own lavapipe device: the flat image's
/// plan (statistics where the operator needs them, tonemap, encode).
fn tonegate_frame(ctx: &GpuContext, img: &HdrImage, op: &Operator, encoding: Encoding) -> Vec<u8> {
    let pipeline = Pipeline {
        operator: op,
        bloom: None,
        grade: None,
        encoding,
    };
    let plan = StagePlan::build(Input::Flat, op, None, None);
    let r = GpuRenderer::new(
        ctx,
        plan,
        GpuInput::Flat(img),
        &pipeline,
        GpuConfig::default(),
    )
    .unwrap();
    r.render(true)
        .unwrap()
        .frame
        .unwrap()
        .as_rgb8()
        .unwrap()
        .as_bytes()
        .to_vec()
}

fn night_and_ramp() -> HdrImage {
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

#[test]
fn the_tone_mapper_on_an_applications_device_writes_tonegates_own_bits() {
    let ours = GpuContext::new(&AdapterChoice::default()).unwrap();
    let (device, queue) = own_device();
    let img = night_and_ramp();
    let input = hdr_input(&device, &queue, &img);
    let output = texture(
        &device,
        (img.width, img.height),
        OUTPUT_FORMAT,
        wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
    );
    let gamma = Encoding::Gamma(tonegate::scene::Positive::try_from(2.4).unwrap());
    let cases = [
        (Operator::default(), Encoding::Srgb),
        (
            Operator::named("reinhard-auto-key", &[]).unwrap(),
            Encoding::Srgb,
        ),
        (Operator::named("agx", &[]).unwrap(), gamma),
        (
            Operator::named(
                "bt2390",
                &[
                    ("target_black", Value::Number(0.1)),
                    ("exposure", Value::Number(50.0)),
                ],
            )
            .unwrap(),
            Encoding::Srgb,
        ),
        // Tables in its uniform, read from the stage's `config`.
        (
            Operator::named("aces2", &[("exposure", Value::Number(4.0))]).unwrap(),
            Encoding::Srgb,
        ),
    ];
    for (op, encoding) in cases {
        let mut mapper = ToneMapper::new(
            &device,
            &queue,
            ToneMapperSettings {
                operator: op.clone(),
                encoding,
            },
        )
        .unwrap();
        // Twice through the same mapper and textures: the kept resources
        // give the same bytes.
        for round in 0..2 {
            let mut encoder = device.create_command_encoder(&Default::default());
            mapper.record(&mut encoder, &input, &output).unwrap();
            queue.submit([encoder.finish()]);
            let got = read_rgb(&device, &queue, &output);
            let want = tonegate_frame(&ours, &img, &op, encoding);
            let differing = got.iter().zip(&want).filter(|(a, b)| a != b).count();
            assert_eq!(got.len(), want.len());
            assert_eq!(
                differing,
                0,
                "{} round {round}: {differing} bytes differ",
                op.name()
            );
        }
        // Not all black, not all white: the comparison compared something.
        let got = read_rgb(&device, &queue, &output);
        assert!(got.iter().any(|&b| b > 20) && got.iter().any(|&b| b < 235));
    }
}

#[test]
fn textures_the_tone_mapper_cannot_use_are_refused_with_the_reason() {
    let (device, queue) = own_device();
    let mut mapper = ToneMapper::new(&device, &queue, ToneMapperSettings::default()).unwrap();
    let hdr = |size, format| {
        texture(
            &device,
            size,
            format,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        )
    };
    let ldr = |size, format| {
        texture(
            &device,
            size,
            format,
            wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
        )
    };
    let good_in = hdr((64, 32), wgpu::TextureFormat::Rgba16Float);
    let good_out = ldr((64, 32), OUTPUT_FORMAT);
    type Is = fn(&ToneMapperError) -> bool;
    let cases: [(wgpu::Texture, wgpu::Texture, Is, &str); 5] = [
        (
            hdr((64, 32), wgpu::TextureFormat::Rgba8Unorm),
            good_out.clone(),
            |e| matches!(e, ToneMapperError::InputFormat { format } if *format == wgpu::TextureFormat::Rgba8Unorm),
            "the input texture is Rgba8Unorm",
        ),
        (
            good_in.clone(),
            ldr((64, 32), wgpu::TextureFormat::Rgba16Float),
            |e| matches!(e, ToneMapperError::OutputFormat { format } if *format == wgpu::TextureFormat::Rgba16Float),
            "the output texture is Rgba16Float",
        ),
        (
            good_in.clone(),
            ldr((64, 31), OUTPUT_FORMAT),
            |e| {
                matches!(
                    e,
                    ToneMapperError::SizeMismatch {
                        input: (64, 32),
                        output: (64, 31)
                    }
                )
            },
            "the input texture is 64x32 and the output 64x31",
        ),
        (
            good_in.clone(),
            texture(
                &device,
                (64, 32),
                OUTPUT_FORMAT,
                wgpu::TextureUsages::COPY_SRC,
            ),
            |e| matches!(e, ToneMapperError::MissingUsage { texture: TextureRole::Output, usage } if *usage == wgpu::TextureUsages::STORAGE_BINDING),
            "the output texture lacks STORAGE_BINDING usage",
        ),
        (
            texture(
                &device,
                (64, 32),
                wgpu::TextureFormat::Rgba32Float,
                wgpu::TextureUsages::COPY_DST,
            ),
            good_out.clone(),
            |e| matches!(e, ToneMapperError::MissingUsage { texture: TextureRole::Input, usage } if *usage == wgpu::TextureUsages::TEXTURE_BINDING),
            "the input texture lacks TEXTURE_BINDING usage",
        ),
    ];
    for (input, output, is, says) in cases {
        let mut encoder = device.create_command_encoder(&Default::default());
        let e = mapper.record(&mut encoder, &input, &output).unwrap_err();
        assert!(is(&e), "{e:?}");
        assert!(e.to_string().starts_with(says), "{e} (wanted {says:?})");
    }
    // The good pair (an f16 input) still records and runs after the refusals.
    let mut encoder = device.create_command_encoder(&Default::default());
    mapper.record(&mut encoder, &good_in, &good_out).unwrap();
    queue.submit([encoder.finish()]);
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    // PQ frames are 16-bit: not into an 8-bit texture, even from an
    // operator that has display levels; refused when asked for, by `new`
    // and by `set_settings`, and the mapper keeps what it had.
    let pq = ToneMapperSettings {
        operator: Operator::named("bt2390", &[]).unwrap(),
        encoding: Encoding::Pq,
    };
    let e = ToneMapper::new(&device, &queue, pq.clone()).err().unwrap();
    assert!(matches!(e, ToneMapperError::PqIntoEightBits), "{e:?}");
    assert!(e.to_string().starts_with("encoding pq"), "{e}");
    let e = mapper.set_settings(pq).unwrap_err();
    assert!(matches!(e, ToneMapperError::PqIntoEightBits), "{e:?}");
    assert_eq!(mapper.settings().encoding, Encoding::Srgb);
}

/// An application's frame loop: `prepare` compiles every pipeline; then
/// 100 frames into a ring of three targets (a swap chain's), the exposure
/// changing every frame, compile nothing more. The frames are the bytes a
/// mapper made for that exposure gives, so the uniform write took effect;
/// switching to another operator compiles once, and switching back nothing.
#[test]
fn exposure_changes_per_frame_compile_nothing_after_prepare() {
    let (device, queue) = own_device();
    let img = night_and_ramp();
    let input = hdr_input(&device, &queue, &img);
    let targets: Vec<wgpu::Texture> = (0..3)
        .map(|_| {
            texture(
                &device,
                (img.width, img.height),
                OUTPUT_FORMAT,
                wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
            )
        })
        .collect();
    let agx = |exposure: f64| ToneMapperSettings {
        operator: Operator::named("agx", &[("exposure", Value::Number(exposure))]).unwrap(),
        encoding: Encoding::Srgb,
    };
    let exposure = |n: u32| 0.25 * 1.05f64.powi(n as i32);
    let mut mapper = ToneMapper::new(&device, &queue, agx(exposure(0))).unwrap();
    assert_eq!(mapper.compiled_pipelines(), 0, "nothing before prepare");
    mapper.prepare();
    let prepared = mapper.compiled_pipelines();
    assert!(prepared >= 2, "tonemap and encode at least: {prepared}");
    let mut checked = 0;
    for n in 0..100u32 {
        mapper.set_settings(agx(exposure(n))).unwrap();
        let target = &targets[n as usize % 3];
        let mut encoder = device.create_command_encoder(&Default::default());
        mapper.record(&mut encoder, &input, target).unwrap();
        queue.submit([encoder.finish()]);
        if n % 33 == 0 {
            let got = read_rgb(&device, &queue, target);
            let mut fresh = ToneMapper::new(&device, &queue, agx(exposure(n))).unwrap();
            let other = &targets[(n as usize + 1) % 3];
            let mut encoder = device.create_command_encoder(&Default::default());
            fresh.record(&mut encoder, &input, other).unwrap();
            queue.submit([encoder.finish()]);
            assert!(got == read_rgb(&device, &queue, other), "frame {n}");
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
    mapper.record(&mut encoder, &input, &targets[0]).unwrap();
    queue.submit([encoder.finish()]);
    let first = read_rgb(&device, &queue, &targets[0]);
    mapper.set_settings(agx(exposure(99))).unwrap();
    let mut encoder = device.create_command_encoder(&Default::default());
    mapper.record(&mut encoder, &input, &targets[0]).unwrap();
    queue.submit([encoder.finish()]);
    assert!(first != read_rgb(&device, &queue, &targets[0]));
    // Another operator is new pipelines, once; back again is none.
    let hable = ToneMapperSettings {
        operator: Operator::named("hable", &[]).unwrap(),
        encoding: Encoding::Srgb,
    };
    mapper.set_settings(hable.clone()).unwrap();
    mapper.prepare();
    let with_hable = mapper.compiled_pipelines();
    assert!(with_hable > prepared);
    mapper.set_settings(agx(1.0)).unwrap();
    mapper.set_settings(hable).unwrap();
    mapper.prepare();
    assert_eq!(mapper.compiled_pipelines(), with_hable);
}
