//! ΔE_ITP (ITU-R BT.2124): the colour difference of HDR pixels in BT.2100's
//! ICtCp with the PQ curve, 720·√(ΔI² + (½ΔCt)² + ΔCp²); 1 is about one
//! just-noticeable difference.
//!
//! Input is linear BT.709 (tonegate's working space) with 1.0 = `peak`
//! cd/m²; it is converted to BT.2020 with the matrix derived from the two
//! spaces' primaries and D65 white, as colour-science derives it.

use super::hdr_input::check_hdr_pair;
use super::MetricsError;
use crate::image::{HdrImage, Image};
use rayon::prelude::*;

use crate::color::{
    apply, inverse, mul, npm, pq_encode as pq, Mat3, BT2020_XY as BT2020, BT709_XY as BT709,
    D65_XY as D65,
};

/// BT.2100's RGB (BT.2020) → LMS, in 4096ths.
const RGB_TO_LMS: Mat3 = [
    [1688.0 / 4096.0, 2146.0 / 4096.0, 262.0 / 4096.0],
    [683.0 / 4096.0, 2951.0 / 4096.0, 462.0 / 4096.0],
    [99.0 / 4096.0, 309.0 / 4096.0, 3688.0 / 4096.0],
];
/// BT.2100's L'M'S' → ICtCp, in 4096ths.
const LMS_TO_ICTCP: Mat3 = [
    [0.5, 0.5, 0.0],
    [6610.0 / 4096.0, -13613.0 / 4096.0, 7003.0 / 4096.0],
    [17933.0 / 4096.0, -17390.0 / 4096.0, -543.0 / 4096.0],
];

/// Linear BT.709 (1.0 = `peak` cd/m²) → ICtCp.
fn to_ictcp(rgb709_to_lms: &Mat3, p: &[f32; 3], peak: f64) -> [f64; 3] {
    let lms = apply(rgb709_to_lms, p.map(|c| f64::from(c) * peak));
    apply(&LMS_TO_ICTCP, lms.map(pq))
}

/// ΔE_ITP per pixel, its mean and maximum.
#[derive(Clone, Debug)]
pub struct Itp {
    pub map: Image<f64>,
    pub mean: f64,
    pub max: f64,
}

/// ΔE_ITP of `test` against `reference` (linear BT.709, 1.0 = `peak` cd/m²).
pub fn delta_e_itp(test: &HdrImage, reference: &HdrImage, peak: f64) -> Result<Itp, MetricsError> {
    check_hdr_pair(test, reference)?;
    if !(peak.is_finite() && peak > 0.0) {
        return Err(MetricsError::BadParameter {
            name: "peak",
            detail: format!("the display peak must be a finite number of cd/m² > 0, got {peak}"),
        });
    }
    let m = mul(
        &RGB_TO_LMS,
        &mul(&inverse(&npm(BT2020, D65)), &npm(BT709, D65)),
    );
    let pixels: Vec<f64> = test
        .pixels
        .par_iter()
        .zip(&reference.pixels)
        .map(|(a, b)| {
            let (x, y) = (to_ictcp(&m, a, peak), to_ictcp(&m, b, peak));
            let (di, dt, dp) = (x[0] - y[0], 0.5 * (x[1] - y[1]), x[2] - y[2]);
            720.0 * (di * di + dt * dt + dp * dp).sqrt()
        })
        .collect();
    let mean = pixels.iter().sum::<f64>() / pixels.len() as f64;
    let max = pixels.iter().copied().fold(0.0, f64::max);
    Ok(Itp {
        map: Image {
            width: test.width,
            height: test.height,
            pixels,
        },
        mean,
        max,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bt709_to_bt2020_matrix_is_bt2087s() {
        // BT.2087's published matrix, to its four decimals.
        let m = mul(&inverse(&npm(BT2020, D65)), &npm(BT709, D65));
        let want = [
            [0.6274, 0.3293, 0.0433],
            [0.0691, 0.9195, 0.0114],
            [0.0164, 0.0880, 0.8956],
        ];
        for i in 0..3 {
            for j in 0..3 {
                assert!((m[i][j] - want[i][j]).abs() < 5e-5, "{m:?}");
            }
        }
    }

    #[test]
    fn pq_meets_its_anchor_points() {
        assert!((pq(10000.0) - 1.0).abs() < 1e-12);
        // ST 2084: 100 cd/m² encodes to about 0.508.
        assert!((pq(100.0) - 0.508).abs() < 1e-3, "{}", pq(100.0));
        assert!(pq(0.0) < 1e-6);
    }

    #[test]
    fn identical_images_differ_by_zero_and_a_grey_step_by_a_little() {
        let a = HdrImage::filled(8, 8, [0.5, 0.5, 0.5]);
        let r = delta_e_itp(&a, &a, 100.0).unwrap();
        assert_eq!((r.mean, r.max), (0.0, 0.0));
        let b = HdrImage::filled(8, 8, [0.51, 0.51, 0.51]);
        let r = delta_e_itp(&b, &a, 100.0).unwrap();
        // A 2 % luminance step at 50 cd/m² is near one JND.
        assert!(r.mean > 0.3 && r.mean < 3.0, "{}", r.mean);
        assert!((r.mean - r.max).abs() < 1e-12 * r.max);
    }
}
