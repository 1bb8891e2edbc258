//! A borrowed, validated view of interleaved 8-bit samples.
//!
//! The metrics take views rather than `Rgb8Image`s so that PNG buffers, GPU
//! read-backs and single-channel or RGBA data can be compared without copying
//! them into the RGB container first.

use super::MetricsError;
use crate::image::Rgb8Image;

/// Interleaved 8-bit samples, row-major, top row first, `channels` samples per
/// pixel (1 = grey, 3 = RGB, 4 = RGBA).
///
/// The fields are public so callers can build a view in a `const` or a test,
/// which means an instance may be inconsistent; every metric therefore
/// re-checks its inputs (cheaply) instead of trusting [`Raster::new`] to have
/// been used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Raster<'a> {
    pub width: u32,
    pub height: u32,
    pub channels: usize,
    pub samples: &'a [u8],
}

impl<'a> Raster<'a> {
    /// A view over `samples`, refused when the length does not match
    /// `width × height × channels`, the channel count is not 1, 3 or 4, or the
    /// image has no pixels.
    pub fn new(
        width: u32,
        height: u32,
        channels: usize,
        samples: &'a [u8],
    ) -> Result<Self, MetricsError> {
        let raster = Self {
            width,
            height,
            channels,
            samples,
        };
        raster.validate("image")?;
        Ok(raster)
    }

    /// Number of pixels (not samples).
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Samples per row.
    pub fn row_len(&self) -> usize {
        self.width as usize * self.channels
    }

    /// Checks the invariants [`Raster::new`] promises; `role` names the image
    /// in the message ("image under test", "reference").
    pub(crate) fn validate(&self, role: &'static str) -> Result<(), MetricsError> {
        if !matches!(self.channels, 1 | 3 | 4) {
            return Err(MetricsError::UnsupportedChannels {
                role,
                channels: self.channels,
            });
        }
        // u128 cannot overflow for u32 × u32 × 4, so the message can always
        // state the exact length that was expected.
        let expected = self.width as u128 * self.height as u128 * self.channels as u128;
        if expected != self.samples.len() as u128 {
            return Err(MetricsError::BadSampleLength {
                role,
                width: self.width,
                height: self.height,
                channels: self.channels,
                expected,
                actual: self.samples.len(),
            });
        }
        if expected == 0 {
            return Err(MetricsError::EmptyImage {
                role,
                width: self.width,
                height: self.height,
            });
        }
        Ok(())
    }
}

impl Rgb8Image {
    /// The image as a three-channel view for the metrics.
    ///
    /// Lives here rather than in `image.rs` so that the container module does
    /// not depend on the metrics.
    pub fn raster(&self) -> Raster<'_> {
        Raster {
            width: self.width,
            height: self.height,
            channels: 3,
            samples: self.as_bytes(),
        }
    }
}

/// Checks both views and that they can be compared sample by sample.
///
/// The order of the checks is the order a user would fix things in: a broken
/// buffer first, then the geometry, then the layout.
pub(crate) fn check_pair(test: &Raster, reference: &Raster) -> Result<(), MetricsError> {
    test.validate("image under test")?;
    reference.validate("reference")?;
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(MetricsError::SizeMismatch {
            test_width: test.width,
            test_height: test.height,
            reference_width: reference.width,
            reference_height: reference.height,
        });
    }
    if test.channels != reference.channels {
        return Err(MetricsError::ChannelMismatch {
            test: test.channels,
            reference: reference.channels,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_accepts_consistent_lengths() {
        let samples = [0u8; 2 * 3 * 4];
        let r = Raster::new(2, 3, 4, &samples).expect("2×3 RGBA is 24 samples");
        assert_eq!(r.pixel_count(), 6);
        assert_eq!(r.row_len(), 8);
    }

    #[test]
    fn new_rejects_a_short_buffer_naming_both_lengths() {
        let samples = [0u8; 10];
        let err = Raster::new(2, 2, 3, &samples).unwrap_err();
        assert_eq!(
            err,
            MetricsError::BadSampleLength {
                role: "image",
                width: 2,
                height: 2,
                channels: 3,
                expected: 12,
                actual: 10
            }
        );
        let text = err.to_string();
        assert!(text.contains("12") && text.contains("10"), "{text}");
    }

    #[test]
    fn new_rejects_two_channels_and_empty_images() {
        assert!(matches!(
            Raster::new(1, 1, 2, &[0, 0]),
            Err(MetricsError::UnsupportedChannels { channels: 2, .. })
        ));
        assert!(matches!(
            Raster::new(0, 5, 3, &[]),
            Err(MetricsError::EmptyImage { .. })
        ));
    }

    #[test]
    fn rgb8_image_view_has_three_channels() {
        let img = Rgb8Image::filled(4, 2, [1, 2, 3]);
        let r = img.raster();
        assert_eq!((r.width, r.height, r.channels), (4, 2, 3));
        assert_eq!(&r.samples[..3], &[1, 2, 3]);
        assert!(Raster::new(r.width, r.height, r.channels, r.samples).is_ok());
    }

    #[test]
    fn check_pair_reports_size_then_channels() {
        let a = [0u8; 12];
        let b = [0u8; 8];
        let test = Raster::new(2, 2, 3, &a).unwrap();
        let reference = Raster::new(2, 1, 4, &b).unwrap();
        let err = check_pair(&test, &reference).unwrap_err();
        assert!(matches!(err, MetricsError::SizeMismatch { .. }), "{err}");
        let c = [0u8; 16];
        let test = Raster::new(4, 1, 3, &a).unwrap();
        let reference = Raster::new(4, 1, 4, &c).unwrap();
        let err = check_pair(&test, &reference).unwrap_err();
        assert_eq!(
            err,
            MetricsError::ChannelMismatch {
                test: 3,
                reference: 4
            }
        );
    }

    #[test]
    fn check_pair_rejects_an_inconsistent_hand_built_view() {
        let a = [0u8; 12];
        let good = Raster::new(2, 2, 3, &a).unwrap();
        let bad = Raster { width: 3, ..good };
        assert!(matches!(
            check_pair(&good, &bad),
            Err(MetricsError::BadSampleLength {
                role: "reference",
                ..
            })
        ));
    }
}
