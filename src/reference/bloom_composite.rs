//! `bloom_composite`: bilinear upsample of the blurred bloom, added after tone mapping.

use crate::image::LinearImage;
use crate::par::*;

/// Bilinear sample of `low` at the full-resolution pixel (x, y) of a
/// `width`×`height` frame, texel centres aligned ((x + 0.5)/W = (xl + 0.5)/Wl),
/// clamped at the edges.
pub fn upsample_at(low: &LinearImage, x: u32, y: u32, width: u32, height: u32) -> [f64; 3] {
    let fx = (x as f64 + 0.5) * low.width as f64 / width as f64 - 0.5;
    let fy = (y as f64 + 0.5) * low.height as f64 / height as f64 - 0.5;
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let (wl, hl) = (low.width as i64 - 1, low.height as i64 - 1);
    let xa = (x0 as i64).clamp(0, wl) as u32;
    let xb = (x0 as i64 + 1).clamp(0, wl) as u32;
    let ya = (y0 as i64).clamp(0, hl) as u32;
    let yb = (y0 as i64 + 1).clamp(0, hl) as u32;
    let (p00, p10, p01, p11) = (
        low.get(xa, ya),
        low.get(xb, ya),
        low.get(xa, yb),
        low.get(xb, yb),
    );
    let mut out = [0.0; 3];
    for c in 0..3 {
        let top = p00[c] * (1.0 - tx) + p10[c] * tx;
        let bottom = p01[c] * (1.0 - tx) + p11[c] * tx;
        out[c] = top * (1.0 - ty) + bottom * ty;
    }
    out
}

/// C = C_tone + k·upsample(C_bloom).
pub fn bloom_composite(toned: &LinearImage, bloom: &LinearImage, strength: f64) -> LinearImage {
    let (w, h) = (toned.width, toned.height);
    let mut out = toned.clone();
    out.pixels
        .par_chunks_mut(w.max(1) as usize)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, px) in row.iter_mut().enumerate() {
                let b = upsample_at(bloom, x as u32, y as u32, w, h);
                for c in 0..3 {
                    px[c] += strength * b[c];
                }
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upsampling_a_constant_is_exact_and_centres_align() {
        let low = LinearImage::filled(3, 2, [0.5, 0.25, 1.0]);
        assert_eq!(upsample_at(&low, 5, 3, 6, 4), [0.5, 0.25, 1.0]);
        let ramp = LinearImage::from_fn(2, 1, |x, _| [x as f64, 0.0, 0.0]);
        // Full-res pixel 1 of 4 sits at low-res 0.25: a quarter of the way.
        assert!((upsample_at(&ramp, 1, 0, 4, 1)[0] - 0.25).abs() < 1e-15);
        let toned = LinearImage::filled(6, 4, [0.1; 3]);
        let c = bloom_composite(&toned, &low, 2.0);
        assert!((c.get(0, 0)[0] - 1.1).abs() < 1e-15);
    }
}
