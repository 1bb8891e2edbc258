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
use super::ssim_kernel::{self, kernel_weights, reflect_index, Sample, VerticalRows, RADIUS, TAPS};
use super::MetricsError;
use crate::image::Image;
use rayon::prelude::*;

/// Window side; also the smallest image side scikit-image accepts.
pub const SSIM_WINDOW: u32 = 2 * RADIUS as u32 + 1;

/// Rows per parallel work item. Fixed (not derived from the thread count) so
/// that the summation order, and therefore the result, never changes.
const BAND_ROWS: usize = 8;

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

/// Interleaved samples of one image, row-major.
#[derive(Clone, Copy)]
struct Plane<'a, T> {
    width: usize,
    height: usize,
    channels: usize,
    samples: &'a [T],
}

impl<'a> Plane<'a, u8> {
    fn of(r: &Raster<'a>) -> Self {
        Plane {
            width: r.width as usize,
            height: r.height as usize,
            channels: r.channels,
            samples: r.samples,
        }
    }
}

/// A sample type SSIM rows are computed for, on the fastest kernel it has.
trait Rows: Sample {
    fn row(
        path: KernelPath,
        w: &[f64; RADIUS + 1],
        a: &[&[Self]; TAPS],
        b: &[&[Self]; TAPS],
        scratch: &mut VerticalRows,
        channels: usize,
        s: &mut [f64],
    );
}

impl Rows for u8 {
    fn row(
        path: KernelPath,
        w: &[f64; RADIUS + 1],
        a: &[&[u8]; TAPS],
        b: &[&[u8]; TAPS],
        scratch: &mut VerticalRows,
        channels: usize,
        s: &mut [f64],
    ) {
        match path {
            KernelPath::Portable => ssim_kernel::row_portable(w, a, b, scratch, channels, s),
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `KernelPath::Avx2Fma` is only chosen after
            // `is_x86_feature_detected!` confirmed AVX2 and FMA.
            KernelPath::Avx2Fma => unsafe { super::ssim_avx2::row(w, a, b, scratch, channels, s) },
        }
    }
}

impl Rows for f64 {
    fn row(
        path: KernelPath,
        w: &[f64; RADIUS + 1],
        a: &[&[f64]; TAPS],
        b: &[&[f64]; TAPS],
        scratch: &mut VerticalRows,
        channels: usize,
        s: &mut [f64],
    ) {
        match path {
            KernelPath::Portable => ssim_kernel::row_portable(w, a, b, scratch, channels, s),
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as for u8.
            KernelPath::Avx2Fma => unsafe { super::ssim_avx2::row(w, a, b, scratch, channels, s) },
        }
    }
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

/// Which compilation of the row kernel runs. The two differ only in the last
/// bits (fused multiply-adds in the filter), far below the 1e-6 tolerance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum KernelPath {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2Fma,
}

impl KernelPath {
    pub(crate) fn best() -> Self {
        #[cfg(target_arch = "x86_64")]
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            return KernelPath::Avx2Fma;
        }
        KernelPath::Portable
    }
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

/// Where SSIM's rows come from: a stored plane, or values computed a band
/// at a time so no whole transformed copy of an image is ever stored.
trait Source: Sync {
    type Sample: Rows;
    fn width(&self) -> usize;
    fn height(&self) -> usize;
    fn channels(&self) -> usize;
    /// Prepares in `window` what the band of output rows `rows` reads.
    fn prepare(&self, rows: std::ops::Range<usize>, window: &mut Vec<Self::Sample>);
    /// The 11 rows around output row `y` (reflected at the image's edges);
    /// `first` is the band's first row, `window` what `prepare` made for it.
    fn rows<'a>(
        &'a self,
        window: &'a [Self::Sample],
        first: usize,
        y: usize,
    ) -> [&'a [Self::Sample]; TAPS];
}

impl<T: Rows> Source for Plane<'_, T> {
    type Sample = T;
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }
    fn channels(&self) -> usize {
        self.channels
    }
    fn prepare(&self, _: std::ops::Range<usize>, _: &mut Vec<T>) {}
    fn rows<'a>(&'a self, _: &'a [T], _: usize, y: usize) -> [&'a [T]; TAPS] {
        let n = self.width * self.channels;
        std::array::from_fn(|k| {
            let r = reflect_index(y as isize + k as isize - RADIUS as isize, self.height);
            &self.samples[r * n..(r + 1) * n]
        })
    }
}

/// One value per pixel, `f` of the stored pixel, made a band at a time.
struct Mapped<'a, P, F> {
    width: usize,
    height: usize,
    pixels: &'a [P],
    f: &'a F,
}

impl<P: Sync, F: Fn(&P) -> f64 + Sync> Source for Mapped<'_, P, F> {
    type Sample = f64;
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }
    fn channels(&self) -> usize {
        1
    }
    fn prepare(&self, rows: std::ops::Range<usize>, window: &mut Vec<f64>) {
        window.clear();
        // The band's rows and RADIUS more on each side, already reflected.
        for k in rows.start as isize - RADIUS as isize..(rows.end + RADIUS) as isize {
            let r = reflect_index(k, self.height);
            let line = &self.pixels[r * self.width..(r + 1) * self.width];
            window.extend(line.iter().map(self.f));
        }
    }
    fn rows<'a>(&'a self, window: &'a [f64], first: usize, y: usize) -> [&'a [f64]; TAPS] {
        let start = y - first;
        std::array::from_fn(|k| &window[(start + k) * self.width..(start + k + 1) * self.width])
    }
}

/// Per-worker buffers, reused across bands.
struct Scratch<T> {
    vertical: VerticalRows,
    s: Vec<f64>,
    window_a: Vec<T>,
    window_b: Vec<T>,
}

/// Computes the mean and, when `map` is given, fills it (width × height).
/// The sizes are checked by the callers.
fn run<S: Source>(
    test: S,
    reference: S,
    map: Option<&mut [f64]>,
    path: KernelPath,
) -> Result<f64, MetricsError> {
    let width = test.width();
    let height = test.height();
    let channels = test.channels();
    let weights = kernel_weights();
    let new_scratch = || Scratch {
        vertical: VerticalRows::new((width + 2 * RADIUS) * channels),
        s: vec![0.0; width * channels],
        window_a: Vec::new(),
        window_b: Vec::new(),
    };
    let band = |scratch: &mut Scratch<S::Sample>, index: usize, map_rows: Option<&mut [f64]>| {
        let rows = index * BAND_ROWS..((index + 1) * BAND_ROWS).min(height);
        band_sum(&test, &reference, &weights, path, scratch, rows, map_rows)
    };
    let bands = height.div_ceil(BAND_ROWS);
    let sums: Vec<f64> = match map {
        Some(map) => map
            .par_chunks_mut(BAND_ROWS * width)
            .enumerate()
            .map_init(new_scratch, |scratch, (index, rows)| {
                band(scratch, index, Some(rows))
            })
            .collect(),
        None => (0..bands)
            .into_par_iter()
            .map_init(new_scratch, |scratch, index| band(scratch, index, None))
            .collect(),
    };
    let total: f64 = sums.iter().sum();
    let cropped = (width - 2 * RADIUS) * (height - 2 * RADIUS) * channels;
    Ok(total / cropped as f64)
}

/// SSIM rows `rows`; returns Σ S over the cropped part of those rows and, when
/// `map_rows` is given, writes their channel-averaged S.
fn band_sum<S: Source>(
    test: &S,
    reference: &S,
    weights: &[f64; RADIUS + 1],
    path: KernelPath,
    scratch: &mut Scratch<S::Sample>,
    rows: std::ops::Range<usize>,
    mut map_rows: Option<&mut [f64]>,
) -> f64 {
    let height = test.height();
    let width = test.width();
    let channels = test.channels();
    let n = width * channels;
    test.prepare(rows.clone(), &mut scratch.window_a);
    reference.prepare(rows.clone(), &mut scratch.window_b);
    let first = rows.start;
    let mut sum = 0.0;
    for y in rows {
        let a = test.rows(&scratch.window_a, first, y);
        let b = reference.rows(&scratch.window_b, first, y);
        let s = &mut scratch.s;
        S::Sample::row(path, weights, &a, &b, &mut scratch.vertical, channels, s);
        if (RADIUS..height - RADIUS).contains(&y) {
            sum += sum_in_lanes(&s[RADIUS * channels..n - RADIUS * channels]);
        }
        if let Some(map) = map_rows.as_deref_mut() {
            let out = &mut map[(y - first) * width..(y - first + 1) * width];
            // Sum then divide, as numpy's mean over the channel axis does.
            for (m, pixel) in out.iter_mut().zip(s.chunks_exact(channels)) {
                *m = pixel.iter().sum::<f64>() / channels as f64;
            }
        }
    }
    sum
}

/// Σ xs with eight independent accumulators: the plain left fold is a chain of
/// dependent additions that costs more than the filtering of a row.
fn sum_in_lanes(xs: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 8];
    let chunks = xs.chunks_exact(8);
    let tail: f64 = chunks.remainder().iter().sum();
    for chunk in chunks {
        for (lane, &x) in lanes.iter_mut().zip(chunk) {
            *lane += x;
        }
    }
    lanes.iter().sum::<f64>() + tail
}

#[cfg(test)]
mod tests {
    use super::*;

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
