//! `bloom_blur`: separable Gaussian, horizontal then vertical, clamped edges.

use crate::image::LinearImage;
use crate::par::*;

/// Normalised weights w\[k\], k = −radius..=radius, ∝ exp(−k²/(2σ²)).
pub fn gaussian_weights(radius: u32, sigma: f64) -> Vec<f64> {
    let r = radius as i64;
    let raw: Vec<f64> = (-r..=r)
        .map(|k| libm::exp(-((k * k) as f64) / (2.0 * sigma * sigma)))
        .collect();
    let sum: f64 = raw.iter().sum();
    raw.into_iter().map(|w| w / sum).collect()
}

/// One 1-D pass along x (`horizontal`) or y, clamping at the edges.
pub fn blur_pass(src: &LinearImage, weights: &[f64], horizontal: bool) -> LinearImage {
    let (w, h) = (src.width as i64, src.height as i64);
    let r = (weights.len() / 2) as i64;
    let mut out = src.clone();
    out.pixels
        .par_chunks_mut(w.max(1) as usize)
        .enumerate()
        .for_each(|(y, row)| {
            let y = y as i64;
            for (x, px) in row.iter_mut().enumerate() {
                let x = x as i64;
                let mut acc = [0.0f64; 3];
                for (i, &wk) in weights.iter().enumerate() {
                    let k = i as i64 - r;
                    let (sx, sy) = if horizontal {
                        ((x + k).clamp(0, w - 1), y)
                    } else {
                        (x, (y + k).clamp(0, h - 1))
                    };
                    let c = src.pixels[(sy * w + sx) as usize];
                    acc[0] += wk * c[0];
                    acc[1] += wk * c[1];
                    acc[2] += wk * c[2];
                }
                *px = acc;
            }
        });
    out
}

/// The two passes of the separable Gaussian.
pub fn bloom_blur(src: &LinearImage, radius: u32, sigma: f64) -> LinearImage {
    let weights = gaussian_weights(radius, sigma);
    let horizontal = blur_pass(src, &weights, true);
    blur_pass(&horizontal, &weights, false)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_are_normalised_and_symmetric() {
        let w = gaussian_weights(4, 1.5);
        assert_eq!(w.len(), 9);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert_eq!(w[0], w[8]);
    }

    #[test]
    fn blur_preserves_a_constant_and_spreads_an_impulse() {
        let flat = LinearImage::filled(7, 5, [2.0, 2.0, 2.0]);
        let b = bloom_blur(&flat, 3, 1.0);
        assert!(b.pixels.iter().all(|p| (p[0] - 2.0).abs() < 1e-14));
        let imp = LinearImage::from_fn(
            9,
            9,
            |x, y| if (x, y) == (4, 4) { [1.0; 3] } else { [0.0; 3] },
        );
        let b = bloom_blur(&imp, 2, 1.0);
        let w = gaussian_weights(2, 1.0);
        assert!((b.get(4, 4)[0] - w[2] * w[2]).abs() < 1e-15);
        assert!((b.get(5, 4)[0] - w[3] * w[2]).abs() < 1e-15);
        let total: f64 = b.pixels.iter().map(|p| p[0]).sum();
        assert!((total - 1.0).abs() < 1e-14);
    }
}
