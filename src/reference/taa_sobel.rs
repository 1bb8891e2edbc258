//! `taa_sobel`: how aliased each pixel of the current jittered frame is, for
//! the edge-aware TAA (the TAA thesis, docs/bibliography.md, §3.8 and
//! §4.3.3).
//!
//! The thesis runs Sobel on the luminance of the lit scene, of the unlit
//! G-buffer and on linear depth, and mixes the three (eq. 4.9). A camera
//! inside one sphere has neither an unlit albedo distinct from what it sees
//! nor a depth edge (every pixel is at the same distance), so only the lit
//! luminance term exists here: g = l. The thesis also stabilises the Sobel
//! value with a small clamped TAA of its own; that is not done here, the
//! value is the current frame's.

use crate::color::{luminance, SMALLEST_NORMAL};
use crate::image::{Image, LinearImage};
use crate::par::*;

/// Luminance at (x, y), the coordinates clamped to the frame.
pub(crate) fn clamped<P: Copy>(img: &Image<P>, x: i64, y: i64) -> P {
    let x = x.clamp(0, img.width as i64 - 1) as usize;
    let y = y.clamp(0, img.height as i64 - 1) as usize;
    img.pixels[y * img.width as usize + x]
}

/// The aliasing amount of every pixel (after the TAA thesis), in [0, 1].
///
/// The Sobel magnitude |G| of BT.709 luminance over the 3×3 neighbourhood
/// (kernels 3.5 and 3.6) is made scale-free for HDR by dividing by 4·Ymax of
/// that neighbourhood: a step from 0 to any Y scores 1, a step from a to b
/// scores (b − a)/b. The thesis's frames are display-referred in [0, 1], so it
/// needs no such division; an HDR frame spans five decades and would mark
/// every edge of the sun and none of the night. The result is clamped to
/// [0, 1] and shaped by eq. 4.10, √(g²(3 − 2g)).
pub fn taa_sobel(current: &LinearImage) -> Image<f64> {
    let (w, h) = (current.width as usize, current.height as usize);
    let y_of = current.map(luminance);
    let mut out = vec![0.0f64; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
        for (i, o) in row.iter_mut().enumerate() {
            let (x, y) = (i as i64, j as i64);
            let l = |dx: i64, dy: i64| clamped(&y_of, x + dx, y + dy);
            let (a, b, c) = (l(-1, -1), l(0, -1), l(1, -1));
            let (d, f) = (l(-1, 0), l(1, 0));
            let (g, hh, k) = (l(-1, 1), l(0, 1), l(1, 1));
            *o = sobel_amount(a, b, c, d, l(0, 0), f, g, hh, k);
        }
    });
    Image {
        width: current.width,
        height: current.height,
        pixels: out,
    }
}

/// The amount for one 3×3 neighbourhood (row-major a..k, e the centre); the
/// shader's `sobel_amount` does the same arithmetic.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sobel_amount(
    a: f64,
    b: f64,
    c: f64,
    d: f64,
    e: f64,
    f: f64,
    g: f64,
    h: f64,
    k: f64,
) -> f64 {
    let gx = (c + 2.0 * f + k) - (a + 2.0 * d + g);
    let gy = (a + 2.0 * b + c) - (g + 2.0 * h + k);
    let ymax = a.max(b).max(c).max(d).max(e).max(f).max(g).max(h).max(k);
    if ymax < SMALLEST_NORMAL {
        return 0.0;
    }
    let m = ((gx * gx + gy * gy).sqrt() / (4.0 * ymax)).clamp(0.0, 1.0);
    (m * m * (3.0 - 2.0 * m)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_areas_score_zero_and_hard_edges_one_at_any_exposure() {
        for scale in [1e-3, 1.0, 5e4] {
            let img = LinearImage::from_fn(8, 8, |x, _| {
                let v = if x < 4 { 0.0 } else { scale };
                [v, v, v]
            });
            let s = taa_sobel(&img);
            assert_eq!(s.get(1, 4), 0.0, "flat dark");
            assert_eq!(s.get(6, 4), 0.0, "flat bright");
            assert!(
                (s.get(4, 4) - 1.0).abs() < 1e-12,
                "edge at {scale}: {}",
                s.get(4, 4)
            );
        }
    }

    #[test]
    fn a_soft_edge_scores_between() {
        let img = LinearImage::from_fn(8, 8, |x, _| {
            let v = if x < 4 { 1.0 } else { 1.2 };
            [v, v, v]
        });
        let v = taa_sobel(&img).get(4, 4);
        assert!(v > 0.0 && v < 0.7, "{v}");
    }
}
