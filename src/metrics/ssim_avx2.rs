//! The SSIM row kernel written with AVX2 + FMA intrinsics.
//!
//! The portable kernel in `ssim_kernel` computes the same thing; LLVM's
//! auto-vectoriser turns it into shuffles and spills (≈ 70 ms single-threaded
//! for a Full HD RGB pair against ≈ 25 ms here), so the hot loops are spelled
//! out. The arithmetic follows the portable kernel operation for operation,
//! except that `acc + w·v` is one fused multiply-add; the S formula never
//! fuses, so identical inputs still give exactly S = 1.
//!
//! Every function here is `unsafe` only because of `#[target_feature]`: the
//! caller must have checked that the CPU has AVX2 and FMA. Memory accesses are
//! through raw pointers whose ranges are checked by `assert!`s once per row.

#![cfg(target_arch = "x86_64")]

use super::ssim_kernel::{reflect_padding, ssim_formula, VerticalRows, C1, C2, RADIUS, TAPS};
use std::arch::x86_64::*;

/// A sample type this kernel reads: 8-bit levels, or floats.
pub(crate) trait Avx2Sample: Copy {
    /// Eight samples at `p` as two vectors of four f64.
    ///
    /// # Safety
    /// `p..p + 8` must be readable; AVX2 must be available.
    unsafe fn load8(p: *const Self) -> (__m256d, __m256d);
    fn value(self) -> f64;
}

impl Avx2Sample for u8 {
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn load8(p: *const u8) -> (__m256d, __m256d) {
        // SAFETY: the caller guarantees 8 readable bytes; the load is unaligned.
        let bytes = unsafe { _mm_loadl_epi64(p.cast()) };
        let ints = _mm256_cvtepu8_epi32(bytes);
        (
            _mm256_cvtepi32_pd(_mm256_castsi256_si128(ints)),
            _mm256_cvtepi32_pd(_mm256_extracti128_si256::<1>(ints)),
        )
    }

    fn value(self) -> f64 {
        f64::from(self)
    }
}

impl Avx2Sample for f64 {
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn load8(p: *const f64) -> (__m256d, __m256d) {
        // SAFETY: the caller guarantees 8 readable samples; unaligned loads.
        unsafe { (_mm256_loadu_pd(p), _mm256_loadu_pd(p.add(4))) }
    }

    fn value(self) -> f64 {
        self
    }
}

/// The five moments of four samples under accumulation.
#[derive(Clone, Copy)]
struct Moments {
    x: __m256d,
    y: __m256d,
    xx: __m256d,
    yy: __m256d,
    xy: __m256d,
}

impl Moments {
    /// The centre tap: w₀ times x, y and their products.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn centre(w0: __m256d, x: __m256d, y: __m256d) -> Self {
        Self {
            x: _mm256_mul_pd(w0, x),
            y: _mm256_mul_pd(w0, y),
            xx: _mm256_mul_pd(w0, _mm256_mul_pd(x, x)),
            yy: _mm256_mul_pd(w0, _mm256_mul_pd(y, y)),
            xy: _mm256_mul_pd(w0, _mm256_mul_pd(x, y)),
        }
    }

    /// Adds the pair of taps at ±k with weight `wk`. Sums and products of
    /// 8-bit values are exact, so only the accumulation rounds, and it rounds
    /// x·x and x·y alike when x = y.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn add_pair(&mut self, wk: __m256d, xl: __m256d, xh: __m256d, yl: __m256d, yh: __m256d) {
        self.x = _mm256_fmadd_pd(wk, _mm256_add_pd(xl, xh), self.x);
        self.y = _mm256_fmadd_pd(wk, _mm256_add_pd(yl, yh), self.y);
        self.xx = _mm256_fmadd_pd(wk, _mm256_fmadd_pd(xl, xl, _mm256_mul_pd(xh, xh)), self.xx);
        self.yy = _mm256_fmadd_pd(wk, _mm256_fmadd_pd(yl, yl, _mm256_mul_pd(yh, yh)), self.yy);
        self.xy = _mm256_fmadd_pd(wk, _mm256_fmadd_pd(xl, yl, _mm256_mul_pd(xh, yh)), self.xy);
    }

    /// Stores the moments at sample `i` of the five rows.
    ///
    /// # Safety
    /// `i + 4` must not exceed the length of any of the rows.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn store(&self, out: &mut VerticalRows, i: usize) {
        // SAFETY: the caller guarantees i + 4 <= len of every row.
        unsafe {
            _mm256_storeu_pd(out.x.as_mut_ptr().add(i), self.x);
            _mm256_storeu_pd(out.y.as_mut_ptr().add(i), self.y);
            _mm256_storeu_pd(out.xx.as_mut_ptr().add(i), self.xx);
            _mm256_storeu_pd(out.yy.as_mut_ptr().add(i), self.yy);
            _mm256_storeu_pd(out.xy.as_mut_ptr().add(i), self.xy);
        }
    }
}

/// Vertical pass, as `ssim_kernel::vertical`: rows `a[k]`, `b[k]` at offset
/// k − RADIUS, results to `out.*[start..start + n]`.
///
/// # Safety
/// AVX2 and FMA must be available.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn vertical<T: Avx2Sample>(
    w: &[f64; RADIUS + 1],
    a: &[&[T]; TAPS],
    b: &[&[T]; TAPS],
    out: &mut VerticalRows,
    start: usize,
) {
    let n = a[RADIUS].len();
    assert!(a.iter().chain(b).all(|row| row.len() == n));
    for row in [&out.x, &out.y, &out.xx, &out.yy, &out.xy] {
        assert!(start + n <= row.len());
    }
    let wv: [__m256d; RADIUS + 1] = std::array::from_fn(|k| _mm256_set1_pd(w[k]));
    let mut i = 0;
    while i + 8 <= n {
        // SAFETY (all loads and stores below): i + 8 <= n, every source row
        // has length n, and every output row is at least start + n long.
        let (xl, xh) = unsafe { T::load8(a[RADIUS].as_ptr().add(i)) };
        let (yl, yh) = unsafe { T::load8(b[RADIUS].as_ptr().add(i)) };
        let mut lo = Moments::centre(wv[0], xl, yl);
        let mut hi = Moments::centre(wv[0], xh, yh);
        for k in 1..=RADIUS {
            let (x_up_lo, x_up_hi) = unsafe { T::load8(a[RADIUS - k].as_ptr().add(i)) };
            let (x_dn_lo, x_dn_hi) = unsafe { T::load8(a[RADIUS + k].as_ptr().add(i)) };
            let (y_up_lo, y_up_hi) = unsafe { T::load8(b[RADIUS - k].as_ptr().add(i)) };
            let (y_dn_lo, y_dn_hi) = unsafe { T::load8(b[RADIUS + k].as_ptr().add(i)) };
            lo.add_pair(wv[k], x_up_lo, x_dn_lo, y_up_lo, y_dn_lo);
            hi.add_pair(wv[k], x_up_hi, x_dn_hi, y_up_hi, y_dn_hi);
        }
        unsafe {
            lo.store(out, start + i);
            hi.store(out, start + i + 4);
        }
        i += 8;
    }
    // The ragged end, one sample at a time with the same operations.
    for i in i..n {
        let x0 = a[RADIUS][i].value();
        let y0 = b[RADIUS][i].value();
        let mut m = [
            w[0] * x0,
            w[0] * y0,
            w[0] * (x0 * x0),
            w[0] * (y0 * y0),
            w[0] * (x0 * y0),
        ];
        for k in 1..=RADIUS {
            let (xl, xh) = (a[RADIUS - k][i].value(), a[RADIUS + k][i].value());
            let (yl, yh) = (b[RADIUS - k][i].value(), b[RADIUS + k][i].value());
            m[0] = w[k].mul_add(xl + xh, m[0]);
            m[1] = w[k].mul_add(yl + yh, m[1]);
            m[2] = w[k].mul_add(xl.mul_add(xl, xh * xh), m[2]);
            m[3] = w[k].mul_add(yl.mul_add(yl, yh * yh), m[3]);
            m[4] = w[k].mul_add(xl.mul_add(yl, xh * yh), m[4]);
        }
        out.x[start + i] = m[0];
        out.y[start + i] = m[1];
        out.xx[start + i] = m[2];
        out.yy[start + i] = m[3];
        out.xy[start + i] = m[4];
    }
}

/// One padded moment row filtered horizontally at samples `i..i + 4`.
///
/// # Safety
/// `i + 2·RADIUS·stride + 4 <= row.len()`; AVX2 and FMA available.
#[inline]
#[target_feature(enable = "avx2,fma")]
unsafe fn filter4(w: &[__m256d; RADIUS + 1], row: &[f64], stride: usize, i: usize) -> __m256d {
    // SAFETY: the caller guarantees the whole window is inside `row`.
    unsafe {
        let centre = row.as_ptr().add(i + RADIUS * stride);
        let mut acc = _mm256_mul_pd(w[0], _mm256_loadu_pd(centre));
        for (k, &wk) in w.iter().enumerate().skip(1) {
            let lo = _mm256_loadu_pd(centre.sub(k * stride));
            let hi = _mm256_loadu_pd(centre.add(k * stride));
            acc = _mm256_fmadd_pd(wk, _mm256_add_pd(lo, hi), acc);
        }
        acc
    }
}

/// Horizontal pass fused with the SSIM formula, as
/// `ssim_kernel::horizontal_ssim`.
///
/// # Safety
/// AVX2 and FMA must be available.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn horizontal_ssim(
    w: &[f64; RADIUS + 1],
    v: &VerticalRows,
    channels: usize,
    s: &mut [f64],
) {
    let n = s.len();
    let padded = n + 2 * RADIUS * channels;
    for row in [&v.x, &v.y, &v.xx, &v.yy, &v.xy] {
        assert!(row.len() >= padded);
    }
    let wv: [__m256d; RADIUS + 1] = std::array::from_fn(|k| _mm256_set1_pd(w[k]));
    let two = _mm256_set1_pd(2.0);
    let c1 = _mm256_set1_pd(C1);
    let c2 = _mm256_set1_pd(C2);
    let mut i = 0;
    while i + 4 <= n {
        // SAFETY: i + 4 <= n, so every window ends by n + 2·RADIUS·channels,
        // which the asserts above checked; `s` has n elements.
        let (ux, uy, uxx, uyy, uxy) = unsafe {
            (
                filter4(&wv, &v.x, channels, i),
                filter4(&wv, &v.y, channels, i),
                filter4(&wv, &v.xx, channels, i),
                filter4(&wv, &v.yy, channels, i),
                filter4(&wv, &v.xy, channels, i),
            )
        };
        // ssim_formula, lane-wise and in the same order, without fusing.
        let vx = _mm256_sub_pd(uxx, _mm256_mul_pd(ux, ux));
        let vy = _mm256_sub_pd(uyy, _mm256_mul_pd(uy, uy));
        let vxy = _mm256_sub_pd(uxy, _mm256_mul_pd(ux, uy));
        let a1 = _mm256_add_pd(_mm256_mul_pd(_mm256_mul_pd(two, ux), uy), c1);
        let a2 = _mm256_add_pd(_mm256_mul_pd(two, vxy), c2);
        let b1 = _mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(ux, ux), _mm256_mul_pd(uy, uy)),
            c1,
        );
        let b2 = _mm256_add_pd(_mm256_add_pd(vx, vy), c2);
        let value = _mm256_div_pd(_mm256_mul_pd(a1, a2), _mm256_mul_pd(b1, b2));
        unsafe { _mm256_storeu_pd(s.as_mut_ptr().add(i), value) };
        i += 4;
    }
    for (i, out) in s.iter_mut().enumerate().skip(i) {
        let filter = |row: &[f64]| {
            let centre = i + RADIUS * channels;
            let mut acc = w[0] * row[centre];
            for (k, &wk) in w.iter().enumerate().skip(1) {
                acc = wk.mul_add(row[centre - k * channels] + row[centre + k * channels], acc);
            }
            acc
        };
        *out = ssim_formula(
            filter(&v.x),
            filter(&v.y),
            filter(&v.xx),
            filter(&v.yy),
            filter(&v.xy),
        );
    }
}

/// Both passes for one row with the AVX2 + FMA kernel.
///
/// # Safety
/// The CPU must support AVX2 and FMA (checked with `is_x86_feature_detected!`).
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn row<T: Avx2Sample>(
    w: &[f64; RADIUS + 1],
    a: &[&[T]; TAPS],
    b: &[&[T]; TAPS],
    scratch: &mut VerticalRows,
    channels: usize,
    s: &mut [f64],
) {
    // SAFETY: this function's own contract: AVX2 and FMA are available.
    unsafe { vertical(w, a, b, scratch, RADIUS * channels) };
    reflect_padding(scratch, channels);
    // SAFETY: as above.
    unsafe { horizontal_ssim(w, scratch, channels, s) };
}
