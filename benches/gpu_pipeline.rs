//! The full plan (sphere + statistics + tonemap + bloom at ½ + encode) on the
//! GPU adapter tonegate picks by default (lavapipe in CI), per frame, at 720p
//! and 1080p, with and without reading the frame back. `tonegate bench`
//! prints the per-stage breakdown and the floor ratio for the same plan.
//! Both executions are measured in the same run: staged (one kernel per
//! stage) and fused (the display-referred stages merged).

use criterion::{criterion_group, criterion_main, Criterion};
use tonegate::conventions::rotation_matrix;
use tonegate::gpu::bench::full_plan_renderer;
use tonegate::gpu::{AdapterChoice, Execution, GpuConfig, GpuContext};
use tonegate::scene::{HistoryFilter, TaaVariant};

fn full_plan(c: &mut Criterion) {
    let ctx = match GpuContext::new(&AdapterChoice::Default) {
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
        let r = full_plan_renderer(&ctx, w, h, config, TaaVariant::Off, HistoryFilter::Bilinear)
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

criterion_group!(benches, full_plan);
criterion_main!(benches);
