//! Pixel containers shared by the readers, both renderers and the metrics.
//!
//! One generic row-major container keeps sizes and indexing in one place; the
//! aliases say which stage of the pipeline an image belongs to.

#[cfg(feature = "reference")]
use crate::par::*;

/// A row-major image, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Image<P> {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<P>,
}

/// Linear HDR radiance as stored in files and fed to the renderers.
pub type HdrImage = Image<[f32; 3]>;
/// Linear RGB in f64: the CPU reference's intermediates.
pub type LinearImage = Image<[f64; 3]>;
/// Display-encoded 8-bit RGB: the pipeline's final output and what goldens hold.
pub type Rgb8Image = Image<[u8; 3]>;
/// 16 bits a channel: a PQ frame, a 16-bit PNG.
pub type Rgb16Image = Image<[u16; 3]>;

/// An encoded frame: the code values a display is sent, at its encoding's
/// depth. What both renderers produce, goldens hold and the gate compares.
#[derive(Clone, Debug, PartialEq)]
pub enum Frame {
    /// 8 bits a channel: the sRGB transfer or a gamma, BT.709 primaries.
    Rgb8(Rgb8Image),
    /// 16 bits a channel, full range: SMPTE ST 2084 (PQ) of absolute
    /// cd/m², BT.2020 primaries (BT.2100).
    Pq16(Rgb16Image),
}

impl Frame {
    pub fn width(&self) -> u32 {
        match self {
            Frame::Rgb8(i) => i.width,
            Frame::Pq16(i) => i.width,
        }
    }

    pub fn height(&self) -> u32 {
        match self {
            Frame::Rgb8(i) => i.height,
            Frame::Pq16(i) => i.height,
        }
    }

    /// Bits per sample of its codes: 8 or 16.
    pub fn bits(&self) -> u32 {
        match self {
            Frame::Rgb8(_) => 8,
            Frame::Pq16(_) => 16,
        }
    }

    /// What its codes are, for messages: "8-bit" or "16-bit PQ".
    pub fn kind(&self) -> &'static str {
        match self {
            Frame::Rgb8(_) => "8-bit",
            Frame::Pq16(_) => "16-bit PQ",
        }
    }

    /// The 8-bit image, if it is one.
    pub fn as_rgb8(&self) -> Option<&Rgb8Image> {
        match self {
            Frame::Rgb8(i) => Some(i),
            Frame::Pq16(_) => None,
        }
    }

    /// The 8-bit image, if it is one.
    pub fn into_rgb8(self) -> Option<Rgb8Image> {
        match self {
            Frame::Rgb8(i) => Some(i),
            Frame::Pq16(_) => None,
        }
    }
}

impl From<Rgb8Image> for Frame {
    fn from(image: Rgb8Image) -> Frame {
        Frame::Rgb8(image)
    }
}

impl<P: Copy> Image<P> {
    /// An image filled with one value.
    pub fn filled(width: u32, height: u32, value: P) -> Self {
        Self {
            width,
            height,
            pixels: vec![value; width as usize * height as usize],
        }
    }

    /// An image whose pixel (x, y) is `f(x, y)`.
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> P) -> Self {
        let mut pixels = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                pixels.push(f(x, y));
            }
        }
        Self {
            width,
            height,
            pixels,
        }
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    pub fn get(&self, x: u32, y: u32) -> P {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Applies `f` to every pixel, keeping the size.
    pub fn map<Q>(&self, f: impl Fn(P) -> Q) -> Image<Q> {
        Image {
            width: self.width,
            height: self.height,
            pixels: self.pixels.iter().map(|&p| f(p)).collect(),
        }
    }

    /// [`Image::map`] on every core: the same pixels, as each depends on
    /// its own input only.
    pub fn par_map<Q: Send>(&self, f: impl Fn(P) -> Q + Sync) -> Image<Q>
    where
        P: Sync,
    {
        let mut pixels = Vec::with_capacity(self.pixels.len());
        advise_huge_pages(&pixels);
        #[cfg(feature = "reference")]
        self.pixels
            .par_iter()
            .map(|&p| f(p))
            .collect_into_vec(&mut pixels);
        #[cfg(not(feature = "reference"))]
        pixels.extend(self.pixels.iter().map(|&p| f(p)));
        Image {
            width: self.width,
            height: self.height,
            pixels,
        }
    }
}

/// Asks the kernel to back `v`'s allocation, not yet touched, with
/// transparent huge pages where it is large enough to hold some: a frame
/// buffer of tens of MB then takes tens of page faults instead of
/// thousands (a 2048x1024 f64 frame is 12,288 4-KiB pages). Only advice: a
/// kernel that refuses it, or another OS, keeps small pages.
pub fn advise_huge_pages<T>(v: &Vec<T>) {
    #[cfg(not(target_os = "linux"))]
    let _ = v;
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let bytes = v.capacity() * std::mem::size_of::<T>();
        if bytes < 2 * HUGE {
            return;
        }
        let start = v.as_ptr() as usize;
        let first = start.next_multiple_of(HUGE);
        let end = (start + bytes) / HUGE * HUGE;
        if end > first {
            // SAFETY: madvise on whole pages inside `v`'s own allocation;
            // MADV_HUGEPAGE changes how pages are backed, never their
            // contents or the mapping's validity.
            unsafe {
                libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
            }
        }
    }
}

impl Rgb8Image {
    /// The samples as one interleaved RGB byte slice.
    pub fn as_bytes(&self) -> &[u8] {
        self.pixels.as_flattened()
    }

    /// Builds an image from interleaved RGB bytes; `None` when the length does not match.
    pub fn from_bytes(width: u32, height: u32, bytes: &[u8]) -> Option<Self> {
        if bytes.len() != width as usize * height as usize * 3 {
            return None;
        }
        Some(Self {
            width,
            height,
            pixels: bytes.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        })
    }
}

impl HdrImage {
    /// A smooth, deterministic HDR ramp (the stress suite's range and size
    /// cases) with detail: luminance from `lo` to `hi`
    /// geometrically along x, a ripple along y, colour varying with position.
    pub fn ramp(width: u32, height: u32, lo: f64, hi: f64) -> HdrImage {
        let span = (hi / lo).ln();
        HdrImage::from_fn(width, height, |x, y| {
            let t = if width > 1 {
                x as f64 / (width - 1) as f64
            } else {
                0.5
            };
            let r = if height > 1 {
                y as f64 / (height - 1) as f64
            } else {
                0.5
            };
            let v = lo * (span * t).exp() * (1.0 + 0.25 * (12.0 * r).sin());
            [(v * 1.1) as f32, v as f32, (v * (0.7 + 0.3 * r)) as f32]
        })
    }

    /// The largest component, at least 0, NaN ignored: no stage before the
    /// tone curve makes a value above it.
    pub fn max_component(&self) -> f32 {
        max_component(&self.pixels)
    }

    /// Widens to the reference's f64 working precision (exact).
    pub fn to_linear(&self) -> LinearImage {
        self.par_map(|p| [p[0] as f64, p[1] as f64, p[2] as f64])
    }
}

impl LinearImage {
    /// Narrows to f32 for writing (rounds to nearest).
    pub fn to_hdr(&self) -> HdrImage {
        self.par_map(|p| [p[0] as f32, p[1] as f32, p[2] as f32])
    }
}

/// The largest component of `pixels`, at least 0, NaN ignored. Eight
/// independent lanes (a comparison, not `f32::max`) let the compiler use
/// vector maxima: the serial NaN-aware fold took 2.5 ms of a 1024×512
/// request.
fn max_component(pixels: &[[f32; 3]]) -> f32 {
    let flat: &[f32] = bytemuck::cast_slice(pixels);
    let mut lanes = [0.0f32; 8];
    let chunks = flat.chunks_exact(8);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (m, &v) in lanes.iter_mut().zip(chunk) {
            // A NaN compares false and is skipped, as f32::max skips it.
            *m = if v > *m { v } else { *m };
        }
    }
    rest.iter()
        .chain(&lanes)
        .fold(0.0f32, |m, &v| if v > m { v } else { m })
}

#[cfg(test)]
mod tests {
    use super::max_component;

    #[test]
    fn max_component_is_the_serial_fold_at_any_length_with_nan_and_negatives() {
        let serial = |p: &[[f32; 3]]| {
            p.iter()
                .flat_map(|p| p.iter().copied())
                .fold(0.0f32, f32::max)
        };
        let mut seed = 7u32;
        let mut next = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1 << 24) as f32
        };
        for n in [0usize, 1, 2, 3, 5, 8, 11, 64, 1001] {
            let mut p: Vec<[f32; 3]> = (0..n)
                .map(|_| [next() * 10.0 - 5.0, next(), -next()])
                .collect();
            assert_eq!(max_component(&p), serial(&p), "{n}");
            if n > 2 {
                // The largest value in every possible lane position, and a
                // NaN in front of it, are still found.
                for at in 0..(3 * n).min(17) {
                    let mut q = p.clone();
                    q[at / 3][at % 3] = 1e30;
                    if at > 0 {
                        q[(at - 1) / 3][(at - 1) % 3] = f32::NAN;
                    }
                    assert_eq!(max_component(&q), 1e30, "{n} at {at}");
                }
                p[0][0] = f32::INFINITY;
                assert_eq!(max_component(&p), f32::INFINITY);
            }
        }
        assert_eq!(max_component(&[[-1.0, f32::NAN, -3.0]]), 0.0);
    }
}
