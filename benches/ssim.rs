//! SSIM and the full comparison on a Full HD RGB pair.
//!
//! Target: mean SSIM of 1920×1080 RGB in ≤ 50 ms on the 2-core CI VM;
//! scikit-image needs ≈ 0.5 s for the same pair (docs/bibliography.md). The
//! pair is a smooth pattern and a noised copy, generated here so the bench
//! needs no files and every run measures the same work.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use tonegate::image::Rgb8Image;
use tonegate::metrics::{compare, mean_ssim, ssim};

const WIDTH: u32 = 1920;
const HEIGHT: u32 = 1080;

/// Smooth gradients with a few soft rings: structure at several scales.
fn smooth_frame() -> Rgb8Image {
    Rgb8Image::from_fn(WIDTH, HEIGHT, |x, y| {
        let (fx, fy) = (x as f64 / WIDTH as f64, y as f64 / HEIGHT as f64);
        let r = ((fx - 0.5).powi(2) + (fy - 0.5).powi(2)).sqrt();
        let ring = 0.5 + 0.5 * (r * 60.0).sin();
        [
            (255.0 * fx) as u8,
            (255.0 * ring) as u8,
            (255.0 * (0.3 + 0.7 * fy * ring)) as u8,
        ]
    })
}

/// `frame` plus uniform noise in [−8, 8] from a fixed-seed xorshift.
fn noised(frame: &Rgb8Image) -> Rgb8Image {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut out = frame.clone();
    for v in out.pixels.iter_mut().flatten() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let noise = (state % 17) as i32 - 8;
        *v = (*v as i32 + noise).clamp(0, 255) as u8;
    }
    out
}

fn bench(c: &mut Criterion) {
    let reference = smooth_frame();
    let test = noised(&reference);
    let mut group = c.benchmark_group("1920x1080_rgb");
    group.sample_size(30);
    group.bench_function("mean_ssim", |b| {
        b.iter(|| mean_ssim(black_box(test.raster()), black_box(reference.raster())))
    });
    group.bench_function("ssim_with_map", |b| {
        b.iter(|| ssim(black_box(test.raster()), black_box(reference.raster())))
    });
    group.bench_function("compare", |b| {
        b.iter(|| compare(black_box(test.raster()), black_box(reference.raster())))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
