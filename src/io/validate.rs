//! The validation policy every HDR load goes through (documented on
//! [`LoadOptions`], where users of the crate see it), and the load report.
//!
//! The report's statistics are computed after the policy, in f64, in
//! row-major order on one thread, with `libm` for `ln`/`exp`/`log2`, so that
//! the same file gives bit-identical numbers on every machine.

use serde::Serialize;

use super::error::HdrIoError;
use super::HdrFormat;
use crate::color::luminance;
use crate::image::HdrImage;
use rayon::prelude::*;

/// 64 Mi pixels: an 8K×8K frame, 768 MiB as `[f32; 3]`.
pub const DEFAULT_MAX_PIXELS: u64 = 64 * 1024 * 1024;

/// The δ in the log-average luminance exp(mean(ln(δ + Y))), as in the
/// image-processing lecture (docs/bibliography.md; after Reinhard et al.
/// 2002): it keeps black pixels from sending the mean to −∞.
pub const LOG_AVERAGE_DELTA: f64 = 1e-4;

/// How strict an HDR load is. Every load applies this policy, in order:
///
/// 1. Size, from the header, before any pixel is allocated: width and height
///    must be non-zero and width × height at most `max_pixels` (default
///    64 Mi pixels = 768 MiB of `[f32; 3]`), so a hostile or damaged header
///    cannot make the tool allocate gigabytes. Formats whose payload size is
///    known (PFM, EXR offset tables) are also checked against the file length.
/// 2. NaN and ±Inf are refused with their count and the first (x, y) in image
///    coordinates (top-left origin, rows top to bottom, whatever the file's
///    own row order; for EXR, relative to the data window), unless `sanitize`
///    is set: then they become 0 and are counted. Refused by default because
///    one NaN poisons every average the tone mapper computes, and silently
///    zeroing would hide a broken exporter.
/// 3. Negative components are clamped to 0 and counted. Not an error: real
///    EXRs carry small negatives from lossy-compression ringing and gamut
///    conversions, and radiance cannot be negative anyway.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoadOptions {
    /// Replace NaN and ±Inf by 0 (and count them) instead of refusing the file.
    pub sanitize: bool,
    /// The most pixels (width × height) a header may declare.
    pub max_pixels: u64,
    /// The image goes to a GPU that holds at most this much: checked from
    /// the header too, so an image the device cannot take is refused
    /// before it is decoded, not after.
    pub device: Option<DeviceFit>,
}

/// The largest frame a GPU renderer takes (`GpuContext::frame_fit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceFit {
    /// The longest side (the adapter's largest 2D texture).
    pub max_side: u32,
    /// The most pixels (its buffer and storage-binding limits).
    pub max_pixels: u64,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            sanitize: false,
            max_pixels: DEFAULT_MAX_PIXELS,
            device: None,
        }
    }
}

/// Rule 1 for a GPU: a header's size against `opts.device`, if set.
pub(crate) fn check_fit(
    file: &str,
    width: u32,
    height: u32,
    opts: &LoadOptions,
) -> Result<(), HdrIoError> {
    let Some(fit) = opts.device else {
        return Ok(());
    };
    if width > fit.max_side
        || height > fit.max_side
        || u64::from(width) * u64::from(height) > fit.max_pixels
    {
        return Err(HdrIoError::TooLargeForDevice {
            file: file.to_string(),
            width,
            height,
            max_side: fit.max_side,
            max_pixels: fit.max_pixels,
        });
    }
    Ok(())
}

/// What was loaded and what the policy changed; serialised into run reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LoadReport {
    /// The path or source name the image came from.
    pub source: String,
    pub format: HdrFormat,
    pub width: u32,
    pub height: u32,
    /// The channels of the part that was read, as stored in the file (an EXR
    /// may list channels it has but that were ignored, such as `A`).
    pub channels: Vec<String>,
    /// BT.709 luminance over all pixels, after clamping and sanitising.
    pub min_luminance: f64,
    pub max_luminance: f64,
    /// exp(mean(ln(`LOG_AVERAGE_DELTA` + Y))).
    pub log_average_luminance: f64,
    /// log2(max Y / smallest positive Y); 0 when no pixel has positive Y.
    pub dynamic_range_stops: f64,
    /// Components that were negative and set to 0.
    pub clamped_negative: u64,
    /// Components that were NaN or ±Inf and set to 0 (only with `sanitize`).
    pub sanitized_nonfinite: u64,
}

/// A decoder's output before the policy is applied.
#[derive(Debug)]
pub(crate) struct Decoded {
    pub image: HdrImage,
    pub channels: Vec<String>,
}

/// Rule 1: checks a header's size and returns it as `u32`s and a pixel count
/// that is safe to allocate.
pub(crate) fn check_dimensions(
    file: &str,
    width: u64,
    height: u64,
    max_pixels: u64,
) -> Result<(u32, u32, usize), HdrIoError> {
    if width == 0 || height == 0 {
        return Err(HdrIoError::EmptyImage {
            file: file.to_string(),
            width,
            height,
        });
    }
    let too_large = || HdrIoError::TooLarge {
        file: file.to_string(),
        width,
        height,
        max_pixels,
    };
    let pixels = u128::from(width) * u128::from(height);
    if pixels > u128::from(max_pixels) {
        return Err(too_large());
    }
    let w = u32::try_from(width).map_err(|_| too_large())?;
    let h = u32::try_from(height).map_err(|_| too_large())?;
    // The [f32; 3] buffer must also be addressable (matters on 32-bit targets).
    let count = usize::try_from(pixels).map_err(|_| too_large())?;
    count.checked_mul(12).ok_or_else(too_large)?;
    Ok((w, h, count))
}

/// Rules 2 and 3, then the statistics.
pub(crate) fn apply_policy(
    decoded: Decoded,
    format: HdrFormat,
    file: &str,
    opts: &LoadOptions,
) -> Result<(HdrImage, LoadReport), HdrIoError> {
    let Decoded {
        mut image,
        channels,
    } = decoded;
    // Blocks on every core; counts add up and the first non-finite pixel is
    // the least index, so the outcome does not depend on the split.
    const BLOCK: usize = 1 << 16;
    let blocks: Vec<(u64, u64, Option<usize>)> = image
        .pixels
        .par_chunks_mut(BLOCK)
        .enumerate()
        .map(|(b, block)| {
            let (mut clamped, mut nonfinite, mut first) = (0u64, 0u64, None);
            for (i, pixel) in block.iter_mut().enumerate() {
                for component in pixel.iter_mut() {
                    if !component.is_finite() {
                        nonfinite += 1;
                        first.get_or_insert(b * BLOCK + i);
                        if opts.sanitize {
                            *component = 0.0;
                        }
                    } else if *component < 0.0 {
                        clamped += 1;
                        *component = 0.0;
                    }
                }
            }
            (clamped, nonfinite, first)
        })
        .collect();
    let clamped_negative: u64 = blocks.iter().map(|b| b.0).sum();
    let nonfinite: u64 = blocks.iter().map(|b| b.1).sum();
    let first_nonfinite = blocks.iter().find_map(|b| b.2);
    if let (Some(index), false) = (first_nonfinite, opts.sanitize) {
        let width = image.width.max(1) as usize;
        return Err(HdrIoError::NonFinite {
            file: file.to_string(),
            count: nonfinite,
            x: (index % width) as u32,
            y: (index / width) as u32,
        });
    }

    let stats = LuminanceStats::of(&image);
    let report = LoadReport {
        source: file.to_string(),
        format,
        width: image.width,
        height: image.height,
        channels,
        min_luminance: stats.min,
        max_luminance: stats.max,
        log_average_luminance: stats.log_average,
        dynamic_range_stops: stats.dynamic_range_stops,
        clamped_negative,
        sanitized_nonfinite: if opts.sanitize { nonfinite } else { 0 },
    };
    Ok((image, report))
}

/// The luminance summary of a validated (finite, non-negative) image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LuminanceStats {
    pub min: f64,
    pub max: f64,
    pub log_average: f64,
    pub dynamic_range_stops: f64,
}

impl LuminanceStats {
    pub(crate) fn of(image: &HdrImage) -> Self {
        let mut min = f64::INFINITY;
        let mut max = f64::NEG_INFINITY;
        let mut min_positive = f64::INFINITY;
        let mut log_sum = 0.0f64;
        // The logarithms on every core, a block at a time; the sum in pixel
        // order as before, so the report's figures keep their bits.
        let mut terms = Vec::new();
        for block in image.pixels.chunks(1 << 16) {
            block
                .par_iter()
                .map(|p| {
                    let y = luminance([f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]);
                    (y, libm::log(LOG_AVERAGE_DELTA + y))
                })
                .collect_into_vec(&mut terms);
            for &(y, log) in &terms {
                min = min.min(y);
                max = max.max(y);
                if y > 0.0 {
                    min_positive = min_positive.min(y);
                }
                log_sum += log;
            }
        }
        let count = image.pixels.len();
        if count == 0 {
            return Self {
                min: 0.0,
                max: 0.0,
                log_average: 0.0,
                dynamic_range_stops: 0.0,
            };
        }
        let dynamic_range_stops = if min_positive.is_finite() {
            libm::log2(max / min_positive)
        } else {
            0.0
        };
        Self {
            min,
            max,
            log_average: libm::exp(log_sum / count as f64),
            dynamic_range_stops,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;

    fn decoded(pixels: Vec<[f32; 3]>, width: u32) -> Decoded {
        let height = pixels.len() as u32 / width;
        Decoded {
            image: Image {
                width,
                height,
                pixels,
            },
            channels: vec!["R".into(), "G".into(), "B".into()],
        }
    }

    #[test]
    fn zero_and_oversized_dimensions_are_refused() {
        assert!(matches!(
            check_dimensions("f", 0, 5, 100),
            Err(HdrIoError::EmptyImage { .. })
        ));
        assert!(matches!(
            check_dimensions("f", 11, 10, 100),
            Err(HdrIoError::TooLarge { .. })
        ));
        assert!(matches!(
            check_dimensions("f", u64::MAX, u64::MAX, u64::MAX),
            Err(HdrIoError::TooLarge { .. })
        ));
        assert_eq!(check_dimensions("f", 10, 10, 100).unwrap(), (10, 10, 100));
    }

    /// The policy runs in blocks on every core: counts over several blocks,
    /// and the first non-finite pixel is the first in the image, not in the
    /// block that finished first.
    #[test]
    fn counts_and_the_first_non_finite_pixel_span_blocks() {
        let width = 300u32;
        let mut pixels = vec![[0.5f32; 3]; 300 * 400];
        pixels[1][0] = -1.0;
        pixels[119_999][2] = -2.0;
        pixels[100_000][1] = f32::NAN;
        pixels[70_001][0] = f32::INFINITY;
        pixels[70_001][2] = f32::NAN;
        let err = apply_policy(
            decoded(pixels.clone(), width),
            HdrFormat::Pfm,
            "f",
            &LoadOptions::default(),
        )
        .unwrap_err();
        match err {
            HdrIoError::NonFinite { count, x, y, .. } => {
                assert_eq!((count, x, y), (3, 70_001 % 300, 70_001 / 300));
            }
            other => panic!("{other}"),
        }
        let opts = LoadOptions {
            sanitize: true,
            ..LoadOptions::default()
        };
        let (image, report) =
            apply_policy(decoded(pixels, width), HdrFormat::Pfm, "f", &opts).unwrap();
        assert_eq!(report.sanitized_nonfinite, 3);
        assert_eq!(report.clamped_negative, 2);
        assert_eq!(image.pixels[70_001], [0.0, 0.5, 0.0]);
        assert_eq!(image.pixels[119_999], [0.5, 0.5, 0.0]);
    }

    #[test]
    fn negatives_are_clamped_and_counted() {
        let (image, report) = apply_policy(
            decoded(vec![[-1.0, 0.5, -0.25], [1.0, 1.0, 1.0]], 2),
            HdrFormat::Pfm,
            "f",
            &LoadOptions::default(),
        )
        .unwrap();
        assert_eq!(image.pixels[0], [0.0, 0.5, 0.0]);
        assert_eq!(report.clamped_negative, 2);
        assert_eq!(report.sanitized_nonfinite, 0);
    }

    #[test]
    fn nonfinite_values_are_refused_with_count_and_first_position() {
        let mut pixels = vec![[0.5f32; 3]; 12];
        pixels[7][1] = f32::NAN; // (3, 1) in a 4-wide image
        pixels[9][0] = f32::INFINITY;
        pixels[9][2] = f32::NEG_INFINITY;
        let error = apply_policy(
            decoded(pixels, 4),
            HdrFormat::Exr,
            "in.exr",
            &LoadOptions::default(),
        )
        .unwrap_err();
        assert_eq!(
            error.to_string(),
            "in.exr: 3 non-finite values (NaN or ±Inf), first at (3, 1); pass --sanitize to set them to 0"
        );
    }

    #[test]
    fn sanitize_zeroes_and_counts_nonfinite_values() {
        let pixels = vec![[f32::NAN, 1.0, -2.0], [f32::INFINITY, 1.0, 1.0]];
        let opts = LoadOptions {
            sanitize: true,
            ..LoadOptions::default()
        };
        let (image, report) = apply_policy(decoded(pixels, 2), HdrFormat::Exr, "f", &opts).unwrap();
        assert_eq!(image.pixels, vec![[0.0, 1.0, 0.0], [0.0, 1.0, 1.0]]);
        assert_eq!(report.sanitized_nonfinite, 2);
        assert_eq!(report.clamped_negative, 1);
    }

    #[test]
    fn statistics_follow_their_definitions() {
        // Y = 0 (black), Y = 1 (white), Y = 0.25 (grey).
        let image = Image {
            width: 3,
            height: 1,
            pixels: vec![[0.0; 3], [1.0; 3], [0.25; 3]],
        };
        let stats = LuminanceStats::of(&image);
        assert_eq!(stats.min, 0.0);
        assert!((stats.max - 1.0).abs() < 1e-15);
        assert!((stats.dynamic_range_stops - 2.0).abs() < 1e-12);
        let expected = ((1e-4f64.ln() + (1.0001f64).ln() + (0.2501f64).ln()) / 3.0).exp();
        assert!((stats.log_average - expected).abs() < 1e-15);
    }

    #[test]
    fn an_all_black_image_has_zero_dynamic_range() {
        let stats = LuminanceStats::of(&Image::filled(4, 4, [0.0f32; 3]));
        assert_eq!(stats.dynamic_range_stops, 0.0);
        assert_eq!(stats.max, 0.0);
        assert!((stats.log_average - LOG_AVERAGE_DELTA).abs() < 1e-18);
    }
}
