//! `grade_stats`: the mean luminance contrast mixes with.

use crate::color::luminance;
use crate::image::LinearImage;
use crate::par::*;
use crate::reference::luminance_stats::CompensatedSum;

/// Mean BT.709 luminance of the frame entering the grade (contrast's grey),
/// summed row by row in order so it is deterministic.
pub fn grade_stats(img: &LinearImage) -> f64 {
    let rows: Vec<CompensatedSum> = img
        .pixels
        .par_chunks(img.width.max(1) as usize)
        .map(|row| {
            let mut s = CompensatedSum::default();
            for &c in row {
                s.add(luminance(c));
            }
            s
        })
        .collect();
    let mut total = CompensatedSum::default();
    for r in rows {
        total.merge(r);
    }
    total.value() / img.pixel_count().max(1) as f64
}
