//! Metrics for linear HDR images (the sphere's output, bloom, EXR files):
//! HDR-FLIP, PU21-PSNR / PU21-SSIM and ΔE_ITP, each beside the module that
//! computes it; this one checks the pair and gathers the set a report shows.
//!
//! Values are linear with BT.709 primaries; 1.0 is `peak` cd/m² where a
//! metric needs absolute units (PU21, ΔE_ITP).

use super::flip::{Flip, FlipStats};
use super::hdr_flip::{hdr_flip, ExposureRange, HdrFlipOptions};
use super::itp::{delta_e_itp, Itp};
use super::pu21::{pu21, Pu21};
use super::MetricsError;
use crate::image::HdrImage;
use serde::{Deserialize, Serialize};

/// The HDR metrics' definitions, as every report states them.
pub const HDR_DEFINITION: &str = "HDR-FLIP: NVIDIA's procedure (exposures from the \
reference's max and median luminance, ACES unless set, error = max over exposures) around \
nv-flip's LDR FLIP of each exposure's 8-bit sRGB rendering; PU21: Mantiuk & Azimi 2021 \
banding_glare, PSNR over the encoded RGB with peak 256, SSIM (the 8-bit SSIM's definition) \
on the encoded luminance with range 256; delta E ITP: ITU-R BT.2124 on BT.2100 ICtCp (PQ) \
of the BT.709 input converted to BT.2020; absolute units: 1.0 = peak cd/m2";

/// How the HDR metrics are taken.
#[derive(Clone, Debug)]
pub struct HdrOptions {
    /// cd/m² that 1.0 maps to (PU21, ΔE_ITP).
    pub peak: f64,
    pub flip: HdrFlipOptions,
}

impl Default for HdrOptions {
    fn default() -> Self {
        HdrOptions {
            peak: super::pu21::DEFAULT_PEAK,
            flip: HdrFlipOptions::default(),
        }
    }
}

/// Every HDR metric of one comparison, as reported.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HdrMetrics {
    #[serde(with = "super::json::extended_f64")]
    pub pu21_psnr: f64,
    pub pu21_ssim: f64,
    pub delta_e_itp_mean: f64,
    pub delta_e_itp_max: f64,
    pub hdr_flip: FlipStats,
    pub hdr_flip_exposures: ExposureRange,
    /// cd/m² that 1.0 was mapped to.
    pub peak: f64,
    pub definition: String,
}

/// The metrics and the maps behind them (for images).
pub struct HdrComparison {
    pub metrics: HdrMetrics,
    pub flip: Flip,
    pub pu21: Pu21,
    pub itp: Itp,
}

/// Every HDR metric of `test` against `reference`.
pub fn compare_hdr(
    test: &HdrImage,
    reference: &HdrImage,
    opts: &HdrOptions,
) -> Result<HdrComparison, MetricsError> {
    let pu = pu21(test, reference, opts.peak)?;
    let itp = delta_e_itp(test, reference, opts.peak)?;
    let (flip, range) = hdr_flip(test, reference, &opts.flip)?;
    Ok(HdrComparison {
        metrics: HdrMetrics {
            pu21_psnr: pu.psnr,
            pu21_ssim: pu.ssim.mean,
            delta_e_itp_mean: itp.mean,
            delta_e_itp_max: itp.max,
            hdr_flip: flip.stats(),
            hdr_flip_exposures: range,
            peak: opts.peak,
            definition: HDR_DEFINITION.into(),
        },
        flip,
        pu21: pu,
        itp,
    })
}

#[cfg(test)]
mod tests {
    use super::super::hdr_input::check_hdr_pair;
    use super::*;

    #[test]
    fn nan_and_mismatched_pairs_are_refused_by_position() {
        let a = HdrImage::filled(12, 12, [1.0; 3]);
        let mut b = a.clone();
        b.pixels[12 * 3 + 5][1] = f32::NAN;
        let e = check_hdr_pair(&b, &a).unwrap_err();
        assert_eq!(
            e,
            MetricsError::NonFinite {
                role: "image under test",
                x: 5,
                y: 3
            }
        );
        assert!(e.to_string().contains("(5, 3)"), "{e}");
        let c = HdrImage::filled(11, 12, [1.0; 3]);
        assert!(matches!(
            check_hdr_pair(&c, &a),
            Err(MetricsError::SizeMismatch { .. })
        ));
        assert!(compare_hdr(&b, &a, &HdrOptions::default()).is_err());
    }
}
