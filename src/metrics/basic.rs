//! Pixel-wise error metrics: MSE, RMSE, PSNR, SNR, mean and maximum
//! difference and the fraction of pixels off by more than k LSB.
//!
//! Every sum here is an exact `u64` over integer samples (it would take ~2⁴⁸
//! samples, each off by 255, to overflow), so MSE is the correctly rounded
//! quotient of two exact integers: the same bits numpy's float64 mean gives,
//! independent of summation order and thread count.

use super::raster::{check_pair, Raster};
use super::MetricsError;
use rayon::prelude::*;

/// Pixels per parallel work item: large enough that rayon's overhead is
/// noise, small enough that a Full HD frame splits over both cores.
const PIXELS_PER_CHUNK: usize = 1 << 15;

/// Exact integer totals from one pass over a pair of images.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct ErrorSums {
    /// Σ (test − reference)² over all samples.
    pub squared_error: u64,
    /// Σ reference² over all samples (the signal energy for SNR).
    pub reference_energy: u64,
    /// Σ |test − reference| over all samples.
    pub abs_error: u64,
    /// max |test − reference| over all samples.
    pub max_abs_diff: u8,
    /// Number of samples (pixels × channels).
    pub samples: u64,
}

impl ErrorSums {
    fn merge(self, other: Self) -> Self {
        Self {
            squared_error: self.squared_error + other.squared_error,
            reference_energy: self.reference_energy + other.reference_energy,
            abs_error: self.abs_error + other.abs_error,
            max_abs_diff: self.max_abs_diff.max(other.max_abs_diff),
            samples: self.samples + other.samples,
        }
    }

    fn of_slices(test: &[u8], reference: &[u8]) -> Self {
        // u32 partial sums vectorise better than u64; 65025 × 2¹⁵ < 2³², so a
        // chunk of PIXELS_PER_CHUNK pixels of up to 4 channels is summed in
        // blocks of 2¹⁵ samples.
        let mut sums = Self::default();
        for (t, r) in test.chunks(1 << 15).zip(reference.chunks(1 << 15)) {
            let mut squared_error = 0u32;
            let mut reference_energy = 0u32;
            let mut abs_error = 0u32;
            let mut max_abs_diff = 0u8;
            for (&t, &r) in t.iter().zip(r) {
                let d = t.abs_diff(r);
                squared_error += u32::from(d) * u32::from(d);
                reference_energy += u32::from(r) * u32::from(r);
                abs_error += u32::from(d);
                max_abs_diff = max_abs_diff.max(d);
            }
            sums = sums.merge(Self {
                squared_error: squared_error.into(),
                reference_energy: reference_energy.into(),
                abs_error: abs_error.into(),
                max_abs_diff,
                samples: t.len() as u64,
            });
        }
        sums
    }

    /// One parallel pass over a checked pair.
    pub(crate) fn of(test: &Raster, reference: &Raster) -> Result<Self, MetricsError> {
        check_pair(test, reference)?;
        let chunk = PIXELS_PER_CHUNK * test.channels;
        Ok(test
            .samples
            .par_chunks(chunk)
            .zip(reference.samples.par_chunks(chunk))
            .map(|(t, r)| Self::of_slices(t, r))
            .reduce(Self::default, Self::merge))
    }

    pub(crate) fn mse(&self) -> f64 {
        self.squared_error as f64 / self.samples as f64
    }

    pub(crate) fn psnr(&self) -> f64 {
        psnr_from_mse(self.mse())
    }

    /// The exact integer sum over the sample count, correctly rounded: the
    /// bits numpy's `mean(abs(test - ref))` gives.
    pub(crate) fn mean_abs_diff(&self) -> f64 {
        self.abs_error as f64 / self.samples as f64
    }

    pub(crate) fn snr(&self) -> f64 {
        if self.squared_error == 0 {
            // Checked first so that two all-black images, where the ratio is
            // 0/0, count as the perfect match they are.
            return f64::INFINITY;
        }
        // A zero-energy reference with any error gives log10(0) = −∞: there is
        // no signal, only noise. numpy gives the same value.
        10.0 * libm::log10(self.reference_energy as f64 / self.squared_error as f64)
    }
}

/// PSNR in dB for 8-bit data: 10·log10(255²/MSE), +∞ exactly when MSE = 0.
///
/// Written out rather than left to 255²/0 = +∞ so the contract does not hang
/// on IEEE division; `libm` keeps the value identical on every machine.
pub(crate) fn psnr_from_mse(mse: f64) -> f64 {
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * libm::log10(255.0 * 255.0 / mse)
    }
}

/// Mean over all pixels and channels of (test − reference)².
pub fn mse(test: Raster, reference: Raster) -> Result<f64, MetricsError> {
    Ok(ErrorSums::of(&test, &reference)?.mse())
}

/// √MSE, in 8-bit levels.
pub fn rmse(test: Raster, reference: Raster) -> Result<f64, MetricsError> {
    Ok(mse(test, reference)?.sqrt())
}

/// 10·log10(255²/MSE) in dB; `f64::INFINITY` for identical images, never NaN
/// and never capped (docs/metrics.md: a cap would hide how close two frames
/// are).
pub fn psnr(test: Raster, reference: Raster) -> Result<f64, MetricsError> {
    Ok(ErrorSums::of(&test, &reference)?.psnr())
}

/// 10·log10(Σ reference² / Σ (test − reference)²) in dB.
///
/// +∞ when the images are identical (including two all-black images);
/// −∞ when the reference is all zero and the test image is not (no signal,
/// only error). Never NaN.
pub fn snr(test: Raster, reference: Raster) -> Result<f64, MetricsError> {
    Ok(ErrorSums::of(&test, &reference)?.snr())
}

/// Mean over all pixels and channels of |test − reference|, in LSB: the
/// typical error, which a few outliers (unlike the maximum) do not decide.
pub fn mean_abs_diff(test: Raster, reference: Raster) -> Result<f64, MetricsError> {
    Ok(ErrorSums::of(&test, &reference)?.mean_abs_diff())
}

/// Largest absolute difference of any sample, in LSB.
pub fn max_abs_diff(test: Raster, reference: Raster) -> Result<u8, MetricsError> {
    Ok(ErrorSums::of(&test, &reference)?.max_abs_diff)
}

/// Fraction (0..=1) of pixels in which at least one channel differs by more
/// than `k` LSB; `k = 1` tolerates the ±1 rounding two correct encoders may
/// disagree by.
pub fn fraction_over(test: Raster, reference: Raster, k: u8) -> Result<f64, MetricsError> {
    check_pair(&test, &reference)?;
    let channels = test.channels;
    let chunk = PIXELS_PER_CHUNK * channels;
    let over: u64 = test
        .samples
        .par_chunks(chunk)
        .zip(reference.samples.par_chunks(chunk))
        .map(|(t, r)| {
            t.chunks_exact(channels)
                .zip(r.chunks_exact(channels))
                .filter(|(tp, rp)| tp.iter().zip(rp.iter()).any(|(&a, &b)| a.abs_diff(b) > k))
                .count() as u64
        })
        .sum();
    Ok(over as f64 / test.pixel_count() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(width: u32, samples: &[u8]) -> Raster<'_> {
        Raster::new(width, samples.len() as u32 / width, 1, samples).unwrap()
    }

    #[test]
    fn hand_computed_values() {
        let reference = [10u8, 20, 30, 40];
        let test = [10u8, 22, 27, 40];
        let (t, r) = (grey(2, &test), grey(2, &reference));
        // (0 + 4 + 9 + 0) / 4
        assert_eq!(mse(t, r).unwrap(), 3.25);
        assert_eq!(rmse(t, r).unwrap(), 3.25f64.sqrt());
        let expected_psnr = 10.0 * (65025.0f64 / 3.25).log10();
        assert!((psnr(t, r).unwrap() - expected_psnr).abs() < 1e-12);
        // Σref² = 3000, Σerr² = 13
        let expected_snr = 10.0 * (3000.0f64 / 13.0).log10();
        assert!((snr(t, r).unwrap() - expected_snr).abs() < 1e-12);
        assert_eq!(max_abs_diff(t, r).unwrap(), 3);
        // (0 + 2 + 3 + 0) / 4
        assert_eq!(mean_abs_diff(t, r).unwrap(), 1.25);
        assert_eq!(fraction_over(t, r, 1).unwrap(), 0.5);
        assert_eq!(fraction_over(t, r, 2).unwrap(), 0.25);
        assert_eq!(fraction_over(t, r, 3).unwrap(), 0.0);
    }

    #[test]
    fn fraction_over_counts_pixels_not_samples() {
        // Two RGB pixels; the first is off in two channels, the second in none.
        let reference = [0u8, 0, 0, 9, 9, 9];
        let test = [5u8, 5, 0, 9, 9, 9];
        let t = Raster::new(2, 1, 3, &test).unwrap();
        let r = Raster::new(2, 1, 3, &reference).unwrap();
        assert_eq!(fraction_over(t, r, 1).unwrap(), 0.5);
    }

    #[test]
    fn identical_images_are_infinitely_good_never_nan() {
        let a = [0u8, 0, 0, 0];
        let b = [7u8, 8, 9, 255];
        for img in [&a[..], &b[..]] {
            let r = grey(2, img);
            assert_eq!(mse(r, r).unwrap(), 0.0);
            assert_eq!(psnr(r, r).unwrap(), f64::INFINITY);
            assert_eq!(snr(r, r).unwrap(), f64::INFINITY);
            assert_eq!(max_abs_diff(r, r).unwrap(), 0);
            assert_eq!(mean_abs_diff(r, r).unwrap(), 0.0);
        }
    }

    #[test]
    fn black_reference_with_error_has_minus_infinite_snr() {
        let black = [0u8; 4];
        let lit = [0u8, 1, 0, 0];
        let v = snr(grey(2, &lit), grey(2, &black)).unwrap();
        assert_eq!(v, f64::NEG_INFINITY);
        assert!(psnr(grey(2, &lit), grey(2, &black)).unwrap().is_finite());
    }

    #[test]
    fn worst_case_difference_is_finite() {
        let black = [0u8; 4];
        let white = [255u8; 4];
        let v = psnr(grey(2, &white), grey(2, &black)).unwrap();
        assert_eq!(v, 0.0);
        assert_eq!(max_abs_diff(grey(2, &white), grey(2, &black)).unwrap(), 255);
    }

    #[test]
    fn sums_do_not_depend_on_chunking() {
        // More than one chunk and more than one u32 block, with a ragged end.
        let n = PIXELS_PER_CHUNK * 3 + 17;
        let reference: Vec<u8> = (0..n * 3).map(|i| (i * 7 % 256) as u8).collect();
        let test: Vec<u8> = (0..n * 3).map(|i| (i * 13 % 256) as u8).collect();
        let t = Raster::new(n as u32, 1, 3, &test).unwrap();
        let r = Raster::new(n as u32, 1, 3, &reference).unwrap();
        let sums = ErrorSums::of(&t, &r).unwrap();
        let serial = ErrorSums::of_slices(&test, &reference);
        assert_eq!(sums, serial);
        let naive: u64 = test
            .iter()
            .zip(&reference)
            .map(|(&a, &b)| (a as i64 - b as i64).pow(2) as u64)
            .sum();
        assert_eq!(sums.squared_error, naive);
        let naive_abs: u64 = test
            .iter()
            .zip(&reference)
            .map(|(&a, &b)| u64::from(a.abs_diff(b)))
            .sum();
        assert_eq!(sums.abs_error, naive_abs);
    }

    #[test]
    fn mismatched_pairs_are_errors() {
        let a = [0u8; 4];
        let b = [0u8; 6];
        assert!(matches!(
            mse(grey(2, &a), grey(2, &b)),
            Err(MetricsError::SizeMismatch { .. })
        ));
        assert!(matches!(
            fraction_over(grey(2, &a), grey(3, &b), 1),
            Err(MetricsError::SizeMismatch { .. })
        ));
    }
}
