//! PNG in and out: 8-bit RGB (the pipeline's output and the goldens) and
//! 16-bit RGB (finer diagnostics), through the `image` crate.
//!
//! Reading accepts grey (expanded to RGB), RGB, and RGBA or grey-alpha only
//! when every alpha sample is opaque: a golden with transparency would be
//! compared against an output that has none, so it is refused rather than
//! silently flattened. A submitted frame may say otherwise ([`Alpha`]): its
//! colour composited over a background, or its alpha dropped. The bit depth must match the function (no silent
//! 8 ↔ 16 conversion that would change what "equal" means in a comparison).
//! A file must end with its IEND chunk (see `read_png`).

use std::fs::File;
use std::io::{BufReader, Cursor, Read, Seek, SeekFrom, Write};
use std::path::Path;

use image::codecs::png::{PngDecoder, PngEncoder};
use image::{DynamicImage, ExtendedColorType, ImageEncoder};

use super::atomic::write_atomically;
use super::error::{catch_decoder_panic, from_image, HdrIoError};
use super::validate::{check_dimensions, DEFAULT_MAX_PIXELS};
pub use crate::image::Rgb16Image;
use crate::image::{Image, Rgb8Image};

const FORMAT: &str = "PNG";

/// What a PNG's alpha channel means when it is read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Alpha {
    /// Refused unless opaque everywhere (goldens and references).
    #[default]
    Opaque,
    /// The colour composited over a background of 8-bit codes (16-bit
    /// codes are these × 257): `c·a + b·(1 − a)` with straight alpha, on
    /// the stored codes, as a browser draws the PNG over a page of that
    /// colour, rounded to the nearest code.
    Over([u8; 3]),
    /// Dropped: the colour channels as they are stored.
    Ignore,
}

pub(crate) fn read_png8(path: &Path) -> Result<Rgb8Image, HdrIoError> {
    let file = path.display().to_string();
    let (handle, len) = open(path, &file)?;
    png8(read_png(handle, len, &file)?, &file, Alpha::Opaque)
}

/// [`read_png8`] on bytes in memory; `file` names them in errors.
pub(crate) fn decode_png8(bytes: &[u8], file: &str, alpha: Alpha) -> Result<Rgb8Image, HdrIoError> {
    png8(
        read_png(Cursor::new(bytes), bytes.len() as u64, file)?,
        file,
        alpha,
    )
}

fn png8(image: DynamicImage, file: &str, alpha: Alpha) -> Result<Rgb8Image, HdrIoError> {
    let file = file.to_string();
    match image {
        DynamicImage::ImageRgb8(rgb) => Ok(from_raw(rgb.width(), rgb.height(), &rgb.into_raw())),
        DynamicImage::ImageLuma8(grey) => {
            Ok(grey_to_rgb(grey.width(), grey.height(), &grey.into_raw()))
        }
        DynamicImage::ImageRgba8(rgba) => {
            let (w, h) = rgba.dimensions();
            let rgb = flatten(&file, rgba.into_raw().as_slice(), 4, alpha)?;
            Ok(from_raw(w, h, &rgb))
        }
        DynamicImage::ImageLumaA8(grey) => {
            let (w, h) = grey.dimensions();
            let rgba = grey_alpha_to_rgba(grey.into_raw().as_slice());
            let rgb = flatten(&file, &rgba, 4, alpha)?;
            Ok(from_raw(w, h, &rgb))
        }
        _ => Err(wrong_depth(&file, "16-bit", "read_png16")),
    }
}

pub(crate) fn read_png16(path: &Path) -> Result<Rgb16Image, HdrIoError> {
    let file = path.display().to_string();
    let (handle, len) = open(path, &file)?;
    png16(read_png(handle, len, &file)?, &file, Alpha::Opaque)
}

/// [`read_png16`] on bytes in memory; `file` names them in errors.
pub(crate) fn decode_png16(
    bytes: &[u8],
    file: &str,
    alpha: Alpha,
) -> Result<Rgb16Image, HdrIoError> {
    png16(
        read_png(Cursor::new(bytes), bytes.len() as u64, file)?,
        file,
        alpha,
    )
}

fn png16(image: DynamicImage, file: &str, alpha: Alpha) -> Result<Rgb16Image, HdrIoError> {
    match image {
        DynamicImage::ImageRgb16(rgb) => Ok(from_raw(rgb.width(), rgb.height(), &rgb.into_raw())),
        DynamicImage::ImageLuma16(grey) => {
            Ok(grey_to_rgb(grey.width(), grey.height(), &grey.into_raw()))
        }
        DynamicImage::ImageRgba16(rgba) => {
            let (w, h) = rgba.dimensions();
            let rgb = flatten(file, rgba.into_raw().as_slice(), 4, alpha)?;
            Ok(from_raw(w, h, &rgb))
        }
        DynamicImage::ImageLumaA16(grey) => {
            let (w, h) = grey.dimensions();
            let rgba = grey_alpha_to_rgba(grey.into_raw().as_slice());
            let rgb = flatten(file, &rgba, 4, alpha)?;
            Ok(from_raw(w, h, &rgb))
        }
        _ => Err(wrong_depth(file, "8-bit", "read_png8")),
    }
}

/// The IEND chunk every PNG must end with: length 0, type, CRC.
const IEND: [u8; 12] = [0, 0, 0, 0, b'I', b'E', b'N', b'D', 0xae, 0x42, 0x60, 0x82];

/// Decodes after checking that the file is complete and that the header's
/// size is within the default pixel limit.
///
/// The IEND check is ours: the `png` decoder stops after the last image data
/// and does not notice a file cut in its final chunks, but a golden that lost
/// its tail was not written completely and must not be trusted.
fn open(path: &Path, file: &str) -> Result<(File, u64), HdrIoError> {
    let io_error = |action| {
        move |source| HdrIoError::Io {
            file: file.to_string(),
            action,
            source,
        }
    };
    let handle = super::open_regular(path).map_err(io_error("open"))?;
    let len = handle.metadata().map_err(io_error("read"))?.len();
    Ok((handle, len))
}

fn read_png<R: Read + Seek>(
    mut handle: R,
    len: u64,
    file: &str,
) -> Result<DynamicImage, HdrIoError> {
    let io_error = |action| {
        move |source| HdrIoError::Io {
            file: file.to_string(),
            action,
            source,
        }
    };
    let mut tail = [0u8; 12];
    let complete = len >= 12 && {
        handle.seek(SeekFrom::End(-12)).map_err(io_error("read"))?;
        handle.read_exact(&mut tail).map_err(io_error("read"))?;
        tail == IEND
    };
    if !complete {
        return Err(HdrIoError::Truncated {
            file: file.to_string(),
            format: FORMAT,
            detail: "the file does not end with the IEND chunk".to_string(),
        });
    }
    handle.seek(SeekFrom::Start(0)).map_err(io_error("read"))?;
    catch_decoder_panic(file, FORMAT, || {
        let decoder =
            PngDecoder::new(BufReader::new(handle)).map_err(|e| from_image(file, FORMAT, e))?;
        let (width, height) = image::ImageDecoder::dimensions(&decoder);
        check_dimensions(
            file,
            u64::from(width),
            u64::from(height),
            DEFAULT_MAX_PIXELS,
        )?;
        DynamicImage::from_decoder(decoder).map_err(|e| from_image(file, FORMAT, e))
    })
}

fn wrong_depth(file: &str, depth: &str, other: &str) -> HdrIoError {
    HdrIoError::Unsupported {
        file: file.to_string(),
        format: FORMAT,
        detail: format!("it is a {depth} PNG; read it with {other}"),
    }
}

/// A code of 8 or 16 bits.
trait Code: Copy + PartialEq + Into<u32> {
    const MAX: u32;
    /// `v` ≤ `MAX`.
    fn of(v: u32) -> Self;
}

impl Code for u8 {
    const MAX: u32 = 255;
    fn of(v: u32) -> u8 {
        v.min(255) as u8
    }
}

impl Code for u16 {
    const MAX: u32 = 65535;
    fn of(v: u32) -> u16 {
        v.min(65535) as u16
    }
}

/// Grey and alpha as RGBA.
fn grey_alpha_to_rgba<T: Copy>(samples: &[T]) -> Vec<T> {
    samples
        .chunks_exact(2)
        .flat_map(|p| [p[0], p[0], p[0], p[1]])
        .collect()
}

/// RGB from RGBA (`stride` 4) as `alpha` says: refused unless opaque,
/// composited over a background, or the alpha dropped.
fn flatten<T: Code>(
    file: &str,
    samples: &[T],
    stride: usize,
    alpha: Alpha,
) -> Result<Vec<T>, HdrIoError> {
    let opaque = |p: &[T]| p[stride - 1].into() == T::MAX;
    match alpha {
        Alpha::Opaque => {
            if let Some(index) = samples.chunks_exact(stride).position(|p| !opaque(p)) {
                return Err(HdrIoError::Unsupported {
                    file: file.to_string(),
                    format: FORMAT,
                    detail: format!(
                        "pixel {index} (in row-major order) is not opaque; goldens and references must have no transparency"
                    ),
                });
            }
            Ok(samples
                .chunks_exact(stride)
                .flat_map(|p| p[..stride - 1].iter().copied())
                .collect())
        }
        Alpha::Ignore => Ok(samples
            .chunks_exact(stride)
            .flat_map(|p| p[..stride - 1].iter().copied())
            .collect()),
        Alpha::Over(background) => {
            // 8-bit background codes at this depth: × 257 for 16 bits.
            let scale = T::MAX / 255;
            let max = u64::from(T::MAX);
            Ok(samples
                .chunks_exact(stride)
                .flat_map(|p| {
                    let a = u64::from(p[stride - 1].into());
                    (0..stride - 1).map(move |i| {
                        let c = u64::from(p[i].into());
                        let b = u64::from(u32::from(background[i]) * scale);
                        // Rounded to nearest: (2x + max) / 2max.
                        let v = (2 * (c * a + b * (max - a)) + max) / (2 * max);
                        T::of(v as u32)
                    })
                })
                .collect())
        }
    }
}

fn from_raw<T: Copy>(width: u32, height: u32, samples: &[T]) -> Image<[T; 3]> {
    Image {
        width,
        height,
        pixels: samples
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
    }
}

fn grey_to_rgb<T: Copy>(width: u32, height: u32, samples: &[T]) -> Image<[T; 3]> {
    Image {
        width,
        height,
        pixels: samples.iter().map(|&v| [v; 3]).collect(),
    }
}

/// Checks that the image is non-empty and its buffer matches its size: the
/// fields are public, and the encoder would otherwise panic or misread.
pub(crate) fn check_consistent<P>(file: &str, image: &Image<P>) -> Result<(), HdrIoError> {
    let expected = image.width as usize * image.height as usize;
    if expected == 0 || image.pixels.len() != expected {
        return Err(HdrIoError::BadImage {
            file: file.to_string(),
            width: image.width,
            height: image.height,
            pixel_count: image.pixels.len(),
        });
    }
    Ok(())
}

fn encode(
    writer: impl Write,
    file: &str,
    bytes: &[u8],
    width: u32,
    height: u32,
    color: ExtendedColorType,
) -> Result<(), HdrIoError> {
    PngEncoder::new(writer)
        .write_image(bytes, width, height, color)
        .map_err(|e| from_image(file, FORMAT, e))
}

pub(crate) fn encode_png8(image: &Rgb8Image) -> Result<Vec<u8>, HdrIoError> {
    const NAME: &str = "<in-memory PNG>";
    check_consistent(NAME, image)?;
    let mut bytes = Cursor::new(Vec::new());
    encode(
        &mut bytes,
        NAME,
        image.as_bytes(),
        image.width,
        image.height,
        ExtendedColorType::Rgb8,
    )?;
    Ok(bytes.into_inner())
}

pub(crate) fn write_png8(path: &Path, image: &Rgb8Image) -> Result<(), HdrIoError> {
    let file = path.display().to_string();
    check_png_extension(path, &file)?;
    check_consistent(&file, image)?;
    write_atomically(path, |w| {
        encode(
            w,
            &file,
            image.as_bytes(),
            image.width,
            image.height,
            ExtendedColorType::Rgb8,
        )
    })
}

pub(crate) fn write_png16(path: &Path, image: &Rgb16Image) -> Result<(), HdrIoError> {
    let file = path.display().to_string();
    check_png_extension(path, &file)?;
    check_consistent(&file, image)?;
    // `image` takes 16-bit samples in native byte order and writes them big-endian.
    let bytes: &[u8] = bytemuck::cast_slice(&image.pixels);
    write_atomically(path, |w| {
        encode(
            w,
            &file,
            bytes,
            image.width,
            image.height,
            ExtendedColorType::Rgb16,
        )
    })
}

/// PNG writers insist on `.png` so that a golden is never written under a
/// name that says it is something else.
pub(crate) fn check_png_extension(path: &Path, file: &str) -> Result<(), HdrIoError> {
    let is_png = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        Ok(())
    } else {
        Err(HdrIoError::UnsupportedExtension {
            file: file.to_string(),
            supported: ".png",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2×1 RGBA8 PNG: an opaque red pixel and a half-transparent one.
    fn rgba_png(second: [u8; 4]) -> Vec<u8> {
        let mut bytes = Vec::new();
        PngEncoder::new(&mut bytes)
            .write_image(
                &[255, 0, 0, 255, second[0], second[1], second[2], second[3]],
                2,
                1,
                ExtendedColorType::Rgba8,
            )
            .unwrap();
        bytes
    }

    #[test]
    fn alpha_is_refused_composited_or_dropped_as_asked() {
        let bytes = rgba_png([200, 100, 50, 128]);
        let e = decode_png8(&bytes, "f.png", Alpha::Opaque).unwrap_err();
        assert!(
            e.to_string()
                .contains("pixel 1 (in row-major order) is not opaque"),
            "{e}"
        );
        // Over black: c·a/255, rounded: 200·128/255 = 100.39 → 100.
        let black = decode_png8(&bytes, "f.png", Alpha::Over([0, 0, 0])).unwrap();
        assert_eq!(black.pixels, [[255, 0, 0], [100, 50, 25]]);
        // Over white: c·a/255 + 255·(255 − a)/255: 100.39 + 127 = 227.39.
        let white = decode_png8(&bytes, "f.png", Alpha::Over([255, 255, 255])).unwrap();
        assert_eq!(white.pixels, [[255, 0, 0], [227, 177, 152]]);
        let dropped = decode_png8(&bytes, "f.png", Alpha::Ignore).unwrap();
        assert_eq!(dropped.pixels, [[255, 0, 0], [200, 100, 50]]);
        // Fully transparent: the background; opaque: the colour.
        let clear = decode_png8(&rgba_png([9, 9, 9, 0]), "f.png", Alpha::Over([1, 2, 3])).unwrap();
        assert_eq!(clear.pixels[1], [1, 2, 3]);
    }
}
