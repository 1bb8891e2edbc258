//! The report's metrics of two encoded frames at either depth
//! (docs/metrics.md#pq-frames).
//!
//! 8-bit frames go through [`compare_with_flip`](super::compare_with_flip) as they always have.
//! 16-bit PQ frames are measured on their codes with the same definitions
//! scaled to 16 bits:
//! - MSE, RMSE, mean and maximum difference and the fraction over k LSB in
//!   16-bit codes, from exact integer sums;
//! - PSNR 10·log10(65535²/MSE);
//! - SSIM as scikit-image's with `data_range=65535` (the codes over 257 on
//!   SSIM's 0..255 scale, which is the same quantity: SSIM's constants
//!   scale with the data range);
//! - FLIP: HDR-FLIP (NVIDIA's tool's defaults: ACES, automatic exposures)
//!   of the light the codes decode to, BT.709 cd/m², since LDR FLIP takes
//!   8-bit sRGB only.

use super::flip::{Flip, DEFAULT_PPD};
use super::hdr_flip::{hdr_flip, HdrFlipOptions};
use super::hdr_input::check_hdr_sizes;
use super::ssim::{mean_ssim_mapped, ssim_mapped, Ssim};
use super::{fraction_over, heatmap_colour, Metrics, MetricsError, SSIM_DEFINITION};
use crate::color::{apply, bt709_to_bt2020, inverse, pq_decode};
use crate::image::{Frame, HdrImage, Image, Rgb16Image, Rgb8Image};
use rayon::prelude::*;

/// The report's metrics of `test` against `reference`, and the FLIP map
/// its `flip_mean` comes from. Frames of different depths are refused.
pub fn compare_frames(test: &Frame, reference: &Frame) -> Result<(Metrics, Flip), MetricsError> {
    compare_frames_by(test, reference, None)
}

/// [`compare_frames`], 8-bit frames by `by` when given (PQ frames stay on
/// the CPU).
pub fn compare_frames_by(
    test: &Frame,
    reference: &Frame,
    by: Option<super::CompareBy>,
) -> Result<(Metrics, Flip), MetricsError> {
    match (test, reference) {
        (Frame::Rgb8(t), Frame::Rgb8(r)) => super::compare_with_flip_by(t.raster(), r.raster(), by),
        (Frame::Pq16(t), Frame::Pq16(r)) => compare_pq16(t, r),
        _ => Err(depth_mismatch(test, reference)),
    }
}

/// The fraction of pixels with any channel more than `k` codes off.
pub fn frame_fraction_over(test: &Frame, reference: &Frame, k: u8) -> Result<f64, MetricsError> {
    crate::perf::clock::timed(crate::perf::clock::Part::FractionOver, || {
        fraction_over_of(test, reference, k)
    })
}

fn fraction_over_of(test: &Frame, reference: &Frame, k: u8) -> Result<f64, MetricsError> {
    match (test, reference) {
        (Frame::Rgb8(t), Frame::Rgb8(r)) => fraction_over(t.raster(), r.raster(), k),
        (Frame::Pq16(t), Frame::Pq16(r)) => {
            check_hdr_sizes(t, r)?;
            Ok(Sums16::of(t, r, u16::from(k)).over as f64 / t.pixels.len() as f64)
        }
        _ => Err(depth_mismatch(test, reference)),
    }
}

/// The largest difference of any sample, in its frame's codes.
pub fn frame_max_abs_diff(test: &Frame, reference: &Frame) -> Result<u16, MetricsError> {
    match (test, reference) {
        (Frame::Rgb8(t), Frame::Rgb8(r)) => {
            super::max_abs_diff(t.raster(), r.raster()).map(u16::from)
        }
        (Frame::Pq16(t), Frame::Pq16(r)) => {
            check_hdr_sizes(t, r)?;
            Ok(Sums16::of(t, r, 1).max_abs_diff)
        }
        _ => Err(depth_mismatch(test, reference)),
    }
}

/// The SSIM map and mean of two frames (for PQ, the mean over channels of
/// each channel's map, as scikit-image averages channels).
pub fn frame_ssim(test: &Frame, reference: &Frame) -> Result<Ssim, MetricsError> {
    match (test, reference) {
        (Frame::Rgb8(t), Frame::Rgb8(r)) => super::ssim(t.raster(), r.raster()),
        (Frame::Pq16(t), Frame::Pq16(r)) => {
            check_hdr_sizes(t, r)?;
            let (mean, map) = ssim16(t, r, true)?;
            let map = map.unwrap_or_else(|| Image::filled(t.width, t.height, 0.0));
            Ok(Ssim { mean, map })
        }
        _ => Err(depth_mismatch(test, reference)),
    }
}

/// The FLIP map of two frames: LDR FLIP of 8-bit frames, HDR-FLIP of the
/// light PQ frames decode to.
pub fn frame_flip(test: &Frame, reference: &Frame) -> Result<Flip, MetricsError> {
    match (test, reference) {
        (Frame::Rgb8(t), Frame::Rgb8(r)) => super::flip::flip(t.raster(), r.raster(), DEFAULT_PPD),
        (Frame::Pq16(t), Frame::Pq16(r)) => {
            check_hdr_sizes(t, r)?;
            Ok(hdr_flip(&pq16_light(t), &pq16_light(r), &HdrFlipOptions::default())?.0)
        }
        _ => Err(depth_mismatch(test, reference)),
    }
}

/// The difference heat map of two frames: each pixel's largest channel
/// difference in its frame's codes, through [`HEATMAP_RAMP`](super::HEATMAP_RAMP)
/// (a 16-bit difference of 255 codes or more is the ramp's top).
pub fn frame_diff_heatmap(test: &Frame, reference: &Frame) -> Result<Rgb8Image, MetricsError> {
    match (test, reference) {
        (Frame::Rgb8(t), Frame::Rgb8(r)) => super::diff_heatmap(t.raster(), r.raster()),
        (Frame::Pq16(t), Frame::Pq16(r)) => {
            check_hdr_sizes(t, r)?;
            Ok(Rgb8Image {
                width: t.width,
                height: t.height,
                pixels: t
                    .pixels
                    .iter()
                    .zip(&r.pixels)
                    .map(|(a, b)| {
                        let d = (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0);
                        heatmap_colour(d.min(255) as u8)
                    })
                    .collect(),
            })
        }
        _ => Err(depth_mismatch(test, reference)),
    }
}

fn depth_mismatch(test: &Frame, reference: &Frame) -> MetricsError {
    MetricsError::BadParameter {
        name: "frame depth",
        detail: format!(
            "the image under test is a {} frame and the reference a {} one; compare frames of one encoding (regenerate the golden after changing a scene's encoding)",
            test.kind(),
            reference.kind()
        ),
    }
}

/// Exact integer totals over a pair of 16-bit frames: 65535² × 2³² samples
/// still fits a u64's 1.8e19.
#[derive(Clone, Copy, Default)]
struct Sums16 {
    squared_error: u64,
    reference_energy: u64,
    abs_error: u64,
    max_abs_diff: u16,
    /// Pixels with a channel more than the asked k codes off.
    over: u64,
    samples: u64,
}

impl Sums16 {
    fn merge(self, o: Self) -> Self {
        Self {
            squared_error: self.squared_error + o.squared_error,
            reference_energy: self.reference_energy + o.reference_energy,
            abs_error: self.abs_error + o.abs_error,
            max_abs_diff: self.max_abs_diff.max(o.max_abs_diff),
            over: self.over + o.over,
            samples: self.samples + o.samples,
        }
    }

    fn of(test: &Rgb16Image, reference: &Rgb16Image, k: u16) -> Self {
        test.pixels
            .par_chunks(1 << 14)
            .zip(reference.pixels.par_chunks(1 << 14))
            .map(|(t, r)| {
                let mut s = Self::default();
                for (t, r) in t.iter().zip(r) {
                    let mut worst = 0u16;
                    for c in 0..3 {
                        let d = t[c].abs_diff(r[c]);
                        s.squared_error += u64::from(d) * u64::from(d);
                        s.reference_energy += u64::from(r[c]) * u64::from(r[c]);
                        s.abs_error += u64::from(d);
                        worst = worst.max(d);
                    }
                    s.max_abs_diff = s.max_abs_diff.max(worst);
                    s.over += u64::from(worst > k);
                    s.samples += 3;
                }
                s
            })
            .reduce(Self::default, Self::merge)
    }
}

/// SSIM of two 16-bit frames: each channel's codes over 257 on SSIM's
/// 0..255 scale (scikit-image's at `data_range=65535`), the mean over the
/// channels; with the per-pixel map, averaged the same way, when `with_map`.
fn ssim16(
    test: &Rgb16Image,
    reference: &Rgb16Image,
    with_map: bool,
) -> Result<(f64, Option<Image<f64>>), MetricsError> {
    let (width, height) = (test.width, test.height);
    let mut mean = 0.0;
    let mut map = with_map.then(|| Image::filled(width, height, 0.0));
    for c in 0..3 {
        let f = |p: &[u16; 3]| f64::from(p[c]) / 257.0;
        match &mut map {
            Some(map) => {
                let s = ssim_mapped(&test.pixels, &reference.pixels, width, height, &f)?;
                mean += s.mean;
                for (a, b) in map.pixels.iter_mut().zip(&s.map.pixels) {
                    *a += b / 3.0;
                }
            }
            None => mean += mean_ssim_mapped(&test.pixels, &reference.pixels, width, height, &f)?,
        }
    }
    Ok((mean / 3.0, map))
}

/// The light a PQ frame's codes decode to, BT.709 cd/m² (negative
/// components, from colours outside BT.709, taken as 0).
pub fn pq16_light(frame: &Rgb16Image) -> HdrImage {
    let m = inverse(&bt709_to_bt2020());
    frame.par_map(|p| {
        let bt2020 = p.map(|c| pq_decode(f64::from(c) / 65535.0));
        apply(&m, bt2020).map(|v| v.max(0.0) as f32)
    })
}

fn compare_pq16(
    test: &Rgb16Image,
    reference: &Rgb16Image,
) -> Result<(Metrics, Flip), MetricsError> {
    check_hdr_sizes(test, reference)?;
    // SSIM first, as for 8-bit frames: it refuses small frames.
    use crate::perf::clock::{timed, Part};
    let (ssim, _) = timed(Part::Ssim, || ssim16(test, reference, false))?;
    let (flip, _) = timed(Part::Flip, || {
        hdr_flip(
            &pq16_light(test),
            &pq16_light(reference),
            &HdrFlipOptions::default(),
        )
    })?;
    let s = timed(Part::Errors, || Sums16::of(test, reference, 1));
    let mse = s.squared_error as f64 / s.samples as f64;
    let snr = if s.squared_error == 0 {
        f64::INFINITY
    } else {
        10.0 * libm::log10(s.reference_energy as f64 / s.squared_error as f64)
    };
    let metrics = Metrics {
        mse,
        rmse: mse.sqrt(),
        psnr: if mse == 0.0 {
            f64::INFINITY
        } else {
            10.0 * libm::log10(65535.0 * 65535.0 / mse)
        },
        snr,
        ssim,
        max_abs_diff: s.max_abs_diff,
        mean_abs_diff: s.abs_error as f64 / s.samples as f64,
        fraction_over_1lsb: s.over as f64 / test.pixels.len() as f64,
        flip_mean: flip.mean(),
        bits: 16,
        ssim_definition: SSIM_DEFINITION.to_owned(),
    };
    Ok((metrics, flip))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pattern(width: u32, height: u32, seed: u32) -> Rgb8Image {
        Rgb8Image::from_fn(width, height, |x, y| {
            let v = |k: u32| ((x * 37 + y * 11 + k * 53 + seed * 101) % 251) as u8;
            [v(0), v(1), v(2)]
        })
    }

    fn widened(img: &Rgb8Image) -> Frame {
        Frame::Pq16(img.map(|p| p.map(|c| u16::from(c) * 257)))
    }

    /// 8-bit codes × 257 are the same fractions of full scale, so every
    /// scale-free metric agrees with the 8-bit one, and the code-valued
    /// ones scale by 257 (257² for MSE).
    #[test]
    fn sixteen_bit_metrics_are_the_eight_bit_ones_scaled() {
        let (a, b) = (pattern(40, 24, 1), pattern(40, 24, 2));
        let (m8, _) = compare_frames(&Frame::Rgb8(a.clone()), &Frame::Rgb8(b.clone())).unwrap();
        let (m16, _) = compare_frames(&widened(&a), &widened(&b)).unwrap();
        assert_eq!(m16.bits, 16);
        assert!(
            (m16.psnr - m8.psnr).abs() < 1e-9,
            "{} {}",
            m16.psnr,
            m8.psnr
        );
        assert!(
            (m16.ssim - m8.ssim).abs() < 1e-12,
            "{} {}",
            m16.ssim,
            m8.ssim
        );
        assert!((m16.snr - m8.snr).abs() < 1e-9);
        // The same exact sums, divided once: equal to the last bit or two.
        let mse = m8.mse * 257.0 * 257.0;
        assert!((m16.mse - mse).abs() <= 1e-15 * mse, "{} {mse}", m16.mse);
        assert_eq!(m16.max_abs_diff, m8.max_abs_diff * 257);
        // Every differing channel is ≥ 257 codes off at 16 bits.
        let over8 =
            frame_fraction_over(&Frame::Rgb8(a.clone()), &Frame::Rgb8(b.clone()), 0).unwrap();
        assert_eq!(m16.fraction_over_1lsb, over8);
    }

    #[test]
    fn one_code_off_counts_only_past_one_lsb() {
        let base = Rgb16Image::filled(16, 16, [30000, 20000, 10000]);
        let mut test = base.clone();
        test.pixels[0][1] += 1;
        test.pixels[5][2] += 2;
        let (t, r) = (Frame::Pq16(test), Frame::Pq16(base));
        assert_eq!(frame_fraction_over(&t, &r, 1).unwrap(), 1.0 / 256.0);
        assert_eq!(frame_fraction_over(&t, &r, 0).unwrap(), 2.0 / 256.0);
        assert_eq!(frame_max_abs_diff(&t, &r).unwrap(), 2);
        let (m, _) = compare_frames(&t, &r).unwrap();
        assert_eq!(m.mse, 5.0 / (256.0 * 3.0));
        // One or two codes are under what HDR-FLIP's exposures resolve here;
        // 2000 codes brighter everywhere is plain to see.
        assert!(m.flip_mean < 1e-3, "{}", m.flip_mean);
        let Frame::Pq16(base) = &r else {
            unreachable!()
        };
        let brighter = Frame::Pq16(base.map(|p| p.map(|c| c + 2000)));
        let (far, _) = compare_frames(&brighter, &r).unwrap();
        assert!(far.flip_mean > 0.01, "{}", far.flip_mean);
        let (same, _) = compare_frames(&r, &r).unwrap();
        assert_eq!(
            (same.psnr, same.flip_mean, same.ssim),
            (f64::INFINITY, 0.0, 1.0)
        );
    }

    #[test]
    fn frames_of_two_depths_are_refused() {
        let a = Frame::Rgb8(pattern(16, 16, 1));
        let b = widened(&pattern(16, 16, 1));
        let e = compare_frames(&a, &b).unwrap_err().to_string();
        assert!(e.contains("8-bit") && e.contains("16-bit PQ"), "{e}");
    }

    #[test]
    fn pq_codes_decode_to_their_light() {
        // 203 cd/m² grey: PQ 0.58069 → code 38055.
        let img = Rgb16Image::filled(1, 1, [38055; 3]);
        let l = pq16_light(&img).pixels[0];
        for c in l {
            assert!((c - 203.0).abs() < 0.05, "{l:?}");
        }
    }
}
