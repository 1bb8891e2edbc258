//! `bloom_bright`: which pixels feed the bloom.

use crate::color::{luminance_with, SMALLEST_NORMAL};
use crate::image::LinearImage;
use crate::par::*;
use crate::scene::BrightPass;

/// `Scaled` (the modified Reinhard for training simulators): C·(Y/Lmax) where
/// Y > threshold, else 0 (on the HDR frame; the factor brings the brightest
/// pixel's contribution to its own colour scale over Lmax). `Threshold` (the
/// image-processing lecture): C where Y > threshold, else 0 (on the
/// tone-mapped frame). Both sources are in docs/bibliography.md.
pub fn bloom_bright(
    src: &LinearImage,
    pass: BrightPass,
    threshold: f64,
    max_luminance: f64,
    weights: [f64; 3],
) -> LinearImage {
    let inv_max = if max_luminance >= SMALLEST_NORMAL && max_luminance.is_finite() {
        1.0 / max_luminance
    } else {
        0.0
    };
    let mut out = src.clone();
    out.pixels.par_iter_mut().for_each(|c| {
        let y = luminance_with(*c, weights);
        *c = if y > threshold {
            match pass {
                BrightPass::Scaled => {
                    let k = y * inv_max;
                    [c[0] * k, c[1] * k, c[2] * k]
                }
                BrightPass::Threshold => *c,
            }
        } else {
            [0.0; 3]
        };
    });
    out
}
