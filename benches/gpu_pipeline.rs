//! The full plan (sphere + statistics + tonemap + bloom at ½ + encode) on the
//! GPU adapter tonegate picks by default (lavapipe in CI), per frame, at 720p
//! and 1080p, with and without reading the frame back. `tonegate bench`
//! prints the per-stage breakdown and the floor ratio for the same plan.

use criterion::{criterion_group, criterion_main, Criterion};
use tonegate::conventions::{rotation_matrix, Camera};
use tonegate::env::BuiltinEnv;
use tonegate::gpu::bench::bench_operator;
use tonegate::gpu::{AdapterChoice, GpuConfig, GpuContext, GpuInput, GpuRenderer};
use tonegate::plan::{Input, StagePlan};
use tonegate::reference::Pipeline;
use tonegate::scene::Encoding;

fn full_plan(c: &mut Criterion) {
    let ctx = match GpuContext::new(&AdapterChoice::Default) {
        Ok(ctx) => ctx,
        Err(e) => panic!("{e}"),
    };
    let (op, bloom) = bench_operator();
    let pipeline = Pipeline {
        operator: &op,
        bloom: Some(&bloom),
        grade: None,
        encoding: Encoding::Srgb,
    };
    let env = BuiltinEnv::Sky.generate(2048, 1024);
    let mut group = c.benchmark_group("gpu_full_plan");
    group.sample_size(10);
    for (w, h) in [(1280, 720), (1920, 1080)] {
        let plan = StagePlan::build(Input::Sphere { spp: 1 }, &op, Some(&bloom), None);
        let camera = Camera {
            width: w,
            height: h,
            fov_y_deg: 60.0,
        };
        let r = GpuRenderer::new(
            &ctx,
            plan,
            GpuInput::Sphere {
                env: &env,
                camera,
                spp: 1,
            },
            &pipeline,
            GpuConfig::default(),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let mut n = 0u32;
        group.bench_function(format!("{w}x{h}"), |b| {
            b.iter(|| {
                n += 1;
                r.set_rotation(&rotation_matrix([1.0, 0.0, 0.0], (n as f64).to_radians()));
                r.render(false).unwrap_or_else(|e| panic!("{e}"))
            })
        });
        group.bench_function(format!("{w}x{h}_with_readback"), |b| {
            b.iter(|| r.render(true).unwrap_or_else(|e| panic!("{e}")))
        });
    }
    group.finish();
}

criterion_group!(benches, full_plan);
criterion_main!(benches);
