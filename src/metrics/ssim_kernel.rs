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
//! The loops are written over pre-trimmed slices of one common length so LLVM
//! drops the bounds checks and vectorises them; the same body is compiled a
//! second time with AVX2+FMA enabled and chosen at run time.

use super::ssim::{C1, C2, RADIUS};

/// How the filter accumulates `acc + w·v`: two roundings on the portable path,
/// one (a hardware FMA) where the CPU has it. The S formula itself never uses
/// this, so that S is exactly 1 for identical inputs on both paths.
pub(crate) trait MulAdd {
    fn mul_add(a: f64, b: f64, c: f64) -> f64;
}

/// `a·b + c` with two roundings; portable.
pub(crate) struct Separate;
impl MulAdd for Separate {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
}

/// `a·b + c` with one rounding. Only instantiated inside functions compiled
/// with the `fma` target feature: elsewhere `f64::mul_add` is a slow libm call.
#[cfg(target_arch = "x86_64")]
pub(crate) struct Fused;
#[cfg(target_arch = "x86_64")]
impl MulAdd for Fused {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

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

/// Vertical pass for one output row: `a[k]`, `b[k]` are the source rows at
/// vertical offset k − RADIUS (already reflected), each `n` samples long;
/// results go to `out.*[start..start + n]`.
#[inline(always)]
pub(crate) fn vertical<M: MulAdd>(
    w: &[f64; RADIUS + 1],
    a: &[&[u8]; 2 * RADIUS + 1],
    b: &[&[u8]; 2 * RADIUS + 1],
    out: &mut VerticalRows,
    start: usize,
) {
    let n = a[RADIUS].len();
    // Re-slicing everything to exactly `n` lets LLVM prove every index below
    // in bounds from the loop condition alone.
    let a: [&[u8]; 2 * RADIUS + 1] = std::array::from_fn(|k| &a[k][..n]);
    let b: [&[u8]; 2 * RADIUS + 1] = std::array::from_fn(|k| &b[k][..n]);
    let ox = &mut out.x[start..start + n];
    let oy = &mut out.y[start..start + n];
    let oxx = &mut out.xx[start..start + n];
    let oyy = &mut out.yy[start..start + n];
    let oxy = &mut out.xy[start..start + n];
    for i in 0..n {
        let x0 = f64::from(a[RADIUS][i]);
        let y0 = f64::from(b[RADIUS][i]);
        let mut sx = w[0] * x0;
        let mut sy = w[0] * y0;
        let mut sxx = w[0] * (x0 * x0);
        let mut syy = w[0] * (y0 * y0);
        let mut sxy = w[0] * (x0 * y0);
        for k in 1..=RADIUS {
            let xl = f64::from(a[RADIUS - k][i]);
            let xh = f64::from(a[RADIUS + k][i]);
            let yl = f64::from(b[RADIUS - k][i]);
            let yh = f64::from(b[RADIUS + k][i]);
            // Sums and products of 8-bit values are exact in f64, so only the
            // weighting rounds, and x·x and x·y round identically when x = y.
            sx = M::mul_add(w[k], xl + xh, sx);
            sy = M::mul_add(w[k], yl + yh, sy);
            sxx = M::mul_add(w[k], xl * xl + xh * xh, sxx);
            syy = M::mul_add(w[k], yl * yl + yh * yh, syy);
            sxy = M::mul_add(w[k], xl * yl + xh * yh, sxy);
        }
        ox[i] = sx;
        oy[i] = sy;
        oxx[i] = sxx;
        oyy[i] = syy;
        oxy[i] = sxy;
    }
}

/// Horizontal pass fused with the SSIM formula: `v.*` are padded rows
/// (`RADIUS · channels` samples of reflection on each side), `s` receives one
/// S value per sample.
#[inline(always)]
pub(crate) fn horizontal_ssim<M: MulAdd>(
    w: &[f64; RADIUS + 1],
    v: &VerticalRows,
    channels: usize,
    s: &mut [f64],
) {
    let n = s.len();
    // taps[q][j] is moment q shifted by j − RADIUS pixels.
    fn shifted(row: &[f64], channels: usize, n: usize) -> [&[f64]; 2 * RADIUS + 1] {
        std::array::from_fn(|j| &row[j * channels..j * channels + n])
    }
    let taps = |row| shifted(row, channels, n);
    let (tx, ty, txx, tyy, txy) = (
        taps(&v.x),
        taps(&v.y),
        taps(&v.xx),
        taps(&v.yy),
        taps(&v.xy),
    );
    let filter = |t: &[&[f64]; 2 * RADIUS + 1], i: usize| -> f64 {
        let mut acc = w[0] * t[RADIUS][i];
        for k in 1..=RADIUS {
            acc = M::mul_add(w[k], t[RADIUS - k][i] + t[RADIUS + k][i], acc);
        }
        acc
    };
    for (i, out) in s.iter_mut().enumerate() {
        let ux = filter(&tx, i);
        let uy = filter(&ty, i);
        let uxx = filter(&txx, i);
        let uyy = filter(&tyy, i);
        let uxy = filter(&txy, i);
        *out = ssim_formula(ux, uy, uxx, uyy, uxy);
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
pub(crate) fn row_portable(
    w: &[f64; RADIUS + 1],
    a: &[&[u8]; 2 * RADIUS + 1],
    b: &[&[u8]; 2 * RADIUS + 1],
    scratch: &mut VerticalRows,
    channels: usize,
    s: &mut [f64],
) {
    vertical::<Separate>(w, a, b, scratch, RADIUS * channels);
    super::ssim::reflect_padding(scratch, channels);
    horizontal_ssim::<Separate>(w, scratch, channels, s);
}

/// Both passes for one row, compiled for AVX2 + FMA.
///
/// # Safety
/// The CPU must support AVX2 and FMA (checked with `is_x86_feature_detected!`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn row_avx2_fma(
    w: &[f64; RADIUS + 1],
    a: &[&[u8]; 2 * RADIUS + 1],
    b: &[&[u8]; 2 * RADIUS + 1],
    scratch: &mut VerticalRows,
    channels: usize,
    s: &mut [f64],
) {
    vertical::<Fused>(w, a, b, scratch, RADIUS * channels);
    super::ssim::reflect_padding(scratch, channels);
    horizontal_ssim::<Fused>(w, scratch, channels, s);
}
