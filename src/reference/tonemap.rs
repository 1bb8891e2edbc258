//! `tonemap`: the operator's f64 curve on every pixel. The operators
//! themselves, their resolution from the statistics and their curves, are
//! in `crate::operators` (docs/operators.md).

use crate::image::LinearImage;
use crate::operators::Tone;
use crate::par::*;

pub use crate::operators::reinhard::{invert3, rgb_to_xyz, DELTA, DELTA_PFS};
pub use crate::operators::ToneParams;

/// Tone-maps a linear HDR frame.
pub fn tonemap(img: &LinearImage, tone: &Tone) -> LinearImage {
    tonemap_into(img.clone(), tone)
}

/// [`tonemap`] in the input's own buffer.
pub fn tonemap_into(mut img: LinearImage, tone: &Tone) -> LinearImage {
    img.pixels.par_iter_mut().for_each(|c| *c = tone.pixel(*c));
    img
}
