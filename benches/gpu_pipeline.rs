//! The full plan (sphere + statistics + tonemap + bloom at ½ + encode) on the
//! GPU adapter tonegate picks by default (lavapipe in CI), per frame, at 720p
//! and 1080p, with and without reading the frame back. `tonegate bench`
//! prints the per-stage breakdown and the floor ratio for the same plan.
//! Both executions are measured in the same run: staged (one kernel per
//! stage) and fused (the display-referred stages merged).
//!
//! `readback_1080p`: where the host's time goes when a 1080p RGBA8 frame
//! comes back, part by part: the GPU's copy into the mapped-readable
//! buffer and the wait for it, the map and unmap, a plain memcpy of the
//! mapped bytes, and the unpacking into RGB (through byte chunks, into a
//! new vector and a reused one, and through whole pixels; the renderer's
//! own function last).
//!
//! `tone_mapper_1080p`: the same flat 1080p image tone-mapped (statistics,
//! `reinhard-global`, sRGB encode) by tonegate's own renderer and by
//! `ToneMapper` on the same device, into an `Rgba8Unorm` storage target and
//! into a `Bgra8UnormSrgb` render target, each frame submitted and waited
//! for: the embedding runs the renderer's stages, so its cost should be the
//! renderer's (less the packed frame buffer it does not write). Then, where
//! the adapter has timestamps, each stage through either, as a multiple of
//! the floor pass in the same submission (`gpu::bench::embedding_stages`),
//! printed as a table.
//!
//! `tone_mapper_record_1080p`: the CPU time of `ToneMapper::record` alone
//! (AgX, a new exposure each frame, into a `Bgra8UnormSrgb` render
//! attachment as a swap chain's) with the targets' views kept, a new view
//! each frame (docs/embedding.md's loop), and a new texture and view each
//! frame (what a swap chain hands out); each frame is submitted and waited
//! for outside the timing. It prints what the mapper created over the
//! frames after the first, and each case's median over the kept views'.
//!
//! `kept_renderers`: the server's GPU tone map of six images of different
//! sizes in turn, all in the 1024×512 size class, with renderers kept for
//! exact sizes (four kept, so every image makes a new one) and for size
//! classes (one kept renderer takes them all): what a renderer's textures,
//! buffers and bind groups cost to make on this adapter.

use criterion::{criterion_group, criterion_main, Criterion};
use tonegate::conventions::rotation_matrix;
use tonegate::gpu::bench::full_plan_renderer;
use tonegate::gpu::{AdapterChoice, Execution, GpuConfig, GpuContext};
use tonegate::scene::{TaaParams, TaaVariant};

fn full_plan(c: &mut Criterion) {
    let ctx = match GpuContext::new(&AdapterChoice::default()) {
        Ok(ctx) => ctx,
        Err(e) => panic!("{e}"),
    };
    let mut group = c.benchmark_group("gpu_full_plan");
    group.sample_size(10);
    for ((w, h), execution) in [(1280, 720), (1920, 1080)]
        .into_iter()
        .flat_map(|size| [(size, Execution::Staged), (size, Execution::Fused)])
    {
        let config = GpuConfig {
            execution,
            ..Default::default()
        };
        let r = full_plan_renderer(
            &ctx,
            w,
            h,
            config,
            TaaParams {
                variant: TaaVariant::Off,
                ..TaaParams::default()
            },
            None,
            None,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let mut n = 0u32;
        let tag = format!("{w}x{h}_{execution:?}").to_lowercase();
        group.bench_function(&tag, |b| {
            b.iter(|| {
                n += 1;
                r.set_rotation(&rotation_matrix([1.0, 0.0, 0.0], (n as f64).to_radians()));
                r.render(false).unwrap_or_else(|e| panic!("{e}"))
            })
        });
        group.bench_function(format!("{tag}_with_readback"), |b| {
            b.iter(|| r.render(true).unwrap_or_else(|e| panic!("{e}")))
        });
    }
    group.finish();
}

fn kept_renderers(c: &mut Criterion) {
    use tonegate::gpu::RendererPool;
    use tonegate::toning::{tone_map_until, OutputKind, ToneSettings};
    let ctx = GpuContext::new(&AdapterChoice::default()).unwrap_or_else(|e| panic!("{e}"));
    let settings = ToneSettings {
        bloom: 0.04,
        ..Default::default()
    };
    let resolved = settings.resolve().unwrap_or_else(|e| panic!("{e}"));
    let pipeline = resolved.pipeline();
    let images: Vec<_> = [
        (1024, 512),
        (1000, 500),
        (1010, 505),
        (1020, 510),
        (990, 495),
        (970, 480),
    ]
    .into_iter()
    .map(|(w, h)| tonegate::env::BuiltinEnv::Sky.generate(w, h))
    .collect();
    let mut group = c.benchmark_group("kept_renderers");
    group.sample_size(10);
    for classes in [false, true] {
        let mut kept = RendererPool::new(&ctx);
        if !classes {
            kept = kept.exact_sizes();
        }
        let mut n = 0usize;
        let tag = if classes { "size_class" } else { "exact_size" };
        group.bench_function(format!("six_sizes_1024x512_{tag}"), |b| {
            b.iter(|| {
                n += 1;
                let img = &images[n % images.len()];
                let gpu = Some((&mut kept, GpuConfig::default()));
                tone_map_until(img, &pipeline, gpu, OutputKind::Encoded, &|| false)
                    .unwrap_or_else(|e| panic!("{e}"))
            })
        });
    }
    group.finish();
}

fn readback(c: &mut Criterion) {
    let ctx = GpuContext::new(&AdapterChoice::default()).unwrap_or_else(|e| panic!("{e}"));
    let n = 1920 * 1080;
    let bytes = n as u64 * 4;
    let buffer = |label: &str, usage: wgpu::BufferUsages| {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage,
            mapped_at_creation: false,
        })
    };
    let source = buffer(
        "bench.frame",
        wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
    );
    let pattern: Vec<u8> = (0..bytes).map(|i| (i * 7 % 251) as u8).collect();
    ctx.queue.write_buffer(&source, 0, &pattern);
    let staging = buffer(
        "bench.frame.read",
        wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
    );
    let wait = || {
        ctx.device
            .poll(wgpu::PollType::wait_indefinitely())
            .unwrap_or_else(|e| panic!("{e}"));
    };
    let map = || {
        let (tx, rx) = std::sync::mpsc::channel();
        staging
            .slice(..)
            .map_async(wgpu::MapMode::Read, move |r| drop(tx.send(r)));
        wait();
        rx.recv()
            .unwrap_or_else(|e| panic!("{e}"))
            .unwrap_or_else(|e| panic!("{e}"));
    };
    let mut group = c.benchmark_group("readback_1080p");
    group.sample_size(20);
    group.bench_function("gpu_copy_and_wait", |b| {
        b.iter(|| {
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            encoder.copy_buffer_to_buffer(&source, 0, &staging, 0, bytes);
            ctx.queue.submit([encoder.finish()]);
            wait();
        })
    });
    group.bench_function("map_and_unmap", |b| {
        b.iter(|| {
            map();
            staging.unmap();
        })
    });
    map();
    {
        let view = staging
            .slice(..)
            .get_mapped_range()
            .unwrap_or_else(|e| panic!("{e}"));
        let mut copy = vec![0u8; bytes as usize];
        group.bench_function("memcpy", |b| b.iter(|| copy.copy_from_slice(&view)));
        group.bench_function("unpack_byte_chunks", |b| {
            b.iter(|| {
                view.chunks_exact(4)
                    .take(n)
                    .map(|c| [c[0], c[1], c[2]])
                    .collect::<Vec<[u8; 3]>>()
            })
        });
        let mut reused: Vec<[u8; 3]> = Vec::with_capacity(n);
        group.bench_function("unpack_byte_chunks_reused", |b| {
            b.iter(|| {
                reused.clear();
                reused.extend(view.chunks_exact(4).take(n).map(|c| [c[0], c[1], c[2]]));
            })
        });
        group.bench_function("unpack_pixels", |b| {
            b.iter(|| {
                let pixels: &[[u8; 4]] = bytemuck::cast_slice(&view[..n * 4]);
                pixels
                    .iter()
                    .map(|&[r, g, b, _]| [r, g, b])
                    .collect::<Vec<[u8; 3]>>()
            })
        });
        group.bench_function("unpack_as_renderer", |b| {
            b.iter(|| tonegate::gpu::readback::unpack_rgba8(&view, n))
        });
    }
    staging.unmap();
    group.finish();
}

fn tone_mapper(c: &mut Criterion) {
    use tonegate::gpu::{GpuInput, GpuRenderer, OutputPath, ToneMapper, ToneMapperSettings};
    use tonegate::operators::Operator;
    use tonegate::plan::{Input, StagePlan};
    use tonegate::reference::Pipeline;
    let ctx = GpuContext::new(&AdapterChoice::default()).unwrap_or_else(|e| panic!("{e}"));
    let (w, h) = (1920, 1080);
    let img = tonegate::env::BuiltinEnv::Sky.generate(w, h);
    let op = Operator::default();
    let pipeline = Pipeline {
        operator: &op,
        bloom: None,
        grade: None,
        encoding: tonegate::scene::Encoding::Srgb,
    };
    let plan = StagePlan::build(Input::Flat, &op, None, None);
    let renderer = GpuRenderer::new(
        &ctx,
        plan,
        GpuInput::Flat(&img),
        &pipeline,
        GpuConfig::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let input = tonegate::gpu::bench::hdr_input(&ctx, &img);
    let input = input.create_view(&Default::default());
    let mut group = c.benchmark_group("tone_mapper_1080p");
    group.sample_size(10);
    group.bench_function("renderer", |b| {
        b.iter(|| renderer.render(false).unwrap_or_else(|e| panic!("{e}")))
    });
    for (tag, format, path, usage) in [
        (
            "embedding_compute",
            wgpu::TextureFormat::Rgba8Unorm,
            OutputPath::Compute,
            wgpu::TextureUsages::STORAGE_BINDING,
        ),
        (
            "embedding_render_pass",
            wgpu::TextureFormat::Bgra8UnormSrgb,
            OutputPath::RenderPass,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        ),
    ] {
        let mut mapper = ToneMapper::new(
            &ctx.device,
            &ctx.queue,
            ToneMapperSettings {
                target: format,
                path,
                ..Default::default()
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let output = tonegate::gpu::bench::texture(&ctx, (w, h), format, usage)
            .create_view(&Default::default());
        group.bench_function(tag, |b| {
            b.iter(|| {
                let mut encoder = ctx.device.create_command_encoder(&Default::default());
                mapper
                    .record(&mut encoder, &input, &output)
                    .unwrap_or_else(|e| panic!("{e}"));
                ctx.queue.submit([encoder.finish()]);
                ctx.wait().unwrap_or_else(|e| panic!("{e}"));
            })
        });
    }
    group.finish();
    match tonegate::gpu::bench::embedding_stages(&ctx, &img, &op, 30) {
        Ok(Some(stages)) => {
            println!("tone_mapper_1080p per stage, median of 30 frames, × the floor pass:");
            println!(
                "{:<16} {:>9} {:>9} {:>7}",
                "stage", "renderer", "embedded", "ratio"
            );
            for s in stages {
                println!(
                    "{:<16} {:>9.3} {:>9.3} {:>7.3}",
                    s.stage,
                    s.renderer,
                    s.embedding,
                    s.embedding / s.renderer
                );
            }
        }
        Ok(None) => println!("tone_mapper_1080p per stage: no timestamp queries on this adapter"),
        Err(e) => panic!("{e}"),
    }
}

fn tone_mapper_record(c: &mut Criterion) {
    use std::time::{Duration, Instant};
    use tonegate::gpu::{OutputPath, ToneMapper, ToneMapperSettings};
    use tonegate::operators::{Operator, Value};
    let ctx = GpuContext::new(&AdapterChoice::default()).unwrap_or_else(|e| panic!("{e}"));
    let (w, h) = (1920, 1080);
    let img = tonegate::env::BuiltinEnv::Sky.generate(w, h);
    let input = tonegate::gpu::bench::hdr_input(&ctx, &img).create_view(&Default::default());
    let format = wgpu::TextureFormat::Bgra8UnormSrgb;
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
    let settings = |n: u64| ToneMapperSettings {
        operator: Operator::named(
            "agx",
            &[("exposure", Value::Number(0.5 + 0.01 * (n % 50) as f64))],
        )
        .unwrap_or_else(|e| panic!("{e}")),
        target: format,
        path: OutputPath::RenderPass,
        ..Default::default()
    };
    let ring: Vec<wgpu::Texture> = (0..3)
        .map(|_| tonegate::gpu::bench::texture(&ctx, (w, h), format, usage))
        .collect();
    let kept: Vec<wgpu::TextureView> = ring
        .iter()
        .map(|t| t.create_view(&Default::default()))
        .collect();
    let mut group = c.benchmark_group("tone_mapper_record_1080p");
    group.sample_size(10);
    let mut medians = Vec::new();
    for case in ["views_kept", "new_view", "new_texture"] {
        let mut mapper =
            ToneMapper::new(&ctx.device, &ctx.queue, settings(0)).unwrap_or_else(|e| panic!("{e}"));
        mapper.prepare().unwrap_or_else(|e| panic!("{e}"));
        let mut frame = 0u64;
        let mut warm = None;
        let mut times = Vec::new();
        group.bench_function(case, |b| {
            b.iter_custom(|iters| {
                let mut spent = Duration::ZERO;
                for _ in 0..iters {
                    mapper
                        .set_settings(settings(frame))
                        .unwrap_or_else(|e| panic!("{e}"));
                    let texture = match case {
                        "new_texture" => tonegate::gpu::bench::texture(&ctx, (w, h), format, usage),
                        _ => ring[frame as usize % 3].clone(),
                    };
                    let made = texture.create_view(&Default::default());
                    let view = match case {
                        "views_kept" => &kept[frame as usize % 3],
                        _ => &made,
                    };
                    let mut encoder = ctx.device.create_command_encoder(&Default::default());
                    let start = Instant::now();
                    mapper
                        .record(&mut encoder, &input, view)
                        .unwrap_or_else(|e| panic!("{e}"));
                    let took = start.elapsed();
                    spent += took;
                    times.push(took.as_secs_f64() * 1e3);
                    ctx.queue.submit([encoder.finish()]);
                    ctx.wait().unwrap_or_else(|e| panic!("{e}"));
                    if frame == 0 {
                        warm = Some(mapper.created());
                    }
                    frame += 1;
                }
                spent
            })
        });
        let created = mapper.created() - warm.unwrap_or_default();
        let median = tonegate::perf::quantile(&times, 0.5);
        println!(
            "tone_mapper_record_1080p {case}: median record {median:.4} ms over {} frames; created after the first: {created:?}",
            times.len()
        );
        medians.push((case, median));
    }
    group.finish();
    let base = medians[0].1;
    for (case, median) in &medians {
        println!(
            "tone_mapper_record_1080p {case}: {:.2}× the kept views' median record",
            median / base
        );
    }
}

/// A new exposure per frame, the two ways: `set_exposure` (one word
/// written) against `set_settings` with the operator rebuilt with its new
/// `exposure` (what an application did before it), on AgX. No GPU work:
/// the time of the call alone.
fn tone_mapper_exposure(c: &mut Criterion) {
    use tonegate::gpu::{ToneMapper, ToneMapperSettings};
    use tonegate::operators::{Operator, Value};
    let ctx = GpuContext::new(&AdapterChoice::default()).unwrap_or_else(|e| panic!("{e}"));
    let agx = |e: f64| ToneMapperSettings {
        operator: Operator::named("agx", &[("exposure", Value::Number(e))]).unwrap(),
        ..ToneMapperSettings::default()
    };
    let mut mapper = ToneMapper::new(&ctx.device, &ctx.queue, agx(1.0)).unwrap();
    let mut group = c.benchmark_group("tone_mapper_exposure");
    let mut n = 0u32;
    group.bench_function("set_exposure", |b| {
        b.iter(|| {
            n = n.wrapping_add(1);
            mapper.set_exposure(0.5 + (n % 64) as f32 / 64.0)
        })
    });
    group.bench_function("set_settings", |b| {
        b.iter(|| {
            n = n.wrapping_add(1);
            mapper
                .set_settings(agx(0.5 + f64::from(n % 64) / 64.0))
                .unwrap()
        })
    });
    group.finish();
}

criterion_group!(
    benches,
    full_plan,
    readback,
    kept_renderers,
    tone_mapper,
    tone_mapper_record,
    tone_mapper_exposure
);
criterion_main!(benches);
