//! The tone mapper's API as an application meets it: what it refuses and
//! why, settings that change per frame without compiling, and timestamps.

use super::*;
use tonegate::gpu::{SourceView, TargetView, TextureRole};
use tonegate::operators::Value;
use tonegate::{ToneMapper, ToneMapperError, ToneMapperSettings};

#[test]
fn views_and_settings_the_tone_mapper_cannot_use_are_refused_with_the_reason() {
    let (device, queue) = own_device("llvmpipe");
    // Default's target is a swap chain's (Bgra8UnormSrgb); these storage
    // targets are Rgba8Unorm.
    let rgba8 = ToneMapperSettings {
        target: F::Rgba8Unorm,
        ..ToneMapperSettings::default()
    };
    let mut mapper = ToneMapper::new(&device, &queue, rgba8).unwrap();
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
        taa: None,
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
                target: wgpu::TextureFormat::Rgba8Unorm,
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
/// so the uniform write took effect; AgX's look is a uniform write too;
/// switching to another operator compiles once, and switching back
/// nothing.
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
    // AgX's look is in the uniform too: the punchy look and back compile
    // nothing, and the punchy frame is a fresh punchy mapper's.
    let look = |word| ToneMapperSettings {
        operator: Operator::named("agx", &[("look", Value::Word(word))]).unwrap(),
        target: F::Bgra8UnormSrgb,
        ..Default::default()
    };
    let frame_with = |m: &mut ToneMapper, k: usize| {
        let mut encoder = device.create_command_encoder(&Default::default());
        m.record(&mut encoder, &input, &views[k]).unwrap();
        queue.submit([encoder.finish()]);
        read(&device, &queue, &targets[k], 0)
    };
    mapper.set_settings(look("punchy")).unwrap();
    let punchy = frame_with(&mut mapper, 1);
    mapper.set_settings(look("none")).unwrap();
    let plain = frame_with(&mut mapper, 1);
    assert_eq!(mapper.compiled_pipelines(), prepared, "the look compiled");
    let mut fresh = ToneMapper::new(&device, &queue, look("punchy")).unwrap();
    assert!(
        punchy == frame_with(&mut fresh, 2),
        "the punchy look took effect"
    );
    assert!(punchy != plain);
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

/// The mapper times its own passes where the device can: the compute pass
/// always, the render pass when the target is a render attachment; a
/// device opened without timestamps is refused with the feature it lacks.
#[test]
fn the_mapper_times_its_passes_on_a_device_with_timestamps() {
    let (device, queue) = own_device("llvmpipe");
    assert!(
        device.features().contains(wgpu::Features::TIMESTAMP_QUERY),
        "lavapipe times"
    );
    let img = night_and_ramp();
    let input = view(&hdr_input(&device, &queue, &img));
    for (target, path) in [
        (F::Rgba8Unorm, OutputPath::Compute),
        (F::Bgra8UnormSrgb, OutputPath::RenderPass),
    ] {
        let mut mapper = ToneMapper::new(
            &device,
            &queue,
            ToneMapperSettings {
                target,
                path,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(mapper.read_timings().unwrap(), None);
        mapper.enable_timestamps().unwrap();
        let output = view(&texture(
            &device,
            (img.width, img.height),
            1,
            target,
            usage_for(path),
        ));
        let mut encoder = device.create_command_encoder(&Default::default());
        mapper.record(&mut encoder, &input, &output).unwrap();
        queue.submit([encoder.finish()]);
        let t = mapper.read_timings().unwrap().unwrap();
        assert!(t.compute_ms > 0.0 && t.compute_ms < 10_000.0, "{t:?}");
        // Each stage of the plan timed on its own, in order.
        let names: Vec<&str> = t.stages.iter().map(|s| s.stage.as_str()).collect();
        let sum: f64 = t.stages.iter().map(|s| s.ms).sum();
        assert!(t.stages.iter().all(|s| s.ms >= 0.0), "{t:?}");
        assert!((sum - t.compute_ms).abs() < 1e-9, "{t:?}");
        match path {
            OutputPath::RenderPass => {
                assert!(t.target_ms.is_some_and(|ms| ms > 0.0), "{t:?}");
                assert_eq!(names, ["luminance_stats", "tonemap"]);
            }
            _ => {
                assert_eq!(t.target_ms, None);
                assert_eq!(names, ["luminance_stats", "tonemap", "target"]);
            }
        }
    }
    // A device opened with nothing asked for.
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    let instance = wgpu::Instance::new(desc);
    let adapter = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN))
        .into_iter()
        .find(|a| a.get_info().name.contains("llvmpipe"))
        .unwrap();
    let (plain, plain_queue) =
        pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor::default())).unwrap();
    let mut mapper = ToneMapper::new(&plain, &plain_queue, ToneMapperSettings::default()).unwrap();
    let e = mapper.enable_timestamps().unwrap_err();
    assert!(
        matches!(e, ToneMapperError::MissingFeature { feature } if feature == wgpu::Features::TIMESTAMP_QUERY),
        "{e:?}"
    );
    assert!(e.to_string().contains("TIMESTAMP_QUERY"), "{e}");
}
