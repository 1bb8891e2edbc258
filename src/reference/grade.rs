//! `grade`: the brightness, contrast and saturation of the image-processing
//! lecture (docs/bibliography.md).

use crate::color::{luminance_with, GRADE_SATURATION_WEIGHTS};
use crate::image::LinearImage;
use crate::par::*;
use crate::scene::Grade;

/// Brightness scales; contrast mixes with the grey of the (brightened) mean
/// luminance; saturation mixes with the pixel's own luminance (weights
/// 0.2125/0.7154/0.0721, the lecture's). mix(a, b, t) = a + (b − a)·t, as in
/// GLSL.
pub fn grade(img: &LinearImage, g: &Grade, mean_luminance: f64) -> LinearImage {
    let (b, c, s) = (g.brightness.get(), g.contrast.get(), g.saturation.get());
    let grey = b * mean_luminance;
    let mut out = img.clone();
    out.pixels.par_iter_mut().for_each(|px| {
        let mut v = px.map(|x| x * b);
        v = v.map(|x| grey + (x - grey) * c);
        let y = luminance_with(v, GRADE_SATURATION_WEIGHTS);
        *px = v.map(|x| y + (x - y) * s);
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::NonNegative;

    fn g(b: f64, c: f64, s: f64) -> Grade {
        Grade {
            brightness: NonNegative::try_from(b).unwrap(),
            contrast: NonNegative::try_from(c).unwrap(),
            saturation: NonNegative::try_from(s).unwrap(),
        }
    }

    #[test]
    fn each_control_does_what_the_lecture_says() {
        let img = LinearImage::from_fn(2, 1, |x, _| {
            if x == 0 {
                [0.2, 0.4, 0.6]
            } else {
                [0.6, 0.4, 0.2]
            }
        });
        let mean = crate::reference::grade_stats::grade_stats(&img);
        assert_eq!(grade(&img, &g(1.0, 1.0, 1.0), mean), img);
        let bright = grade(&img, &g(2.0, 1.0, 1.0), mean);
        assert!((bright.get(0, 0)[2] - 1.2).abs() < 1e-15);
        let flat = grade(&img, &g(1.0, 0.0, 1.0), mean);
        assert!(flat
            .pixels
            .iter()
            .flatten()
            .all(|&v| (v - mean).abs() < 1e-15));
        let grey = grade(&img, &g(1.0, 1.0, 0.0), mean);
        let p = grey.get(0, 0);
        assert!((p[0] - p[1]).abs() < 1e-15 && (p[1] - p[2]).abs() < 1e-15);
    }
}
