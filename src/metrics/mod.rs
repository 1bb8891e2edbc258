//! Full-reference image metrics (docs/metrics.md): how far a rendered 8-bit
//! frame is from its golden.
//!
//! - [`raster`]: the borrowed sample view every metric takes;
//! - [`basic`]: MSE, RMSE, PSNR, SNR, maximum difference, fraction over k LSB,
//!   from exact integer sums;
//! - [`ssim`](mod@ssim): SSIM in scikit-image's definition (agreeing to ~1e-12), fast;
//! - [`visual`]: the SSIM map and difference heat-map images;
//! - [`json`]: how +∞ PSNR/SNR is written to JSON.
//!
//! [`compare`] computes the whole set for a report. Tools disagree on SSIM for
//! the same pair, so every report carries [`SSIM_DEFINITION`].

pub mod basic;
pub mod flip;
pub mod frames;
pub mod hdr;
pub mod hdr_flip;
pub mod hdr_input;
pub mod itp;
pub mod json;
pub mod pu21;
pub mod raster;
pub mod ssim;
#[cfg(target_arch = "x86_64")]
mod ssim_avx2;
mod ssim_bands;
mod ssim_kernel;
pub mod visual;

pub use basic::{fraction_over, max_abs_diff, mean_abs_diff, mse, psnr, rmse, snr};
pub use frames::{
    compare_frames, compare_frames_by, frame_diff_heatmap, frame_flip, frame_fraction_over,
    frame_max_abs_diff, frame_ssim,
};
pub use raster::Raster;
pub use ssim::{mean_ssim, ssim, Ssim, SSIM_WINDOW};
pub use visual::{diff_heatmap, heatmap_colour, ssim_map_image, HEATMAP_RAMP};

use serde::{Deserialize, Serialize};
use std::fmt;

/// The SSIM definition every report states (docs/metrics.md).
pub const SSIM_DEFINITION: &str = "Wang et al. 2004 as scikit-image 0.26 \
structural_similarity(gaussian_weights=True, sigma=1.5, use_sample_covariance=False, \
data_range=255, channel_axis=-1): per channel on 0..255 samples in float64, 11-tap \
Gaussian window (sigma 1.5, truncate 3.5) with mirrored ('reflect') borders, K1=0.01, \
K2=0.03, population covariance, mean over the map with a 5-pixel border cropped, \
then averaged over channels";

/// The FLIP definition every report states.
pub const FLIP_DEFINITION: &str = "FLIP (Andersson et al. 2020), NVIDIA's C++ implementation \
through the nv-flip crate, LDR, on the 8-bit sRGB frames at 67.02 pixels per degree (a 0.7 m \
wide 4K display seen from 0.7 m): flip_mean is the mean of the per-pixel map, \
max_flip_percentile the weighted percentile of FLIP's 100-bucket histogram; on 16-bit \
PQ frames, HDR-FLIP (ACES, automatic exposures) of the decoded light in BT.709 cd/m²";

/// Why two images could not be compared.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MetricsError {
    /// The images have different dimensions, so pixels do not correspond.
    #[error(
        "image under test is {test_width}×{test_height} but the reference is \
         {reference_width}×{reference_height}; render at the reference's size \
         (or regenerate the golden) before comparing"
    )]
    SizeMismatch {
        test_width: u32,
        test_height: u32,
        reference_width: u32,
        reference_height: u32,
    },
    /// The images have different channel counts (e.g. RGB against RGBA).
    #[error(
        "image under test has {test} channel(s) per pixel but the reference has \
         {reference}; convert both to the same layout (e.g. drop alpha) first"
    )]
    ChannelMismatch { test: usize, reference: usize },
    /// A sample buffer's length does not match its declared size.
    #[error(
        "{role} is declared {width}×{height} with {channels} channel(s), which \
         needs {expected} samples, but its buffer holds {actual}; check the \
         width, height and channel count it was described with"
    )]
    BadSampleLength {
        role: &'static str,
        width: u32,
        height: u32,
        channels: usize,
        expected: u128,
        actual: usize,
    },
    /// Only grey, RGB and RGBA interleaved samples are supported.
    #[error(
        "{role} has {channels} channel(s) per pixel; only 1 (grey), 3 (RGB) or \
         4 (RGBA) interleaved 8-bit channels are supported"
    )]
    UnsupportedChannels { role: &'static str, channels: usize },
    /// An image without pixels has no mean error.
    #[error("{role} is {width}×{height}: there are no pixels to compare")]
    EmptyImage {
        role: &'static str,
        width: u32,
        height: u32,
    },
    /// SSIM's 11×11 window does not fit (scikit-image refuses these too).
    #[error(
        "SSIM uses an 11×11 Gaussian window (sigma 1.5, as scikit-image), so both \
         sides must be at least 11 pixels, but the images are {width}×{height}; \
         use MSE/PSNR for images this small"
    )]
    TooSmallForSsim { width: u32, height: u32 },
    /// An HDR value that is NaN or infinite: no metric of it means anything.
    #[error("{role} has a non-finite value (NaN or ±Inf) at ({x}, {y}); HDR metrics need finite values (load with --sanitize to zero them)")]
    NonFinite { role: &'static str, x: u32, y: u32 },
    /// A metric's parameter is out of its range.
    #[error("{name}: {detail}")]
    BadParameter { name: &'static str, detail: String },
    /// The device computing a metric failed (the GPU's FLIP).
    #[error("{metric} on the GPU failed: {detail}")]
    Device {
        metric: &'static str,
        detail: String,
    },
}

/// Every metric of one comparison, as reported and gated on.
///
/// In JSON, `psnr` and `snr` may be `1e999` (+∞, identical images) or
/// `-1e999` (−∞ SNR: all-zero reference), see [`json`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Mean squared error over all pixels and channels, in LSB².
    pub mse: f64,
    /// √MSE, in LSB.
    pub rmse: f64,
    /// 10·log10(255²/MSE) dB; +∞ for identical images.
    #[serde(with = "json::extended_f64")]
    pub psnr: f64,
    /// 10·log10(Σ ref² / Σ (test − ref)²) dB; +∞ for identical images.
    #[serde(with = "json::extended_f64")]
    pub snr: f64,
    /// Mean SSIM as [`SSIM_DEFINITION`] states.
    pub ssim: f64,
    /// Largest absolute sample difference, in LSB.
    pub max_abs_diff: u16,
    /// Mean absolute sample difference, in LSB.
    pub mean_abs_diff: f64,
    /// Fraction of pixels with any channel off by more than 1 LSB.
    pub fraction_over_1lsb: f64,
    /// Mean FLIP error ([`flip`], NVIDIA's implementation) at
    /// [`flip::DEFAULT_PPD`]; 0 for identical images, 1 at most.
    pub flip_mean: f64,
    /// Bits per sample of the frames compared: 8, or 16 for PQ frames,
    /// whose MSE, PSNR and LSB counts are in 16-bit codes and whose FLIP is
    /// HDR-FLIP of the decoded light ([`frames`]).
    #[serde(default = "eight_bits")]
    pub bits: u32,
    /// Which SSIM this is; tools disagree, so the report says.
    pub ssim_definition: String,
}

fn eight_bits() -> u32 {
    8
}

/// Compares `test` (the image under test) with `reference` (the golden).
///
/// Refuses images under 11×11 ([`MetricsError::TooSmallForSsim`]) because the
/// report promises an SSIM; the individual pixel metrics ([`mse`], [`psnr`],
/// ...) accept any non-empty size.
pub fn compare(test: Raster, reference: Raster) -> Result<Metrics, MetricsError> {
    compare_with_flip(test, reference).map(|(m, _)| m)
}

/// [`compare`], and the FLIP map its `flip_mean` comes from (for
/// percentiles and the error-map image).
pub fn compare_with_flip(
    test: Raster,
    reference: Raster,
) -> Result<(Metrics, flip::Flip), MetricsError> {
    compare_with_flip_by(test, reference, None)
}

/// How a pair of 8-bit images is compared when not on the CPU: the report's
/// metrics and the FLIP map (the GPU's, in the gate: `gpu::compare`). It
/// must give the CPU's figures within their locks.
pub type CompareFn<'f> =
    dyn Fn(Raster, Raster) -> Result<(Metrics, flip::Flip), MetricsError> + Sync + 'f;

/// A [`CompareFn`] held by reference, named in debug output by what it is.
#[derive(Clone, Copy)]
pub struct CompareBy<'a>(pub &'a CompareFn<'a>);

impl fmt::Debug for CompareBy<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("CompareBy(..)")
    }
}

/// [`compare_with_flip`], by `by` when given.
pub fn compare_with_flip_by(
    test: Raster,
    reference: Raster,
    by: Option<CompareBy>,
) -> Result<(Metrics, flip::Flip), MetricsError> {
    use crate::perf::clock::{timed, Part};
    if let Some(CompareBy(f)) = by {
        return timed(Part::Gpu, || f(test, reference));
    }
    // SSIM first: it refuses small images, and it is expensive, so a refusal
    // costs nothing.
    let ssim = timed(Part::Ssim, || mean_ssim(test, reference))?;
    let flip = timed(Part::Flip, || {
        flip::flip(test, reference, flip::DEFAULT_PPD)
    })?;
    let sums = timed(Part::Errors, || basic::ErrorSums::of(&test, &reference))?;
    let over = timed(Part::FractionOver, || fraction_over(test, reference, 1))?;
    Ok((metrics_from(&sums, ssim, over, flip.mean()), flip))
}

/// The report's metrics of an 8-bit pair from its error sums, mean SSIM,
/// fraction over 1 code and FLIP mean: one formula for every device.
pub(crate) fn metrics_from(
    sums: &basic::ErrorSums,
    ssim: f64,
    fraction_over_1lsb: f64,
    flip_mean: f64,
) -> Metrics {
    let mse = sums.mse();
    Metrics {
        mse,
        rmse: mse.sqrt(),
        psnr: sums.psnr(),
        snr: sums.snr(),
        ssim,
        max_abs_diff: u16::from(sums.max_abs_diff),
        mean_abs_diff: sums.mean_abs_diff(),
        fraction_over_1lsb,
        flip_mean,
        bits: 8,
        ssim_definition: SSIM_DEFINITION.to_owned(),
    }
}

impl fmt::Display for Metrics {
    /// One line for a terminal; the definition is left to the JSON report.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "MSE {:.6}  RMSE {:.6}  PSNR {:.4} dB  SNR {:.4} dB  SSIM {:.6}  \
             max |diff| {}  mean |diff| {:.4}  >1 LSB {:.4}%  FLIP {:.5}",
            self.mse,
            self.rmse,
            self.psnr,
            self.snr,
            self.ssim,
            self.max_abs_diff,
            self.mean_abs_diff,
            self.fraction_over_1lsb * 100.0,
            self.flip_mean
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Rgb8Image;

    /// A smooth frame with some texture, so that SSIM has structure to see.
    fn frame() -> Rgb8Image {
        Rgb8Image::from_fn(48, 32, |x, y| {
            [(x * 5) as u8, (y * 7) as u8, ((x * y) % 251) as u8]
        })
    }

    #[test]
    fn a_frame_against_itself_is_perfect() {
        let f = frame();
        let m = compare(f.raster(), f.raster()).unwrap();
        assert_eq!(m.mse, 0.0);
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.psnr, f64::INFINITY);
        assert_eq!(m.snr, f64::INFINITY);
        assert_eq!(m.ssim, 1.0);
        assert_eq!(m.max_abs_diff, 0);
        assert_eq!(m.fraction_over_1lsb, 0.0);
    }

    #[test]
    fn a_perturbed_frame_is_finite_and_below_one() {
        let f = frame();
        let mut g = f.clone();
        for p in g.pixels.iter_mut().step_by(7) {
            p[1] = p[1].wrapping_add(9);
        }
        let m = compare(g.raster(), f.raster()).unwrap();
        assert!(m.psnr.is_finite() && m.psnr > 0.0, "{}", m.psnr);
        assert!(m.snr.is_finite(), "{}", m.snr);
        assert!(m.ssim < 1.0, "{}", m.ssim);
        assert!(m.mse > 0.0 && (m.rmse * m.rmse - m.mse).abs() < 1e-9);
        assert!(m.max_abs_diff >= 9);
        assert!(m.fraction_over_1lsb > 0.1 && m.fraction_over_1lsb < 0.2);
    }

    #[test]
    fn mismatches_are_errors_not_panics() {
        let f = frame();
        let small = Rgb8Image::filled(47, 32, [0; 3]);
        let err = compare(f.raster(), small.raster()).unwrap_err();
        assert!(matches!(err, MetricsError::SizeMismatch { .. }));
        let text = err.to_string();
        assert!(text.contains("48×32") && text.contains("47×32"), "{text}");

        let rgba = vec![0u8; 48 * 32 * 4];
        let rgba = Raster::new(48, 32, 4, &rgba).unwrap();
        let err = compare(f.raster(), rgba).unwrap_err();
        assert_eq!(
            err,
            MetricsError::ChannelMismatch {
                test: 3,
                reference: 4
            }
        );
    }

    #[test]
    fn tiny_images_are_an_error_for_compare_but_not_for_mse() {
        let a = Rgb8Image::filled(7, 7, [1, 2, 3]);
        let err = compare(a.raster(), a.raster()).unwrap_err();
        assert_eq!(
            err,
            MetricsError::TooSmallForSsim {
                width: 7,
                height: 7
            }
        );
        assert_eq!(mse(a.raster(), a.raster()).unwrap(), 0.0);
    }

    #[test]
    fn json_has_the_promised_fields_and_infinity_literal() {
        let f = frame();
        let m = compare(f.raster(), f.raster()).unwrap();
        let text = serde_json::to_string(&m).unwrap();
        assert!(text.contains(r#""psnr":1e999"#), "{text}");
        assert!(text.contains(r#""snr":1e999"#), "{text}");
        assert!(text.contains(r#""ssim":1.0"#), "{text}");
        assert!(
            text.contains(r#""ssim_definition":"Wang et al. 2004"#),
            "{text}"
        );
        for field in [
            "mse",
            "rmse",
            "max_abs_diff",
            "mean_abs_diff",
            "fraction_over_1lsb",
            "flip_mean",
        ] {
            assert!(text.contains(&format!("\"{field}\":")), "{field} in {text}");
        }
        let back: Metrics = serde_json::from_str(&text).unwrap();
        assert_eq!(back, m);
    }

    #[test]
    fn display_is_one_line_with_inf() {
        let f = frame();
        let m = compare(f.raster(), f.raster()).unwrap();
        let line = m.to_string();
        assert!(
            line.contains("PSNR inf dB") && !line.contains('\n'),
            "{line}"
        );
    }
}
