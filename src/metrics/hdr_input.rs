//! What every HDR metric asks of its input pair before it starts: the same
//! size, some pixels, finite values; and the luminance PU21 and the report
//! share. The metrics (`hdr_flip`, `pu21`, `itp`) and their aggregate
//! (`hdr`) import from here, never from each other.

use super::MetricsError;
use crate::image::{HdrImage, Image};
use rayon::prelude::*;

/// The images HDR metrics take.
pub type HdrView<'a> = &'a HdrImage;

/// Refuses a pair that cannot be compared: sizes differ, no pixels, or a
/// value that is not finite (HDR metrics of NaN or ±Inf mean nothing).
pub fn check_hdr_pair(test: &HdrImage, reference: &HdrImage) -> Result<(), MetricsError> {
    check_hdr_sizes(test, reference)?;
    for (role, img) in [("image under test", test), ("reference", reference)] {
        if let Some(e) = non_finite(role, img) {
            return Err(e);
        }
    }
    Ok(())
}

/// The first non-finite value of `img`, as the error that names it.
pub(crate) fn non_finite(role: &'static str, img: &HdrImage) -> Option<MetricsError> {
    img.pixels
        .par_iter()
        .position_first(|p| !p.iter().all(|c| c.is_finite()))
        .map(|i| MetricsError::NonFinite {
            role,
            x: i as u32 % img.width,
            y: i as u32 / img.width,
        })
}

/// The size half of [`check_hdr_pair`]: equal sizes, pixels present. For
/// metrics that find a non-finite value in a pass they make anyway (its
/// result is then NaN) and only then look for where it is, and for 16-bit
/// frames, whose codes are all finite.
pub(crate) fn check_hdr_sizes<P>(
    test: &Image<P>,
    reference: &Image<P>,
) -> Result<(), MetricsError> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(MetricsError::SizeMismatch {
            test_width: test.width,
            test_height: test.height,
            reference_width: reference.width,
            reference_height: reference.height,
        });
    }
    for (role, img) in [("image under test", test), ("reference", reference)] {
        if img.pixels.is_empty() || img.pixels.len() != img.width as usize * img.height as usize {
            return Err(MetricsError::EmptyImage {
                role,
                width: img.width,
                height: img.height,
            });
        }
    }
    Ok(())
}

/// Luminance with pfstools' weights, which PU21's authors use.
pub fn luminance_pfs(p: &[f32; 3]) -> f64 {
    0.212656 * f64::from(p[0]) + 0.715158 * f64::from(p[1]) + 0.072186 * f64::from(p[2])
}
