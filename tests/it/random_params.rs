//! One rule for parameters on both renderers, tried at random: parameter
//! sets drawn from every operator's own declaration (each number in its
//! declared range, log-uniform over wide ones, the bounds themselves and,
//! where a range is open-ended, values f32 cannot hold), with bloom, grade
//! and gamma now and then, sent to `POST /tonemap` on the CPU reference
//! and on the GPU. Neither path may answer 500; both answer alike (200, or
//! the same refusal); and two 200s are two images at most 1 LSB apart
//! anywhere, the bound every operator's GPU frame is held to against its
//! f64 frame (tests/it/operators.rs). `TONEGATE_RANDOM_REQUESTS` sets how
//! many requests (default 1000; 10,000 for the figure in docs/api.md),
//! `TONEGATE_RANDOM_SEED` the seed.

use crate::common;
use crate::common::server::start;
use tonegate::operators::{Kind, Range};

/// xorshift64*: reproducible from its seed, no more is needed.
struct Draw(u64);

impl Draw {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// In [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    fn pick<'a, T>(&mut self, from: &'a [T]) -> &'a T {
        &from[(self.next() % from.len() as u64) as usize]
    }
    /// A number in `r`: a bound itself now and then, log-uniform over a
    /// range of more than two decades, uniform otherwise; an open-ended
    /// range reaches past what f32 holds (1e-300, 1e300).
    fn number(&mut self, r: &Range) -> f64 {
        let lo = if r.min_open && r.min == 0.0 {
            1e-300
        } else {
            r.min
        };
        let hi = if r.max.is_infinite() { 1e300 } else { r.max };
        let v = if self.chance(0.1) {
            lo
        } else if self.chance(0.1) {
            hi
        } else if lo > 0.0 && hi / lo > 100.0 {
            // Mostly within 1e-30..1e30 when open-ended.
            let (a, b) = if r.max.is_infinite() {
                (lo.max(1e-30).ln(), 1e30f64.max(lo).ln())
            } else {
                (lo.ln(), hi.ln())
            };
            (a + (b - a) * self.unit()).exp()
        } else {
            lo + (hi - lo) * self.unit()
        };
        // An open bound itself is not in the range: step inside it.
        match v {
            v if r.contains(v) => v,
            v if v <= r.min => r.min + (r.min.abs() * 1e-9).max(1e-300),
            _ => r.max - (r.max.abs() * 1e-9).max(1e-300),
        }
    }
}

/// A query string for one operator, drawn from its declaration.
fn draw_query(
    d: &mut Draw,
    ops: &[std::sync::Arc<dyn tonegate::operators::ToneOperator>],
) -> String {
    let op = d.pick(ops).clone();
    let mut q = vec![format!("operator={}", op.name())];
    for p in op.params() {
        if d.chance(0.3) {
            continue;
        }
        let value = match p.kind {
            Kind::Number(r) => format!("{:e}", d.number(&r)),
            Kind::NumberOrAuto(r) if d.chance(0.3) => {
                let _ = r;
                "auto".into()
            }
            Kind::NumberOrAuto(r) => format!("{:e}", d.number(&r)),
            Kind::Flag => d.chance(0.5).to_string(),
            Kind::Word(words) => (*d.pick(words)).to_owned(),
        };
        q.push(format!("{}={value}", p.name));
    }
    let factor = Range::closed(0.0, tonegate::scene::GRADE_MAX);
    if d.chance(0.2) {
        q.push(format!("bloom={:e}", d.number(&Range::closed(1e-3, 100.0))));
        if d.chance(0.5) {
            q.push(format!(
                "bloom_sigma={:e}",
                d.number(&Range::closed(0.1, 1e6))
            ));
        }
        if d.chance(0.3) {
            q.push("bloom_pass=threshold".into());
            q.push(format!(
                "bloom_threshold={:e}",
                d.number(&Range::closed(0.0, 1e6))
            ));
        }
    }
    for g in ["brightness", "contrast", "saturation"] {
        if d.chance(0.15) {
            q.push(format!("{g}={:e}", d.number(&factor)));
        }
    }
    if d.chance(0.15) {
        let (lo, hi) = tonegate::scene::GAMMA_RANGE;
        q.push(format!("gamma={:e}", d.number(&Range::closed(lo, hi))));
    }
    q.join("&")
}

/// A small image over twelve decades, with black, one dim and one blinding
/// pixel: what pushes the statistics and the curves to their ends.
fn image(dir: &std::path::Path) -> Vec<u8> {
    let img = tonegate::image::HdrImage::from_fn(24, 16, |x, y| {
        let t = (x + 24 * y) as f32 / 383.0;
        match (x, y) {
            (0, 0) => [0.0; 3],
            (1, 0) => [1e-6, 2e-6, 5e-7],
            (2, 0) => [1e6, 3e5, 2e5],
            _ => {
                let v = 10f32.powf(-6.0 + 12.0 * t);
                [v, v * (0.3 + 0.7 * t), v * (1.0 - 0.5 * t)]
            }
        }
    });
    let path = dir.join("range.pfm");
    tonegate::io::write_image_hdr(&path, &img).unwrap();
    std::fs::read(&path).unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn random_parameters_get_the_same_answer_and_image_on_both_renderers() {
    let requests: usize = std::env::var("TONEGATE_RANDOM_REQUESTS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1000);
    let seed: u64 = std::env::var("TONEGATE_RANDOM_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0x746f_6e65);
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |_| {}).await;
    let body = image(dir.path());
    let ops = tonegate::operators::all();
    let mut d = Draw(seed | 1);
    let (mut same_refusal, mut both_ok, mut worst) = (0usize, 0usize, 0i32);
    let started = std::time::Instant::now();
    for i in 0..requests / 2 {
        let q = draw_query(&mut d, &ops);
        let mut answers = Vec::new();
        for gpu in [false, true] {
            let r = s.tonemap(&format!("gpu={gpu}&{q}"), body.clone()).await;
            let status = r.status().as_u16();
            let bytes = r.bytes().await.unwrap();
            assert!(
                status != 500 && status != 503,
                "request {i} (seed {seed}), gpu={gpu}, {q}: {status} {}",
                String::from_utf8_lossy(&bytes)
            );
            answers.push((status, bytes));
        }
        let ((cs, cpu), (gs, gpu)) = (&answers[0], &answers[1]);
        assert_eq!(
            cs,
            gs,
            "request {i} (seed {seed}), {q}: CPU {} / GPU {}",
            String::from_utf8_lossy(cpu),
            String::from_utf8_lossy(gpu)
        );
        if *cs != 200 {
            // The same refusal: the same code and detail.
            assert_eq!(cpu, gpu, "request {i} (seed {seed}), {q}");
            same_refusal += 1;
            continue;
        }
        let (a, b) = (
            tonegate::io::decode_png8(cpu, "cpu").unwrap(),
            tonegate::io::decode_png8(gpu, "gpu").unwrap(),
        );
        let diff = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .flat_map(|(p, q)| (0..3).map(move |k| (i32::from(p[k]) - i32::from(q[k])).abs()))
            .max()
            .unwrap();
        assert!(
            diff <= 1,
            "request {i} (seed {seed}), {q}: {diff} LSB apart"
        );
        worst = worst.max(diff);
        both_ok += 1;
    }
    eprintln!(
        "random parameters (seed {seed}): {} requests in {:.1} s: {both_ok} sets answered 200 \
         on both (worst {worst} LSB apart), {same_refusal} refused alike, no 500",
        requests / 2 * 2,
        started.elapsed().as_secs_f64()
    );
    assert!(both_ok > requests / 4, "most sets are valid: {both_ok}");
}
