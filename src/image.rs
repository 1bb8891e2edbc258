//! Pixel containers shared by the readers, both renderers and the metrics.
//!
//! One generic row-major container keeps sizes and indexing in one place; the
//! aliases say which stage of the pipeline an image belongs to.

use rayon::prelude::*;

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
        self.pixels
            .par_iter()
            .map(|&p| f(p))
            .collect_into_vec(&mut pixels);
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
