//! SSIM over bands of rows run in parallel: where a band's rows come from
//! (a stored image, or values mapped from one a band at a time), which
//! kernel computes them, and the band sums added in band order.

use super::raster::Raster;
use super::ssim_kernel::{self, kernel_weights, reflect_index, Sample, VerticalRows, RADIUS, TAPS};
use super::MetricsError;
use rayon::prelude::*;

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

/// Rows per parallel work item. Fixed (not derived from the thread count) so
/// that the summation order, and therefore the result, never changes.
const BAND_ROWS: usize = 8;

/// Interleaved samples of one image, row-major.
#[derive(Clone, Copy)]
pub(super) struct Plane<'a, T> {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub samples: &'a [T],
}

impl<'a> Plane<'a, u8> {
    pub(super) fn of(r: &Raster<'a>) -> Self {
        Plane {
            width: r.width as usize,
            height: r.height as usize,
            channels: r.channels,
            samples: r.samples,
        }
    }
}

/// A sample type SSIM rows are computed for, on the fastest kernel it has.
pub(super) trait Rows: Sample {
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

/// Where SSIM's rows come from: a stored plane, or values computed a band
/// at a time so no whole transformed copy of an image is ever stored.
pub(super) trait Source: Sync {
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
pub(super) struct Mapped<'a, P, F> {
    pub width: usize,
    pub height: usize,
    pub pixels: &'a [P],
    pub f: &'a F,
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
pub(super) fn run<S: Source>(
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
