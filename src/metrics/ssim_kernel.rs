//! The inner loops of SSIM: one output row of the five Gaussian-filtered
//! moments and the SSIM formula, fused so that nothing but the final S row is
//! written to memory.
//!
//! scipy's `gaussian_filter` filters axis 0 (vertical) first, then axis 1, and
//! so do we. The vertical pass reads the eleven source rows as `u8` and forms
//! x, y, x², y², xy on the fly: the products of 8-bit samples are exact in
//! f64, so computing them late costs no accuracy and saves five rows of
//! memory traffic per tap. The horizontal pass then runs over the five padded
//! vertical rows and feeds S directly.
//!
//! Both passes use the symmetric form w₀·v₀ + Σₖ wₖ·(v₋ₖ + v₊ₖ) (6 multiplies
//! instead of 11), like scipy's `correlate1d` does for symmetric kernels.
//!
//! This is the portable kernel: loops over fixed-size lane arrays that LLVM
//! vectorises for whatever the target baseline is. `ssim_avx2` is the same
//! computation in intrinsics, chosen at run time where the CPU allows.

/// Gaussian window radius: scipy's int(truncate·σ + 0.5) with truncate = 3.5
/// and σ = 1.5 (scikit-image picks truncate = 3.5 to get Wang's 11 taps).
pub(crate) const RADIUS: usize = 5;
const SIGMA: f64 = 1.5;
const DATA_RANGE: f64 = 255.0;
/// (K1·L)², evaluated as Python evaluates `(K1 * R) ** 2`.
pub(crate) const C1: f64 = (0.01 * DATA_RANGE) * (0.01 * DATA_RANGE);
/// (K2·L)².
pub(crate) const C2: f64 = (0.03 * DATA_RANGE) * (0.03 * DATA_RANGE);

/// The five vertically filtered moments of one row, each padded by `RADIUS`
/// reflected pixels on both sides so the horizontal pass needs no border case.
pub(crate) struct VerticalRows {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub xx: Vec<f64>,
    pub yy: Vec<f64>,
    pub xy: Vec<f64>,
}

impl VerticalRows {
    pub(crate) fn new(padded_len: usize) -> Self {
        Self {
            x: vec![0.0; padded_len],
            y: vec![0.0; padded_len],
            xx: vec![0.0; padded_len],
            yy: vec![0.0; padded_len],
            xy: vec![0.0; padded_len],
        }
    }
}

/// Samples per step of the inner loops: 8 f64 fill two AVX2 registers (or
/// one AVX-512 register). Fixed-size arrays give LLVM's SLP vectoriser
/// straight-line code with no aliasing or bounds questions to answer.
const LANES: usize = 8;
/// Taps of the 1-D kernel.
pub(crate) const TAPS: usize = 2 * RADIUS + 1;

/// A sample type the kernels read: 8-bit levels (the frames) or floats
/// (perceptually encoded HDR values).
pub(crate) trait Sample: Copy + Send + Sync + 'static {
    /// Samples `i..i + L` of `row` as f64.
    fn load<const L: usize>(row: &[Self], i: usize) -> [f64; L];
}

impl Sample for u8 {
    #[inline(always)]
    fn load<const L: usize>(row: &[u8], i: usize) -> [f64; L] {
        // One bounds check for the whole chunk, so LLVM emits a vector load.
        let chunk: &[u8; L] = row[i..i + L].try_into().expect("slice of length L");
        chunk.map(f64::from)
    }
}

impl Sample for f64 {
    #[inline(always)]
    fn load<const L: usize>(row: &[f64], i: usize) -> [f64; L] {
        load_f64::<L>(row, i)
    }
}

#[inline(always)]
fn load_f64<const L: usize>(row: &[f64], i: usize) -> [f64; L] {
    let chunk: &[f64; L] = row[i..i + L].try_into().expect("slice of length L");
    *chunk
}

/// The five vertically filtered moments of samples `i..i + L`.
#[inline(always)]
fn vertical_lanes<T: Sample, const L: usize>(
    w: &[f64; RADIUS + 1],
    a: &[&[T]; TAPS],
    b: &[&[T]; TAPS],
    i: usize,
) -> [[f64; L]; 5] {
    let x0 = T::load::<L>(a[RADIUS], i);
    let y0 = T::load::<L>(b[RADIUS], i);
    let mut sx = [0.0; L];
    let mut sy = [0.0; L];
    let mut sxx = [0.0; L];
    let mut syy = [0.0; L];
    let mut sxy = [0.0; L];
    for l in 0..L {
        sx[l] = w[0] * x0[l];
        sy[l] = w[0] * y0[l];
        sxx[l] = w[0] * (x0[l] * x0[l]);
        syy[l] = w[0] * (y0[l] * y0[l]);
        sxy[l] = w[0] * (x0[l] * y0[l]);
    }
    for k in 1..=RADIUS {
        let xl = T::load::<L>(a[RADIUS - k], i);
        let xh = T::load::<L>(a[RADIUS + k], i);
        let yl = T::load::<L>(b[RADIUS - k], i);
        let yh = T::load::<L>(b[RADIUS + k], i);
        for l in 0..L {
            // Sums and products of 8-bit values are exact in f64, so only the
            // weighting rounds, and x·x and x·y round identically when x = y
            // (for floats as well: the same operations on the same values).
            sx[l] += w[k] * (xl[l] + xh[l]);
            sy[l] += w[k] * (yl[l] + yh[l]);
            sxx[l] += w[k] * (xl[l] * xl[l] + xh[l] * xh[l]);
            syy[l] += w[k] * (yl[l] * yl[l] + yh[l] * yh[l]);
            sxy[l] += w[k] * (xl[l] * yl[l] + xh[l] * yh[l]);
        }
    }
    [sx, sy, sxx, syy, sxy]
}

/// Vertical pass for one output row: `a[k]`, `b[k]` are the source rows at
/// vertical offset k − RADIUS (already reflected), each `n` samples long;
/// results go to `out.*[start..start + n]`.
#[inline(always)]
pub(crate) fn vertical<T: Sample>(
    w: &[f64; RADIUS + 1],
    a: &[&[T]; TAPS],
    b: &[&[T]; TAPS],
    out: &mut VerticalRows,
    start: usize,
) {
    let n = a[RADIUS].len();
    let mut store = |i: usize, moments: &[&[f64]; 5]| {
        let len = moments[0].len();
        for (row, m) in [
            &mut out.x,
            &mut out.y,
            &mut out.xx,
            &mut out.yy,
            &mut out.xy,
        ]
        .into_iter()
        .zip(moments)
        {
            row[start + i..start + i + len].copy_from_slice(m);
        }
    };
    let mut i = 0;
    while i + LANES <= n {
        let [x, y, xx, yy, xy] = vertical_lanes::<T, LANES>(w, a, b, i);
        store(i, &[&x, &y, &xx, &yy, &xy]);
        i += LANES;
    }
    while i < n {
        let [x, y, xx, yy, xy] = vertical_lanes::<T, 1>(w, a, b, i);
        store(i, &[&x, &y, &xx, &yy, &xy]);
        i += 1;
    }
}

/// One moment filtered horizontally at samples `i..i + L`; `row` is padded
/// and `stride` is the distance between neighbouring pixels (the channels).
#[inline(always)]
fn horizontal_lanes<const L: usize>(
    w: &[f64; RADIUS + 1],
    row: &[f64],
    stride: usize,
    i: usize,
) -> [f64; L] {
    let centre = i + RADIUS * stride;
    let c = load_f64::<L>(row, centre);
    let mut acc = [0.0; L];
    for l in 0..L {
        acc[l] = w[0] * c[l];
    }
    for (k, &wk) in w.iter().enumerate().skip(1) {
        let lo = load_f64::<L>(row, centre - k * stride);
        let hi = load_f64::<L>(row, centre + k * stride);
        for l in 0..L {
            acc[l] += wk * (lo[l] + hi[l]);
        }
    }
    acc
}

#[inline(always)]
fn ssim_lanes<const L: usize>(
    w: &[f64; RADIUS + 1],
    v: &VerticalRows,
    stride: usize,
    i: usize,
    s: &mut [f64],
) {
    let ux = horizontal_lanes::<L>(w, &v.x, stride, i);
    let uy = horizontal_lanes::<L>(w, &v.y, stride, i);
    let uxx = horizontal_lanes::<L>(w, &v.xx, stride, i);
    let uyy = horizontal_lanes::<L>(w, &v.yy, stride, i);
    let uxy = horizontal_lanes::<L>(w, &v.xy, stride, i);
    let out = &mut s[i..i + L];
    for l in 0..L {
        out[l] = ssim_formula(ux[l], uy[l], uxx[l], uyy[l], uxy[l]);
    }
}

/// Horizontal pass fused with the SSIM formula: `v.*` are padded rows
/// (`RADIUS · channels` samples of reflection on each side), `s` receives one
/// S value per sample.
#[inline(always)]
pub(crate) fn horizontal_ssim(
    w: &[f64; RADIUS + 1],
    v: &VerticalRows,
    channels: usize,
    s: &mut [f64],
) {
    let n = s.len();
    let mut i = 0;
    while i + LANES <= n {
        ssim_lanes::<LANES>(w, v, channels, i, s);
        i += LANES;
    }
    while i < n {
        ssim_lanes::<1>(w, v, channels, i, s);
        i += 1;
    }
}

/// S from the filtered moments, in scikit-image's operation order. No FMA
/// here: with identical inputs the numerator and denominator then round
/// identically and S is exactly 1.
#[inline(always)]
pub(crate) fn ssim_formula(ux: f64, uy: f64, uxx: f64, uyy: f64, uxy: f64) -> f64 {
    let vx = uxx - ux * ux;
    let vy = uyy - uy * uy;
    let vxy = uxy - ux * uy;
    let a1 = 2.0 * ux * uy + C1;
    let a2 = 2.0 * vxy + C2;
    let b1 = ux * ux + uy * uy + C1;
    let b2 = vx + vy + C2;
    (a1 * a2) / (b1 * b2)
}

/// Both passes for one row on the portable path.
pub(crate) fn row_portable<T: Sample>(
    w: &[f64; RADIUS + 1],
    a: &[&[T]; TAPS],
    b: &[&[T]; TAPS],
    scratch: &mut VerticalRows,
    channels: usize,
    s: &mut [f64],
) {
    vertical(w, a, b, scratch, RADIUS * channels);
    reflect_padding(scratch, channels);
    horizontal_ssim(w, scratch, channels, s);
}

/// The normalised kernel's centre and one-sided weights, as scipy's
/// `_gaussian_kernel1d`: exp(−0.5/σ² · x²) over x = −5..=5, divided by the sum.
pub(crate) fn kernel_weights() -> [f64; RADIUS + 1] {
    let sigma2 = SIGMA * SIGMA;
    let phi = |x: i32| libm::exp(-0.5 / sigma2 * f64::from(x * x));
    let sum: f64 = (-(RADIUS as i32)..=RADIUS as i32).map(phi).sum();
    std::array::from_fn(|k| phi(k as i32) / sum)
}

/// scipy's 'reflect' border: index `i` of a line of `n` samples extended by
/// mirroring about the edges (d c b a | a b c d | d c b a), repeated as often
/// as needed, so it is defined for lines shorter than the kernel radius too.
pub(crate) fn reflect_index(i: isize, n: usize) -> usize {
    let period = 2 * n as isize;
    let m = i.rem_euclid(period) as usize;
    if m < n {
        m
    } else {
        2 * n - 1 - m
    }
}

/// Fills the `RADIUS` pixels of padding on each side of the five vertical rows
/// by reflecting their interior.
pub(crate) fn reflect_padding(rows: &mut VerticalRows, channels: usize) {
    let width = rows.x.len() / channels - 2 * RADIUS;
    for row in [
        &mut rows.x,
        &mut rows.y,
        &mut rows.xx,
        &mut rows.yy,
        &mut rows.xy,
    ] {
        for p in 0..RADIUS {
            let left_src = RADIUS + reflect_index(p as isize - RADIUS as isize, width);
            let right_dst = RADIUS + width + p;
            let right_src = RADIUS + reflect_index((width + p) as isize, width);
            row.copy_within(left_src * channels..(left_src + 1) * channels, p * channels);
            row.copy_within(
                right_src * channels..(right_src + 1) * channels,
                right_dst * channels,
            );
        }
    }
}
