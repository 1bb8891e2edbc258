//! SSIM exactly as scikit-image computes it in the Wang et al. 2004 setting:
//! `structural_similarity(test, reference, gaussian_weights=True, sigma=1.5,
//! use_sample_covariance=False, data_range=255, channel_axis=-1)`.
//!
//! What that call does (read from scikit-image 0.26's source, and locked by
//! `tests/metrics_skimage.rs`):
//! - each channel separately, samples as float64 in 0..=255;
//! - `scipy.ndimage.gaussian_filter(σ = 1.5, truncate = 3.5, mode='reflect')`:
//!   radius int(3.5·1.5 + 0.5) = 5, 11 taps exp(−x²/2σ²) normalised to sum 1,
//!   borders mirrored about the edge (d c b a | a b c d | d c b a);
//! - ux, uy, uxx, uyy, uxy filtered; vx = uxx − ux², vy = uyy − uy²,
//!   vxy = uxy − ux·uy (population covariance);
//! - S = (2·ux·uy + C1)(2·vxy + C2) / ((ux² + uy² + C1)(vx + vy + C2)) with
//!   C1 = (0.01·255)², C2 = (0.03·255)²;
//! - the mean of S over the map with a 5-pixel border cropped, then the mean
//!   over channels;
//! - images narrower or shorter than the 11-pixel window are refused
//!   ("win_size exceeds image extent"), and so are they here.
//!
//! Work is split into fixed bands of rows run in parallel; the band size does
//! not depend on the thread count, and partial sums are added in band order,
//! so the result is the same on any number of cores.
//!
//! The same kernels also take one float per pixel computed from a stored
//! image a band at a time ([`ssim_mapped`]: PU21-SSIM's encoded luminance).

use super::raster::{check_pair, Raster};
use super::ssim_bands::{run, KernelPath, Mapped, Plane};
use super::ssim_kernel::RADIUS;
use super::MetricsError;
use crate::image::Image;

/// Window side; also the smallest image side scikit-image accepts.
pub const SSIM_WINDOW: u32 = 2 * RADIUS as u32 + 1;

/// Mean SSIM and the per-pixel SSIM map.
#[derive(Clone, Debug, PartialEq)]
pub struct Ssim {
    /// scikit-image's mean SSIM (border-cropped, channel-averaged).
    pub mean: f64,
    /// S at every pixel, averaged over channels, full size and uncropped: the
    /// border pixels are kept because a defect there is still a defect, even
    /// though the mean leaves them out.
    pub map: Image<f64>,
}

/// The Gaussian window's taps 0..=RADIUS (symmetric, normalised to sum 1
/// over the window), as the CPU's SSIM weighs: the GPU's SSIM takes them.
#[cfg(feature = "gpu")]
pub(crate) fn gaussian_taps() -> [f64; RADIUS + 1] {
    super::ssim_kernel::kernel_weights()
}

/// Mean SSIM (see the module documentation for the exact definition).
///
/// Errors when the pair cannot be compared or either side is under 11 pixels.
pub fn mean_ssim(test: Raster, reference: Raster) -> Result<f64, MetricsError> {
    check_size(&test, &reference)?;
    run(
        Plane::of(&test),
        Plane::of(&reference),
        None,
        KernelPath::best(),
    )
}

/// SSIM of `f(test)` against `f(reference)` — one value per pixel, already
/// on SSIM's 8-bit scale (0..255) — with its map, computed a band at a
/// time: the mapped images are never stored whole, which on a large frame
/// costs more (fresh memory) than the mapping itself.
pub fn ssim_mapped<P: Sync>(
    test: &[P],
    reference: &[P],
    width: u32,
    height: u32,
    f: &(impl Fn(&P) -> f64 + Sync),
) -> Result<Ssim, MetricsError> {
    let mut map = Image::filled(width, height, 0.0);
    let mean = ssim_mapped_into(test, reference, width, height, f, Some(&mut map.pixels))?;
    Ok(Ssim { mean, map })
}

/// [`ssim_mapped`]'s mean only.
pub fn mean_ssim_mapped<P: Sync>(
    test: &[P],
    reference: &[P],
    width: u32,
    height: u32,
    f: &(impl Fn(&P) -> f64 + Sync),
) -> Result<f64, MetricsError> {
    ssim_mapped_into(test, reference, width, height, f, None)
}

fn ssim_mapped_into<P: Sync>(
    test: &[P],
    reference: &[P],
    width: u32,
    height: u32,
    f: &(impl Fn(&P) -> f64 + Sync),
    map: Option<&mut [f64]>,
) -> Result<f64, MetricsError> {
    let n = width as usize * height as usize;
    for (role, len) in [
        ("image under test", test.len()),
        ("reference", reference.len()),
    ] {
        if len != n || n == 0 {
            return Err(MetricsError::BadSampleLength {
                role,
                width,
                height,
                channels: 1,
                expected: n as u128,
                actual: len,
            });
        }
    }
    if width < SSIM_WINDOW || height < SSIM_WINDOW {
        return Err(MetricsError::TooSmallForSsim { width, height });
    }
    let source = |pixels| Mapped {
        width: width as usize,
        height: height as usize,
        pixels,
        f,
    };
    run(source(test), source(reference), map, KernelPath::best())
}

/// Mean SSIM together with the per-pixel map.
pub fn ssim(test: Raster, reference: Raster) -> Result<Ssim, MetricsError> {
    ssim_on(&test, &reference, KernelPath::best())
}

pub(crate) fn ssim_on(
    test: &Raster,
    reference: &Raster,
    path: KernelPath,
) -> Result<Ssim, MetricsError> {
    check_size(test, reference)?;
    let mut map = Image::filled(test.width, test.height, 0.0);
    let mean = run(
        Plane::of(test),
        Plane::of(reference),
        Some(&mut map.pixels),
        path,
    )?;
    Ok(Ssim { mean, map })
}

fn check_size(test: &Raster, reference: &Raster) -> Result<(), MetricsError> {
    check_pair(test, reference)?;
    if test.width < SSIM_WINDOW || test.height < SSIM_WINDOW {
        return Err(MetricsError::TooSmallForSsim {
            width: test.width,
            height: test.height,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::ssim_kernel::{kernel_weights, reflect_index};

    fn pattern(width: u32, height: u32, channels: usize, seed: u32) -> Vec<u8> {
        // A small deterministic hash so the tests need no RNG crate.
        (0..width * height * channels as u32)
            .map(|i| {
                let mut v = i.wrapping_mul(2654435761) ^ seed.wrapping_mul(40503);
                v ^= v >> 13;
                v = v.wrapping_mul(0x5bd1e995);
                (v >> 24) as u8
            })
            .collect()
    }

    #[test]
    fn mapped_values_give_the_ssim_of_the_stored_image() {
        // Heights that are not a multiple of the band, so windows reflect at
        // both edges; the mapping is the identity on grey levels.
        for (w, h) in [(23, 11), (17, 29), (40, 8 * 3 + 5)] {
            let a = pattern(w, h, 1, 3);
            let b = pattern(w, h, 1, 4);
            let stored = mean_ssim(
                Raster::new(w, h, 1, &a).unwrap(),
                Raster::new(w, h, 1, &b).unwrap(),
            )
            .unwrap();
            let f = |v: &u8| f64::from(*v);
            let mapped = mean_ssim_mapped(&a, &b, w, h, &f).unwrap();
            // The same arithmetic, but the AVX2 u8 loads and the f64 loads feed
            // the same FMAs: equal to the last bits.
            assert!(
                (mapped - stored).abs() < 1e-12,
                "{w}x{h}: {mapped} vs {stored}"
            );
            let with_map = ssim_mapped(&a, &b, w, h, &f).unwrap();
            assert_eq!(with_map.mean, mapped);
            assert_eq!(with_map.map.pixels.len(), (w * h) as usize);
        }
    }

    #[test]
    fn weights_match_scipy() {
        let w = kernel_weights();
        let total = w[0] + 2.0 * w[1..].iter().sum::<f64>();
        assert!((total - 1.0).abs() < 1e-15);
        // scipy.ndimage._filters._gaussian_kernel1d(1.5, 0, 5)[5], [10]
        assert!((w[0] - 0.266_011_724_861_794_36).abs() < 1e-15, "{}", w[0]);
        assert!((w[5] - 0.001_028_380_084_479_11).abs() < 1e-15, "{}", w[5]);
    }

    #[test]
    fn reflect_index_matches_scipy_for_short_lines() {
        // scipy.ndimage.correlate1d(line, e0 of 11 taps, mode='reflect')
        // reads line[i − 5]; these are the indices it used for i = 0, 1, ...
        assert_eq!(reflect_index(-5, 1), 0);
        assert_eq!([reflect_index(-5, 2), reflect_index(-4, 2)], [0, 0]);
        assert_eq!(
            [-5, -4, -3].map(|i| reflect_index(i, 3)),
            [1, 2, 2],
            "n = 3"
        );
        assert_eq!([-5, -4, -3, -2].map(|i| reflect_index(i, 4)), [3, 3, 2, 1]);
        assert_eq!(
            [-5, -4, -3, -2, -1, 0, 1].map(|i| reflect_index(i, 7)),
            [4, 3, 2, 1, 0, 0, 1]
        );
        assert_eq!(
            [7, 8, 13, 14, 15].map(|i| reflect_index(i, 7)),
            [6, 5, 0, 0, 1]
        );
    }

    #[test]
    fn identical_images_give_exactly_one_on_every_path() {
        for channels in [1, 3, 4] {
            let a = pattern(23, 17, channels, 1);
            let r = Raster::new(23, 17, channels, &a).unwrap();
            for path in paths() {
                let s = ssim_on(&r, &r, path).unwrap();
                assert_eq!(s.mean, 1.0, "{channels} channels, {path:?}");
                assert!(s.map.pixels.iter().all(|&v| v == 1.0));
            }
        }
    }

    #[test]
    fn perturbed_image_scores_below_one() {
        let a = pattern(40, 30, 3, 1);
        let mut b = a.clone();
        b[3 * (15 * 40 + 20)] ^= 0x40;
        let (ra, rb) = (
            Raster::new(40, 30, 3, &a).unwrap(),
            Raster::new(40, 30, 3, &b).unwrap(),
        );
        let s = ssim(ra, rb).unwrap();
        assert!(s.mean < 1.0 && s.mean > 0.9, "{}", s.mean);
        assert!(s.map.get(20, 15) < 1.0);
        assert_eq!(s.map.get(0, 0), 1.0, "far from the change");
        assert_eq!(mean_ssim(ra, rb).unwrap(), s.mean);
    }

    #[test]
    fn paths_agree_and_thread_count_does_not_matter() {
        let (w, h) = (67, 45);
        let a = pattern(w, h, 3, 1);
        let b = pattern(w, h, 3, 2);
        let ra = Raster::new(w, h, 3, &a).unwrap();
        let rb = Raster::new(w, h, 3, &b).unwrap();
        let base = ssim_on(&ra, &rb, KernelPath::Portable).unwrap();
        for path in paths() {
            let other = ssim_on(&ra, &rb, path).unwrap();
            assert!((other.mean - base.mean).abs() < 1e-12);
            let single = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap()
                .install(|| ssim_on(&ra, &rb, path).unwrap());
            assert_eq!(single, other, "{path:?}");
        }
    }

    #[test]
    fn windows_larger_than_the_image_are_an_error() {
        for (w, h) in [(10, 40), (40, 10), (7, 7), (1, 1)] {
            let a = pattern(w, h, 3, 1);
            let r = Raster::new(w, h, 3, &a).unwrap();
            let err = mean_ssim(r, r).unwrap_err();
            assert_eq!(
                err,
                MetricsError::TooSmallForSsim {
                    width: w,
                    height: h
                }
            );
            assert!(err.to_string().contains("11"), "{err}");
            assert!(ssim(r, r).is_err());
        }
        let a = pattern(11, 11, 1, 1);
        let r = Raster::new(11, 11, 1, &a).unwrap();
        assert_eq!(mean_ssim(r, r).unwrap(), 1.0);
    }

    /// The integration test `metrics_skimage` exercises the fastest kernel
    /// only; this holds every compiled kernel to the same scikit-image values.
    #[test]
    fn every_path_matches_the_skimage_vectors() {
        let doc: serde_json::Value =
            serde_json::from_str(include_str!("../../tests/skimage/vectors.json")).unwrap();
        let mut checked = 0;
        for case in doc["cases"].as_array().unwrap() {
            let Some(want) = case["ssim"].as_f64() else {
                continue;
            };
            let samples = |key: &str| -> Vec<u8> {
                let values = case[key].as_array().unwrap();
                values.iter().map(|v| v.as_u64().unwrap() as u8).collect()
            };
            let (a, b) = (samples("test"), samples("reference"));
            let dims = |key: &str| case[key].as_u64().unwrap();
            let (w, h, c) = (
                dims("width") as u32,
                dims("height") as u32,
                dims("channels"),
            );
            let ra = Raster::new(w, h, c as usize, &a).unwrap();
            let rb = Raster::new(w, h, c as usize, &b).unwrap();
            for path in paths() {
                let got = ssim_on(&ra, &rb, path).unwrap().mean;
                assert!(
                    (got - want).abs() < 1e-6,
                    "{case} {path:?}: {got} vs {want}",
                    case = case["name"]
                );
                checked += 1;
            }
        }
        assert!(checked >= 12, "{checked}");
    }

    fn paths() -> Vec<KernelPath> {
        let mut paths = vec![KernelPath::Portable];
        if KernelPath::best() != KernelPath::Portable {
            paths.push(KernelPath::best());
        }
        paths
    }
}
