//! The full plan (sphere + statistics + tonemap + bloom at ½ + encode) on the
//! GPU adapter tonegate picks by default (lavapipe in CI), per frame, at 720p
//! and 1080p, with and without reading the frame back. `tonegate bench`
//! prints the per-stage breakdown and the floor ratio for the same plan.

use criterion::{criterion_group, criterion_main, Criterion};
use tonegate::conventions::rotation_matrix;
use tonegate::gpu::bench::full_plan_renderer;
use tonegate::gpu::{AdapterChoice, GpuConfig, GpuContext};

fn full_plan(c: &mut Criterion) {
    let ctx = match GpuContext::new(&AdapterChoice::Default) {
        Ok(ctx) => ctx,
        Err(e) => panic!("{e}"),
    };
    let mut group = c.benchmark_group("gpu_full_plan");
    group.sample_size(10);
    for (w, h) in [(1280, 720), (1920, 1080)] {
        let r =
            full_plan_renderer(&ctx, w, h, GpuConfig::default()).unwrap_or_else(|e| panic!("{e}"));
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
