//! `histogram`: a frame's weighted histogram of log2 luminance, what
//! `Metering::Histogram` meters (scene::Adaptation; docs/adaptation.md),
//! in f64.

use crate::image::LinearImage;
use crate::scene::{Adaptation, Mask};

/// The histogram's bins over [`Adaptation::min_ev`, `max_ev`].
pub const BINS: usize = crate::scene::HISTOGRAM_BINS;

/// A frame's weighted histogram of log2 luminance (`Metering::Histogram`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Histogram {
    pub bins: [u64; BINS],
}

/// The bin of luminance `y`: below `min_ev` (zero included) the first,
/// above `max_ev` the last; `None` for a NaN, infinite or negative one,
/// which is not metered.
pub fn bin_of(y: f64, a: &Adaptation) -> Option<usize> {
    if !(y.is_finite() && y >= 0.0) {
        return None;
    }
    let at = (y.log2() - a.min_ev) * BINS as f64 / (a.max_ev - a.min_ev);
    // A NaN never gets here; log2(0) = −inf clamps to the first bin.
    Some(at.floor().clamp(0.0, (BINS - 1) as f64) as usize)
}

/// The weight of pixel (`x`, `y`) of a `w`×`h` frame under `mask`.
pub fn mask_weight(mask: Mask, x: u32, y: u32, w: u32, h: u32) -> u64 {
    // Four bands from each edge in: 1 + ⌊8·distance to the nearer edge / n⌋.
    let band = |i: u32, n: u32| 1 + u64::from(8 * i.min(n - 1 - i) / n);
    match mask {
        Mask::Uniform => 1,
        Mask::Centre => band(x, w) * band(y, h),
    }
}

/// The histogram of `img` for `a` (its range and mask), luminance by
/// `weights`.
pub fn histogram(img: &LinearImage, weights: [f64; 3], a: &Adaptation) -> Histogram {
    let mut bins = [0u64; BINS];
    for (i, &c) in img.pixels.iter().enumerate() {
        let (x, y) = (i as u32 % img.width, i as u32 / img.width);
        if let Some(b) = bin_of(crate::color::luminance_with(c, weights), a) {
            bins[b] += mask_weight(a.mask, x, y, img.width, img.height);
        }
    }
    Histogram { bins }
}

impl Histogram {
    /// The EV at the centre of bin `i`.
    pub fn centre(i: usize, a: &Adaptation) -> f64 {
        a.min_ev + (i as f64 + 0.5) * (a.max_ev - a.min_ev) / BINS as f64
    }

    /// The metered EV: the mean bin centre of the weight left once the
    /// darkest `low` and the brightest 1 − `high` of it are dropped (a bin
    /// cut by either in part); `None` when none is left.
    pub fn metered_ev(&self, a: &Adaptation) -> Option<f64> {
        let total: u64 = self.bins.iter().sum();
        let (lo, hi) = (a.low * total as f64, a.high * total as f64);
        let (mut below, mut sum, mut kept) = (0.0, 0.0, 0.0);
        for (i, &c) in self.bins.iter().enumerate() {
            let upto = below + c as f64;
            let k = upto.clamp(lo, hi) - f64::clamp(below, lo, hi);
            sum += k * Histogram::centre(i, a);
            kept += k;
            below = upto;
        }
        (kept > 0.0).then(|| sum / kept)
    }
}
