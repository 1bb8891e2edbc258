//! FLIP and PU21-SSIM on a Full HD pair, against two targets (last measured
//! on the 2-vCPU developer machine, 2026-11-23: FLIP 448.8 ms against
//! flip-evaluator 1.7's 1266.5 ms; PU21-SSIM 37.8 ms, 1.40× the 8-bit SSIM).
//!
//! - FLIP: no slower than NVIDIA's flip-evaluator on the same pair in the same
//!   run; `benches/flip_evaluator.sh` writes the pair, runs this bench and
//!   times flip-evaluator on it, and prints both.
//! - PU21-SSIM (encoding included) within 1.5× of tonegate's 8-bit SSIM on
//!   the same size: both are measured here, in one run.
//!
//! The pair is generated (no files): a smooth pattern and a noised copy, the
//! HDR one spanning 16 stops. With `TONEGATE_FLIP_PAIR=DIR` the 8-bit pair is
//! also written there as raw RGB for the Python side.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use tonegate::image::{HdrImage, Rgb8Image};
use tonegate::metrics::flip::{flip, DEFAULT_PPD};
use tonegate::metrics::mean_ssim;
use tonegate::metrics::pu21::{pu21_psnr, pu21_ssim, pu21_ssim_mean};

const WIDTH: u32 = 1920;
const HEIGHT: u32 = 1080;

fn xorshift(state: &mut u64) -> u64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    *state
}

fn ldr_pair() -> (Rgb8Image, Rgb8Image) {
    let reference = Rgb8Image::from_fn(WIDTH, HEIGHT, |x, y| {
        let (fx, fy) = (x as f64 / WIDTH as f64, y as f64 / HEIGHT as f64);
        let ring = 0.5 + 0.5 * (((fx - 0.5).powi(2) + (fy - 0.5).powi(2)).sqrt() * 60.0).sin();
        [
            (255.0 * fx) as u8,
            (255.0 * ring) as u8,
            (255.0 * (0.3 + 0.7 * fy * ring)) as u8,
        ]
    });
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut test = reference.clone();
    for v in test.pixels.iter_mut().flatten() {
        let noise = (xorshift(&mut state) % 17) as i32 - 8;
        *v = (*v as i32 + noise).clamp(0, 255) as u8;
    }
    (test, reference)
}

fn hdr_pair() -> (HdrImage, HdrImage) {
    let reference = HdrImage::from_fn(WIDTH, HEIGHT, |x, y| {
        let stops = 16.0 * (x as f32 / WIDTH as f32 - 0.5);
        let wave = 0.5 * (y as f32 * 0.05).sin();
        [0.2, 0.25, 0.3].map(|k: f32| k * (stops + wave).exp2())
    });
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut test = reference.clone();
    for v in test.pixels.iter_mut().flatten() {
        let noise = (xorshift(&mut state) % 1001) as f32 / 1000.0 - 0.5;
        *v *= 1.0 + 0.05 * noise;
    }
    (test, reference)
}

fn bench(c: &mut Criterion) {
    let (test, reference) = ldr_pair();
    if let Ok(dir) = std::env::var("TONEGATE_FLIP_PAIR") {
        let raw = |img: &Rgb8Image| img.pixels.iter().flatten().copied().collect::<Vec<u8>>();
        let dir = std::path::Path::new(&dir);
        std::fs::create_dir_all(dir).expect("pair folder");
        std::fs::write(dir.join("test.rgb"), raw(&test)).expect("test.rgb");
        std::fs::write(dir.join("reference.rgb"), raw(&reference)).expect("reference.rgb");
    }
    let (hdr_test, hdr_reference) = hdr_pair();
    let mut group = c.benchmark_group("1920x1080");
    group.sample_size(10);
    group.bench_function("flip", |b| {
        b.iter(|| {
            flip(
                black_box(test.raster()),
                black_box(reference.raster()),
                DEFAULT_PPD,
            )
        })
    });
    group.bench_function("ssim_8bit_rgb", |b| {
        b.iter(|| mean_ssim(black_box(test.raster()), black_box(reference.raster())))
    });
    group.bench_function("pu21_ssim", |b| {
        b.iter(|| pu21_ssim_mean(black_box(&hdr_test), black_box(&hdr_reference), 100.0))
    });
    group.bench_function("pu21_ssim_with_map", |b| {
        b.iter(|| pu21_ssim(black_box(&hdr_test), black_box(&hdr_reference), 100.0))
    });
    group.bench_function("pu21_psnr", |b| {
        b.iter(|| pu21_psnr(black_box(&hdr_test), black_box(&hdr_reference), 100.0))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
