//! PU21 (Mantiuk & Azimi, "PU21: A novel perceptually uniform encoding for
//! adapting existing quality metrics for HDR", Picture Coding Symposium 2021)
//! and PSNR/SSIM on PU21-encoded images, as the authors' `pu21_metric` runs
//! them: absolute luminance in cd/m² encoded with the recommended
//! `banding_glare` fit, PSNR over the encoded RGB channels against a peak of
//! 256, SSIM on the encoded luminance with a dynamic range of 256.
//!
//! tonegate's images are relative (1.0 is whatever the scene makes it): a
//! scene or command states the display peak in cd/m² that 1.0 maps to.

use super::hdr_input::{check_hdr_pair, check_hdr_sizes, luminance_pfs, non_finite, HdrView};
use super::ssim::{mean_ssim_mapped, ssim_mapped, Ssim};
use super::MetricsError;
use rayon::prelude::*;
use std::sync::OnceLock;

/// The `banding_glare` parameters p1…p7 of V = p7·(((p1 + p2·Y^p4) /
/// (1 + p3·Y^p4))^p5 − p6), from the authors' pu21_encoder (parameters of
/// 06/02/2020, the encoding the paper recommends).
pub const BANDING_GLARE: [f64; 7] = [
    0.353487901,
    0.3734658629,
    8.277049286e-05,
    0.9062562627,
    0.09150303166,
    0.9099517204,
    596.3148142,
];
/// The luminance range the fit covers, cd/m²; values outside are clamped.
pub const L_MIN: f64 = 0.005;
pub const L_MAX: f64 = 10000.0;
/// The peak of PU21-PSNR and the dynamic range of PU21-SSIM (the authors'
/// `psnr(T, R, 256)` and `ssim(T, R, 'DynamicRange', 256)`).
pub const PU21_RANGE: f64 = 256.0;
/// The display peak 1.0 maps to when a scene does not say (cd/m²).
pub const DEFAULT_PEAK: f64 = 100.0;

/// The PU21 value of luminance `y` cd/m², by the formula.
pub fn encode_exact(y: f64) -> f64 {
    formula(y.clamp(L_MIN, L_MAX))
}

/// The fit itself, also outside its range (the table's end segments need
/// the smooth curve on both sides of the clamp).
fn formula(y: f64) -> f64 {
    let [p1, p2, p3, p4, p5, p6, p7] = BANDING_GLARE;
    let t = libm::pow(y, p4);
    p7 * (libm::pow((p1 + p2 * t) / (1.0 + p3 * t), p5) - p6)
}

/// Segments per binade of the encoding table.
const SEGMENTS: usize = 1024;
/// Binades 2^-8 (0.0039, below L_MIN) up to 2^13 (8192, whose binade holds L_MAX).
const FIRST_BINADE: i32 = -8;
const BINADES: usize = 22;

/// The formula at the segment ends of every binade: the encoding is a
/// smooth curve, so interpolating it linearly between 1024 points per
/// binade stays within 1e-5 PU units of the formula (tested; 4e-8 of the
/// 256 range PSNR and SSIM use), at two table reads instead of two `pow`s.
fn table() -> &'static [f64] {
    static TABLE: OnceLock<Vec<f64>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = Vec::with_capacity(BINADES * SEGMENTS + 1);
        for b in 0..BINADES {
            let base = libm::exp2(f64::from(FIRST_BINADE + b as i32));
            for k in 0..SEGMENTS {
                t.push(formula(base * (1.0 + k as f64 / SEGMENTS as f64)));
            }
        }
        t.push(formula(libm::exp2(f64::from(
            FIRST_BINADE + BINADES as i32,
        ))));
        t
    })
}

/// The PU21 value of luminance `y` cd/m² (clamped to the fit's range), by
/// the table.
pub fn encode(y: f64) -> f64 {
    let y = if y.is_nan() {
        L_MIN
    } else {
        y.clamp(L_MIN, L_MAX)
    };
    let bits = y.to_bits();
    let exponent = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let mantissa = bits & ((1u64 << 52) - 1);
    let segment = (mantissa >> (52 - 10)) as usize;
    let frac = (mantissa & ((1u64 << 42) - 1)) as f64 / (1u64 << 42) as f64;
    let i = (exponent - FIRST_BINADE) as usize * SEGMENTS + segment;
    let t = table();
    t[i] + frac * (t[i + 1] - t[i])
}

/// PU21-PSNR and PU21-SSIM of a pair.
#[derive(Clone, Debug)]
pub struct Pu21 {
    /// 10·log10(256² / MSE) over the encoded R, G, B; +∞ when identical.
    pub psnr: f64,
    /// SSIM of the encoded luminance (map and mean).
    pub ssim: Ssim,
    /// The display peak 1.0 was mapped to, cd/m².
    pub peak: f64,
}

fn check_peak(peak: f64) -> Result<(), MetricsError> {
    if peak.is_finite() && peak > 0.0 {
        Ok(())
    } else {
        Err(MetricsError::BadParameter {
            name: "peak",
            detail: format!("the display peak must be a finite number of cd/m² > 0, got {peak}"),
        })
    }
}

/// PU21-PSNR and PU21-SSIM of `test` against `reference` (linear, 1.0 =
/// `peak` cd/m²). Non-finite values are refused.
pub fn pu21(test: HdrView, reference: HdrView, peak: f64) -> Result<Pu21, MetricsError> {
    Ok(Pu21 {
        psnr: pu21_psnr(test, reference, peak)?,
        ssim: pu21_ssim(test, reference, peak)?,
        peak,
    })
}

/// PU21-PSNR: 10·log10(256² / MSE) over the encoded R, G and B; +∞ when
/// the images are identical.
pub fn pu21_psnr(test: HdrView, reference: HdrView, peak: f64) -> Result<f64, MetricsError> {
    check_hdr_pair(test, reference)?;
    check_peak(peak)?;
    // Squared error of the encoded channels, summed per row in parallel
    // and added in row order (the same result on any number of threads).
    let w = test.width as usize;
    let row_errors: Vec<f64> = test
        .pixels
        .par_chunks(w)
        .zip(reference.pixels.par_chunks(w))
        .map(|(t, r)| {
            let mut sum = 0.0;
            for (a, b) in t.iter().zip(r) {
                for c in 0..3 {
                    let d = encode(f64::from(a[c]) * peak) - encode(f64::from(b[c]) * peak);
                    sum += d * d;
                }
            }
            sum
        })
        .collect();
    let mse = row_errors.iter().sum::<f64>() / (test.pixels.len() * 3) as f64;
    Ok(if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * libm::log10(PU21_RANGE * PU21_RANGE / mse)
    })
}

/// The encoded luminance of a pixel on SSIM's 8-bit scale (255/256 of the
/// PU value: SSIM does not change when values and range scale together);
/// NaN for a pixel that is not finite, which then makes the SSIM NaN.
fn encoded_luminance(p: &[f32; 3], peak: f64) -> f64 {
    if p.iter().all(|c| c.is_finite()) {
        encode(luminance_pfs(p) * peak) * (255.0 / PU21_RANGE)
    } else {
        f64::NAN
    }
}

/// A NaN SSIM means a pixel was not finite: the error names the first.
fn refuse_non_finite(mean: f64, test: HdrView, reference: HdrView) -> Result<(), MetricsError> {
    if !mean.is_nan() {
        return Ok(());
    }
    match non_finite("image under test", test).or_else(|| non_finite("reference", reference)) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// PU21-SSIM: SSIM of the encoded luminance (pfstools' weights) with a
/// dynamic range of 256, and its map.
pub fn pu21_ssim(test: HdrView, reference: HdrView, peak: f64) -> Result<Ssim, MetricsError> {
    check_hdr_sizes(test, reference)?;
    check_peak(peak)?;
    let f = |p: &[f32; 3]| encoded_luminance(p, peak);
    let s = ssim_mapped(&test.pixels, &reference.pixels, test.width, test.height, &f)?;
    refuse_non_finite(s.mean, test, reference)?;
    Ok(s)
}

/// [`pu21_ssim`]'s mean only.
pub fn pu21_ssim_mean(test: HdrView, reference: HdrView, peak: f64) -> Result<f64, MetricsError> {
    check_hdr_sizes(test, reference)?;
    check_peak(peak)?;
    let f = |p: &[f32; 3]| encoded_luminance(p, peak);
    let mean = mean_ssim_mapped(&test.pixels, &reference.pixels, test.width, test.height, &f)?;
    refuse_non_finite(mean, test, reference)?;
    Ok(mean)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_follows_the_formula_over_the_whole_range() {
        let mut worst: f64 = 0.0;
        // A dense log sweep, plus every segment end and midpoint.
        let n = 200_000;
        for i in 0..=n {
            let y = L_MIN * (L_MAX / L_MIN).powf(i as f64 / n as f64);
            worst = worst.max((encode(y) - encode_exact(y)).abs());
        }
        // Linear interpolation between 1024 points per binade: the worst
        // measured is 9.8e-6 PU units, at 8196 cd/m² (the binade 2^13, whose
        // segments are 8 cd/m² wide), 4e-8 of the 256 range.
        assert!(worst < 1e-5, "table error {worst:e} PU units");
        assert_eq!(encode(0.0), encode(L_MIN), "below the range: clamped");
        assert_eq!(encode(-3.0), encode(L_MIN), "negative: clamped");
        assert_eq!(encode(1e9), encode(L_MAX), "above the range: clamped");
        assert!((encode(L_MAX) - encode_exact(L_MAX)).abs() < 1e-5);
    }

    #[test]
    fn published_values() {
        // PU21 maps the range onto about 0..596 (p7) with 100 cd/m² near 256:
        // the reason the authors use 256 as PSNR peak and SSIM range.
        assert!(encode_exact(L_MIN).abs() < 1.0, "{}", encode_exact(L_MIN));
        let v100 = encode_exact(100.0);
        assert!((v100 - 256.0).abs() < 15.0, "{v100}");
        assert!(encode_exact(L_MAX) < BANDING_GLARE[6]);
        // Monotonic.
        let mut last = f64::NEG_INFINITY;
        for i in 0..1000 {
            let v = encode(L_MIN * 1.02f64.powi(i));
            assert!(v >= last);
            last = v;
        }
    }
}
