//! `tonegate frames submit`'s targets (docs/frames.md#speed): the ingest of
//! exact matches, 1080p PNG frames whose digests are positives of their
//! tests (read, hashed, looked up and recorded; not decoded), in frames per
//! second; and the fuzzy comparison of one untriaged 1080p frame with a
//! positive (decoded both, every figure, the rules), per frame, with the
//! CPU's metrics and with the GPU's on the default adapter. All through
//! `frames::submit` on a SQLite history in a temporary folder.
//!
//! `cargo bench --bench frames`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::path::Path;
use tonegate::frames::rules::Rules;
use tonegate::frames::{collect_folder, submit, Submission};
use tonegate::history::{History, Label, MAIN};
use tonegate::image::{Frame, Image};
use tonegate::io::write_frame_png;

/// Frames in the exact-match folder.
const FRAMES: usize = 60;

/// A 1080p frame that compresses as a rendered one does (smooth, with
/// detail): a gradient, a pattern, a little noise, seeded by `i`.
fn frame(i: usize) -> Frame {
    let mut state = 0x9e37_79b9_u32.wrapping_mul(i as u32 + 1);
    Frame::Rgb8(Image::from_fn(1920, 1080, |x, y| {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        let noise = state % 5;
        let ring = ((x / 7 + y / 11 + i as u32) % 32) * 3;
        [
            ((x * 255 / 1920) + noise).min(255) as u8,
            ((y * 255 / 1080) + ring).min(255) as u8,
            ((x + y) % 256) as u8,
        ]
    }))
}

/// Submits `dir` and marks every digest positive.
fn submit_all_positive(history: &History, dir: &Path) {
    let report = submit(
        history,
        Submission {
            inputs: collect_folder(dir).unwrap(),
            keys: Default::default(),
            idempotency_key: None,
            rules: &Rules::default(),
            compare: None,
        },
    )
    .unwrap();
    for f in &report.frames {
        history
            .triage(MAIN, &f.test, &f.digest, Label::Positive, ("bench", "seed"))
            .unwrap();
    }
}

fn ingest(c: &mut Criterion) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("frames");
    std::fs::create_dir_all(&dir).unwrap();
    for i in 0..FRAMES {
        write_frame_png(&dir.join(format!("t{i:03}.png")), &frame(i)).unwrap();
    }
    let bytes: u64 = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().metadata().unwrap().len())
        .sum();
    println!(
        "{FRAMES} 1080p PNG frames, {:.2} MB each",
        bytes as f64 / FRAMES as f64 / 1e6
    );
    let history = History::open(&tmp.path().join("h.sqlite")).unwrap();
    submit_all_positive(&history, &dir);
    let rules = Rules::default();
    let mut group = c.benchmark_group("frames");
    group.sample_size(10);
    group.throughput(Throughput::Elements(FRAMES as u64));
    group.bench_function("exact_matches_1080p", |b| {
        b.iter(|| {
            let report = submit(
                &history,
                Submission {
                    inputs: collect_folder(&dir).unwrap(),
                    keys: Default::default(),
                    idempotency_key: None,
                    rules: &rules,
                    compare: None,
                },
            )
            .unwrap();
            assert!(report.passed);
        })
    });
    // One untriaged frame against one positive under a fuzzy rule.
    let fuzzy_dir = tmp.path().join("fuzzy");
    std::fs::create_dir_all(&fuzzy_dir).unwrap();
    let path = fuzzy_dir.join("scene.png");
    write_frame_png(&path, &frame(0)).unwrap();
    submit_all_positive(&history, &fuzzy_dir);
    let Frame::Rgb8(mut off) = frame(0) else {
        unreachable!()
    };
    off.pixels[0][0] ^= 1;
    write_frame_png(&path, &Frame::Rgb8(off)).unwrap();
    let fuzzy: Rules = toml::from_str(
        "[[tests]]\npattern = \"*\"\nchecks = [{ max_abs_diff = 1 }, { min_ssim = 0.99 }, { max_flip_mean = 0.01 }]",
    )
    .unwrap();
    group.throughput(Throughput::Elements(1));
    // The same comparison with the GPU's metrics (`frames submit --metrics
    // gpu`) on the default adapter, in the same run.
    let ctx = tonegate::gpu::GpuContext::new(&Default::default()).unwrap();
    let gpu = tonegate::gpu::compare::GpuCompare::new(&ctx);
    gpu.self_check().unwrap();
    println!("GPU metrics on {}", ctx.adapter.name);
    let on_gpu = |t: tonegate::metrics::Raster, r: tonegate::metrics::Raster| gpu.compare(t, r);
    for (name, compare) in [
        ("fuzzy_1080p_cpu_metrics", None),
        (
            "fuzzy_1080p_gpu_metrics",
            Some(tonegate::metrics::CompareBy(&on_gpu)),
        ),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                let report = submit(
                    &history,
                    Submission {
                        inputs: collect_folder(&fuzzy_dir).unwrap(),
                        keys: Default::default(),
                        idempotency_key: None,
                        rules: &fuzzy,
                        compare,
                    },
                )
                .unwrap();
                assert!(report.passed, "{}", report.console());
            })
        });
    }
    group.finish();
}

criterion_group!(benches, ingest);
criterion_main!(benches);
