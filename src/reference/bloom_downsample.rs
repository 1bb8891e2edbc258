//! `bloom_downsample`: box average to 1/factor resolution.

use crate::image::LinearImage;

/// The low-resolution size: ceil(size / factor), so no row or column is lost.
pub fn downsampled_size(width: u32, height: u32, factor: u32) -> (u32, u32) {
    (width.div_ceil(factor), height.div_ceil(factor))
}

/// Each output pixel is the mean of its factor×factor block; blocks cut by the
/// right or bottom edge average only the pixels they have.
pub fn bloom_downsample(src: &LinearImage, factor: u32) -> LinearImage {
    let (w, h) = downsampled_size(src.width, src.height, factor);
    LinearImage::from_fn(w, h, |bx, by| {
        let x0 = bx * factor;
        let y0 = by * factor;
        let x1 = (x0 + factor).min(src.width);
        let y1 = (y0 + factor).min(src.height);
        let mut acc = [0.0f64; 3];
        for y in y0..y1 {
            for x in x0..x1 {
                let c = src.get(x, y);
                acc[0] += c[0];
                acc[1] += c[1];
                acc[2] += c[2];
            }
        }
        let n = ((x1 - x0) * (y1 - y0)) as f64;
        [acc[0] / n, acc[1] / n, acc[2] / n]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odd_sizes_keep_the_last_row_and_column() {
        let img = LinearImage::from_fn(5, 3, |x, y| [x as f64, y as f64, 1.0]);
        let d = bloom_downsample(&img, 2);
        assert_eq!((d.width, d.height), (3, 2));
        // The last column block holds x = 4 only; the last row block y = 2 only.
        assert_eq!(d.get(2, 1), [4.0, 2.0, 1.0]);
        assert_eq!(d.get(0, 0), [0.5, 0.5, 1.0]);
    }
}
